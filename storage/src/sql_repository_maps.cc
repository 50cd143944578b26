// SqlRepository: map versions per robot and their findings.
#include "sql_repository.h"

#include "blob_codec.h"

namespace storage::internal {
namespace {

constexpr const char* kVersionColumns =
    "SELECT robot_id, version, parent_version, snapshot_id, origin, run_id, action, action_detail, "
    "created_by, "
    "reason, created_at_ms, approval, approved_by, approved_at_ms, nodes, edges, observation_edges, views, "
    "components, known_area_m2, chi2, open_findings FROM map_versions ";

/// "" for a version without an action (uploads).
std::string ActionText(const std::optional<MapAction>& action) {
  return action ? std::string(Name(*action)) : "";
}

Result<MapVersionRecord> VersionFromRow(const SqlRow& row) {
  MapVersionRecord version;
  version.robot_id = row.Text(0);
  version.version = row.Int(1);
  const std::string where =
      "map version " + std::to_string(version.version) + " of robot " + version.robot_id;
  if (!row.IsNull(2)) version.parent_version = row.Int(2);
  version.snapshot_id = row.Text(3);
  ASSIGN_OR_RETURN(version.origin, StoredState<MapOrigin>(row, 4, where));
  if (!row.IsNull(5)) version.run_id = row.Text(5);
  if (!row.Text(6).empty()) {
    ASSIGN_OR_RETURN(version.action, StoredState<MapAction>(row, 6, where));
  }
  version.action_detail = row.Text(7);
  version.created_by = row.Text(8);
  version.reason = row.Text(9);
  version.created_at_ms = row.Int(10);
  ASSIGN_OR_RETURN(version.approval, StoredState<MapApproval>(row, 11, where));
  version.approved_by = row.Text(12);
  version.approved_at_ms = row.Int(13);
  version.nodes = row.Int(14);
  version.edges = row.Int(15);
  version.observation_edges = row.Int(16);
  version.views = row.Int(17);
  version.components = row.Int(18);
  version.known_area_m2 = row.Real(19);
  version.chi2 = row.Real(20);
  version.open_findings = row.Int(21);
  return version;
}

Result<std::vector<MapVersionRecord>> VersionsFromRows(const SqlRows& rows) {
  std::vector<MapVersionRecord> versions;
  for (const SqlRow& row : rows) {
    ASSIGN_OR_RETURN(auto version, VersionFromRow(row));
    versions.push_back(std::move(version));
  }
  return versions;
}

Status CheckVersion(const MapVersionRecord& version) {
  if (version.robot_id.empty()) return InvalidArgument("map version robot_id is empty");
  RETURN_IF_ERROR(CheckText(version.robot_id, "map version robot_id", 128));
  if (version.snapshot_id.empty()) return InvalidArgument("map version snapshot_id is empty");
  RETURN_IF_ERROR(CheckText(version.snapshot_id, "map version snapshot_id", 64));
  if (version.origin == MapOrigin::kUpload && version.run_id.empty()) {
    return InvalidArgument("an upload map version needs run_id");
  }
  RETURN_IF_ERROR(CheckText(version.run_id, "map version run_id", 128));
  RETURN_IF_ERROR(CheckText(version.action_detail, "map version action_detail", 4096));
  RETURN_IF_ERROR(CheckText(version.created_by, "map version created_by"));
  RETURN_IF_ERROR(CheckText(version.reason, "map version reason", 4096));
  RETURN_IF_ERROR(CheckText(version.approved_by, "map version approved_by"));
  if (version.metadata.size() > kMaxMapMetadataBytes) {
    return InvalidArgument("map version metadata: " + std::to_string(version.metadata.size()) +
                           " bytes, more than the limit " + std::to_string(kMaxMapMetadataBytes));
  }
  return Status::Ok();
}

Status CheckFindings(const std::vector<MapFindingRecord>& findings) {
  for (const MapFindingRecord& finding : findings) {
    RETURN_IF_ERROR(CheckText(finding.summary, "finding summary", 4096));
    RETURN_IF_ERROR(CheckText(finding.detail_json, "finding detail_json", 1 << 20));
  }
  return Status::Ok();
}

std::int64_t OpenCount(const std::vector<MapFindingRecord>& findings) {
  std::int64_t open = 0;
  for (const MapFindingRecord& finding : findings) open += finding.state == FindingState::kOpen ? 1 : 0;
  return open;
}

Status InsertFindings(SqlTransaction& transaction, const std::string& robot_id, std::int64_t version,
                      const std::vector<MapFindingRecord>& findings) {
  for (const MapFindingRecord& finding : findings) {
    RETURN_IF_ERROR(transaction.Exec(
        "INSERT INTO map_findings (robot_id, version, finding_id, kind, severity, summary, state, "
        "detail_json) "
        "VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
        {robot_id, version, finding.finding_id, std::string(Name(finding.kind)), finding.severity,
         finding.summary, std::string(Name(finding.state)), finding.detail_json}));
  }
  return Status::Ok();
}

}  // namespace

Status CheckMapVersion(const MapVersionRecord& version, const std::vector<MapFindingRecord>& findings) {
  RETURN_IF_ERROR(CheckVersion(version));
  return CheckFindings(findings);
}

Result<MapVersionRecord> SqlRepository::AppendMapVersionIn(SqlTransaction& transaction,
                                                           const MapVersionRecord& version,
                                                           std::optional<std::int64_t> expected_head,
                                                           const std::vector<MapFindingRecord>& findings,
                                                           const EncodedBlob& metadata) {
  MapVersionRecord stored = version;
  stored.metadata.clear();
  // The robot's row lock serialises appends for one robot across connections and processes (SQLite
  // serialises every write transaction anyway).
  ASSIGN_OR_RETURN(
      auto locked,
      transaction.Query("UPDATE robots SET robot_id = robot_id WHERE robot_id = $1 RETURNING robot_id",
                        {version.robot_id}));
  if (locked.empty())
    return FailedPrecondition("map version names robot " + version.robot_id + ", which is not stored");
  if (version.origin == MapOrigin::kUpload) {
    ASSIGN_OR_RETURN(auto existing,
                     transaction.Query(std::string(kVersionColumns) +
                                           "WHERE robot_id = $1 AND run_id = $2 AND origin = 'upload'",
                                       {version.robot_id, version.run_id}));
    if (!existing.empty()) return VersionFromRow(existing.front());
  }
  ASSIGN_OR_RETURN(auto head, transaction.Query("SELECT MAX(version), MAX(CASE WHEN approval IN ('approved', "
                                                "'pending') THEN version END) FROM map_versions "
                                                "WHERE robot_id = $1",
                                                {version.robot_id}));
  const std::int64_t newest = head.empty() || head.front().IsNull(0) ? 0 : head.front().Int(0);
  const std::int64_t head_version = head.empty() || head.front().IsNull(1) ? 0 : head.front().Int(1);
  if (expected_head && *expected_head != head_version) {
    return Aborted("the map of robot " + version.robot_id + " is at version " + std::to_string(head_version) +
                   ", not " + std::to_string(*expected_head) +
                   ": it changed meanwhile; look again and retry");
  }
  if (version.supersedes_pending) {
    ASSIGN_OR_RETURN(
        auto superseded,
        transaction.Query("UPDATE map_versions SET approval = 'stale', approved_by = $3, approved_at_ms = $4 "
                          "WHERE robot_id = $1 AND version = $2 AND approval = 'pending' RETURNING version",
                          {version.robot_id, *version.supersedes_pending, version.approved_by, NowMs()}));
    if (superseded.empty()) {
      return Aborted("map version " + std::to_string(*version.supersedes_pending) + " of robot " +
                     version.robot_id + " is no longer pending: it was reviewed meanwhile");
    }
  }
  if (version.parent_version && (*version.parent_version < 1 || *version.parent_version > newest)) {
    return FailedPrecondition("parent version " + std::to_string(*version.parent_version) + " of robot " +
                              version.robot_id + " does not exist");
  }
  ASSIGN_OR_RETURN(auto snapshot, transaction.Query("SELECT 1 FROM snapshots WHERE snapshot_id = $1",
                                                    {version.snapshot_id}));
  if (snapshot.empty())
    return FailedPrecondition("map version names snapshot " + version.snapshot_id + ", which is not stored");
  stored.version = newest + 1;
  stored.open_findings = OpenCount(findings);
  if (stored.created_at_ms == 0) stored.created_at_ms = NowMs();
  SqlValue parent = SqlNull{};
  if (stored.parent_version) parent = *stored.parent_version;
  SqlValue run = SqlNull{};
  if (!stored.run_id.empty()) run = stored.run_id;
  RETURN_IF_ERROR(transaction.Exec(
      "INSERT INTO map_versions (robot_id, version, parent_version, snapshot_id, origin, run_id, action, "
      "action_detail, created_by, reason, created_at_ms, approval, approved_by, approved_at_ms, nodes, "
      "edges, "
      "observation_edges, views, components, known_area_m2, chi2, open_findings) VALUES ($1, $2, $3, $4, "
      "$5, $6, "
      "$7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20, $21, $22)",
      {stored.robot_id,
       stored.version,
       parent,
       stored.snapshot_id,
       std::string(Name(stored.origin)),
       run,
       ActionText(stored.action),
       stored.action_detail,
       stored.created_by,
       stored.reason,
       stored.created_at_ms,
       std::string(Name(stored.approval)),
       stored.approved_by,
       stored.approved_at_ms,
       stored.nodes,
       stored.edges,
       stored.observation_edges,
       stored.views,
       stored.components,
       stored.known_area_m2,
       stored.chi2,
       stored.open_findings}));
  RETURN_IF_ERROR(InsertFindings(transaction, stored.robot_id, stored.version, findings));
  if (!version.metadata.empty()) {
    RETURN_IF_ERROR(transaction.Exec(
        "INSERT INTO map_metadata (robot_id, version, data, data_crc32, data_size) VALUES "
        "($1, $2, $3, $4, $5)",
        {stored.robot_id, stored.version, SqlBlob{metadata.compressed}, metadata.crc32, metadata.raw_size}));
  }
  return stored;
}

Result<MapVersionRecord> SqlRepository::AppendMapVersion(const MapVersionRecord& version,
                                                         std::optional<std::int64_t> expected_head,
                                                         const std::vector<MapFindingRecord>& findings) {
  RETURN_IF_ERROR(CheckMapVersion(version, findings));
  const EncodedBlob metadata =
      EncodeBlob(version.metadata);  // before the transaction: the lock is held briefly
  MapVersionRecord stored;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(stored, AppendMapVersionIn(transaction, version, expected_head, findings, metadata));
    Fault("append_map_version:before_commit");
    return Status::Ok();
  }));
  return stored;
}

