#include "server/health.h"

#include <cstdio>

namespace server {

HealthMonitor::HealthMonitor(storage::Repository& repository, std::string prober,
                             std::chrono::milliseconds interval, std::function<void(bool healthy)> on_change)
    : repository_(repository),
      prober_(std::move(prober)),
      interval_(interval),
      on_change_(std::move(on_change)) {}

HealthMonitor::~HealthMonitor() { Stop(); }

void HealthMonitor::Start() {
  Probe();
  thread_ = std::thread([this] { Loop(); });
}

void HealthMonitor::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

HealthMonitor::State HealthMonitor::Current() const {
  State state;
  {
    std::lock_guard lock(mutex_);
    if (!probe_error_.empty()) return State{false, "write probe failed: " + probe_error_};
  }
  if (auto failure = repository_.LastWriteFailure()) {
    const auto now = std::chrono::duration_cast<std::chrono::milliseconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
    const std::int64_t age = now - failure->at_ms;
    if (age < 3 * interval_.count()) {
      char seconds[32];
      std::snprintf(seconds, sizeof seconds, "%.1f", static_cast<double>(age) / 1000.0);
      state = State{false, std::string("a write failed ") + seconds + " s ago: " + failure->message};
    }
  }
  return state;
}

void HealthMonitor::Probe() {
  const storage::Status probed = repository_.ProbeWrite(prober_);
  {
    std::lock_guard lock(mutex_);
    probe_error_ = probed.ok() ? "" : probed.ToString();
  }
  const bool healthy = Current().healthy;
  bool changed = false;
  {
    std::lock_guard lock(mutex_);
    changed = reported_ != static_cast<int>(healthy);
    reported_ = static_cast<int>(healthy);
  }
  if (changed && on_change_) on_change_(healthy);
}

void HealthMonitor::Loop() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, interval_, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    Probe();
    lock.lock();
  }
}

}  // namespace server
