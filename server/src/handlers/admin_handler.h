// Admin: credentials. SetCredential mints a new token for a principal (replacing its previous one).
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class AdminHandler final : public fleet::v1::Admin::Service {
 public:
  explicit AdminHandler(ServiceContext& context) : context_(context) {}
  grpc::Status SetCredential(grpc::ServerContext* call, const fleet::v1::SetCredentialRequest* request,
                             fleet::v1::SetCredentialResponse* response) override;

 private:
  ServiceContext& context_;
};

}  // namespace server