namespace {

// The robots page. Each robot's figures are index probes (migration 10: map_versions (robot_id, approval,
// version)), so a page costs the same whatever the robots' history lengths or the fleet's runs; the newest
// version's number is its count (versions are numbered 1, 2, … and never deleted one by one).
constexpr const char* kRobotSummarySelect =
    "SELECT s.robot_id, s.robot_model, s.firmware, s.registered_at_ms, s.newest, s.current_version, "
    "s.pending, n.approval, n.open_findings FROM (SELECT r.robot_id, r.robot_model, r.firmware, "
    "r.registered_at_ms, "
    "(SELECT MAX(v.version) FROM map_versions v WHERE v.robot_id = r.robot_id) AS newest, "
    "(SELECT MAX(v.version) FROM map_versions v WHERE v.robot_id = r.robot_id AND v.approval = 'approved') "
    "AS current_version, "
    "(SELECT COUNT(*) FROM map_versions v WHERE v.robot_id = r.robot_id AND v.approval = 'pending') AS "
    "pending "
    "FROM robots r WHERE ";
constexpr const char* kRobotSummaryEnd =
    ") s LEFT JOIN map_versions n ON n.robot_id = s.robot_id AND n.version = s.newest ORDER BY s.robot_id";

Result<RobotMapSummary> RobotSummaryFromRow(const SqlRow& row) {
  RobotMapSummary summary;
  summary.robot = RobotFromRow(row);
  summary.versions = row.IsNull(4) ? 0 : row.Int(4);
  summary.current_version = row.IsNull(5) ? 0 : row.Int(5);
  summary.pending_versions = row.Int(6);
  if (!row.IsNull(7)) {
    ASSIGN_OR_RETURN(summary.newest_approval,
                     StoredState<MapApproval>(row, 7,
                                              "map version " + std::to_string(summary.versions) +
                                                  " of robot " + summary.robot.robot_id));
    summary.newest_open_findings = row.Int(8);
  }
  return summary;
}

Result<std::vector<RobotMapSummary>> RobotSummariesWhere(SqlTransaction& transaction,
                                                         const std::string& where,
                                                         const std::vector<SqlValue>& params) {
  ASSIGN_OR_RETURN(auto rows, transaction.Query(kRobotSummarySelect + where + kRobotSummaryEnd, params));
  std::vector<RobotMapSummary> summaries;
  summaries.reserve(rows.size());
  for (const SqlRow& row : rows) {
    ASSIGN_OR_RETURN(auto summary, RobotSummaryFromRow(row));
    summaries.push_back(std::move(summary));
  }
  return summaries;
}

}  // namespace

