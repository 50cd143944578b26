// SqlRepository: the job queue. A lease is (job, random token, expiry); every later call names the token,
// so a worker whose lease expired and was retaken cannot complete or fail the job any more: each job
// completes exactly once. On PostgreSQL the candidate row is locked FOR UPDATE SKIP LOCKED, so concurrent
// workers on many machines skip each other's candidates instead of queueing behind them; on SQLite the
// write transaction (BEGIN IMMEDIATE) already makes the lease atomic.
#include "crypto.h"
#include "sql_repository.h"

namespace storage::internal {
namespace {

constexpr const char* kJobColumns =
    "job_id, kind, payload, state, attempts, max_attempts, parent_job_id, lease_owner, lease_expires_at_ms, "
    "last_error, progress_done, progress_total, created_at_ms, updated_at_ms, robot_id";

Result<JobRecord> JobFromRow(const SqlRow& row) {
  JobRecord job;
  job.job_id = row.Int(0);
  job.kind = row.Text(1);
  job.payload = row.Text(2);
  ASSIGN_OR_RETURN(job.state, StoredState<JobState>(row, 3, "job " + std::to_string(job.job_id)));
  job.attempts = row.Int(4);
  job.max_attempts = row.Int(5);
  if (!row.IsNull(6)) job.parent_job_id = row.Int(6);
  if (!row.IsNull(7)) job.lease_owner = row.Text(7);
  if (!row.IsNull(8)) job.lease_expires_at_ms = row.Int(8);
  job.last_error = row.Text(9);
  job.progress_done = row.Int(10);
  job.progress_total = row.Int(11);
  job.created_at_ms = row.Int(12);
  job.updated_at_ms = row.Int(13);
  if (!row.IsNull(14)) job.robot_id = row.Text(14);
  return job;
}

Status LeaseLost(const JobLease& lease) {
  return FailedPrecondition("the lease on job " + std::to_string(lease.job.job_id) +
                            " is no longer held (it expired and was retaken, or the job was cancelled)");
}

}  // namespace

Status CheckJob(const NewJob& job) {
  if (job.kind.empty()) return InvalidArgument("job kind is empty");
  RETURN_IF_ERROR(CheckText(job.kind, "job kind", 128));
  if (job.max_attempts < 1) return InvalidArgument("job max_attempts must be at least 1");
  if (job.progress_total < 0) return InvalidArgument("job progress_total is negative");
  if (job.robot_id) RETURN_IF_ERROR(CheckText(*job.robot_id, "job robot_id", 128));
  return Status::Ok();
}

Result<std::int64_t> SqlRepository::EnqueueJobIn(SqlTransaction& transaction, const NewJob& job) {
  const std::int64_t now = NowMs();
  SqlValue parent = SqlNull{};
  if (job.parent_job_id) parent = *job.parent_job_id;
  ASSIGN_OR_RETURN(
      auto rows,
      transaction.Query("INSERT INTO jobs (kind, payload, state, attempts, max_attempts, parent_job_id, "
                        "last_error, progress_done, "
                        "progress_total, created_at_ms, updated_at_ms, robot_id) VALUES ($1, $2, 'queued', "
                        "0, $3, $4, '', 0, $5, $6, "
                        "$6, $7) RETURNING job_id",
                        {job.kind, SqlBlob{job.payload}, job.max_attempts, parent, job.progress_total, now,
                         job.robot_id ? SqlValue{*job.robot_id} : SqlValue{SqlNull{}}}));
  return rows.front().Int(0);
}

Result<std::int64_t> SqlRepository::EnqueueJob(const NewJob& job) {
  RETURN_IF_ERROR(CheckJob(job));
  std::int64_t job_id = 0;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(job_id, EnqueueJobIn(transaction, job));
    return Status::Ok();
  }));
  return job_id;
}

Result<std::optional<JobLease>> SqlRepository::LeaseJob(const std::string& worker,
                                                        std::chrono::milliseconds lease_duration,
                                                        const std::string& kind) {
  RETURN_IF_ERROR(CheckText(worker, "worker", 256));
  if (lease_duration.count() <= 0) return InvalidArgument("lease duration must be positive");
  const std::string skip_locked = database_->dialect() == Dialect::kPostgres ? " FOR UPDATE SKIP LOCKED" : "";
  const std::string token = HexEncode(RandomBytes(16));
  std::optional<JobLease> lease;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    const std::int64_t now = NowMs();
    // A job whose lease expired on its last attempt is not retried: it failed.
    RETURN_IF_ERROR(transaction.Exec(
        "UPDATE jobs SET state = 'failed', lease_token = NULL, lease_expires_at_ms = NULL, updated_at_ms = "
        "$1, "
        "last_error = 'the lease expired on the last attempt (worker died or hung)' "
        "WHERE job_id IN (SELECT job_id FROM jobs WHERE state = 'leased' AND lease_expires_at_ms < $1 "
        "AND attempts >= max_attempts" +
            skip_locked + ")",
        {now}));
    // The lowest job id among the queued jobs and the expired leases, each looked up on its own so that an
    // index gives it in job id order: one OR over both made SQLite collect and sort every queued job on
    // every lease, which grew with the backlog.
    const std::string of_kind = kind.empty() ? "" : "kind = $1 AND ";
    const std::string rest = " AND attempts < max_attempts ORDER BY job_id LIMIT 1" + skip_locked;
    std::vector<SqlValue> params;
    if (!kind.empty()) params.emplace_back(kind);
    const std::string expired =
        "state = 'leased' AND lease_expires_at_ms < $" + std::to_string(params.size() + 1);
    std::optional<std::int64_t> job_id;
    for (const bool queued : {true, false}) {
      std::vector<SqlValue> bound = params;
      if (!queued) bound.emplace_back(now);
      ASSIGN_OR_RETURN(auto candidates,
                       transaction.Query("SELECT job_id FROM jobs WHERE " + of_kind +
                                             (queued ? std::string("state = 'queued'") : expired) + rest,
                                         bound));
      if (!candidates.empty() && (!job_id || candidates.front().Int(0) < *job_id))
        job_id = candidates.front().Int(0);
    }
    if (!job_id) return Status::Ok();
    ASSIGN_OR_RETURN(auto rows,
                     transaction.Query("UPDATE jobs SET state = 'leased', attempts = attempts + 1, "
                                       "lease_owner = $1, lease_token = $2, lease_expires_at_ms = $3, "
                                       "updated_at_ms = $4 WHERE job_id = $5 RETURNING " +
                                           std::string(kJobColumns),
                                       {worker, token, now + lease_duration.count(), now, *job_id}));
    if (!rows.empty()) {
      ASSIGN_OR_RETURN(auto job, JobFromRow(rows.front()));
      lease = JobLease{std::move(job), token};
    }
    return Status::Ok();
  }));
  return lease;
}

