// SqlRepository: erasure of a robot, retention of raw runs and finished jobs, and the audit log that records
// each. Erasure is one write transaction (nothing half-deleted); retention works in bounded batches so the
// write lock is held briefly and the caller loops until a batch comes back empty.
#include <limits>

#include "blob_codec.h"
#include "sql_repository.h"

namespace storage::internal {
namespace {

constexpr int kMaxBatch = 10000;

/// Counts the rows `where_sql` selects in `table`, then deletes them.
Result<std::int64_t> CountAndDelete(SqlTransaction& transaction, const std::string& table,
                                    const std::string& where_sql, const std::vector<SqlValue>& params) {
  ASSIGN_OR_RETURN(auto counted,
                   transaction.Query("SELECT COUNT(*) FROM " + table + " WHERE " + where_sql, params));
  RETURN_IF_ERROR(transaction.Exec("DELETE FROM " + table + " WHERE " + where_sql, params));
  return counted.front().Int(0);
}

std::string ErasureJson(const RobotErasure& e) {
  const std::pair<const char*, std::int64_t> fields[] = {{"runs", e.runs},
                                                         {"reports", e.reports},
                                                         {"decisions", e.decisions},
                                                         {"ambiguous_views", e.ambiguous_views},
                                                         {"protrusion_regions", e.protrusion_regions},
                                                         {"map_versions", e.map_versions},
                                                         {"map_findings", e.map_findings},
                                                         {"map_metadata", e.map_metadata},
                                                         {"snapshots", e.snapshots},
                                                         {"jobs", e.jobs},
                                                         {"credentials", e.credentials}};
  std::string json = "{";
  for (const auto& [name, count] : fields) {
    if (json.size() > 1) json += ",";
    json += "\"" + std::string(name) + "\":" + std::to_string(count);
  }
  return json + "}";
}

AuditEntry AuditFromRow(const SqlRow& row) {
  return AuditEntry{row.Int(0), row.Int(1), row.Text(2), row.Text(3), row.Text(4), row.Text(5)};
}

}  // namespace

Result<AuditEntry> SqlRepository::AppendAuditIn(SqlTransaction& transaction, const AuditEntry& entry) {
  RETURN_IF_ERROR(CheckText(entry.actor, "audit actor", 256));
  RETURN_IF_ERROR(CheckText(entry.action, "audit action", 128));
  RETURN_IF_ERROR(CheckText(entry.subject, "audit subject", 256));
  RETURN_IF_ERROR(CheckText(entry.detail_json, "audit detail_json", 64 * 1024));
  if (entry.actor.empty() || entry.action.empty()) {
    return InvalidArgument("an audit entry needs an actor and an action");
  }
  AuditEntry stored = entry;
  if (stored.at_ms == 0) stored.at_ms = NowMs();
  ASSIGN_OR_RETURN(
      auto rows,
      transaction.Query(
          "INSERT INTO audit_log (at_ms, actor, action, subject, detail_json) VALUES ($1, $2, $3, $4, $5) "
          "RETURNING entry_id",
          {stored.at_ms, stored.actor, stored.action, stored.subject, stored.detail_json}));
  stored.entry_id = rows.front().Int(0);
  return stored;
}

Result<AuditEntry> SqlRepository::AppendAudit(const AuditEntry& entry) {
  AuditEntry stored;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto appended, AppendAuditIn(transaction, entry));
    stored = appended;
    return Status::Ok();
  }));
  return stored;
}

Result<std::vector<AuditEntry>> SqlRepository::ListAudit(int limit, std::optional<std::int64_t> before_id) {
  if (limit < 1 || limit > 1000) return InvalidArgument("limit must be in 1..1000");
  std::vector<AuditEntry> entries;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "SELECT entry_id, at_ms, actor, action, subject, detail_json FROM audit_log WHERE entry_id < $1 "
            "ORDER BY entry_id DESC LIMIT $2",
            {before_id.value_or(std::numeric_limits<std::int64_t>::max()), std::int64_t{limit}}));
    for (const SqlRow& row : rows) entries.push_back(AuditFromRow(row));
    return Status::Ok();
  }));
  return entries;
}

