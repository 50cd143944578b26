// The statistics roll-up (migration 7) against both back-ends: whatever was written — new reports,
// replacements, bulk batches, an erased robot, reports stored before the migration — every filter and
// grouping answers exactly what the reports themselves say; the batches are all or nothing; report pairs
// page like runs.
#include <gtest/gtest.h>

#include <random>

#include "blob_codec.h"
#include "migrations.h"
#include "postgres_database.h"
#include "sqlite_database.h"
#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

constexpr std::int64_t kDay = 86400000;
const char* const kFirmware[] = {"fw-1", "fw-2", "fw-3"};
const char* const kModels[] = {"vac-s", "vac-l"};
const char* const kSets[] = {"default", "tuned"};

std::string Describe(const FleetStatistics& s) {
  return "reports=" + std::to_string(s.reports) + " robots=" + std::to_string(s.robots) +
         " recovery=" + std::to_string(s.recovery_created) + "/" + std::to_string(s.recovery_accepted) + "/" +
         std::to_string(s.recovery_retracted) + " merge=" + std::to_string(s.merge_created) + "/" +
         std::to_string(s.merge_conditionally_accepted) + "/" +
         std::to_string(s.merge_conditional_then_rejected) + " views=" + std::to_string(s.views_total) + "/" +
         std::to_string(s.views_ambiguous) + " localized=" + std::to_string(s.started_localized) +
         " protrusions=" + std::to_string(s.protrusions_found);
}

std::string Describe(const std::vector<GroupStatistics>& groups) {
  std::string text;
  for (const GroupStatistics& group : groups)
    text += "[" + group.key + ": " + Describe(group.statistics) + "] ";
  return text;
}

class RollupContractTest : public BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (HasFatalFailure()) return;
    for (const char* set : kSets)
      ASSERT_THAT(repo().PutParameterSet({set, std::string("params ") + set}), IsOk());
  }

  /// Random counters for one report (seeded per call order, so every run of the test writes the same).
  ReportBundle RandomReport(const RunRecord& run, const std::string& set) {
    std::uniform_int_distribution<int> count(0, 9);
    ReportBundle bundle;
    ReportRecord& r = bundle.report;
    r.robot_id = run.robot_id;
    r.run_id = run.run_id;
    r.parameter_set = set;
    r.recovery_created = count(random_);
    r.recovery_accepted = count(random_) % 3;
    r.recovery_retracted = count(random_) % 2;
    r.merge_created = count(random_);
    r.merge_conditionally_accepted = count(random_) % 4;
    r.merge_conditional_then_rejected = count(random_) % 2;
    r.views_total = 10 + count(random_);
    r.views_ambiguous = count(random_) % 5;
    r.started_localized = count(random_) % 2 == 0;
    r.protrusions_found = count(random_) % 3;
    r.report = "report " + run.robot_id + "/" + run.run_id + "/" + set;
    return bundle;
  }

  /// `robots` robots, each with `runs` runs over five days (one before 1970) on two firmwares, reports of
  /// both sets for most runs.
  void Populate(int robots, int runs) {
    for (int robot = 0; robot < robots; ++robot) {
      const std::string robot_id = "robot-" + std::to_string(robot);
      ASSERT_THAT(repo().PutRobot(RobotRecord{robot_id, kModels[robot % 2], kFirmware[0], 1}), IsOk());
      for (int i = 0; i < runs; ++i) {
        RunRecord run =
            MakeRun("run-" + std::to_string(i), (i % 5 - 1) * kDay + robot * 1000 + i, 50, robot_id);
        run.firmware = kFirmware[(robot + i / 3) % 3];
        run.robot_model = kModels[robot % 2];
        ASSERT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted);
        for (const char* set : kSets) {
          if ((i + robot) % 4 == 3 && std::string(set) == "tuned") continue;
          ASSERT_THAT(repo().PutReport(RandomReport(run, set)), IsOk());
        }
        written_.push_back(run);
      }
    }
  }

  /// Every filter shape and grouping, read through the roll-up and from the reports: equal, key by key.
  void ExpectRollupMatchesReports(const std::string& when) {
    std::vector<RunFilter> filters;
    for (const std::string set : {"", "default", "tuned"}) {
      RunFilter filter;
      filter.parameter_set = set;
      filters.push_back(filter);
      filter.firmware = "fw-2";
      filters.push_back(filter);
      filter.robot_model = "vac-l";
      filters.push_back(filter);
      filter.firmware.clear();
      filters.push_back(filter);
      RunFilter timed;
      timed.parameter_set = set;
      timed.started_from_ms = 0;
      timed.started_before_ms = 2 * kDay;
      filters.push_back(timed);
      RunFilter one_robot;
      one_robot.parameter_set = set;
      one_robot.robot_id = "robot-1";
      filters.push_back(one_robot);
    }
    const std::optional<GroupBy> groupings[] = {std::nullopt,           GroupBy::kDay,
                                                GroupBy::kFirmware,     GroupBy::kRobotModel,
                                                GroupBy::kParameterSet, GroupBy::kRobot};
    for (const RunFilter& filter : filters) {
      for (const auto& group_by : groupings) {
        const std::string shape = when + ": set=\"" + filter.parameter_set + "\" firmware=\"" +
                                  filter.firmware + "\" model=\"" + filter.robot_model + "\" robot=\"" +
                                  filter.robot_id + "\"" + (filter.started_from_ms ? " timed" : "") +
                                  " group " + std::to_string(group_by ? static_cast<int>(*group_by) : -1);
        auto expected = repo().AggregateFromReportsForTesting(filter, group_by);
        ASSERT_THAT(expected, IsOk()) << shape << ": " << expected.status().ToString();
        if (!group_by) {
          auto total = repo().Aggregate(filter);
          ASSERT_THAT(total, IsOk()) << shape << ": " << total.status().ToString();
          const FleetStatistics want = expected->empty() ? FleetStatistics{} : expected->front().statistics;
          EXPECT_EQ(Describe(*total), Describe(want)) << shape;
        } else {
          auto groups = repo().AggregateBy(filter, *group_by);
          ASSERT_THAT(groups, IsOk()) << shape << ": " << groups.status().ToString();
          EXPECT_EQ(Describe(*groups), Describe(*expected)) << shape;
        }
      }
    }
  }

  std::mt19937 random_{20260101};
  std::vector<RunRecord> written_;
};

