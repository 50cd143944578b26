// SqlRepository: the Repository written once over SqlDatabase, for both SQLite and PostgreSQL. The SQL uses
// the subset both databases share (ON CONFLICT, RETURNING, CAST, CASE); the one dialect difference in a
// statement is the job lease's FOR UPDATE SKIP LOCKED (SQLite's write lock already serialises leases).
//
// Thread safety: as Repository; all state is in the database. The fault hook is set before sharing.
#pragma once

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "blob_codec.h"
#include "sql_database.h"
#include "storage/repository.h"

namespace storage::internal {

class SqlRepository final : public Repository {
 public:
  /// Takes a database that MigrateToLatest already brought to the latest schema.
  explicit SqlRepository(std::unique_ptr<SqlDatabase> database) : database_(std::move(database)) {}

  /// Tests only: called at named points inside write transactions (e.g. "insert_run:before_commit") so a
  /// test can kill the process mid-transaction.
  void SetFaultHookForTesting(std::function<void(const std::string& point)> hook) {
    fault_hook_ = std::move(hook);
  }
  SqlDatabase& database() { return *database_; }

  Result<std::int64_t> SchemaVersion() override;

  Status PutRobot(const RobotRecord& robot) override;
  Result<RobotRecord> GetRobot(const std::string& robot_id) override;
  Result<std::vector<RobotRecord>> ListRobots() override;
  Result<RobotSummaryPage> ListRobotSummaries(const RobotSummaryQuery& query) override;
  Result<RobotMapSummary> GetRobotSummary(const std::string& robot_id) override;
  Status SetCredential(const std::string& principal, const std::string& secret) override;
  Result<bool> VerifyCredential(const std::string& principal, const std::string& secret) override;
  Status RevokeCredential(const std::string& principal) override;
  Result<std::vector<CredentialRecord>> ListCredentials(const std::string& prefix, const std::string& after,
                                                        int limit, bool active_only) override;
  Result<CredentialChanges> CredentialChangesSince(std::int64_t since, int limit) override;
  Status ProbeWrite(const std::string& prober) override;
  std::optional<WriteFailure> LastWriteFailure() const override;

  Result<std::string> PutSnapshot(const std::string& bytes) override;
  Result<SnapshotRecord> GetSnapshot(const std::string& snapshot_id) override;

  Result<InsertOutcome> InsertRun(const RunRecord& run) override;
  Result<StoredUpload> StoreUpload(const UploadBundle& upload) override;
  Result<RunRecord> GetRun(const RunKey& key) override;
  Result<std::vector<std::string>> ListRunRobots(const std::string& run_id, int limit) override;
  Result<RunPage> ListRuns(const RunFilter& filter, int page_size,
                           const std::optional<RunCursor>& after) override;

  Result<InsertOutcome> PutParameterSet(const ParameterSetRecord& parameter_set) override;
  Result<ParameterSetRecord> GetParameterSet(const std::string& name) override;
  Result<std::vector<std::string>> ListParameterSetNames() override;
  Result<InsertOutcome> PutModel(const ModelRecord& model) override;
  Result<ModelRecord> GetModel(const std::string& name, std::int64_t version) override;
  Result<ModelRecord> GetActiveModel(const std::string& name) override;
  Status ActivateModel(const std::string& name, std::int64_t version) override;

  Status PutReport(const ReportBundle& bundle) override;
  Result<ReportRecord> GetReport(const RunKey& run, const std::string& parameter_set) override;
  Result<std::vector<std::string>> ListReportParameterSets(const RunKey& run) override;
  Result<std::vector<DecisionRecord>> ListDecisions(const RunKey& run,
                                                    const std::string& parameter_set) override;
  Result<std::vector<AmbiguousViewRecord>> ListAmbiguousViews(const RunKey& run,
                                                              const std::string& parameter_set) override;
  Result<std::vector<ProtrusionRegionRecord>> ListProtrusionRegions(
      const RunKey& run, const std::string& parameter_set) override;
  Status LabelProtrusionRegion(const RunKey& run, const std::string& parameter_set, std::int64_t region_id,
                               const std::string& label, const std::string& labelled_by) override;
  Result<std::vector<ProtrusionRegionRecord>> ListLabelledRegions(const std::string& parameter_set,
                                                                  int limit) override;

  Result<FleetStatistics> Aggregate(const RunFilter& filter) override;
  Result<std::vector<GroupStatistics>> AggregateBy(const RunFilter& filter, GroupBy group_by) override;
  Result<ReportPairPage> ListReportPairs(const RunFilter& filter, const std::string& set_a,
                                         const std::string& set_b, int page_size,
                                         const std::optional<RunCursor>& after, ReportPairScan scan) override;
  Status InsertRuns(const std::vector<RunRecord>& runs) override;
  Status PutReports(const std::vector<ReportBundle>& bundles) override;
  /// Tests only: the statistics read from the reports themselves, as without the roll-up.
  Result<std::vector<GroupStatistics>> AggregateFromReportsForTesting(const RunFilter& filter,
                                                                      std::optional<GroupBy> group_by);

