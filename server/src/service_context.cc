#include "service_context.h"

namespace server {

// The one mapping from the project's status codes to gRPC's (same names, same meaning).
grpc::Status ToGrpc(const slamcore::Status& status) {
  using slamcore::StatusCode;
  switch (status.code()) {
    case StatusCode::kOk: return grpc::Status::OK;
    case StatusCode::kInvalidArgument: return {grpc::StatusCode::INVALID_ARGUMENT, status.message()};
    case StatusCode::kNotFound: return {grpc::StatusCode::NOT_FOUND, status.message()};
    case StatusCode::kAlreadyExists: return {grpc::StatusCode::ALREADY_EXISTS, status.message()};
    case StatusCode::kFailedPrecondition: return {grpc::StatusCode::FAILED_PRECONDITION, status.message()};
    case StatusCode::kAborted: return {grpc::StatusCode::ABORTED, status.message()};
    case StatusCode::kDataLoss: return {grpc::StatusCode::DATA_LOSS, status.message()};
    case StatusCode::kUnavailable: return {grpc::StatusCode::UNAVAILABLE, status.message()};
    case StatusCode::kInternal: return {grpc::StatusCode::INTERNAL, status.message()};
  }
  return {grpc::StatusCode::INTERNAL, status.message()};
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

namespace {
const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    default: return "UNKNOWN";
  }
}
}  // namespace

RpcScope::RpcScope(Metrics* metrics, const char* method)
    : metrics_(metrics), method_(method), started_(std::chrono::steady_clock::now()) {}

grpc::Status RpcScope::Done(grpc::Status status) {
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const std::string method = std::string("method=\"") + method_ + "\"";
  metrics_->Increment("fleetd_rpc_total", method + ",code=\"" + CodeName(status.error_code()) + "\"");
  metrics_->Observe("fleetd_rpc_latency_seconds", method, seconds);
  return status;
}

}  // namespace server
