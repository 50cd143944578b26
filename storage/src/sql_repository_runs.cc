// SqlRepository: runs, run listing and fleet statistics. Filters are fixed SQL with every value bound as a
// parameter; an empty filter value disables its clause inside the SQL ("$1 = '' OR robot_id = $1"), so
// no SQL text is ever built from a value.
#include <limits>

#include "blob_codec.h"
#include "crypto.h"
#include "sql_repository.h"

namespace storage::internal {
namespace {

constexpr std::size_t kMaxBatch = 10000;

/// The digest that decides whether a re-sent run is the same run: every stored field, length-prefixed.
std::string RunDigest(const RunRecord& run) {
  std::string canonical;
  auto add = [&canonical](const std::string& field) {
    canonical += std::to_string(field.size());
    canonical += ':';
    canonical += field;
  };
  add(run.robot_id);
  add(run.firmware);
  add(run.robot_model);
  add(std::to_string(run.started_at_ms));
  add(std::to_string(run.ended_at_ms));
  add(run.parent_snapshot_id.value_or("-"));
  add(run.child_snapshot_id.value_or("-"));
  add(Sha256Hex(run.telemetry));
  return Sha256Hex(canonical);
}

SqlValue OptionalText(const std::optional<std::string>& value) {
  if (value) return *value;
  return SqlNull{};
}

Status CheckRun(const RunRecord& run) {
  if (run.run_id.empty()) return InvalidArgument("run_id is empty");
  RETURN_IF_ERROR(CheckText(run.run_id, "run_id", 128));
  if (run.robot_id.empty()) return InvalidArgument("robot_id is empty");
  RETURN_IF_ERROR(CheckText(run.robot_id, "robot_id", 128));
  RETURN_IF_ERROR(CheckText(run.firmware, "firmware"));
  RETURN_IF_ERROR(CheckText(run.robot_model, "robot_model"));
  if (run.ended_at_ms < run.started_at_ms)
    return InvalidArgument("run " + run.run_id + " ends before it starts");
  if (run.parent_snapshot_id) RETURN_IF_ERROR(CheckText(*run.parent_snapshot_id, "parent_snapshot_id", 64));
  if (run.child_snapshot_id) RETURN_IF_ERROR(CheckText(*run.child_snapshot_id, "child_snapshot_id", 64));
  return Status::Ok();
}

constexpr const char* kRunColumns =
    "r.run_id, r.robot_id, r.firmware, r.robot_model, r.started_at_ms, r.ended_at_ms, r.parent_snapshot_id, "
    "r.child_snapshot_id, r.telemetry_size, r.telemetry_pruned_at_ms";

RunRecord RunFromRow(const SqlRow& row) {
  RunRecord run;
  run.run_id = row.Text(0);
  run.robot_id = row.Text(1);
  run.firmware = row.Text(2);
  run.robot_model = row.Text(3);
  run.started_at_ms = row.Int(4);
  run.ended_at_ms = row.Int(5);
  if (!row.IsNull(6)) run.parent_snapshot_id = row.Text(6);
  if (!row.IsNull(7)) run.child_snapshot_id = row.Text(7);
  run.telemetry_size = row.Int(8);
  if (!row.IsNull(9)) run.telemetry_pruned_at_ms = row.Int(9);
  return run;
}

// The filter clause over runs r; parameters $1..$6 are FilterParams().
constexpr const char* kRunFilterSql =
    "(CAST($1 AS TEXT) = '' OR r.robot_id = $1) AND (CAST($2 AS TEXT) = '' OR r.firmware = $2) AND "
    "(CAST($3 AS TEXT) = '' OR r.robot_model = $3) AND r.started_at_ms >= $5 AND r.started_at_ms < $6";

std::vector<SqlValue> FilterParams(const RunFilter& filter) {
  return {filter.robot_id,
          filter.firmware,
          filter.robot_model,
          filter.parameter_set,
          filter.started_from_ms.value_or(std::numeric_limits<std::int64_t>::min()),
          filter.started_before_ms.value_or(std::numeric_limits<std::int64_t>::max())};
}

FleetStatistics StatisticsFromRow(const SqlRow& row, std::size_t first) {
  FleetStatistics s;
  s.reports = row.Int(first + 0);
  s.robots = row.Int(first + 1);
  s.recovery_created = row.Int(first + 2);
  s.recovery_accepted = row.Int(first + 3);
  s.merge_created = row.Int(first + 4);
  s.merge_conditionally_accepted = row.Int(first + 5);
  s.merge_conditional_then_rejected = row.Int(first + 6);
  s.views_total = row.Int(first + 7);
  s.views_ambiguous = row.Int(first + 8);
  s.started_localized = row.Int(first + 9);
  s.protrusions_found = row.Int(first + 10);
  s.recovery_retracted = row.Int(first + 11);
  return s;
}

/// `key_sql` is one of a fixed set of column expressions chosen by enum, never caller text.
std::string StatisticsSql(const std::string& key_sql, bool grouped) {
  std::string sql = "SELECT " + key_sql +
                    ", COUNT(*), COUNT(DISTINCT r.robot_id)"
                    ", CAST(COALESCE(SUM(p.recovery_created), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.recovery_accepted), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.merge_created), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.merge_conditionally_accepted), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.merge_conditional_then_rejected), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.views_total), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.views_ambiguous), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.started_localized), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.protrusions_found), 0) AS BIGINT)"
                    ", CAST(COALESCE(SUM(p.recovery_retracted), 0) AS BIGINT)"
                    " FROM reports p JOIN runs r ON r.robot_id = p.robot_id AND r.run_id = p.run_id WHERE " +
                    std::string(kRunFilterSql) + " AND (CAST($4 AS TEXT) = '' OR p.parameter_set = $4)";
  if (grouped) sql += " GROUP BY 1 ORDER BY 1";
  return sql;
}

std::string GroupKeySql(GroupBy group_by) {
  switch (group_by) {
    case GroupBy::kRobot: return "r.robot_id";
    case GroupBy::kFirmware: return "r.firmware";
    case GroupBy::kRobotModel: return "r.robot_model";
    case GroupBy::kParameterSet: return "p.parameter_set";
    // Floor division for negative times too; integer arithmetic in both databases.
    case GroupBy::kDay:
      return "CAST(CASE WHEN r.started_at_ms >= 0 THEN r.started_at_ms / 86400000 "
             "ELSE (r.started_at_ms - 86399999) / 86400000 END AS TEXT)";
  }
  return "''";
}

}  // namespace

Result<InsertOutcome> SqlRepository::InsertRunIn(SqlTransaction& transaction, const RunRecord& run,
                                                 const std::string& digest, const EncodedBlob& telemetry) {
  ASSIGN_OR_RETURN(
      auto inserted,
      transaction.Query(
          "INSERT INTO runs (run_id, robot_id, firmware, robot_model, started_at_ms, ended_at_ms, "
          "parent_snapshot_id, "
          "child_snapshot_id, telemetry, telemetry_crc32, telemetry_size, payload_sha256, uploaded_at_ms) "
          "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) ON CONFLICT (robot_id, run_id) DO "
          "NOTHING "
          "RETURNING run_id",
          {run.run_id, run.robot_id, run.firmware, run.robot_model, run.started_at_ms, run.ended_at_ms,
           OptionalText(run.parent_snapshot_id), OptionalText(run.child_snapshot_id),
           SqlBlob{telemetry.compressed}, telemetry.crc32, telemetry.raw_size, digest, NowMs()}));
  if (!inserted.empty()) return InsertOutcome::kInserted;
  return CompareExisting(transaction, "SELECT payload_sha256 FROM runs WHERE robot_id = $1 AND run_id = $2",
                         {run.robot_id, run.run_id}, digest,
                         "run " + run.run_id + " of robot " + run.robot_id);
}

Result<InsertOutcome> SqlRepository::InsertRun(const RunRecord& run) {
  RETURN_IF_ERROR(CheckRun(run));
  // Hashing and compressing happen before the transaction so the write lock is held briefly.
  const std::string digest = RunDigest(run);
  const EncodedBlob telemetry = EncodeBlob(run.telemetry);
  InsertOutcome outcome = InsertOutcome::kInserted;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto inserted, InsertRunIn(transaction, run, digest, telemetry));
    outcome = inserted;
    Fault("insert_run:before_commit");
    return Status::Ok();
  }));
  return outcome;
}

