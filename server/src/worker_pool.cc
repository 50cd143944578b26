#include "server/worker_pool.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "server/jobs.h"
#include "server/log.h"
#include "run_lookup.h"

namespace server {
namespace {

bool Terminal(storage::JobState state) {
  return state == storage::JobState::kDone || state == storage::JobState::kFailed ||
         state == storage::JobState::kCancelled;
}

}  // namespace

WorkerPool::WorkerPool(storage::Repository& repository, Metrics& metrics, WorkerOptions options)
    : repository_(repository),
      metrics_(metrics),
      options_(std::move(options)),
      classifiers_(repository, options_.model_name) {}

WorkerPool::~WorkerPool() { Stop(); }

void WorkerPool::Start() {
  metrics_.SetGauge("fleetd_workers", "", options_.threads);
  for (int i = 0; i < options_.threads; ++i) threads_.emplace_back([this, i] { AnalysisLoop(i); });
  if (options_.coordinator) threads_.emplace_back([this] { CoordinatorLoop(); });
  threads_.emplace_back([this] { HeartbeatLoop(); });
}

void WorkerPool::Wake() {
  std::lock_guard lock(mutex_);
  ++wake_count_;
  wake_.notify_all();
}

void WorkerPool::Stop() {
  if (stopping_.exchange(true)) {
    for (auto& thread : threads_) {
      if (thread.joinable()) thread.join();
    }
    return;
  }
  Wake();
  for (auto& thread : threads_) {
    if (thread.joinable()) thread.join();
  }
}

bool WorkerPool::WaitFor(std::chrono::milliseconds duration) {
  std::unique_lock lock(mutex_);
  const std::uint64_t seen = wake_count_;
  wake_.wait_for(lock, duration, [&] { return stopping_.load() || wake_count_ != seen; });
  return !stopping_;
}

void WorkerPool::Track(const storage::JobLease& lease) {
  std::lock_guard lock(mutex_);
  leases_.push_back(lease);
}

void WorkerPool::Untrack(const storage::JobLease& lease) {
  std::lock_guard lock(mutex_);
  leases_.erase(
      std::remove_if(leases_.begin(), leases_.end(),
                     [&](const storage::JobLease& held) { return held.lease_token == lease.lease_token; }),
      leases_.end());
}

void WorkerPool::HeartbeatLoop() {
  const auto period = std::max(std::chrono::milliseconds(500), options_.lease / 4);
  while (!stopping_) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, period, [this] { return stopping_.load(); });
    }
    std::vector<storage::JobLease> held;
    {
      std::lock_guard lock(mutex_);
      held = leases_;
    }
    for (const auto& lease : held) {
      const storage::Status status = repository_.HeartbeatJob(lease, options_.lease);
      if (!status.ok()) {
        log::Warn("lease_lost",
                  {{"job", static_cast<long long>(lease.job.job_id)}, {"error", status.ToString()}});
      }
    }
  }
}

void WorkerPool::AnalysisLoop(int index) {
  const std::string owner = options_.name + "/" + std::to_string(index);
  while (!stopping_) {
    auto leased = repository_.LeaseJob(owner, options_.lease, kAnalyzeRunJob);
    if (!leased.ok()) {
      log::Warn("lease_failed", {{"worker", owner}, {"error", leased.status().ToString()}});
      WaitFor(std::chrono::milliseconds(1000));
      continue;
    }
    if (!leased->has_value()) {
      WaitFor(std::chrono::milliseconds(500));
      continue;
    }
    ProcessAnalysis(**leased);
  }
}

