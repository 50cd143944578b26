// Admin: credentials, erasure and the audit log. SetCredential mints a new token for a principal (replacing
// its previous one); DeleteRobot erases a robot and everything derived from it (storage::Repository::
// DeleteRobot), audited; ListAuditLog reads the audit log.
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class AdminHandler final : public fleet::v1::Admin::Service {
 public:
  explicit AdminHandler(ServiceContext& context) : context_(context) {}
  grpc::Status SetCredential(grpc::ServerContext* call, const fleet::v1::SetCredentialRequest* request,
                             fleet::v1::SetCredentialResponse* response) override;
  grpc::Status DeleteRobot(grpc::ServerContext* call, const fleet::v1::DeleteRobotRequest* request,
                           fleet::v1::DeleteRobotResponse* response) override;
  grpc::Status ListAuditLog(grpc::ServerContext* call, const fleet::v1::ListAuditLogRequest* request,
                            fleet::v1::ListAuditLogResponse* response) override;

 private:
  ServiceContext& context_;
};

}  // namespace server