Result<StoredUpload> SqlRepository::StoreUpload(const UploadBundle& upload) {
  RETURN_IF_ERROR(CheckRobot(upload.robot));
  RETURN_IF_ERROR(CheckRun(upload.run));
  RETURN_IF_ERROR(CheckJob(upload.analysis_job));
  RETURN_IF_ERROR(CheckMapVersion(upload.map_version, upload.findings));
  if (upload.run.robot_id != upload.robot.robot_id || upload.map_version.robot_id != upload.robot.robot_id)
    return InvalidArgument("upload of robot " + upload.robot.robot_id +
                           ": its run and map version name robot " + upload.run.robot_id + " and " +
                           upload.map_version.robot_id);
  if (upload.map_version.origin != MapOrigin::kUpload || upload.map_version.run_id != upload.run.run_id)
    return InvalidArgument("upload of run " + upload.run.run_id +
                           ": its map version must be the run's upload");
  // Hashing and compressing happen before the transaction so the write lock is held briefly.
  std::vector<const std::string*> snapshots;
  for (const std::string& bytes : upload.snapshots) snapshots.push_back(&bytes);
  ASSIGN_OR_RETURN(auto new_snapshots, EncodeNewSnapshots(snapshots));
  const std::string digest = RunDigest(upload.run);
  const EncodedBlob telemetry = EncodeBlob(upload.run.telemetry);
  const EncodedBlob metadata = EncodeBlob(upload.map_version.metadata);
  StoredUpload stored;
  RETURN_IF_ERROR(Write([&](SqlTransaction& transaction) -> Status {
    RETURN_IF_ERROR(PutRobotIn(transaction, upload.robot));
    for (const EncodedSnapshot& snapshot : new_snapshots.absent)
      RETURN_IF_ERROR(PutSnapshotIn(transaction, snapshot));
    ASSIGN_OR_RETURN(stored.run, InsertRunIn(transaction, upload.run, digest, telemetry));
    stored.analysis_job_id = 0;
    if (stored.run == InsertOutcome::kInserted) {
      ASSIGN_OR_RETURN(stored.analysis_job_id, EnqueueJobIn(transaction, upload.analysis_job));
    }
    ASSIGN_OR_RETURN(stored.map_version, AppendMapVersionIn(transaction, upload.map_version, std::nullopt,
                                                            upload.findings, metadata));
    Fault("store_upload:before_commit");
    return Status::Ok();
  }));
  return stored;
}