void WorkerPool::ProcessAnalysis(const storage::JobLease& lease) {
  Track(lease);
  const auto payload = DecodeAnalyzePayload(lease.job.payload);
  storage::Status status;
  std::string outcome = "done";
  storage::RunKey run;
  if (payload.ok()) {
    // Jobs queued before run ids were per robot name the run by id alone.
    auto key = ResolveRun(repository_, Principal{"fleetd:worker", Role::kAdmin, ""}, payload->robot_id,
                          payload->run_id);
    if (key.ok())
      run = *key;
    else
      run = storage::RunKey{payload->robot_id, payload->run_id};
  }
  if (!payload.ok()) {
    status = payload.status();
  } else {
    auto classifier = classifiers_.Get();
    // The budget: a deadline, and the job's own state looked up at most once a second (CancelJob marks it).
    AnalysisBudget budget;
    budget.max_seconds = options_.analysis_budget_seconds;
    auto next_check = std::chrono::steady_clock::now();
    budget.cancelled = [&] {
      const auto now = std::chrono::steady_clock::now();
      if (now < next_check) return false;
      next_check = now + std::chrono::seconds(1);
      auto job = repository_.GetJob(lease.job.job_id);
      return job.ok() && job->state == storage::JobState::kCancelled;
    };
    auto analysed = AnalyzeStoredRun(repository_, run, payload->parameter_set, classifier.get(), budget);
    if (analysed.ok()) {
      metrics_.Observe("fleetd_analysis_seconds", "", analysed->seconds);
      log::Info("run_analysed", {{"job", static_cast<long long>(lease.job.job_id)},
                                 {"run_id", payload->run_id},
                                 {"robot_id", run.robot_id},
                                 {"parameter_set", payload->parameter_set},
                                 {"seconds", analysed->seconds},
                                 {"regions", static_cast<long long>(analysed->regions)}});
      // The upload's map version gets its findings (and the repair policy its say); a failure retries the job.
      status = MapHistory(repository_, options_.map_policy)
                   .OnRunAnalysed(
                       run, analysed->report,
                       {analysed->maps.parent, analysed->maps.uploaded_child, analysed->child_snapshot_id});
    } else if (analysed.status().code() == storage::StatusCode::kNotFound &&
               analysed.status().message().find("run") != std::string::npos &&
               repository_.GetRun(run).status().code() == storage::StatusCode::kNotFound) {
      // Ingest enqueues before it stores (so a stored run always has its job): the store may still be under
      // way, or it never happened (the upload was cut, and its retry brings a job of its own). Give it time
      // and hand the job back; on the last attempt the job is done: there is nothing to analyse.
      if (lease.job.attempts >= lease.job.max_attempts) {
        outcome = "no_run";
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        outcome = "no_run_yet";
        status = storage::NotFound("run " + payload->run_id + " is not stored (yet)");
      }
    } else {
      status = analysed.status();
    }
  }
  Untrack(lease);
  if (status.ok()) {
    const storage::Status completed = repository_.CompleteJob(lease);
    if (!completed.ok()) outcome = "lease_lost";
  } else {
    outcome = "failed";
    log::Warn("analysis_failed",
              {{"job", static_cast<long long>(lease.job.job_id)}, {"error", status.ToString()}});
    const storage::Status failed = repository_.FailJob(lease, status.ToString());
    if (!failed.ok()) outcome = "lease_lost";
  }
  metrics_.Increment("fleetd_jobs_total", "kind=\"analyze_run\",outcome=\"" + outcome + "\"");
}

void WorkerPool::CoordinatorLoop() {
  const std::string owner = options_.name + "/coordinator";
  while (!stopping_) {
    auto leased = repository_.LeaseJob(owner, options_.lease, kReprocessJob);
    if (!leased.ok() || !leased->has_value()) {
      WaitFor(std::chrono::milliseconds(leased.ok() ? 300 : 1000));
      continue;
    }
    Coordinate(std::move(**leased));
  }
}

