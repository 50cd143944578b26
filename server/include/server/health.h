// HealthMonitor: whether this fleetd can do its job, for /healthz and the gRPC health service. A thread
// writes the health probe (storage::Repository::ProbeWrite) every `interval`; fleetd is unhealthy while the
// last probe failed or while any write of its Repository failed UNAVAILABLE (database full, read-only,
// unreachable) within the last three intervals. A probe alone can pass on a full disk (a small write may
// reuse pages the database already has), so the outcome of real writes counts too.
//
// Thread safety: Current() may be called from any thread; Start/Stop from the owner.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "storage/repository.h"

namespace server {

class HealthMonitor {
 public:
  struct State {
    bool healthy = true;
    std::string reason;  // empty when healthy: "write probe failed: ..." / "a write failed 2.1 s ago: ..."
  };
  /// `on_change(healthy)` runs on the monitor's thread whenever the state flips (and once at Start).
  HealthMonitor(storage::Repository& repository, std::string prober, std::chrono::milliseconds interval,
                std::function<void(bool healthy)> on_change);
  ~HealthMonitor();

  /// Probes once now, then every interval on a thread of its own.
  void Start();
  void Stop();
  State Current() const;

 private:
  void Probe();
  void Loop();

  storage::Repository& repository_;
  const std::string prober_;
  const std::chrono::milliseconds interval_;
  const std::function<void(bool)> on_change_;
  mutable std::mutex mutex_;  // guards probe_error_, stopping_, reported_
  std::condition_variable wake_;
  std::string probe_error_;  // empty: the last probe succeeded
  bool stopping_ = false;
  int reported_ = -1;  // last state given to on_change_ (-1: none yet)
  std::thread thread_;
};

}  // namespace server
