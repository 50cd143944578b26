// The job queue contract on both back-ends: leases, expiry, retries, cancel, progress, and many workers
// (threads, and forked processes with one killed mid-job) that never share a job and complete each once.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

using std::chrono::milliseconds;

class JobQueueContractTest : public BackendTest {
 protected:
  std::int64_t Enqueue(const std::string& kind = "analyze_run", std::int64_t max_attempts = 3) {
    auto id = repo().EnqueueJob(NewJob{kind, "payload-" + kind, max_attempts, std::nullopt, 0});
    EXPECT_THAT(id, IsOk());
    return id.ok() ? *id : -1;
  }
  JobLease MustLease(const std::string& worker, milliseconds duration = milliseconds(60000)) {
    auto lease = repo().LeaseJob(worker, duration, "");
    EXPECT_THAT(lease, IsOk());
    EXPECT_TRUE(lease.ok() && lease->has_value()) << "no job to lease";
    return lease.ok() && lease->has_value() ? **lease : JobLease{};
  }
};

TEST_P(JobQueueContractTest, EnqueueLeaseCompleteInOrder) {
  const std::int64_t first = Enqueue();
  const std::int64_t second = Enqueue();
  EXPECT_LT(first, second);
  JobLease lease = MustLease("worker-a");
  EXPECT_EQ(lease.job.job_id, first);
  EXPECT_EQ(lease.job.state, JobState::kLeased);
  EXPECT_EQ(lease.job.attempts, 1);
  EXPECT_EQ(lease.job.payload, "payload-analyze_run");
  EXPECT_EQ(lease.job.lease_owner, "worker-a");
  ASSERT_THAT(repo().CompleteJob(lease), IsOk());
  EXPECT_EQ(repo().GetJob(first)->state, JobState::kDone);
  EXPECT_EQ(repo().CompleteJob(lease).code(), StatusCode::kFailedPrecondition) << "completes exactly once";
  EXPECT_EQ(MustLease("worker-a").job.job_id, second);
  EXPECT_FALSE(repo().LeaseJob("worker-a", milliseconds(1000), "")->has_value()) << "queue is empty";
  EXPECT_EQ(repo().GetJob(999).status().code(), StatusCode::kNotFound);
}

TEST_P(JobQueueContractTest, LeaseCanBeLimitedToOneKind) {
  Enqueue("reprocess");
  const std::int64_t analyze = Enqueue("analyze_run");
  auto lease = repo().LeaseJob("worker", milliseconds(1000), "analyze_run");
  ASSERT_THAT(lease, IsOk());
  ASSERT_TRUE(lease->has_value());
  EXPECT_EQ((*lease)->job.job_id, analyze);
  EXPECT_FALSE(repo().LeaseJob("worker", milliseconds(1000), "analyze_run")->has_value());
}