  Result<MapVersionRecord> AppendMapVersion(const MapVersionRecord& version,
                                            std::optional<std::int64_t> expected_head,
                                            const std::vector<MapFindingRecord>& findings) override;
  Result<std::vector<MapVersionRecord>> ListMapVersions(const std::string& robot_id) override;
  Result<std::optional<MapVersionRecord>> GetCurrentMapVersion(const std::string& robot_id) override;
  Result<std::optional<MapVersionRecord>> FindMapVersionOfSnapshot(const std::string& robot_id,
                                                                   const std::string& snapshot_id) override;
  Result<std::string> GetMapMetadata(const std::string& robot_id, std::int64_t version) override;
  Result<MapVersionRecord> GetMapVersion(const std::string& robot_id, std::int64_t version) override;
  Result<MapVersionRecord> GetMapVersionOfRun(const RunKey& run) override;
  Result<std::vector<MapFindingRecord>> ListMapFindings(const std::string& robot_id,
                                                        std::int64_t version) override;
  Status UpdateMapVersionHealth(const std::string& robot_id, std::int64_t version, double known_area_m2,
                                const std::vector<MapFindingRecord>& findings) override;
  Result<MapVersionRecord> ReviewMapVersion(const std::string& robot_id, std::int64_t version, bool approve,
                                            const std::string& reviewed_by) override;

  Result<std::int64_t> EnqueueJob(const NewJob& job) override;
  Result<std::optional<JobLease>> LeaseJob(const std::string& worker,
                                           std::chrono::milliseconds lease_duration,
                                           const std::string& kind) override;
  Status HeartbeatJob(const JobLease& lease, std::chrono::milliseconds lease_duration) override;
  Status UpdateJobProgress(const JobLease& lease, std::int64_t done, std::int64_t total) override;
  Status CompleteJob(const JobLease& lease) override;
  Status FailJob(const JobLease& lease, const std::string& error) override;
  Status CancelJob(std::int64_t job_id) override;
  Result<JobRecord> GetJob(std::int64_t job_id) override;
  Result<std::vector<JobRecord>> ListJobs(std::optional<JobState> state, int limit) override;

  Result<RobotErasure> DeleteRobot(const std::string& robot_id, const std::string& actor) override;
  Result<std::int64_t> PruneRunTelemetry(std::int64_t uploaded_before_ms, int limit) override;
  Result<std::int64_t> PruneFinishedJobs(std::int64_t finished_before_ms, int limit) override;
  Result<AuditEntry> AppendAudit(const AuditEntry& entry) override;
  Result<std::vector<AuditEntry>> ListAudit(int limit, std::optional<std::int64_t> before_id) override;

 private:
  Status Write(const std::function<Status(SqlTransaction&)>& body) {
    Status status = database_->InTransaction(TransactionMode::kWrite, body);
    if (status.code() == StatusCode::kUnavailable) NoteWriteFailure(status);
    return status;
  }
  void NoteWriteFailure(const Status& status);
  /// The robot's ($1) newest version meeting `condition` (SQL over map_versions' columns, its parameters from
  /// $2 on).
  Result<std::optional<MapVersionRecord>> NewestMapVersionWhere(const std::string& condition,
                                                                const std::vector<SqlValue>& params);
  Status Read(const std::function<Status(SqlTransaction&)>& body) {
    return database_->InTransaction(TransactionMode::kRead, body);
  }
  void Fault(const std::string& point) const {
    if (fault_hook_) fault_hook_(point);
  }
  /// Inserts a payload-bearing row unless the key exists; returns kAlreadyPresent when the stored digest
  /// equals `sha256`, ALREADY_EXISTS when it differs.
  Result<InsertOutcome> CompareExisting(SqlTransaction& transaction, const std::string& select_digest_sql,
                                        const std::vector<SqlValue>& key, const std::string& sha256,
                                        const std::string& what);