Result<RobotErasure> SqlRepository::DeleteRobot(const std::string& robot_id, const std::string& actor) {
  if (robot_id.empty()) return InvalidArgument("robot_id is empty");
  RETURN_IF_ERROR(CheckText(robot_id, "robot_id", 128));
  RobotErasure erased;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    // The robot's row lock: a concurrent map append for it waits, then finds no robot.
    ASSIGN_OR_RETURN(
        auto locked,
        transaction.Query("UPDATE robots SET robot_id = robot_id WHERE robot_id = $1 RETURNING robot_id",
                          {robot_id}));
    if (locked.empty()) return NotFound("no robot " + robot_id);
    const std::vector<SqlValue> robot = {robot_id};

    // Snapshots the robot named; those nobody else names are deleted once its rows are gone.
    ASSIGN_OR_RETURN(
        auto candidates,
        transaction.Query(
            "SELECT parent_snapshot_id FROM runs WHERE robot_id = $1 AND parent_snapshot_id IS NOT NULL "
            "UNION "
            "SELECT child_snapshot_id FROM runs WHERE robot_id = $1 AND child_snapshot_id IS NOT NULL UNION "
            "SELECT snapshot_id FROM map_versions WHERE robot_id = $1",
            robot));

    struct Step {
      const char* table;
      const char* where;
      std::int64_t* count;
    };
    // Children before parents (foreign keys); a job of another robot whose parent goes loses the link.
    RETURN_IF_ERROR(
        transaction.Exec("UPDATE jobs SET parent_job_id = NULL WHERE parent_job_id IN (SELECT job_id FROM "
                         "jobs WHERE robot_id = $1) "
                         "AND (robot_id IS NULL OR robot_id <> $1)",
                         robot));
    RETURN_IF_ERROR(RemoveRobotFromRollup(transaction, robot_id));
    std::int64_t child_jobs = 0;
    const Step steps[] = {
        {"decisions", "robot_id = $1", &erased.decisions},
        {"ambiguous_views", "robot_id = $1", &erased.ambiguous_views},
        {"protrusion_regions", "robot_id = $1", &erased.protrusion_regions},
        {"reports", "robot_id = $1", &erased.reports},
        {"map_findings", "robot_id = $1", &erased.map_findings},
        {"map_metadata", "robot_id = $1", &erased.map_metadata},
        {"map_versions", "robot_id = $1", &erased.map_versions},
        {"runs", "robot_id = $1", &erased.runs},
        {"jobs", "robot_id = $1 AND parent_job_id IS NOT NULL", &child_jobs},
        {"jobs", "robot_id = $1", &erased.jobs},
    };
    for (const Step& step : steps) {
      ASSIGN_OR_RETURN(auto count, CountAndDelete(transaction, step.table, step.where, robot));
      *step.count = count;
    }
    erased.jobs += child_jobs;
    ASSIGN_OR_RETURN(auto credentials,
                     CountAndDelete(transaction, "credentials", "principal = $1", {"robot:" + robot_id}));
    erased.credentials = credentials;
    if (erased.credentials > 0) {
      // The row is gone, so the epoch it takes tells every process polling the epochs to drop its cache.
      RETURN_IF_ERROR(NextCredentialEpoch(transaction).status());
    }
    for (const SqlRow& row : candidates) {
      ASSIGN_OR_RETURN(
          auto deleted,
          transaction.Query(
              "DELETE FROM snapshots WHERE snapshot_id = $1 "
              "AND NOT EXISTS (SELECT 1 FROM runs WHERE parent_snapshot_id = $1 OR child_snapshot_id = $1) "
              "AND NOT EXISTS (SELECT 1 FROM map_versions WHERE snapshot_id = $1) RETURNING snapshot_id",
              {row.Text(0)}));
      erased.snapshots += static_cast<std::int64_t>(deleted.size());
    }
    RETURN_IF_ERROR(transaction.Exec("DELETE FROM robots WHERE robot_id = $1", robot));
    Fault("delete_robot:before_audit");
    ASSIGN_OR_RETURN(auto audited, AppendAuditIn(transaction, AuditEntry{0, 0, actor, "delete_robot",
                                                                         robot_id, ErasureJson(erased)}));
    return Status::Ok();
  }));
  return erased;
}

Result<std::int64_t> SqlRepository::PruneRunTelemetry(std::int64_t uploaded_before_ms, int limit) {
  if (limit < 1 || limit > kMaxBatch) return InvalidArgument("limit must be in 1..10000");
  static const EncodedBlob kEmpty = EncodeBlob("");
  return CountReturnedRows(
      "UPDATE runs SET telemetry = $1, telemetry_crc32 = $2, telemetry_size = 0, telemetry_pruned_at_ms = $3 "
      "WHERE (robot_id, run_id) IN (SELECT robot_id, run_id FROM runs WHERE telemetry_pruned_at_ms IS NULL "
      "AND uploaded_at_ms < $4 ORDER BY uploaded_at_ms LIMIT $5) RETURNING run_id",
      {SqlBlob{kEmpty.compressed}, kEmpty.crc32, NowMs(), uploaded_before_ms, std::int64_t{limit}});
}

Result<std::int64_t> SqlRepository::PruneFinishedJobs(std::int64_t finished_before_ms, int limit) {
  if (limit < 1 || limit > kMaxBatch) return InvalidArgument("limit must be in 1..10000");
  // A parent goes in a later batch than its last child (the foreign key), never before.
  return CountReturnedRows(
      "DELETE FROM jobs WHERE job_id IN (SELECT j.job_id FROM jobs j WHERE j.state IN ('done', 'failed', "
      "'cancelled') AND j.updated_at_ms < $1 AND NOT EXISTS (SELECT 1 FROM jobs c WHERE c.parent_job_id = "
      "j.job_id) "
      "ORDER BY j.job_id LIMIT $2) RETURNING job_id",
      {finished_before_ms, std::int64_t{limit}});
}

Result<std::int64_t> SqlRepository::CountReturnedRows(const std::string& sql,
                                                      const std::vector<SqlValue>& params) {
  std::int64_t count = 0;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(sql, params));
    count = static_cast<std::int64_t>(rows.size());
    return Status::Ok();
  }));
  return count;
}

}  // namespace storage::internal
