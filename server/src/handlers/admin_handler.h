// Admin: credentials, erasure and the audit log. SetCredential mints a new token for a principal (replacing
// its previous one); RotateCredential replaces an existing one (admins for anyone, everyone for itself);
// RevokeCredential makes a token useless at once; ListCredentials shows principals, never secrets;
// DeleteRobot erases a robot and everything derived from it (storage::Repository::DeleteRobot); each of
// these changes is recorded in the audit log, which ListAuditLog reads.
#pragma once

#include "fleet/v1/service.grpc.pb.h"
#include "service_context.h"

namespace server {

class AdminHandler final : public fleet::v1::Admin::Service {
 public:
  explicit AdminHandler(ServiceContext& context) : context_(context) {}
  grpc::Status SetCredential(grpc::ServerContext* call, const fleet::v1::SetCredentialRequest* request,
                             fleet::v1::SetCredentialResponse* response) override;
  grpc::Status RotateCredential(grpc::ServerContext* call, const fleet::v1::RotateCredentialRequest* request,
                                fleet::v1::SetCredentialResponse* response) override;
  grpc::Status RevokeCredential(grpc::ServerContext* call, const fleet::v1::RevokeCredentialRequest* request,
                                fleet::v1::RevokeCredentialResponse* response) override;
  grpc::Status ListCredentials(grpc::ServerContext* call, const fleet::v1::ListCredentialsRequest* request,
                               fleet::v1::ListCredentialsResponse* response) override;
  grpc::Status DeleteRobot(grpc::ServerContext* call, const fleet::v1::DeleteRobotRequest* request,
                           fleet::v1::DeleteRobotResponse* response) override;
  grpc::Status ListAuditLog(grpc::ServerContext* call, const fleet::v1::ListAuditLogRequest* request,
                            fleet::v1::ListAuditLogResponse* response) override;

 private:
  ServiceContext& context_;
};

}  // namespace server
