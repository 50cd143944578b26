#include "server/retention.h"

#include <functional>
#include <string>

#include "server/log.h"

namespace server {
namespace {

constexpr double kMsPerDay = 86400000.0;

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Calls `prune(batch)` until it removes nothing; the total.
template <typename Prune>
storage::Result<std::int64_t> PruneAll(Prune prune, int batch) {
  std::int64_t total = 0;
  while (true) {
    ASSIGN_OR_RETURN(auto removed, prune(batch));
    total += removed;
    if (removed == 0) return total;
  }
}

}  // namespace

RetentionTask::RetentionTask(storage::Repository& repository, Metrics& metrics, RetentionPolicy policy)
    : repository_(repository), metrics_(metrics), policy_(policy) {}

RetentionTask::~RetentionTask() { Stop(); }

storage::Result<RetentionCounts> RetentionTask::RunOnce(std::int64_t now_ms) {
  RetentionCounts counts;
  struct Pass {
    double days;
    const char* action;
    const char* what;
    std::int64_t* count;
    std::function<storage::Result<std::int64_t>(std::int64_t, int)> prune;
  };
  const Pass passes[] = {
      {policy_.retain_runs_days, "prune_run_events", "runs uploaded before", &counts.run_events,
       [this](std::int64_t before, int batch) { return repository_.PruneRunTelemetry(before, batch); }},
      {policy_.retain_jobs_days, "prune_jobs", "jobs finished before", &counts.jobs,
       [this](std::int64_t before, int batch) { return repository_.PruneFinishedJobs(before, batch); }},
  };
  for (const Pass& pass : passes) {
    if (pass.days <= 0.0) continue;
    const std::int64_t before = now_ms - static_cast<std::int64_t>(pass.days * kMsPerDay);
    ASSIGN_OR_RETURN(const std::int64_t removed,
                     PruneAll([&](int batch) { return pass.prune(before, batch); }, policy_.batch));
    *pass.count = removed;
    if (removed == 0) continue;
    metrics_.Increment("fleetd_retention_pruned_total", std::string("what=\"") + pass.action + "\"",
                       static_cast<double>(removed));
    const std::string policy = std::string(pass.what) + " " + std::to_string(before) + " ms (" +
                               std::to_string(pass.days) + " days)";
    ASSIGN_OR_RETURN(auto audited, repository_.AppendAudit(
                                       storage::AuditEntry{0, now_ms, "fleetd:retention", pass.action, policy,
                                                           "{\"count\":" + std::to_string(removed) + "}"}));
    log::Info("retention_pruned", {{"action", pass.action}, {"count", static_cast<long long>(removed)}});
  }
  return counts;
}

void RetentionTask::Start() {
  if (policy_.retain_runs_days <= 0.0 && policy_.retain_jobs_days <= 0.0) return;
  thread_ = std::thread([this] { Loop(); });
}

void RetentionTask::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RetentionTask::Loop() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    lock.unlock();
    try {
      auto pass = RunOnce(NowMs());
      if (!pass.ok()) log::Warn("retention_failed", {{"error", pass.status().ToString()}});
    } catch (const std::exception& e) {  // a thread's exception would end the process: log it, try next time
      log::Warn("retention_failed", {{"error", e.what()}});
    }
    lock.lock();
    wake_.wait_for(lock, policy_.interval, [this] { return stopping_; });
  }
}

}  // namespace server