TEST_P(JobQueueContractTest, ExpiredLeaseGoesBackToTheQueue) {
  const std::int64_t id = Enqueue();
  JobLease stale = MustLease("dead-worker", milliseconds(50));
  std::this_thread::sleep_for(milliseconds(120));
  JobLease fresh = MustLease("live-worker");
  EXPECT_EQ(fresh.job.job_id, id);
  EXPECT_EQ(fresh.job.attempts, 2);
  EXPECT_EQ(repo().HeartbeatJob(stale, milliseconds(1000)).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().CompleteJob(stale).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().FailJob(stale, "late").code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(repo().CompleteJob(fresh), IsOk());
}

TEST_P(JobQueueContractTest, LeasesTheOldestOfTheQueuedJobsAndTheExpiredLeases) {
  // Queued jobs and expired leases are looked up apart (each in index order); the lease takes the lower id.
  const std::int64_t first = Enqueue();
  const std::int64_t reprocess = Enqueue("reprocess");
  const std::int64_t second = Enqueue();
  JobLease stale = MustLease("dead-worker", milliseconds(50));
  ASSERT_EQ(stale.job.job_id, first);
  std::this_thread::sleep_for(milliseconds(120));
  EXPECT_EQ(MustLease("live-worker").job.job_id, first) << "the expired lease is older than the queued jobs";
  auto of_kind = repo().LeaseJob("live-worker", milliseconds(50), "analyze_run");
  ASSERT_THAT(of_kind, IsOk());
  ASSERT_TRUE(of_kind->has_value());
  EXPECT_EQ((*of_kind)->job.job_id, second) << "the reprocess job between them is of another kind";
  std::this_thread::sleep_for(milliseconds(120));
  // Now `second` is an expired lease and `reprocess` (older) is still queued.
  EXPECT_EQ(MustLease("live-worker").job.job_id, reprocess);
  auto again = repo().LeaseJob("live-worker", milliseconds(60000), "analyze_run");
  ASSERT_THAT(again, IsOk());
  ASSERT_TRUE(again->has_value());
  EXPECT_EQ((*again)->job.job_id, second);
  EXPECT_EQ((*again)->job.attempts, 2);
  EXPECT_FALSE(repo().LeaseJob("live-worker", milliseconds(1000), "")->has_value());
}

TEST_P(JobQueueContractTest, HeartbeatKeepsTheLease) {
  Enqueue();
  JobLease lease = MustLease("worker", milliseconds(150));
  for (int i = 0; i < 3; ++i) {
    std::this_thread::sleep_for(milliseconds(60));
    ASSERT_THAT(repo().HeartbeatJob(lease, milliseconds(150)), IsOk());
  }
  EXPECT_FALSE(repo().LeaseJob("thief", milliseconds(1000), "")->has_value());
  EXPECT_THAT(repo().CompleteJob(lease), IsOk());
}

TEST_P(JobQueueContractTest, FailRetriesUntilMaxAttemptsThenFails) {
  const std::int64_t id = Enqueue("analyze_run", 2);
  ASSERT_THAT(repo().FailJob(MustLease("w"), "replay crashed"), IsOk());
  auto job = repo().GetJob(id);
  EXPECT_EQ(job->state, JobState::kQueued);
  EXPECT_EQ(job->last_error, "replay crashed");
  ASSERT_THAT(repo().FailJob(MustLease("w"), "replay crashed again"), IsOk());
  job = repo().GetJob(id);
  EXPECT_EQ(job->state, JobState::kFailed);
  EXPECT_EQ(job->attempts, 2);
  EXPECT_FALSE(repo().LeaseJob("w", milliseconds(1000), "")->has_value());
}

TEST_P(JobQueueContractTest, LeaseExpiringOnTheLastAttemptFailsTheJob) {
  const std::int64_t id = Enqueue("analyze_run", 1);
  MustLease("dies", milliseconds(30));
  std::this_thread::sleep_for(milliseconds(80));
  EXPECT_FALSE(repo().LeaseJob("w", milliseconds(1000), "")->has_value());
  auto job = repo().GetJob(id);
  EXPECT_EQ(job->state, JobState::kFailed);
  EXPECT_NE(job->last_error.find("expired"), std::string::npos);
}

TEST_P(JobQueueContractTest, CancelStopsQueuedAndLeasedJobs) {
  const std::int64_t queued = Enqueue();
  const std::int64_t leased = Enqueue();
  JobLease lease = MustLease("w");  // takes `queued`, the older one
  ASSERT_EQ(lease.job.job_id, queued);
  ASSERT_THAT(repo().CancelJob(leased), IsOk());
  ASSERT_THAT(repo().CancelJob(queued), IsOk());
  EXPECT_EQ(repo().CompleteJob(lease).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().GetJob(queued)->state, JobState::kCancelled);
  EXPECT_EQ(repo().CancelJob(queued).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().CancelJob(12345).code(), StatusCode::kNotFound);
  EXPECT_FALSE(repo().LeaseJob("w", milliseconds(1000), "")->has_value());
}

TEST_P(JobQueueContractTest, ProgressParentsAndListing) {
  auto parent = repo().EnqueueJob(NewJob{"reprocess", "all runs", 3, std::nullopt, 2});
  ASSERT_THAT(parent, IsOk());
  auto child = repo().EnqueueJob(NewJob{"analyze_run", "run-1", 3, *parent, 0});
  ASSERT_THAT(child, IsOk());
  EXPECT_EQ(repo().GetJob(*child)->parent_job_id, *parent);
  EXPECT_EQ(repo().EnqueueJob(NewJob{"x", "", 3, 424242, 0}).status().code(),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().EnqueueJob(NewJob{"", "", 3, std::nullopt, 0}).status().code(),
            StatusCode::kInvalidArgument);
  JobLease lease = MustLease("w");
  ASSERT_EQ(lease.job.job_id, *parent);
  ASSERT_THAT(repo().UpdateJobProgress(lease, 1, 2), IsOk());
  EXPECT_EQ(repo().GetJob(*parent)->progress_done, 1);
  EXPECT_EQ(repo().GetJob(*parent)->progress_total, 2);
  EXPECT_EQ(repo().ListJobs(std::nullopt, 10)->size(), 2u);
  auto leased = repo().ListJobs(JobState::kLeased, 10);
  ASSERT_EQ(leased->size(), 1u);
  EXPECT_EQ((*leased)[0].job_id, *parent);
  EXPECT_EQ(repo().ListJobs(JobState::kQueued, 10)->front().job_id, *child);
}

// Worker loop shared by the thread and process tests: lease, "work", complete; report each completion.
template <typename OnComplete>
void DrainQueue(Repository& repository, const std::string& worker, OnComplete on_complete) {
  for (int idle = 0; idle < 20;) {
    auto lease = repository.LeaseJob(worker, milliseconds(400), "");
    if (!lease.ok()) {  // UNAVAILABLE under contention: try again, but not forever
      ++idle;
      continue;
    }
    if (!lease->has_value()) {
      ++idle;  // maybe a dead worker's lease has not expired yet
      std::this_thread::sleep_for(milliseconds(50));
      continue;
    }
    idle = 0;
    if (repository.CompleteJob(**lease).ok()) on_complete((*lease)->job.job_id);
  }
}

TEST_P(JobQueueContractTest, ConcurrentThreadsNeverShareAJob) {
  constexpr int kJobs = 120, kThreads = 6;
  std::set<std::int64_t> ids;
  for (int i = 0; i < kJobs; ++i) ids.insert(Enqueue());
  // A worker that dies holding a lease: its job must still complete, once, after the lease expires.
  ASSERT_TRUE(repo().LeaseJob("abandons", milliseconds(300), "")->has_value());
  std::mutex mutex;
  std::map<std::int64_t, int> completions;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      // Each thread has its own Repository: its own SQLite connection, or its own PostgreSQL pool.
      auto repository = OpenRepository(url_, OpenOptions{1, std::chrono::milliseconds(10000)});
      ASSERT_THAT(repository, IsOk());
      DrainQueue(**repository, "thread-" + std::to_string(t), [&](std::int64_t id) {
        std::lock_guard<std::mutex> lock(mutex);
        ++completions[id];
      });
    });
  }
  for (std::thread& thread : threads) thread.join();
  ASSERT_EQ(completions.size(), ids.size());
  for (const auto& [id, count] : completions) EXPECT_EQ(count, 1) << "job " << id;
  EXPECT_EQ(repo().ListJobs(JobState::kDone, 1000)->size(), ids.size());
}

