// Repository: the one interface to everything the fleet service keeps (robots, credentials, runs, map
// snapshots, reports with their rows, parameter sets, classifier models, map versions with their findings,
// the job queue), with two back-ends: an embedded SQLite file (default) and PostgreSQL (scale-out). One
// contract test suite (storage/tests/repository_contract_test.cc) runs against both. Schema: storage/docs/schema.md.
//
// Thread safety: a Repository is safe to use from many threads at once. Every method is one database
// transaction: either all of its writes are stored or none (also when the process is killed). Several
// processes may open the same database (SQLite file or PostgreSQL server); the job queue hands each job to
// at most one live lease across all of them.
//
// Errors: every method returns a Status or Result. Corrupt stored bytes (checksum mismatch) are DATA_LOSS
// and are never returned as data; a busy or unreachable database is UNAVAILABLE; a record referring to a
// missing robot, snapshot or parameter set is FAILED_PRECONDITION; a different payload under an existing
// key is ALREADY_EXISTS. Filter values are always bound as statement parameters, never spliced into SQL.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "storage/records.h"
#include "storage/status.h"

namespace storage {

class Repository {
 public:
  virtual ~Repository() = default;

  /// The schema version of the open database (== LatestSchemaVersion() after a successful open).
  virtual Result<std::int64_t> SchemaVersion() = 0;

  // ---- Robots and credentials ----
  /// Inserts or updates (model, firmware) of a robot; registered_at_ms keeps its first value.
  virtual Status PutRobot(const RobotRecord& robot) = 0;
  /// NOT_FOUND when no such robot.
  virtual Result<RobotRecord> GetRobot(const std::string& robot_id) = 0;
  virtual Result<std::vector<RobotRecord>> ListRobots() = 0;
  /// A page of robots with their map histories in brief, in one read whose cost follows the page, not the
  /// fleet's runs or the robots' history lengths. INVALID_ARGUMENT for a limit outside 1..kMaxRobotPage.
  virtual Result<RobotSummaryPage> ListRobotSummaries(const RobotSummaryQuery& query) = 0;
  /// One robot's row of that page; NOT_FOUND when no such robot.
  virtual Result<RobotMapSummary> GetRobotSummary(const std::string& robot_id) = 0;
  /// Stores a salted SHA-256 of `secret` for `principal` (a robot or a user), replacing the previous one.
  /// The secret itself is never stored. Secrets are tokens of 256 random bits (server/auth.h), so a fast
  /// hash suffices and makes checking cheap. Credentials stored as PBKDF2 by older versions are still
  /// verified, and rewritten as salted SHA-256 on their first successful check.
  virtual Status SetCredential(const std::string& principal, const std::string& secret) = 0;
  /// True when `secret` matches; false when it does not or the principal has no credential (after the
  /// same work as a check, so unknown principals cannot be told apart by timing).
  virtual Result<bool> VerifyCredential(const std::string& principal, const std::string& secret) = 0;
  /// Revokes the principal's credential: its token is refused from the commit on (the row stays, marked
  /// revoked, for the listing). NOT_FOUND when it has none; revoking a revoked one is OK. FAILED_PRECONDITION
  /// when it is the last unrevoked "admin:" principal (nobody could mint tokens any more).
  virtual Status RevokeCredential(const std::string& principal) = 0;
  /// Credentials whose principal starts with `prefix` (empty: all), sorted, after `after`, at most `limit`
  /// (1..1000). `active_only` leaves revoked ones out.
  virtual Result<std::vector<CredentialRecord>> ListCredentials(const std::string& prefix,
                                                                const std::string& after, int limit,
                                                                bool active_only) = 0;
  /// Principals whose credential changed after `since` (an epoch from an earlier call), at most `limit`;
  /// `since` < 0 returns only the newest epoch (where a new poller starts). Epochs are handed out in commit order, so polling with the returned epoch misses no change:
  /// every process sharing the database can drop the cached tokens of rotated or revoked principals.
  virtual Result<CredentialChanges> CredentialChangesSince(std::int64_t since, int limit) = 0;

  // ---- Health ----
  /// One small write transaction (the health probe): OK when the database accepts writes now. A full disk,
  /// a read-only file or an unreachable server is UNAVAILABLE.
  virtual Status ProbeWrite(const std::string& prober) = 0;
  /// The newest write transaction of this Repository that failed UNAVAILABLE (the database could not take
  /// it), if any: when and why. Successes do not clear it; the health check reads its age.
  virtual std::optional<WriteFailure> LastWriteFailure() const = 0;