Status SqlRepository::InsertRuns(const std::vector<RunRecord>& runs) {
  if (runs.size() > kMaxBatch) return InvalidArgument("runs: at most 10000 per batch");
  std::vector<std::string> digests;
  std::vector<EncodedBlob> blobs;
  for (const RunRecord& run : runs) {
    RETURN_IF_ERROR(CheckRun(run));
    digests.push_back(RunDigest(run));
    blobs.push_back(EncodeBlob(run.telemetry));
  }
  return Write([&](SqlTransaction& transaction) -> Status {
    for (std::size_t i = 0; i < runs.size(); ++i) {
      RETURN_IF_ERROR(InsertRunIn(transaction, runs[i], digests[i], blobs[i]).status());
    }
    return Status::Ok();
  });
}

Result<RunRecord> SqlRepository::GetRun(const RunKey& key) {
  std::optional<SqlRow> row;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(std::string("SELECT ") + kRunColumns +
                                                      ", r.telemetry, r.telemetry_crc32 FROM runs r "
                                                      "WHERE r.robot_id = $1 AND r.run_id = $2",
                                                  {key.robot_id, key.run_id}));
    if (!rows.empty()) row = rows.front();
    return Status::Ok();
  }));
  if (!row) return NotFound("no run " + key.run_id + " of robot " + key.robot_id);
  RunRecord run = RunFromRow(*row);
  ASSIGN_OR_RETURN(auto telemetry, DecodeBlob(row->Text(10), row->Int(11), run.telemetry_size,
                                              "telemetry of run " + key.run_id));
  run.telemetry = std::move(telemetry);
  return run;
}

Result<std::vector<std::string>> SqlRepository::ListRunRobots(const std::string& run_id, int limit) {
  if (limit < 1 || limit > 1000) return InvalidArgument("limit must be in 1..1000");
  std::vector<std::string> robots;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(
        auto rows, transaction.Query("SELECT robot_id FROM runs WHERE run_id = $1 ORDER BY robot_id LIMIT $2",
                                     {run_id, std::int64_t{limit}}));
    for (const SqlRow& row : rows) robots.push_back(row.Text(0));
    return Status::Ok();
  }));
  return robots;
}