TEST_P(RollupContractTest, EveryFilterAndGroupingMatchesTheReportsThroughReplacementAndErasure) {
  Populate(4, 12);
  ExpectRollupMatchesReports("after writing");
  // Retried analyses replace reports with other counters: the roll-up takes the difference.
  for (std::size_t i = 0; i < written_.size(); i += 3) {
    ASSERT_THAT(repo().PutReport(RandomReport(written_[i], "default")), IsOk());
  }
  ExpectRollupMatchesReports("after replacing");
  ASSERT_THAT(repo().DeleteRobot("robot-2", "admin:test"), IsOk());
  ExpectRollupMatchesReports("after erasing robot-2");
  ASSERT_THAT(repo().DeleteRobot("robot-0", "admin:test"), IsOk());
  ASSERT_THAT(repo().DeleteRobot("robot-1", "admin:test"), IsOk());
  ASSERT_THAT(repo().DeleteRobot("robot-3", "admin:test"), IsOk());
  ExpectRollupMatchesReports("after erasing everyone");
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM report_rollup")[0].Int(0), 0) << "no empty cells are kept";
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM report_robot_counts")[0].Int(0), 0);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM report_robot_presence")[0].Int(0), 0);
}

TEST_P(RollupContractTest, BulkBatchesAreAllOrNothingAndKeepTheRollup) {
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-1", "vac-s", "fw-1", 1}), IsOk());
  std::vector<RunRecord> runs;
  std::vector<ReportBundle> reports;
  for (int i = 0; i < 30; ++i) {
    runs.push_back(MakeRun("bulk-" + std::to_string(i), i * kDay / 3, 20, "robot-1"));
    reports.push_back(RandomReport(runs.back(), "default"));
  }
  std::vector<RunRecord> bad_runs = runs;
  bad_runs.back().robot_id = "no-such-robot";
  EXPECT_FALSE(repo().InsertRuns(bad_runs).ok()) << "a run of an unknown robot fails the batch";
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0), 0) << "nothing of a failed batch is stored";
  ASSERT_THAT(repo().InsertRuns(runs), IsOk());
  std::vector<ReportBundle> bad_reports = reports;
  bad_reports.back().report.parameter_set = "no-such-set";
  EXPECT_FALSE(repo().PutReports(bad_reports).ok());
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM reports")[0].Int(0), 0);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM report_rollup")[0].Int(0), 0)
      << "the roll-up rolls back with them";
  ASSERT_THAT(repo().PutReports(reports), IsOk());
  ExpectRollupMatchesReports("after the batches");
  EXPECT_FALSE(repo().InsertRuns(std::vector<RunRecord>(10001, runs[0])).ok()) << "batches are bounded";
}