  // ---- Map snapshots (content-addressed) ----
  /// Stores the bytes once and returns their id (hex SHA-256); storing the same bytes again is a no-op.
  virtual Result<std::string> PutSnapshot(const std::string& bytes) = 0;
  /// NOT_FOUND, or DATA_LOSS when the stored bytes no longer match their checksum or id.
  virtual Result<SnapshotRecord> GetSnapshot(const std::string& snapshot_id) = 0;

  // ---- Runs ----
  /// A run is (robot_id, run_id): each robot has its own run ids. Idempotent per robot: the same run twice
  /// stores one (kAlreadyPresent); a different payload under the same robot and run_id is ALREADY_EXISTS;
  /// another robot's run of the same id is a different run. The robot and snapshots it names must be
  /// stored (FAILED_PRECONDITION).
  virtual Result<InsertOutcome> InsertRun(const RunRecord& run) = 0;
  /// An upload in one transaction, so a crash or an error stores all of it or nothing: PutRobot, the new
  /// snapshots, InsertRun, the analysis job when the run is new, and AppendMapVersion (no expected head).
  /// A run already present with the same payload stores no second job and returns its map version; a
  /// different payload is ALREADY_EXISTS and nothing is written. One commit instead of five is also what
  /// makes ingest fast: each commit waits for the disk.
  virtual Result<StoredUpload> StoreUpload(const UploadBundle& upload) = 0;
  /// The run with its telemetry (empty when retention pruned it: see telemetry_pruned_at_ms); NOT_FOUND or
  /// DATA_LOSS.
  virtual Result<RunRecord> GetRun(const RunKey& key) = 0;
  /// The robots that have a run of this id, sorted, at most `limit` (1..1000): resolves a run named by id
  /// alone (one robot: that run; several: the caller must name the robot).
  virtual Result<std::vector<std::string>> ListRunRobots(const std::string& run_id, int limit) = 0;
  /// Runs matching the filter ordered by (started_at_ms, run_id, robot_id), at most page_size (1..1000),
  /// after `after` (keyset pagination: stable while runs are added). Telemetry is not loaded.
  virtual Result<RunPage> ListRuns(const RunFilter& filter, int page_size,
                                   const std::optional<RunCursor>& after) = 0;

  // ---- Parameter sets and classifier models (immutable once stored) ----
  /// Idempotent like InsertRun: same bytes under the same name is fine, different bytes ALREADY_EXISTS.
  virtual Result<InsertOutcome> PutParameterSet(const ParameterSetRecord& parameter_set) = 0;
  virtual Result<ParameterSetRecord> GetParameterSet(const std::string& name) = 0;
  virtual Result<std::vector<std::string>> ListParameterSetNames() = 0;
  /// Idempotent per (name, version); when model.active the model becomes the only active one of its name.
  virtual Result<InsertOutcome> PutModel(const ModelRecord& model) = 0;
  virtual Result<ModelRecord> GetModel(const std::string& name, std::int64_t version) = 0;
  /// NOT_FOUND when no version of `name` is active.
  virtual Result<ModelRecord> GetActiveModel(const std::string& name) = 0;
  /// Makes (name, version) the only active version of `name`.
  virtual Status ActivateModel(const std::string& name, std::int64_t version) = 0;

  // ---- Reports (one per run and parameter set) ----
  /// Stores or replaces the report with its decisions, ambiguous views and protrusion regions, all in one
  /// transaction. Labels already given to a region id survive a replacement (a retried analysis).
  virtual Status PutReport(const ReportBundle& bundle) = 0;
  virtual Result<ReportRecord> GetReport(const RunKey& run, const std::string& parameter_set) = 0;
  /// Parameter sets that have a report for this run, sorted.
  virtual Result<std::vector<std::string>> ListReportParameterSets(const RunKey& run) = 0;
  virtual Result<std::vector<DecisionRecord>> ListDecisions(const RunKey& run,
                                                            const std::string& parameter_set) = 0;
  virtual Result<std::vector<AmbiguousViewRecord>> ListAmbiguousViews(const RunKey& run,
                                                                      const std::string& parameter_set) = 0;
  virtual Result<std::vector<ProtrusionRegionRecord>> ListProtrusionRegions(
      const RunKey& run, const std::string& parameter_set) = 0;
  /// Sets the label of one region; NOT_FOUND when the region does not exist.
  virtual Status LabelProtrusionRegion(const RunKey& run, const std::string& parameter_set,
                                       std::int64_t region_id, const std::string& label,
                                       const std::string& labelled_by) = 0;
  /// Labelled regions of a parameter set (empty: all) for classifier training, at most `limit`.
  virtual Result<std::vector<ProtrusionRegionRecord>> ListLabelledRegions(const std::string& parameter_set,
                                                                          int limit) = 0;

