// The gRPC side of fleetd: one ServerBuilder lifecycle with every service handler (server/src/handlers/),
// the health service and server reflection. gRPC stays inside fleet_server.cc and the handlers.
//
// Thread safety: Create, then Shutdown once from the owner thread; handlers run on gRPC's threads.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "server/auth.h"
#include "server/config.h"
#include "server/metrics.h"
#include "storage/repository.h"

namespace server {

class FleetServer {
 public:
  /// Binds config.listen (port 0: a free port) and starts serving. `job_enqueued` wakes local workers.
  static slamcore::Result<std::unique_ptr<FleetServer>> Create(const FleetdConfig& config,
                                                               storage::Repository& repository,
                                                               Metrics& metrics, Authenticator& authenticator,
                                                               std::function<void()> job_enqueued);
  ~FleetServer();
  /// "127.0.0.1:41234".
  std::string BoundAddress() const;
  /// The gRPC health service's answer (HealthMonitor decides; SERVING after Create).
  void SetServing(bool serving);
  /// Health NOT_SERVING, stop accepting, let in-flight calls finish until `deadline`, then cancel them.
  void Shutdown(std::chrono::system_clock::time_point deadline);

 private:
  class Impl;
  explicit FleetServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Stores the default parameter set (slamcore's defaults) under `name` unless a set of that name exists.
slamcore::Status EnsureDefaultParameterSet(storage::Repository& repository, const std::string& name);

}  // namespace server
