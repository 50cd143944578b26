// What every RPC handler shares (storage, auth, limits, metrics), and the helpers each handler uses at its
// boundary: authenticate + authorise + rate-limit a call, map the project's Status to grpc::Status, and
// count/time the call. Internal to server/.
//
// Thread safety: ServiceContext members are themselves thread-safe; RpcScope is per call.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "ingest_admission.h"
#include "server/auth.h"
#include "server/map_history.h"
#include "server/metrics.h"
#include "slamcore/status.h"
#include "storage/repository.h"

namespace server {

struct Limits {
  std::int64_t max_events_per_run = 2'000'000;
  std::int64_t max_run_bytes = 512LL << 20;
};

struct ServiceContext {
  storage::Repository* repository = nullptr;
  Authenticator* authenticator = nullptr;
  RateLimiter* rate_limiter = nullptr;
  IngestAdmission* admission = nullptr;  // upload streams and bytes in flight; null: unbounded
  Metrics* metrics = nullptr;
  Limits limits;
  std::string default_parameter_set = "default";
  std::string model_name = "protrusion";
  MapPolicy map_policy;
  std::function<void()> job_enqueued;  // wakes in-process workers; may be empty
};

/// The one mapping of the project's status codes to gRPC's: each to the code of the same name, message kept.
grpc::Status ToGrpc(const slamcore::Status& status);
grpc::Status InvalidArgument(const std::string& message);

/// The caller's address from grpc::ServerContext::peer(), without the port ("127.0.0.1", "[::1]").
std::string PeerAddress(const std::string& peer);

/// Authenticates the call's bearer token, checks `permission` for its role and the principal's rate limit.
/// UNAUTHENTICATED, PERMISSION_DENIED, RESOURCE_EXHAUSTED or UNAVAILABLE (credential store down).
grpc::Status Authorize(ServiceContext& context, grpc::ServerContext* call, Permission permission,
                       Principal* principal);

/// Counts and times one RPC: fleetd_rpc_total{method,code}, fleetd_rpc_latency_seconds{method}.
class RpcScope {
 public:
  RpcScope(Metrics* metrics, const char* method);
  grpc::Status Done(grpc::Status status);

 private:
  Metrics* metrics_;
  const char* method_;
  std::chrono::steady_clock::time_point started_;
};

/// Unix seconds ⇄ storage's milliseconds.
inline std::int64_t ToMillis(double seconds) {
  return static_cast<std::int64_t>(seconds * 1000.0 + (seconds >= 0 ? 0.5 : -0.5));
}
inline double ToSeconds(std::int64_t millis) { return static_cast<double>(millis) / 1000.0; }

}  // namespace server
