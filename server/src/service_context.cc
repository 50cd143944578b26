#include "service_context.h"

#include "fleet/status_codes.h"

namespace server {

// The project's status codes to gRPC's by the one table (fleet/status_codes.h: same names, same meaning).
grpc::Status ToGrpc(const slamcore::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return {fleet::ToGrpcCode(status.code()), status.message()};
}

grpc::Status InvalidArgument(const std::string& message) {
  return {grpc::StatusCode::INVALID_ARGUMENT, message};
}

std::string PeerAddress(const std::string& peer) {
  // "ipv4:127.0.0.1:41234" / "ipv6:[::1]:41234" → the address without the port: limits are per host.
  const std::size_t colon = peer.rfind(':');
  std::string address = colon == std::string::npos ? peer : peer.substr(0, colon);
  if (address.rfind("ipv4:", 0) == 0 || address.rfind("ipv6:", 0) == 0) address = address.substr(5);
  return address;
}

grpc::Status Authorize(ServiceContext& context, grpc::ServerContext* call, Permission permission,
                       Principal* principal) {
  std::string authorization;
  const auto& metadata = call->client_metadata();
  auto it = metadata.find("authorization");
  if (it != metadata.end()) authorization.assign(it->second.data(), it->second.size());
  Authenticator::Verdict verdict =
      context.authenticator->Authenticate(authorization, PeerAddress(call->peer()));
  if (verdict.outcome == Authenticator::Outcome::kUnavailable)
    return {grpc::StatusCode::UNAVAILABLE, verdict.message};
  if (verdict.outcome != Authenticator::Outcome::kOk)
    return {grpc::StatusCode::UNAUTHENTICATED, verdict.message};
  if (!Allows(verdict.principal.role, permission)) {
    return {grpc::StatusCode::PERMISSION_DENIED, verdict.principal.name + " (role " +
                                                     RoleName(verdict.principal.role) + ") may not " +
                                                     PermissionName(permission)};
  }
  if (context.rate_limiter != nullptr && !context.rate_limiter->Allow(verdict.principal.name)) {
    return {grpc::StatusCode::RESOURCE_EXHAUSTED,
            "rate limit exceeded for " + verdict.principal.name + "; retry later"};
  }
  *principal = std::move(verdict.principal);
  return grpc::Status::OK;
}

RpcScope::RpcScope(Metrics* metrics, const char* method)
    : metrics_(metrics), method_(method), started_(std::chrono::steady_clock::now()) {}

grpc::Status RpcScope::Done(grpc::Status status) {
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const std::string method = std::string("method=\"") + method_ + "\"";
  metrics_->Increment("fleetd_rpc_total",
                      method + ",code=\"" + fleet::GrpcCodeName(status.error_code()) + "\"");
  metrics_->Observe("fleetd_rpc_latency_seconds", method, seconds);
  return status;
}

}  // namespace server