TEST_P(JobQueueContractTest, ConcurrentProcessesNeverShareAJobEvenWhenOneIsKilled) {
  constexpr int kJobs = 60, kWorkers = 4;
  for (int i = 0; i < kJobs; ++i) Enqueue();
  repo_.reset();  // no database handle crosses fork()

  int completions_pipe[2], victim_pipe[2];
  ASSERT_EQ(pipe(completions_pipe), 0);
  ASSERT_EQ(pipe(victim_pipe), 0);
  // The victim leases one job, tells the parent which, and waits to be killed with the lease held.
  const pid_t victim = fork();
  ASSERT_GE(victim, 0);
  if (victim == 0) {
    auto repository = OpenRepository(url_, OpenOptions{1, std::chrono::milliseconds(10000)});
    std::int64_t id = -1;
    if (repository.ok()) {
      auto lease = (*repository)->LeaseJob("victim", milliseconds(500), "");
      if (lease.ok() && lease->has_value()) id = (*lease)->job.job_id;
    }
    (void)!write(victim_pipe[1], &id, sizeof(id));
    pause();
    _exit(0);
  }
  std::int64_t victim_job = -1;
  ASSERT_EQ(read(victim_pipe[0], &victim_job, sizeof(victim_job)), static_cast<ssize_t>(sizeof(victim_job)));
  ASSERT_GT(victim_job, 0);
  kill(victim, SIGKILL);
  waitpid(victim, nullptr, 0);

  std::vector<pid_t> workers;
  for (int w = 0; w < kWorkers; ++w) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(completions_pipe[0]);
      auto repository = OpenRepository(url_, OpenOptions{1, std::chrono::milliseconds(10000)});
      if (!repository.ok()) _exit(2);
      DrainQueue(**repository, "process-" + std::to_string(w), [&](std::int64_t id) {
        (void)!write(completions_pipe[1], &id, sizeof(id));  // atomic: smaller than PIPE_BUF
      });
      _exit(0);
    }
    workers.push_back(pid);
  }
  close(completions_pipe[1]);
  std::map<std::int64_t, int> completions;
  std::int64_t id = 0;
  while (read(completions_pipe[0], &id, sizeof(id)) == static_cast<ssize_t>(sizeof(id))) ++completions[id];
  close(completions_pipe[0]);
  for (pid_t pid : workers) {
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }

  Reopen();
  ASSERT_EQ(completions.size(), static_cast<std::size_t>(kJobs));
  for (const auto& [job, count] : completions) EXPECT_EQ(count, 1) << "job " << job;
  auto retaken = repo().GetJob(victim_job);
  EXPECT_EQ(retaken->state, JobState::kDone);
  EXPECT_EQ(retaken->attempts, 2) << "the killed worker's lease expired and another worker took the job";
}

INSTANTIATE_TEST_SUITE_P(Backends, JobQueueContractTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

}  // namespace
}  // namespace storage::testing