  // ---- Fleet statistics (aggregated by the database) ----
  // Read from a roll-up that every report write keeps (storage/docs/schema.md, migration 7), so their cost
  // does not grow with the number of runs, whenever it answers the filter exactly: no robot or time
  // restriction, and firmware or model restricted only where robots can still be counted exactly (the total;
  // grouping by the restricted dimension). Other filters read the reports (indexed, counters only).
  virtual Result<FleetStatistics> Aggregate(const RunFilter& filter) = 0;
  /// One row per group, ordered by key.
  virtual Result<std::vector<GroupStatistics>> AggregateBy(const RunFilter& filter, GroupBy group_by) = 0;
  /// Runs matching `filter` (its parameter_set ignored) that have a report under both sets, in ListRuns
  /// order, at most page_size (1..1000) after `after`; the reports carry their counters only (no bytes).
  /// `scan` chooses what the read walks (ReportPairScan): a page costs the rows walked to fill it.
  virtual Result<ReportPairPage> ListReportPairs(const RunFilter& filter, const std::string& set_a,
                                                 const std::string& set_b, int page_size,
                                                 const std::optional<RunCursor>& after,
                                                 ReportPairScan scan) = 0;

  // ---- Bulk writes (importers and generators): each is one transaction, all or nothing ----
  /// InsertRun for each run, at most 10,000; a run already stored with the same payload is kept.
  virtual Status InsertRuns(const std::vector<RunRecord>& runs) = 0;
  /// PutReport for each bundle, at most 10,000.
  virtual Status PutReports(const std::vector<ReportBundle>& bundles) = 0;

  // ---- Map history (per robot) ----
  /// Appends `version` (its `version` field is ignored) as the robot's newest version, number newest + 1,
  /// with its findings, in one transaction that holds the robot's row lock, so concurrent appends for one
  /// robot never interleave. With `expected_head` set (the version a repair started from), ABORTED unless it
  /// is the robot's head: its newest version that is approved or pending (rejected and stale versions are
  /// side branches that repairs do not continue). A version naming a run_id that already has an upload version returns that one
  /// unchanged (uploads are retried; run ids are per robot). The robot and snapshot must be stored
  /// (FAILED_PRECONDITION).
  virtual Result<MapVersionRecord> AppendMapVersion(const MapVersionRecord& version,
                                                    std::optional<std::int64_t> expected_head,
                                                    const std::vector<MapFindingRecord>& findings) = 0;
  /// The robot's versions, oldest first (empty when it has none).
  virtual Result<std::vector<MapVersionRecord>> ListMapVersions(const std::string& robot_id) = 0;
  virtual Result<MapVersionRecord> GetMapVersion(const std::string& robot_id, std::int64_t version) = 0;
  /// The robot's newest approved version (the map it should run on), none when no version is approved. An
  /// index probe, whatever the history's length: what a robot's daily GetMap and upload read.
  virtual Result<std::optional<MapVersionRecord>> GetCurrentMapVersion(const std::string& robot_id) = 0;
  /// The robot's newest version holding `snapshot_id`, none when no version of this robot holds it.
  virtual Result<std::optional<MapVersionRecord>> FindMapVersionOfSnapshot(
      const std::string& robot_id, const std::string& snapshot_id) = 0;
  /// The metadata stored with a version (MapVersionRecord::metadata); empty when it has none or there is no
  /// such version. DATA_LOSS when the stored bytes are corrupt.
  virtual Result<std::string> GetMapMetadata(const std::string& robot_id, std::int64_t version) = 0;
  /// The upload version made from `run_id`; NOT_FOUND when there is none.
  virtual Result<MapVersionRecord> GetMapVersionOfRun(const RunKey& run) = 0;
  virtual Result<std::vector<MapFindingRecord>> ListMapFindings(const std::string& robot_id,
                                                                std::int64_t version) = 0;
  /// Replaces a version's findings and its open count, and sets its known area: its run's analysis computes
  /// them after the upload (rendering the map would slow ingest down).
  virtual Status UpdateMapVersionHealth(const std::string& robot_id, std::int64_t version,
                                        double known_area_m2,
                                        const std::vector<MapFindingRecord>& findings) = 0;
  /// A pending version becomes "approved" or "rejected"; FAILED_PRECONDITION when it is not pending, or when
  /// approving it would not make it current (a newer version is approved already).
  virtual Result<MapVersionRecord> ReviewMapVersion(const std::string& robot_id, std::int64_t version,
                                                    bool approve, const std::string& reviewed_by) = 0;

