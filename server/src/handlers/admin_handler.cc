#include "admin_handler.h"

#include "analyzer/telemetry_codec.h"
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

namespace server {

grpc::Status AdminHandler::DeleteRobot(grpc::ServerContext* call, const fleet::v1::DeleteRobotRequest* request,
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
  // Its tokens stop working here at once (other replicas: within the cache TTL; the credential is gone).
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
  log::Info("robot_deleted", {{"robot_id", robot_id},
                              {"by", caller.name},
                              {"runs", static_cast<long long>(erased->runs)},
                              {"snapshots", static_cast<long long>(erased->snapshots)}});
  return scope.Done(grpc::Status::OK);
}

grpc::Status AdminHandler::ListAuditLog(grpc::ServerContext* call, const fleet::v1::ListAuditLogRequest* request,
                                        fleet::v1::ListAuditLogResponse* response) {
  RpcScope scope(context_.metrics, "Admin/ListAuditLog");
  Principal caller;
  if (grpc::Status denied = Authorize(context_, call, Permission::kAdmin, &caller); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->limit() < 0 || request->limit() > 1000) return scope.Done(InvalidArgument("limit: expected 0..1000"));
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