Result<RobotSummaryPage> SqlRepository::ListRobotSummaries(const RobotSummaryQuery& query) {
  if (query.limit < 1 || query.limit > kMaxRobotPage) {
    return InvalidArgument("limit: expected 1.." + std::to_string(kMaxRobotPage) + " robots, got " +
                           std::to_string(query.limit));
  }
  RETURN_IF_ERROR(CheckText(query.after_robot_id, "after_robot_id", 128));
  // One more than the page, to tell whether another page follows. Robots waiting for review are read from
  // the partial index of pending versions, so that filter does not walk the whole fleet.
  const std::string where =
      query.only_pending
          ? "r.robot_id IN (SELECT DISTINCT robot_id FROM map_versions WHERE approval = 'pending' AND "
            "robot_id > $1 ORDER BY robot_id LIMIT $2) ORDER BY r.robot_id"
          : "r.robot_id > $1 ORDER BY r.robot_id LIMIT $2";
  RobotSummaryPage page;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(page.robots, RobotSummariesWhere(transaction, where,
                                                      {query.after_robot_id, std::int64_t{query.limit} + 1}));
    ASSIGN_OR_RETURN(auto total, transaction.Query(query.only_pending
                                                       ? "SELECT COUNT(DISTINCT robot_id) FROM map_versions "
                                                         "WHERE approval = 'pending'"
                                                       : "SELECT COUNT(*) FROM robots",
                                                   {}));
    page.total = total.front().Int(0);
    return Status::Ok();
  }));
  page.more = page.robots.size() > static_cast<std::size_t>(query.limit);
  if (page.more) page.robots.pop_back();
  return page;
}