  // ---- Job queue ----
  /// Returns the new job id.
  virtual Result<std::int64_t> EnqueueJob(const NewJob& job) = 0;
  /// Atomically takes the oldest queued job (of `kind`; empty: any kind) or a job whose lease expired, for
  /// `lease_duration`. Empty optional when there is none. A job whose lease expired on its last attempt
  /// becomes failed instead. Lease expiry compares clocks of the workers: keep them NTP-synchronised.
  virtual Result<std::optional<JobLease>> LeaseJob(const std::string& worker,
                                                   std::chrono::milliseconds lease_duration,
                                                   const std::string& kind) = 0;
  /// Extends a held lease; FAILED_PRECONDITION when the lease was lost (expired and retaken, cancelled).
  virtual Status HeartbeatJob(const JobLease& lease, std::chrono::milliseconds lease_duration) = 0;
  virtual Status UpdateJobProgress(const JobLease& lease, std::int64_t done, std::int64_t total) = 0;
  /// Marks the job done; FAILED_PRECONDITION when the lease was lost, so a job completes exactly once.
  virtual Status CompleteJob(const JobLease& lease) = 0;
  /// Requeues the job, or marks it failed once it used max_attempts; FAILED_PRECONDITION if lease lost.
  virtual Status FailJob(const JobLease& lease, const std::string& error) = 0;
  /// Cancels a queued or leased job; FAILED_PRECONDITION when it already finished, NOT_FOUND if unknown.
  virtual Status CancelJob(std::int64_t job_id) = 0;
  virtual Result<JobRecord> GetJob(std::int64_t job_id) = 0;
  /// Jobs ordered by id, optionally only those in `state`, at most `limit`.
  virtual Result<std::vector<JobRecord>> ListJobs(std::optional<JobState> state, int limit) = 0;

  // ---- Erasure, retention and the audit log (docs/formats/service.md, "Erasure and retention") ----
  /// Deletes the robot and everything it uploaded or that was derived from it, in one transaction: its
  /// runs, their reports of every parameter set with decisions, ambiguous views and (labelled) regions, its
  /// map versions and findings, the snapshots no other robot's run or map version names, the jobs that
  /// name it, its credential ("robot:<id>"); and appends an audit entry by `actor` with the counts.
  /// NOT_FOUND when no such robot (nothing written).
  virtual Result<RobotErasure> DeleteRobot(const std::string& robot_id, const std::string& actor) = 0;
  /// Retention of raw runs: drops the events (telemetry) of at most `limit` (1..10000) runs uploaded before
  /// `uploaded_before_ms` that still have them; the runs' metadata, reports, snapshots and map versions stay.
  /// Returns how many were pruned (0: none left).
  virtual Result<std::int64_t> PruneRunTelemetry(std::int64_t uploaded_before_ms, int limit) = 0;
  /// Retention of jobs: deletes at most `limit` (1..10000) done, failed or cancelled jobs last updated before
  /// `finished_before_ms` that no remaining job names as parent. Returns how many were deleted.
  virtual Result<std::int64_t> PruneFinishedJobs(std::int64_t finished_before_ms, int limit) = 0;
  /// Appends an entry (entry_id assigned; at_ms assigned when 0); returns it.
  virtual Result<AuditEntry> AppendAudit(const AuditEntry& entry) = 0;
  /// Entries newest first, at most `limit` (1..1000), older than entry `before_id` when set.
  virtual Result<std::vector<AuditEntry>> ListAudit(int limit, std::optional<std::int64_t> before_id) = 0;
};

struct OpenOptions {
  int postgres_pool_size = 4;  // connections kept per Repository (PostgreSQL only)
  std::chrono::milliseconds sqlite_busy_timeout{10000};
};

/// The schema version this program writes and understands.
std::int64_t LatestSchemaVersion();

/// Opens (creating when needed) and migrates a database:
///   "sqlite:/path/to/fleet.db"                              embedded file
///   "postgresql://user@host:port/dbname?..." or "postgres://..."   a libpq connection URL from config
/// Fails with FAILED_PRECONDITION when the database's schema is newer than this program, DATA_LOSS when
/// the file is not a database or is corrupt, UNAVAILABLE when the server cannot be reached,
/// INVALID_ARGUMENT for an unknown URL scheme.
/// Error messages never carry the URL's password: it is replaced by "***" (also when libpq echoes it).
Result<std::unique_ptr<Repository>> OpenRepository(const std::string& url, const OpenOptions& options = {});

/// The URL with its password (the part between "user:" and "@" of a postgresql:// URL) replaced by "***";
/// other URLs unchanged. For logs.
std::string RedactDatabaseUrl(const std::string& url);
/// The URL's password as written (percent-encoded) and decoded; empty when there is none.
std::vector<std::string> DatabaseUrlPasswords(const std::string& url);

}  // namespace storage