void WorkerPool::Coordinate(storage::JobLease lease) {
  const std::int64_t parent = lease.job.job_id;
  Track(lease);
  struct Untracker {
    WorkerPool* pool;
    const storage::JobLease* lease;
    ~Untracker() { pool->Untrack(*lease); }
  } untracker{this, &lease};

  const auto payload = DecodeReprocessPayload(lease.job.payload);
  if (!payload.ok()) {
    (void)repository_.FailJob(lease, payload.status().ToString());
    return;
  }
  // Children enqueued by an earlier attempt (a coordinator that died or shut down) are adopted.
  std::vector<std::int64_t> children;
  if (lease.job.attempts > 1) {
    auto jobs = repository_.ListJobs(std::nullopt, 1000000);
    if (!jobs.ok()) {
      (void)repository_.FailJob(lease, jobs.status().ToString());
      return;
    }
    for (const auto& job : *jobs) {
      if (job.parent_job_id == parent) children.push_back(job.job_id);
    }
  }
  auto cancel_children = [&](const std::vector<std::int64_t>& ids) {
    for (std::int64_t id : ids) (void)repository_.CancelJob(id);
  };
  if (children.empty()) {
    std::vector<storage::RunKey> runs;
    std::int64_t pruned = 0;  // runs whose events retention dropped: nothing to rerun
    std::optional<storage::RunCursor> cursor;
    do {
      auto page = repository_.ListRuns(payload->filter, 1000, cursor);
      if (!page.ok()) {
        (void)repository_.FailJob(lease, page.status().ToString());
        return;
      }
      for (const auto& run : page->runs) {
        if (run.telemetry_pruned_at_ms) {
          ++pruned;
        } else {
          runs.push_back(run.key());
        }
      }
      cursor = page->next;
    } while (cursor);
    for (const storage::RunKey& run : runs) {
      storage::NewJob child;
      child.kind = kAnalyzeRunJob;
      child.payload = EncodeAnalyzePayload({run.robot_id, run.run_id, payload->parameter_set});
      child.robot_id = run.robot_id;
      child.parent_job_id = parent;
      child.max_attempts = 3;
      auto id = repository_.EnqueueJob(child);
      if (!id.ok()) {
        cancel_children(children);
        (void)repository_.FailJob(lease, id.status().ToString());
        return;
      }
      children.push_back(*id);
      if (children.size() % 200 == 0 && !repository_.HeartbeatJob(lease, options_.lease).ok()) {
        cancel_children(children);  // the parent was cancelled while fanning out
        return;
      }
    }
    log::Info("reprocess_started", {{"job", static_cast<long long>(parent)},
                                    {"parameter_set", payload->parameter_set},
                                    {"runs", static_cast<long long>(runs.size())},
                                    {"skipped_pruned", static_cast<long long>(pruned)}});
    Wake();
  }
  const auto total = static_cast<std::int64_t>(children.size());
  std::vector<std::int64_t> pending = children;
  std::int64_t failed = 0;
  while (true) {
    // Check the oldest pending children (the queue is FIFO, so they finish first).
    std::vector<std::int64_t> still;
    std::size_t checked = 0;
    for (std::int64_t id : pending) {
      if (checked++ >= 256) {
        still.push_back(id);
        continue;
      }
      auto job = repository_.GetJob(id);
      if (job.ok() && Terminal(job->state)) {
        if (job->state != storage::JobState::kDone) ++failed;
        continue;
      }
      still.push_back(id);
    }
    pending = std::move(still);
    const std::int64_t done = total - static_cast<std::int64_t>(pending.size());
    metrics_.SetGauge("fleetd_job_progress_ratio", "job=\"" + std::to_string(parent) + "\"",
                      total == 0 ? 1.0 : static_cast<double>(done) / static_cast<double>(total));
    auto self = repository_.GetJob(parent);
    const bool cancelled = self.ok() && self->state == storage::JobState::kCancelled;
    if (cancelled || !repository_.UpdateJobProgress(lease, done, total).ok()) {
      cancel_children(pending);
      log::Info("reprocess_cancelled",
                {{"job", static_cast<long long>(parent)}, {"done", static_cast<long long>(done)}});
      return;
    }
    if (pending.empty()) break;
    if (!WaitFor(std::chrono::milliseconds(200))) {
      (void)repository_.FailJob(lease, "fleetd shutting down; job handed back");
      return;
    }
  }
  (void)repository_.CompleteJob(lease);
  log::Info("reprocess_done", {{"job", static_cast<long long>(parent)},
                               {"runs", static_cast<long long>(total)},
                               {"failed", static_cast<long long>(failed)}});
  metrics_.Increment("fleetd_jobs_total", "kind=\"reprocess\",outcome=\"done\"");
}

}  // namespace server
