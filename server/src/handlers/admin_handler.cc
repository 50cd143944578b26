#include "admin_handler.h"

#include "server/log.h"

namespace server {

grpc::Status AdminHandler::SetCredential(grpc::ServerContext* call, const fleet::v1::SetCredentialRequest* request,
                                         fleet::v1::SetCredentialResponse* response) {
  RpcScope scope(context_.metrics, "Admin/SetCredential");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  auto principal = ParsePrincipal(request->principal());
  if (!principal.ok()) return scope.Done(ToGrpc(principal.status()));
  auto token = context_.authenticator->IssueToken(*principal);
  if (!token.ok()) return scope.Done(ToGrpc(token.status()));
  response->set_principal(principal->name);
  response->set_token(*token);
  log::Info("credential_set", {{"principal", principal->name}, {"by", caller.name}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::RotateCredential(grpc::ServerContext* call,
                                            const fleet::v1::RotateCredentialRequest* request,
                                            fleet::v1::SetCredentialResponse* response) {
  RpcScope scope(context_.metrics, "Admin/RotateCredential");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRotateOwn, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  auto principal = ParsePrincipal(request->principal());
  if (!principal.ok()) return scope.Done(ToGrpc(principal.status()));
  if (principal->name != caller.name && !Allows(caller.role, Permission::kAdmin)) {
    return scope.Done({grpc::StatusCode::PERMISSION_DENIED,
                       caller.name + " may rotate only its own token, not " + principal->name + "'s"});
  }
  auto token = context_.authenticator->RotateToken(*principal);
  if (!token.ok()) return scope.Done(ToGrpc(token.status()));
  response->set_principal(principal->name);
  response->set_token(*token);
  log::Info("credential_rotated", {{"principal", principal->name}, {"by", caller.name}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::RevokeCredential(grpc::ServerContext* call,
                                            const fleet::v1::RevokeCredentialRequest* request,
                                            fleet::v1::RevokeCredentialResponse* response) {
  RpcScope scope(context_.metrics, "Admin/RevokeCredential");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  auto principal = ParsePrincipal(request->principal());
  if (!principal.ok()) return scope.Done(ToGrpc(principal.status()));
  if (storage::Status revoked = context_.authenticator->RevokeToken(*principal); !revoked.ok()) {
    return scope.Done(ToGrpc(revoked));
  }
  response->set_principal(principal->name);
  log::Info("credential_revoked", {{"principal", principal->name}, {"by", caller.name}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::ListCredentials(grpc::ServerContext* call, const fleet::v1::ListCredentialsRequest* request,
                                           fleet::v1::ListCredentialsResponse* response) {
  RpcScope scope(context_.metrics, "Admin/ListCredentials");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  const int page_size = request->page_size() == 0 ? 100 : request->page_size();
  if (page_size < 1 || page_size > 1000) return scope.Done(InvalidArgument("page_size: expected 1..1000"));
  auto credentials = context_.repository->ListCredentials(request->prefix(), request->page_token(), page_size,
                                                          !request->include_revoked());
  if (!credentials.ok()) return scope.Done(ToGrpc(credentials.status()));
  for (const storage::CredentialRecord& record : *credentials) {
    fleet::v1::Credential* out = response->add_credentials();
    out->set_principal(record.principal);
    if (auto principal = ParsePrincipal(record.principal); principal.ok()) out->set_role(RoleName(principal->role));
    out->set_updated_at(ToSeconds(record.updated_at_ms));
    out->set_revoked(record.revoked);
  }
  if (static_cast<int>(credentials->size()) == page_size) response->set_next_page_token(credentials->back().principal);
  return scope.Done(grpc::Status::OK);
}

}  // namespace server