  /// Runs one write statement with RETURNING in its own transaction; how many rows it returned.
  Result<std::int64_t> CountReturnedRows(const std::string& sql, const std::vector<SqlValue>& params);
  /// One run or report written inside `transaction` (the single and the batched writes share them); the
  /// digest and blobs are computed before the transaction so its lock is held briefly.
  Result<InsertOutcome> InsertRunIn(SqlTransaction& transaction, const RunRecord& run,
                                    const std::string& digest, const EncodedBlob& telemetry);
  // The writes StoreUpload combines, each also its own method's transaction body. Checks and encoding happen
  // before the transaction (CheckRobot, CheckJob, CheckMapVersion, EncodeNewSnapshots).
  Status PutRobotIn(SqlTransaction& transaction, const RobotRecord& robot);
  struct EncodedSnapshot {
    std::string id;
    EncodedBlob blob;
  };
  struct SnapshotsToStore {
    std::vector<std::string> ids;         // every snapshot's id, in order
    std::vector<EncodedSnapshot> absent;  // those not stored yet, each once, compressed
  };
  /// Hashes the snapshots and compresses those the database does not hold yet (a read transaction).
  Result<SnapshotsToStore> EncodeNewSnapshots(const std::vector<const std::string*>& snapshots);
  Status PutSnapshotIn(SqlTransaction& transaction, const EncodedSnapshot& snapshot);
  Result<std::int64_t> EnqueueJobIn(SqlTransaction& transaction, const NewJob& job);
  Result<MapVersionRecord> AppendMapVersionIn(SqlTransaction& transaction, const MapVersionRecord& version,
                                              std::optional<std::int64_t> expected_head,
                                              const std::vector<MapFindingRecord>& findings,
                                              const EncodedBlob& metadata);
  Status PutReportIn(SqlTransaction& transaction, const ReportBundle& bundle, const EncodedBlob& blob);
  /// Without `group_by`: the total as one group (none when no report matches).
  Result<std::vector<GroupStatistics>> AggregateBy(const RunFilter& filter, std::optional<GroupBy> group_by);
  Result<std::vector<GroupStatistics>> AggregateFromReports(SqlTransaction& transaction,
                                                            const RunFilter& filter,
                                                            std::optional<GroupBy> group_by);
  /// Appends `entry` inside `transaction` (DeleteRobot's audit entry commits with the deletion).
  Result<AuditEntry> AppendAuditIn(SqlTransaction& transaction, const AuditEntry& entry);

  std::unique_ptr<SqlDatabase> database_;
  std::function<void(const std::string&)> fault_hook_;
  mutable std::mutex write_failure_mutex_;  // guards write_failure_
  std::optional<WriteFailure> write_failure_;
};

/// credentials.algorithm of a revoked credential (salt and hash are emptied).
inline constexpr const char* kRevokedAlgorithm = "revoked";

/// Takes the next credential epoch inside a write transaction. The counter's row lock (PostgreSQL) or the
/// write lock (SQLite) is held until commit, so epochs commit in order.
Result<std::int64_t> NextCredentialEpoch(SqlTransaction& transaction);

/// The argument checks of PutRobot, EnqueueJob and AppendMapVersion (INVALID_ARGUMENT naming the field).
/// A robot from its columns (robot_id, robot_model, firmware, registered_at_ms) at the row's start.
RobotRecord RobotFromRow(const SqlRow& row);
Status CheckRobot(const RobotRecord& robot);
Status CheckJob(const NewJob& job);
Status CheckMapVersion(const MapVersionRecord& version, const std::vector<MapFindingRecord>& findings);

/// Milliseconds since the Unix epoch, from the system clock.
std::int64_t NowMs();

/// Rejects strings the databases cannot store as TEXT (NUL bytes) or that exceed `max_bytes`.
Status CheckText(const std::string& value, const std::string& field, std::size_t max_bytes = 1024);

/// The state a TEXT column holds (records.h's name tables); DATA_LOSS naming `where` (the row) and the stored
/// spelling when it is none of E's: a corrupt value is reported, never read as some default.
template <typename E>
Result<E> StoredState(const SqlRow& row, std::size_t column, const std::string& where) {
  Result<E> parsed = Parse<E>(row.Text(column));
  if (!parsed.ok()) return DataLoss(where + ": stored " + parsed.status().message());
  return parsed;
}

// The statistics roll-up (sql_repository_rollup.cc, migration 7).
/// Adds a written report to the roll-up; `replaced` is the report it replaced (same key), if any.
Status AddReportToRollup(SqlTransaction& transaction, const ReportRecord& report,
                         const std::optional<ReportRecord>& replaced);
/// Takes every report of the robot out of the roll-up (before erasure deletes them).
Status RemoveRobotFromRollup(SqlTransaction& transaction, const std::string& robot_id);
/// The statistics from the roll-up, one group without `group_by` (key ""; none when nothing matches); nullopt
/// when the roll-up cannot answer this filter and grouping exactly (the caller then reads the reports).
std::optional<Result<std::vector<GroupStatistics>>> AggregateFromRollup(SqlTransaction& transaction,
                                                                        const RunFilter& filter,
                                                                        std::optional<GroupBy> group_by);

}  // namespace storage::internal
