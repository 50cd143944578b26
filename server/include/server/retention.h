// Retention, run by the server in one place (fleetd --role all|server): raw run events (telemetry) older
// than --retain-runs-days are dropped, the runs' metadata, reports, snapshots and map versions kept; finished
// jobs (done, failed, cancelled) older than --retain-jobs-days are deleted, so /api/jobs, ListJobs and
// /metrics never walk an ever-growing table. Each pass that removed something appends an audit entry
// (actor "fleetd:retention") with the policy and the counts. docs/formats/service.md, "Erasure and retention".
//
// Thread safety: Start/Stop from one thread; RunOnce may be called from any thread (the repository is
// thread-safe; passes on several replicas at once are harmless: each batch is its own transaction).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "server/metrics.h"
#include "storage/repository.h"

namespace server {

struct RetentionPolicy {
  double retain_runs_days = 0.0;  // <= 0: run events are kept for ever
  double retain_jobs_days = 7.0;  // <= 0: finished jobs are kept for ever
  std::chrono::milliseconds interval{std::chrono::hours(1)};
  int batch = 500;  // rows per transaction
};

struct RetentionCounts {
  std::int64_t run_events = 0;  // runs whose events were dropped
  std::int64_t jobs = 0;        // finished jobs deleted
};

class RetentionTask {
 public:
  RetentionTask(storage::Repository& repository, Metrics& metrics, RetentionPolicy policy);
  ~RetentionTask();  // stops the thread

  /// A pass now (at wall-clock `now_ms`), then every policy.interval on a thread of its own until Stop.
  void Start();
  void Stop();
  /// One pass: prunes in batches until nothing is left, audits what it removed.
  storage::Result<RetentionCounts> RunOnce(std::int64_t now_ms);

 private:
  void Loop();

  storage::Repository& repository_;
  Metrics& metrics_;
  const RetentionPolicy policy_;
  std::mutex mutex_;  // guards stopping_
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace server