Result<RobotMapSummary> SqlRepository::GetRobotSummary(const std::string& robot_id) {
  std::vector<RobotMapSummary> found;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(found, RobotSummariesWhere(transaction, "r.robot_id = $1", {robot_id}));
    return Status::Ok();
  }));
  if (found.empty()) return NotFound("no robot " + robot_id);
  return found.front();
}

Result<std::vector<MapVersionRecord>> SqlRepository::ListMapVersions(const std::string& robot_id) {
  std::vector<MapVersionRecord> versions;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(std::string(kVersionColumns) + "WHERE robot_id = $1 ORDER BY version", {robot_id}));
    ASSIGN_OR_RETURN(versions, VersionsFromRows(rows));
    return Status::Ok();
  }));
  return versions;
}

Result<MapVersionRecord> SqlRepository::GetMapVersion(const std::string& robot_id, std::int64_t version) {
  std::optional<MapVersionRecord> found;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows,
                     transaction.Query(std::string(kVersionColumns) + "WHERE robot_id = $1 AND version = $2",
                                       {robot_id, version}));
    if (!rows.empty()) {
      ASSIGN_OR_RETURN(found, VersionFromRow(rows.front()));
    }
    return Status::Ok();
  }));
  if (!found) return NotFound("robot " + robot_id + " has no map version " + std::to_string(version));
  return *found;
}

Result<std::optional<MapVersionRecord>> SqlRepository::NewestMapVersionWhere(
    const std::string& condition, const std::vector<SqlValue>& params) {
  std::optional<MapVersionRecord> found;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(std::string(kVersionColumns) + "WHERE robot_id = $1 AND " +
                                                      condition + " ORDER BY version DESC LIMIT 1",
                                                  params));
    if (!rows.empty()) {
      ASSIGN_OR_RETURN(found, VersionFromRow(rows.front()));
    }
    return Status::Ok();
  }));
  return found;
}

Result<std::optional<MapVersionRecord>> SqlRepository::GetCurrentMapVersion(const std::string& robot_id) {
  return NewestMapVersionWhere("approval = 'approved'", {robot_id});
}

Result<std::optional<MapVersionRecord>> SqlRepository::FindMapVersionOfSnapshot(
    const std::string& robot_id, const std::string& snapshot_id) {
  return NewestMapVersionWhere("snapshot_id = $2", {robot_id, snapshot_id});
}

Result<std::string> SqlRepository::GetMapMetadata(const std::string& robot_id, std::int64_t version) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "SELECT data, data_crc32, data_size FROM map_metadata WHERE robot_id = $1 AND version = $2",
            {robot_id, version}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return std::string();
  return DecodeBlob(row->Text(0), row->Int(1), row->Int(2),
                    "metadata of map version " + std::to_string(version) + " of robot " + robot_id);
}

Result<MapVersionRecord> SqlRepository::GetMapVersionOfRun(const RunKey& run) {
  std::optional<MapVersionRecord> found;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows,
                     transaction.Query(std::string(kVersionColumns) +
                                           "WHERE robot_id = $1 AND run_id = $2 AND origin = 'upload'",
                                       {run.robot_id, run.run_id}));
    if (!rows.empty()) {
      ASSIGN_OR_RETURN(found, VersionFromRow(rows.front()));
    }
    return Status::Ok();
  }));
  if (!found) return NotFound("run " + run.run_id + " of robot " + run.robot_id + " made no map version");
  return *found;
}