TEST_P(RollupContractTest, ReportPairsPageThroughRunsWithBothSets) {
  Populate(3, 8);
  std::size_t expected = 0;
  for (const RunRecord& run : written_) {
    expected += repo().GetReport(run.key(), "tuned").ok() ? 1 : 0;
  }
  // Whatever the scan walks, the same pairs come back in the same order, page after page.
  std::vector<std::vector<std::string>> orders;
  for (const ReportPairScan scan :
       {ReportPairScan::kRunsInStartOrder, ReportPairScan::kReportsOfSetA, ReportPairScan::kReportsOfSetB}) {
    std::vector<std::string>& order = orders.emplace_back();
    std::optional<RunCursor> after;
    do {
      auto page = repo().ListReportPairs(RunFilter{}, "default", "tuned", 5, after, scan);
      ASSERT_THAT(page, IsOk());
      for (const ReportPair& pair : page->pairs) {
        order.push_back(pair.run.robot_id + "/" + pair.run.run_id);
        auto a = repo().GetReport(pair.run.key(), "default");
        auto b = repo().GetReport(pair.run.key(), "tuned");
        ASSERT_THAT(a, IsOk()) << pair.run.run_id;
        ASSERT_THAT(b, IsOk()) << pair.run.run_id;
        EXPECT_EQ(pair.a.recovery_created, a->recovery_created);
        EXPECT_EQ(pair.b.views_ambiguous, b->views_ambiguous);
        EXPECT_EQ(pair.b.started_localized, b->started_localized);
        EXPECT_EQ(pair.a.recovery_retracted, a->recovery_retracted);
        EXPECT_TRUE(pair.a.report.empty()) << "counters only";
      }
      after = page->next;
    } while (after);
    EXPECT_EQ(order.size(), expected);
  }
  EXPECT_GT(expected, 5u) << "more than one page";
  EXPECT_EQ(orders[1], orders[0]);
  EXPECT_EQ(orders[2], orders[0]);
  RunFilter fw;
  fw.firmware = "fw-2";
  for (const ReportPairScan scan : {ReportPairScan::kRunsInStartOrder, ReportPairScan::kReportsOfSetB}) {
    auto filtered = repo().ListReportPairs(fw, "default", "tuned", 1000, std::nullopt, scan);
    ASSERT_THAT(filtered, IsOk());
    EXPECT_FALSE(filtered->pairs.empty());
    for (const ReportPair& pair : filtered->pairs) EXPECT_EQ(pair.run.firmware, "fw-2");
  }
  EXPECT_FALSE(repo()
                   .ListReportPairs(RunFilter{}, "default", "tuned", 0, std::nullopt,
                                    ReportPairScan::kRunsInStartOrder)
                   .ok());
}

TEST_P(RollupContractTest, MigrationSevenRollsUpTheReportsAlreadyStored) {
  const std::string url = *NewDatabaseUrl(GetParam());
  {
    auto database = GetParam() == Backend::kSqlite
                        ? internal::OpenSqliteDatabase(url.substr(7), std::chrono::milliseconds(5000))
                        : internal::OpenPostgresDatabase(url, 1);
    ASSERT_THAT(database, IsOk());
    ASSERT_THAT(internal::MigrateTo(**database, 6), IsOk());
    internal::SqlRepository old(std::move(database).value());
    ASSERT_THAT(old.PutParameterSet({"default", "p"}), IsOk());
    const internal::EncodedBlob blob = internal::EncodeBlob("bytes");
    for (int robot = 0; robot < 3; ++robot) {
      const std::string robot_id = "robot-" + std::to_string(robot);
      ASSERT_THAT(old.PutRobot(RobotRecord{robot_id, "vac-s", "fw-1", 1}), IsOk());
      for (int i = 0; i < 4; ++i) {
        RunRecord run = MakeRun("run-" + std::to_string(i), i * kDay, 10, robot_id);
        run.firmware = kFirmware[i % 2];
        ASSERT_THAT(old.InsertRun(run), IsOk());
        ASSERT_THAT(old.database().InTransaction(
                        internal::TransactionMode::kWrite,
                        [&](internal::SqlTransaction& t) {
                          return t.Exec(
                              "INSERT INTO reports (robot_id, run_id, parameter_set, recovery_created, "
                              "recovery_accepted, "
                              "merge_created, merge_conditionally_accepted, merge_conditional_then_rejected, "
                              "views_total, "
                              "views_ambiguous, started_localized, protrusions_found, data, data_crc32, "
                              "data_size, created_at_ms, "
                              "recovery_retracted) VALUES ($1, $2, 'default', $3, 1, 2, 1, 0, 12, $4, 1, 1, "
                              "$5, $6, $7, 8, 0)",
                              {robot_id, run.run_id, std::int64_t{robot + i}, std::int64_t{i},
                               internal::SqlBlob{blob.compressed}, blob.crc32, blob.raw_size});
                        }),
                    IsOk());
      }
    }
  }
  auto upgraded = internal::OpenSqlRepository(url, OpenOptions{});
  ASSERT_THAT(upgraded, IsOk());
  repo_ = std::move(upgraded).value();
  url_ = url;
  ASSERT_EQ(*repo().SchemaVersion(), LatestSchemaVersion());  // migrated through 7 and whatever came after
  EXPECT_GT(RawQuery("SELECT COUNT(*) FROM report_rollup")[0].Int(0), 0);
  ExpectRollupMatchesReports("after migrating a schema-6 database");
}

INSTANTIATE_TEST_SUITE_P(Backends, RollupContractTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

}  // namespace
}  // namespace storage::testing