Result<RunPage> SqlRepository::ListRuns(const RunFilter& filter, int page_size,
                                        const std::optional<RunCursor>& after) {
  if (page_size < 1 || page_size > 1000) return InvalidArgument("page_size must be in 1..1000");
  std::vector<SqlValue> params = FilterParams(filter);
  params.emplace_back(after ? after->started_at_ms : std::numeric_limits<std::int64_t>::min());  // $7
  params.emplace_back(after ? after->run_id : std::string());                                    // $8
  params.emplace_back(std::int64_t{page_size} + 1);  // $9: one extra row tells whether a next page exists
  params.emplace_back(after ? after->robot_id : std::string());  // $10
  const std::string sql =
      std::string("SELECT ") + kRunColumns + " FROM runs r WHERE " + kRunFilterSql +
      " AND (CAST($4 AS TEXT) = '' OR EXISTS (SELECT 1 FROM reports p WHERE p.robot_id = r.robot_id"
      " AND p.run_id = r.run_id"
      " AND p.parameter_set = $4))"
      " AND (r.started_at_ms > $7 OR (r.started_at_ms = $7 AND (r.run_id > $8 OR"
      " (r.run_id = $8 AND CAST($10 AS TEXT) <> '' AND r.robot_id > $10))))"
      " ORDER BY r.started_at_ms, r.run_id, r.robot_id LIMIT $9";
  RunPage page;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(sql, params));
    for (const SqlRow& row : rows) page.runs.push_back(RunFromRow(row));
    return Status::Ok();
  }));
  if (page.runs.size() > static_cast<std::size_t>(page_size)) {
    page.runs.resize(static_cast<std::size_t>(page_size));
    page.next = RunCursor{page.runs.back().started_at_ms, page.runs.back().run_id, page.runs.back().robot_id};
  }
  return page;
}

Result<std::vector<GroupStatistics>> SqlRepository::AggregateFromReports(SqlTransaction& transaction,
                                                                         const RunFilter& filter,
                                                                         std::optional<GroupBy> group_by) {
  ASSIGN_OR_RETURN(auto rows, transaction.Query(StatisticsSql(group_by ? GroupKeySql(*group_by) : "''",
                                                              group_by.has_value()),
                                                FilterParams(filter)));
  std::vector<GroupStatistics> groups;
  for (const SqlRow& row : rows) {
    if (!group_by && row.Int(1) == 0) continue;  // the total over no reports
    groups.push_back(GroupStatistics{row.Text(0), StatisticsFromRow(row, 1)});
  }
  return groups;
}

Result<std::vector<GroupStatistics>> SqlRepository::AggregateFromReportsForTesting(
    const RunFilter& filter, std::optional<GroupBy> group_by) {
  std::vector<GroupStatistics> groups;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto read, AggregateFromReports(transaction, filter, group_by));
    groups = std::move(read);
    return Status::Ok();
  }));
  return groups;
}

Result<FleetStatistics> SqlRepository::Aggregate(const RunFilter& filter) {
  ASSIGN_OR_RETURN(auto groups, AggregateBy(filter, std::nullopt));
  return groups.empty() ? FleetStatistics{} : groups.front().statistics;
}

Result<std::vector<GroupStatistics>> SqlRepository::AggregateBy(const RunFilter& filter, GroupBy group_by) {
  return AggregateBy(filter, std::optional<GroupBy>(group_by));
}

Result<std::vector<GroupStatistics>> SqlRepository::AggregateBy(const RunFilter& filter,
                                                                std::optional<GroupBy> group_by) {
  std::vector<GroupStatistics> groups;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    auto read = AggregateFromRollup(transaction, filter, group_by);
    if (!read) read = AggregateFromReports(transaction, filter, group_by);
    if (!read->ok()) return read->status();
    groups = std::move(*read).value();
    return Status::Ok();
  }));
  return groups;
}