Result<std::vector<MapFindingRecord>> SqlRepository::ListMapFindings(const std::string& robot_id,
                                                                     std::int64_t version) {
  std::vector<MapFindingRecord> findings;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query("SELECT finding_id, kind, severity, summary, state, detail_json FROM map_findings "
                          "WHERE robot_id = $1 AND version = $2 ORDER BY finding_id",
                          {robot_id, version}));
    for (const SqlRow& row : rows) {
      const std::string where = "finding " + std::to_string(row.Int(0)) + " of map version " +
                                std::to_string(version) + " of robot " + robot_id;
      ASSIGN_OR_RETURN(const FindingKind kind, StoredState<FindingKind>(row, 1, where));
      ASSIGN_OR_RETURN(const FindingState state, StoredState<FindingState>(row, 4, where));
      findings.push_back({.finding_id = row.Int(0),
                          .kind = kind,
                          .severity = row.Real(2),
                          .summary = row.Text(3),
                          .state = state,
                          .detail_json = row.Text(5)});
    }
    return Status::Ok();
  }));
  return findings;
}

Status SqlRepository::UpdateMapVersionHealth(const std::string& robot_id, std::int64_t version,
                                             double known_area_m2,
                                             const std::vector<MapFindingRecord>& findings) {
  RETURN_IF_ERROR(CheckFindings(findings));
  return Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto updated,
                     transaction.Query("UPDATE map_versions SET open_findings = $3, known_area_m2 = $4 WHERE "
                                       "robot_id = $1 AND version = $2 "
                                       "RETURNING version",
                                       {robot_id, version, OpenCount(findings), known_area_m2}));
    if (updated.empty())
      return NotFound("robot " + robot_id + " has no map version " + std::to_string(version));
    RETURN_IF_ERROR(transaction.Exec("DELETE FROM map_findings WHERE robot_id = $1 AND version = $2",
                                     {robot_id, version}));
    return InsertFindings(transaction, robot_id, version, findings);
  });
}

Result<MapVersionRecord> SqlRepository::ReviewMapVersion(const std::string& robot_id, std::int64_t version,
                                                         bool approve, const std::string& reviewed_by) {
  RETURN_IF_ERROR(CheckText(reviewed_by, "reviewed_by"));
  std::optional<MapVersionRecord> reviewed;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    // Under the robot's row lock, like appends: a review and a repair of one map never interleave.
    RETURN_IF_ERROR(
        transaction.Exec("UPDATE robots SET robot_id = robot_id WHERE robot_id = $1", {robot_id}));
    if (approve) {
      ASSIGN_OR_RETURN(auto newer, transaction.Query("SELECT MAX(version) FROM map_versions WHERE robot_id = "
                                                     "$1 AND approval = 'approved' AND version > $2",
                                                     {robot_id, version}));
      if (!newer.empty() && !newer.front().IsNull(0)) {
        return FailedPrecondition(
            "version " + std::to_string(newer.front().Int(0)) + " of robot " + robot_id +
            " is approved and newer than " + std::to_string(version) +
            ": approving it would not make it the robot's map; repair the current version instead");
      }
    }
    ASSIGN_OR_RETURN(
        auto rows,
        transaction.Query(
            "UPDATE map_versions SET approval = $3, approved_by = $4, approved_at_ms = $5 "
            "WHERE robot_id = $1 AND version = $2 AND approval = 'pending' RETURNING version",
            {robot_id, version, std::string(Name(approve ? MapApproval::kApproved : MapApproval::kRejected)),
             reviewed_by, NowMs()}));
    ASSIGN_OR_RETURN(auto current,
                     transaction.Query(std::string(kVersionColumns) + "WHERE robot_id = $1 AND version = $2",
                                       {robot_id, version}));
    if (current.empty())
      return NotFound("robot " + robot_id + " has no map version " + std::to_string(version));
    ASSIGN_OR_RETURN(reviewed, VersionFromRow(current.front()));
    if (rows.empty()) {
      return FailedPrecondition("map version " + std::to_string(version) + " of robot " + robot_id + " is " +
                                std::string(Name(reviewed->approval)) +
                                ", not pending: only pending versions are reviewed");
    }
    return Status::Ok();
  }));
  return *reviewed;
}

}  // namespace storage::internal
