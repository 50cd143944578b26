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

}  // namespace server