Result<ReportPairPage> SqlRepository::ListReportPairs(const RunFilter& filter, const std::string& set_a,
                                                      const std::string& set_b, int page_size,
                                                      const std::optional<RunCursor>& after,
                                                      ReportPairScan scan) {
  if (page_size < 1 || page_size > 1000) return InvalidArgument("page_size must be in 1..1000");
  std::string counters_a, counters_b;
  for (const char* column :
       {"recovery_created", "recovery_accepted", "merge_created", "merge_conditionally_accepted",
        "merge_conditional_then_rejected", "views_total", "views_ambiguous", "started_localized",
        "protrusions_found", "recovery_retracted"}) {
    counters_a += std::string(", a.") + column;
    counters_b += std::string(", b.") + column;
  }
  std::vector<SqlValue> params = FilterParams(filter);
  params[3] = std::string();  // $4 unused: both sets are named below
  params.emplace_back(after ? after->started_at_ms : std::numeric_limits<std::int64_t>::min());  // $7
  params.emplace_back(after ? after->run_id : std::string());                                    // $8
  params.emplace_back(std::int64_t{page_size} + 1);                                              // $9
  params.emplace_back(after ? after->robot_id : std::string());                                  // $10
  params.emplace_back(set_a);                                                                    // $11
  params.emplace_back(set_b);                                                                    // $12
  // What the read walks. CROSS JOIN fixes SQLite's order: the runs in keyset order (runs_by_start), probing
  // each run's two reports by key, so a page costs its size when both sets cover the runs; or one set's
  // reports (reports_by_parameter_set), probing the run and the other report, so a set that covers few runs
  // costs its own size, not the fleet's. PostgreSQL reorders joins, and for a few hundred reports prefers
  // hashing them against a scan of every run; a LATERAL probe (OFFSET 0 keeps it a probe) makes it walk the
  // set's reports too.
  std::string walk = "runs r CROSS JOIN reports a CROSS JOIN reports b";
  if (scan != ReportPairScan::kRunsInStartOrder) {
    const std::string walked = scan == ReportPairScan::kReportsOfSetA ? "a" : "b";
    const std::string other = walked == "a" ? "b" : "a";
    const std::string run = database_->dialect() == Dialect::kPostgres
                                ? std::string("LATERAL (SELECT ") + kRunColumns +
                                      " FROM runs r WHERE r.robot_id = " + walked +
                                      ".robot_id AND r.run_id = " + walked + ".run_id OFFSET 0) r"
                                : "runs r";
    walk = "reports " + walked + " CROSS JOIN " + run + " CROSS JOIN reports " + other;
  }
  const std::string sql =
      std::string("SELECT ") + kRunColumns + counters_a + counters_b + " FROM " + walk +
      " WHERE a.robot_id = r.robot_id AND a.run_id = r.run_id"
      " AND a.parameter_set = $11 AND b.robot_id = r.robot_id AND b.run_id = r.run_id AND b.parameter_set = "
      "$12"
      " AND " +
      std::string(kRunFilterSql) + " AND CAST($4 AS TEXT) = ''" +
      " AND (r.started_at_ms > $7 OR (r.started_at_ms = $7 AND (r.run_id > $8 OR"
      " (r.run_id = $8 AND CAST($10 AS TEXT) <> '' AND r.robot_id > $10))))"
      " ORDER BY r.started_at_ms, r.run_id, r.robot_id LIMIT $9";  // a walk of a set's reports: sorted after
  const auto report_of = [](const SqlRow& row, std::size_t first, const RunRecord& run,
                            const std::string& set) {
    ReportRecord report;
    report.robot_id = run.robot_id;
    report.run_id = run.run_id;
    report.parameter_set = set;
    std::int64_t* targets[] = {&report.recovery_created,
                               &report.recovery_accepted,
                               &report.merge_created,
                               &report.merge_conditionally_accepted,
                               &report.merge_conditional_then_rejected,
                               &report.views_total,
                               &report.views_ambiguous,
                               nullptr,
                               &report.protrusions_found,
                               &report.recovery_retracted};
    for (std::size_t i = 0; i < std::size(targets); ++i) {
      if (targets[i] != nullptr) *targets[i] = row.Int(first + i);
    }
    report.started_localized = row.Int(first + 7) != 0;
    return report;
  };
  ReportPairPage page;
  RETURN_IF_ERROR(Read([&](SqlTransaction& transaction) -> Status {
    ASSIGN_OR_RETURN(auto rows, transaction.Query(sql, params));
    for (const SqlRow& row : rows) {
      RunRecord run = RunFromRow(row);
      ReportRecord a = report_of(row, 10, run, set_a), b = report_of(row, 20, run, set_b);
      page.pairs.push_back(ReportPair{std::move(run), std::move(a), std::move(b)});
    }
    return Status::Ok();
  }));
  if (page.pairs.size() > static_cast<std::size_t>(page_size)) {
    page.pairs.resize(static_cast<std::size_t>(page_size));
    const RunRecord& last = page.pairs.back().run;
    page.next = RunCursor{last.started_at_ms, last.run_id, last.robot_id};
  }
  return page;
}

}  // namespace storage::internal