Status SqlRepository::HeartbeatJob(const JobLease& lease, std::chrono::milliseconds lease_duration) {
  if (lease_duration.count() <= 0) return InvalidArgument("lease duration must be positive");
  return Write([&](SqlTransaction& transaction) -> Status {
    const std::int64_t now = NowMs();
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("UPDATE jobs SET lease_expires_at_ms = $3, updated_at_ms = $4 "
                          "WHERE job_id = $1 AND lease_token = $2 AND state = 'leased' RETURNING job_id",
                          {lease.job.job_id, lease.lease_token, now + lease_duration.count(), now}));
    return rows.empty() ? LeaseLost(lease) : Status::Ok();
  });
}

Status SqlRepository::UpdateJobProgress(const JobLease& lease, std::int64_t done, std::int64_t total) {
  if (done < 0 || total < 0) return InvalidArgument("job progress is negative");
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("UPDATE jobs SET progress_done = $3, progress_total = $4, updated_at_ms = $5 "
                          "WHERE job_id = $1 AND lease_token = $2 AND state = 'leased' RETURNING job_id",
                          {lease.job.job_id, lease.lease_token, done, total, NowMs()}));
    return rows.empty() ? LeaseLost(lease) : Status::Ok();
  });
}

Status SqlRepository::CompleteJob(const JobLease& lease) {
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("UPDATE jobs SET state = 'done', lease_token = NULL, lease_expires_at_ms = NULL, "
                          "updated_at_ms = $3 "
                          "WHERE job_id = $1 AND lease_token = $2 AND state = 'leased' RETURNING job_id",
                          {lease.job.job_id, lease.lease_token, NowMs()}));
    if (rows.empty()) return LeaseLost(lease);
    Fault("complete_job:before_commit");
    return Status::Ok();
  });
}

Status SqlRepository::FailJob(const JobLease& lease, const std::string& error) {
  const std::string message = error.substr(0, 4096);
  RETURN_IF_ERROR(CheckText(message, "job error"));
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "UPDATE jobs SET state = CASE WHEN attempts >= max_attempts THEN 'failed' ELSE 'queued' END, "
            "last_error = $3, lease_token = NULL, lease_expires_at_ms = NULL, updated_at_ms = $4 "
            "WHERE job_id = $1 AND lease_token = $2 AND state = 'leased' RETURNING job_id",
            {lease.job.job_id, lease.lease_token, message, NowMs()}));
    return rows.empty() ? LeaseLost(lease) : Status::Ok();
  });
}

Status SqlRepository::CancelJob(std::int64_t job_id) {
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows,
                     transaction.Query("UPDATE jobs SET state = 'cancelled', lease_token = NULL, "
                                       "lease_expires_at_ms = NULL, updated_at_ms = $2 "
                                       "WHERE job_id = $1 AND state IN ('queued', 'leased') RETURNING job_id",
                                       {job_id, NowMs()}));
    if (!rows.empty()) return Status::Ok();
    ASSIGN_OR_RETURN(auto state, transaction.Query("SELECT state FROM jobs WHERE job_id = $1", {job_id}));
    if (state.empty()) return NotFound("no job " + std::to_string(job_id));
    return FailedPrecondition("job " + std::to_string(job_id) + " is already " + state.front().Text(0));
  });
}

Result<JobRecord> SqlRepository::GetJob(std::int64_t job_id) {
  std::optional<JobRecord> job;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE job_id = $1", {job_id}));
    if (!rows.empty()) {
      ASSIGN_OR_RETURN(job, JobFromRow(rows.front()));
    }
    return Status::Ok();
  }));
  if (!job) return NotFound("no job " + std::to_string(job_id));
  return *job;
}

Result<std::vector<JobRecord>> SqlRepository::ListJobs(std::optional<JobState> state, int limit) {
  if (limit < 1) return InvalidArgument("limit must be positive");
  std::vector<JobRecord> jobs;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows, transaction.Query(
                       std::string("SELECT ") + kJobColumns +
                           " FROM jobs WHERE (CAST($1 AS TEXT) = '' OR state = $1) ORDER BY job_id LIMIT $2",
                       {std::string(state ? Name(*state) : ""), std::int64_t{limit}}));
    for (const SqlRow& row : rows) {
      ASSIGN_OR_RETURN(auto job, JobFromRow(row));
      jobs.push_back(std::move(job));
    }
    return Status::Ok();
  }));
  return jobs;
}

}  // namespace storage::internal
