#include "admin_handler.h"

#include "analyzer/telemetry_codec.h"
#include "server/log.h"

namespace server {
namespace {

/// A credential change is an admin action: it goes to the audit log too, after the change has committed (in
/// its own transaction; a failure to record it is logged, the change stands).
void AuditCredentialChange(storage::Repository& repository, const std::string& actor, const char* action,
                           const std::string& principal) {
  auto appended = repository.AppendAudit(storage::AuditEntry{0, 0, actor, action, principal, "{}"});
  if (!appended.ok()) {
    log::Error("audit_failed",
               {{"action", action}, {"subject", principal}, {"error", appended.status().ToString()}});
  }
}

}  // namespace

grpc::Status AdminHandler::SetCredential(grpc::ServerContext* call,
                                         const fleet::v1::SetCredentialRequest* request,
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
  AuditCredentialChange(*context_.repository, caller.name, "set_credential", principal->name);
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
  AuditCredentialChange(*context_.repository, caller.name, "rotate_credential", principal->name);
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
  AuditCredentialChange(*context_.repository, caller.name, "revoke_credential", principal->name);
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::ListCredentials(grpc::ServerContext* call,
                                           const fleet::v1::ListCredentialsRequest* request,
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
    if (auto principal = ParsePrincipal(record.principal); principal.ok())
      out->set_role(RoleName(principal->role));
    out->set_updated_at(ToSeconds(record.updated_at_ms));
    out->set_revoked(record.revoked);
  }
  if (static_cast<int>(credentials->size()) == page_size)
    response->set_next_page_token(credentials->back().principal);
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::DeleteRobot(grpc::ServerContext* call,
                                       const fleet::v1::DeleteRobotRequest* request,
                                       fleet::v1::DeleteRobotResponse* response) {
  RpcScope scope(context_.metrics, "Admin/DeleteRobot");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  // The ids' one syntax (as at upload), so nothing odd reaches storage or the log.
  if (slamcore::Status valid = analyzer::ValidateId(request->robot_id(), "robot_id"); !valid.ok()) {
    return scope.Done(ToGrpc(valid));
  }
  if (request->confirm() != request->robot_id()) {
    return scope.Done(InvalidArgument("confirm: must repeat robot_id (\"" + request->robot_id() +
                                      "\"): an erasure cannot be undone"));
  }
  const std::string& robot_id = request->robot_id();
  auto erased = context_.repository->DeleteRobot(robot_id, caller.name);
  if (!erased.ok()) return scope.Done(ToGrpc(erased.status()));
  // Its tokens stop working here at once; other replicas drop them at their next credential-epoch poll.
  context_.authenticator->ForgetPrincipal("robot:" + robot_id);
  response->set_robot_id(robot_id);
  response->set_runs(erased->runs);
  response->set_reports(erased->reports);
  response->set_decisions(erased->decisions);
  response->set_ambiguous_views(erased->ambiguous_views);
  response->set_protrusion_regions(erased->protrusion_regions);
  response->set_map_versions(erased->map_versions);
  response->set_map_findings(erased->map_findings);
  response->set_snapshots(erased->snapshots);
  response->set_jobs(erased->jobs);
  response->set_credentials(erased->credentials);
  response->set_map_metadata(erased->map_metadata);
  log::Info("robot_deleted", {{"robot_id", robot_id},
                              {"by", caller.name},
                              {"runs", static_cast<long long>(erased->runs)},
                              {"snapshots", static_cast<long long>(erased->snapshots)}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::ListAuditLog(grpc::ServerContext* call,
                                        const fleet::v1::ListAuditLogRequest* request,
                                        fleet::v1::ListAuditLogResponse* response) {
  RpcScope scope(context_.metrics, "Admin/ListAuditLog");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->limit() < 0 || request->limit() > 1000)
    return scope.Done(InvalidArgument("limit: expected 0..1000"));
  if (request->before_id() < 0) return scope.Done(InvalidArgument("before_id: must be >= 0"));
  std::optional<std::int64_t> before;
  if (request->before_id() > 0) before = request->before_id();
  auto entries = context_.repository->ListAudit(request->limit() == 0 ? 100 : request->limit(), before);
  if (!entries.ok()) return scope.Done(ToGrpc(entries.status()));
  for (const storage::AuditEntry& entry : *entries) {
    fleet::v1::AuditEntry* out = response->add_entries();
    out->set_entry_id(entry.entry_id);
    out->set_at(ToSeconds(entry.at_ms));
    out->set_actor(entry.actor);
    out->set_action(entry.action);
    out->set_subject(entry.subject);
    out->set_detail_json(entry.detail_json);
  }
  return scope.Done(grpc::Status::OK);
}

}  // namespace server
