// Analysis workers: threads that lease "analyze_run" jobs from storage's queue, analyse the run with the
// job's parameter set and store the report; plus one coordinator thread that leases "reprocess" jobs, fans
// each out into per-run analyze_run children and keeps the parent's progress until every child finished
// (then completes it) or the parent is cancelled (then cancels the children still waiting).
//
// Leases are renewed by a heartbeat thread every lease/4, so a dead process's jobs return to the queue
// after one lease. Stop() stops leasing, lets in-flight analyses finish, and hands a coordinator's parent
// job back to the queue (another process resumes it, adopting the children already enqueued).
//
// Thread safety: Start/Stop from one owner thread; Wake from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "server/analysis.h"
#include "server/map_history.h"
#include "server/metrics.h"
#include "storage/repository.h"

namespace server {

struct WorkerOptions {
  int threads = 1;              // analysis threads
  bool coordinator = true;      // also run reprocess jobs' coordination
  std::string name = "fleetd";  // lease owner prefix: "<name>/<thread>"
  std::chrono::milliseconds lease{120000};
  double analysis_budget_seconds = 600.0;  // one analysis's replay and rendering; <= 0: no limit
  std::string model_name = "protrusion";
  MapPolicy map_policy;  // what happens to a robot's map after its run is analysed
};

class WorkerPool {
 public:
  WorkerPool(storage::Repository& repository, Metrics& metrics, WorkerOptions options);
  ~WorkerPool();

  void Start();
  /// A job was enqueued: wake an idle worker at once instead of at its next poll.
  void Wake();
  /// Stops leasing and joins the threads; in-flight analyses finish first.
  void Stop();

 private:
  void AnalysisLoop(int index);
  void ProcessAnalysis(const storage::JobLease& lease);
  void CoordinatorLoop();
  void Coordinate(storage::JobLease lease);
  void HeartbeatLoop();
  void Track(const storage::JobLease& lease);
  void Untrack(const storage::JobLease& lease);
  bool WaitFor(std::chrono::milliseconds duration);  // false when stopping

  storage::Repository& repository_;
  Metrics& metrics_;
  const WorkerOptions options_;
  ClassifierCache classifiers_;
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;  // guards wake_count_, leases_
  std::condition_variable wake_;
  std::uint64_t wake_count_ = 0;
  std::vector<storage::JobLease> leases_;  // held leases, for the heartbeat thread
  std::vector<std::thread> threads_;
};

}  // namespace server
