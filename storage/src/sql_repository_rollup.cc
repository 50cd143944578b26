// SqlRepository: the statistics roll-up (migration 7) that keeps fleet statistics independent of the number
// of stored runs. Every report write adds its counters to three derived tables in the report's own
// transaction; erasure takes a robot's share out again. The tables are never the source of truth: a query
// the roll-up cannot answer exactly falls back to the reports themselves (storage/docs/schema.md).
//
//   report_rollup          (parameter_set, day, firmware, robot_model) → reports and counter sums
//   report_robot_rollup    (parameter_set, robot_id) → the same per robot (group by robot; robots per set)
//   report_robot_presence  (parameter_set, dimension, group_key, robot_id) → reports: whether a robot has a
//                          report in a group of one dimension ("day", "firmware", "robot_model")
//   report_robot_counts    (parameter_set, dimension, group_key) → robots: the presence rows of that group
#include <array>
#include <map>

#include "sql_repository.h"

namespace storage::internal {
namespace {

// The report counters summed by the roll-up, in the column order of reports and the roll-up tables.
constexpr std::array<const char*, 10> kCounterColumns = {"recovery_created",
                                                         "recovery_accepted",
                                                         "merge_created",
                                                         "merge_conditionally_accepted",
                                                         "merge_conditional_then_rejected",
                                                         "views_total",
                                                         "views_ambiguous",
                                                         "started_localized",
                                                         "protrusions_found",
                                                         "recovery_retracted"};

std::array<std::int64_t, 10> CountersOf(const ReportRecord& report) {
  return {report.recovery_created,
          report.recovery_accepted,
          report.merge_created,
          report.merge_conditionally_accepted,
          report.merge_conditional_then_rejected,
          report.views_total,
          report.views_ambiguous,
          std::int64_t{report.started_localized ? 1 : 0},
          report.protrusions_found,
          report.recovery_retracted};
}

/// The day number (UTC) of a time in ms, rounding down also before 1970 (as the SQL of GroupBy::kDay).
std::int64_t DayOf(std::int64_t ms) { return ms >= 0 ? ms / 86400000 : (ms - 86399999) / 86400000; }

/// "INSERT INTO table (keys..., reports, counters...) VALUES (...) ON CONFLICT (keys) DO UPDATE SET x = x + excluded.x".
std::string AddSql(const std::string& table, const std::vector<std::string>& keys) {
  std::string columns, values, updates = "reports = " + table + ".reports + excluded.reports";
  int next = 1;
  for (const std::string& key : keys) {
    columns += key + ", ";
    values += "$" + std::to_string(next++) + ", ";
  }
  columns += "reports";
  values += "$" + std::to_string(next++);
  for (const char* column : kCounterColumns) {
    columns += std::string(", ") + column;
    values += ", $" + std::to_string(next++);
    updates += std::string(", ") + column + " = " + table + "." + column + " + excluded." + column;
  }
  std::string conflict;
  for (const std::string& key : keys) conflict += (conflict.empty() ? "" : ", ") + key;
  return "INSERT INTO " + table + " (" + columns + ") VALUES (" + values + ") ON CONFLICT (" + conflict +
         ") DO UPDATE SET " + updates;
}

/// Adds `reports` and `counters` (both may be negative) to one roll-up row keyed by `key`.
Status AddToRow(SqlTransaction& transaction, const std::string& table,
                const std::vector<std::string>& key_columns, std::vector<SqlValue> key, std::int64_t reports,
                const std::array<std::int64_t, 10>& counters) {
  key.emplace_back(reports);
  for (std::int64_t value : counters) key.emplace_back(value);
  return transaction.Exec(AddSql(table, key_columns), key);
}

struct RunCell {
  std::int64_t day = 0;
  std::string firmware, robot_model;
};

Result<RunCell> CellOfRun(SqlTransaction& transaction, const std::string& robot_id,
                          const std::string& run_id) {
  ASSIGN_OR_RETURN(
      auto rows,
      transaction.Query(
          "SELECT started_at_ms, firmware, robot_model FROM runs WHERE robot_id = $1 AND run_id = $2",
          {robot_id, run_id}));
  if (rows.empty()) return FailedPrecondition("no run " + run_id + " of robot " + robot_id);
  return RunCell{DayOf(rows.front().Int(0)), rows.front().Text(1), rows.front().Text(2)};
}

}  // namespace

Status AddReportToRollup(SqlTransaction& transaction, const ReportRecord& report,
                         const std::optional<ReportRecord>& replaced) {
  ASSIGN_OR_RETURN(auto cell, CellOfRun(transaction, report.robot_id, report.run_id));
  std::array<std::int64_t, 10> delta = CountersOf(report);
  if (replaced) {
    const auto old = CountersOf(*replaced);
    for (std::size_t i = 0; i < delta.size(); ++i) delta[i] -= old[i];
  }
  const std::int64_t new_reports = replaced ? 0 : 1;
  RETURN_IF_ERROR(AddToRow(transaction, "report_rollup", {"parameter_set", "day", "firmware", "robot_model"},
                           {report.parameter_set, cell.day, cell.firmware, cell.robot_model}, new_reports,
                           delta));
  RETURN_IF_ERROR(AddToRow(transaction, "report_robot_rollup", {"parameter_set", "robot_id"},
                           {report.parameter_set, report.robot_id}, new_reports, delta));
  if (replaced) return Status::Ok();  // a replacement keeps its run, so the robot's presence is unchanged
  // One presence row per dimension in one statement; the rows it inserted (reports = 1) are groups the robot
  // was not in yet, whose robot count rises.
  const std::string day = std::to_string(cell.day);
  ASSIGN_OR_RETURN(
      auto presence,
      transaction.Query(
          "INSERT INTO report_robot_presence (parameter_set, dimension, group_key, robot_id, reports) "
          "VALUES ($1, 'day', $2, $5, 1), ($1, 'firmware', $3, $5, 1), ($1, 'robot_model', $4, $5, 1) "
          "ON CONFLICT (parameter_set, dimension, group_key, robot_id) "
          "DO UPDATE SET reports = report_robot_presence.reports + 1 RETURNING dimension, group_key, reports",
          {report.parameter_set, day, cell.firmware, cell.robot_model, report.robot_id}));
  for (const SqlRow& row : presence) {
    if (row.Int(2) != 1) continue;
    RETURN_IF_ERROR(
        transaction.Exec("INSERT INTO report_robot_counts (parameter_set, dimension, group_key, robots) "
                         "VALUES ($1, $2, $3, 1) "
                         "ON CONFLICT (parameter_set, dimension, group_key) DO UPDATE SET robots = "
                         "report_robot_counts.robots + 1",
                         {report.parameter_set, row.Text(0), row.Text(1)}));
  }
  return Status::Ok();
}

Status RemoveRobotFromRollup(SqlTransaction& transaction, const std::string& robot_id) {
  std::string sums;
  for (const char* column : kCounterColumns)
    sums += std::string(", CAST(COALESCE(SUM(p.") + column + "), 0) AS BIGINT)";
  ASSIGN_OR_RETURN(
      auto cells,
      transaction.Query(
          "SELECT p.parameter_set, CASE WHEN r.started_at_ms >= 0 THEN r.started_at_ms / 86400000 "
          "ELSE (r.started_at_ms - 86399999) / 86400000 END, r.firmware, r.robot_model, COUNT(*)" +
              sums +
              " FROM reports p JOIN runs r ON r.robot_id = p.robot_id AND r.run_id = p.run_id WHERE "
              "p.robot_id = $1 "
              "GROUP BY 1, 2, 3, 4",
          {robot_id}));
  for (const SqlRow& row : cells) {
    std::array<std::int64_t, 10> minus{};
    for (std::size_t i = 0; i < minus.size(); ++i) minus[i] = -row.Int(5 + i);
    RETURN_IF_ERROR(AddToRow(transaction, "report_rollup",
                             {"parameter_set", "day", "firmware", "robot_model"},
                             {row.Text(0), row.Int(1), row.Text(2), row.Text(3)}, -row.Int(4), minus));
  }
  RETURN_IF_ERROR(transaction.Exec("DELETE FROM report_rollup WHERE reports <= 0", {}));
  RETURN_IF_ERROR(transaction.Exec(
      "UPDATE report_robot_counts SET robots = robots - 1 WHERE EXISTS (SELECT 1 FROM report_robot_presence "
      "pr "
      "WHERE pr.robot_id = $1 AND pr.parameter_set = report_robot_counts.parameter_set "
      "AND pr.dimension = report_robot_counts.dimension AND pr.group_key = report_robot_counts.group_key)",
      {robot_id}));
  RETURN_IF_ERROR(transaction.Exec("DELETE FROM report_robot_counts WHERE robots <= 0", {}));
  RETURN_IF_ERROR(transaction.Exec("DELETE FROM report_robot_presence WHERE robot_id = $1", {robot_id}));
  return transaction.Exec("DELETE FROM report_robot_rollup WHERE robot_id = $1", {robot_id});
}

namespace {

/// The filter's restriction on firmware and model as SQL over report_rollup c, parameters $1 (set), $2, $3.
constexpr const char* kRollupFilterSql =
    "(CAST($1 AS TEXT) = '' OR c.parameter_set = $1) AND (CAST($2 AS TEXT) = '' OR c.firmware = $2) AND "
    "(CAST($3 AS TEXT) = '' OR c.robot_model = $3)";

std::string SumsSql() {
  std::string sql = "CAST(COALESCE(SUM(c.reports), 0) AS BIGINT)";
  for (const char* column : kCounterColumns)
    sql += std::string(", CAST(COALESCE(SUM(c.") + column + "), 0) AS BIGINT)";
  return sql;
}

FleetStatistics SumsFromRow(const SqlRow& row, std::size_t first) {
  FleetStatistics s;
  s.reports = row.Int(first);
  std::int64_t* targets[] = {&s.recovery_created,
                             &s.recovery_accepted,
                             &s.merge_created,
                             &s.merge_conditionally_accepted,
                             &s.merge_conditional_then_rejected,
                             &s.views_total,
                             &s.views_ambiguous,
                             &s.started_localized,
                             &s.protrusions_found,
                             &s.recovery_retracted};
  for (std::size_t i = 0; i < std::size(targets); ++i) *targets[i] = row.Int(first + 1 + i);
  return s;
}

/// Groups from rows (key, sums...) with their robots from rows (key, robots).
std::vector<GroupStatistics> Joined(const SqlRows& sums, const SqlRows& robots) {
  std::map<std::string, std::int64_t> robots_of;
  for (const SqlRow& row : robots) robots_of[row.Text(0)] = row.Int(1);
  std::vector<GroupStatistics> groups;
  for (const SqlRow& row : sums) {
    GroupStatistics group{row.Text(0), SumsFromRow(row, 1)};
    group.statistics.robots = robots_of[group.key];
    groups.push_back(std::move(group));
  }
  return groups;
}

const char* DimensionOf(GroupBy group_by) {
  switch (group_by) {
    case GroupBy::kDay: return "day";
    case GroupBy::kFirmware: return "firmware";
    case GroupBy::kRobotModel: return "robot_model";
    default: return nullptr;
  }
}

}  // namespace

std::optional<Result<std::vector<GroupStatistics>>> AggregateFromRollup(SqlTransaction& transaction,
                                                                        const RunFilter& filter,
                                                                        std::optional<GroupBy> group_by) {
  // The roll-up has no robot or time of day; robots are counted exactly per one dimension only.
  if (!filter.robot_id.empty() || filter.started_from_ms || filter.started_before_ms) return std::nullopt;
  const bool by_firmware = !filter.firmware.empty(), by_model = !filter.robot_model.empty();
  const std::vector<SqlValue> params = {filter.parameter_set, filter.firmware, filter.robot_model};
  const auto fail = [](const Status& status) {
    return std::optional<Result<std::vector<GroupStatistics>>>(status);
  };
  std::vector<GroupStatistics> groups;

  if (!group_by || *group_by == GroupBy::kParameterSet) {
    if (by_firmware && by_model) return std::nullopt;
    if (!group_by && filter.parameter_set.empty() && (by_firmware || by_model)) return std::nullopt;
    if (group_by && (by_firmware || by_model)) return std::nullopt;
    const std::string key = group_by ? "c.parameter_set" : "''";
    auto sums = transaction.Query("SELECT " + key + ", " + SumsSql() + " FROM report_rollup c WHERE " +
                                      kRollupFilterSql + " GROUP BY 1 ORDER BY 1",
                                  params);
    if (!sums.ok()) return fail(sums.status());
    // Robots: one row per (set, robot) in report_robot_rollup, or one presence row per robot of the group.
    std::string robots_sql;
    std::vector<SqlValue> robots_params = {filter.parameter_set};
    if (by_firmware || by_model) {
      robots_sql =
          "SELECT '', robots FROM report_robot_counts WHERE parameter_set = $1 AND dimension = $2 AND "
          "group_key = $3";
      robots_params.emplace_back(std::string(by_firmware ? "firmware" : "robot_model"));
      robots_params.emplace_back(by_firmware ? filter.firmware : filter.robot_model);
    } else if (group_by) {
      robots_sql =
          "SELECT parameter_set, COUNT(*) FROM report_robot_rollup WHERE (CAST($1 AS TEXT) = '' OR "
          "parameter_set = $1) GROUP BY 1";
    } else {
      robots_sql =
          "SELECT '', COUNT(DISTINCT robot_id) FROM report_robot_rollup WHERE (CAST($1 AS TEXT) = '' OR "
          "parameter_set = $1)";
    }
    auto robots = transaction.Query(robots_sql, robots_params);
    if (!robots.ok()) return fail(robots.status());
    return Joined(*sums, *robots);
  }

  if (*group_by == GroupBy::kRobot) {
    if (by_firmware || by_model) return std::nullopt;
    auto rows = transaction.Query(
        "SELECT c.robot_id, " + SumsSql() +
            " FROM report_robot_rollup c WHERE (CAST($1 AS TEXT) = '' OR c.parameter_set = $1) "
            "GROUP BY 1 ORDER BY 1",
        {filter.parameter_set});
    if (!rows.ok()) return fail(rows.status());
    for (const SqlRow& row : *rows) {
      GroupStatistics group{row.Text(0), SumsFromRow(row, 1)};
      group.statistics.robots = 1;
      groups.push_back(std::move(group));
    }
    return groups;
  }

  // Day, firmware or model: robots per group from the counts of that dimension, so the set must be one set
  // and the filter may restrict only the grouped dimension itself.
  const char* dimension = DimensionOf(*group_by);
  if (dimension == nullptr || filter.parameter_set.empty()) return std::nullopt;
  if ((by_firmware && *group_by != GroupBy::kFirmware) || (by_model && *group_by != GroupBy::kRobotModel)) {
    return std::nullopt;
  }
  const std::string key = *group_by == GroupBy::kDay        ? "CAST(c.day AS TEXT)"
                          : *group_by == GroupBy::kFirmware ? "c.firmware"
                                                            : "c.robot_model";
  auto sums = transaction.Query("SELECT " + key + ", " + SumsSql() + " FROM report_rollup c WHERE " +
                                    kRollupFilterSql + " GROUP BY 1 ORDER BY 1",
                                params);
  if (!sums.ok()) return fail(sums.status());
  auto robots = transaction.Query(
      "SELECT group_key, robots FROM report_robot_counts WHERE parameter_set = $1 AND dimension = $2",
      {filter.parameter_set, std::string(dimension)});
  if (!robots.ok()) return fail(robots.status());
  return Joined(*sums, *robots);
}

}  // namespace storage::internal
