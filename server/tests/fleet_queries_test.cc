// FleetQueries against a real SQLite file: the figures, day keys, empty shares, the Fig. 12 confusion
// matrix, the comparison score and ranking, and who sees what. The transports' tests only check their mapping.
#include "server/fleet_queries.h"

#include <gtest/gtest.h>

#include "server/jobs.h"
#include "sqlite_repository_test.h"
#include "status_matchers.h"

namespace server {
namespace {

constexpr std::int64_t kDay = 86400000;
constexpr std::int64_t k2026 = 20454;  // 2026-01-01 in days since the epoch

const Principal kEngineer{"engineer:ana", Role::kEngineer, "ana"};
const Principal kRobotA{"robot:a", Role::kRobot, "a"};

storage::ReportBundle Report(const std::string& robot, const std::string& run, const std::string& set,
                             std::int64_t recoveries, bool localized, std::int64_t ambiguous) {
  storage::ReportBundle bundle;
  storage::ReportRecord& r = bundle.report;
  r.robot_id = robot;
  r.run_id = run;
  r.parameter_set = set;
  r.recovery_created = recoveries;
  r.recovery_accepted = recoveries / 2;
  r.views_total = 10;
  r.views_ambiguous = ambiguous;
  r.started_localized = localized;
  fleet::v1::RunReport proto;
  proto.add_protrusion_regions()->set_id(1);
  r.report = proto.SerializeAsString();
  return bundle;
}

class FleetQueriesTest : public SqliteRepositoryTest {
 protected:
  void SetUp() override {
    SqliteRepositoryTest::SetUp();
    if (HasFatalFailure()) return;
    for (const char* set : {"default", "tuned"})
      ASSERT_THAT(repository_->PutParameterSet({set, set}), IsOk());
    for (const char* robot : {"a", "b"})
      ASSERT_THAT(repository_->PutRobot({robot, "vac", "fw-1", 1}), IsOk());
    // a: two runs on 2026-01-01 and 2026-01-02; b: one run on 2026-01-02 on another firmware.
    Run("a", "r1", k2026 * kDay + 5, "fw-1");
    Run("a", "r2", (k2026 + 1) * kDay, "fw-1");
    Run("b", "r1", (k2026 + 1) * kDay + 7, "fw-2");
    Put(Report("a", "r1", "default", 4, true, 2));
    Put(Report("a", "r2", "default", 2, false, 0));
    Put(Report("b", "r1", "default", 6, false, 5));
    // tuned: a/r1 changes by 1 recovery and its start localization (score 1 + 1 = 2), b/r1 by 3 recoveries.
    Put(Report("a", "r1", "tuned", 5, false, 2));
    Put(Report("a", "r2", "tuned", 2, false, 0));
    Put(Report("b", "r1", "tuned", 3, false, 5));
  }
  void Run(const std::string& robot, const std::string& id, std::int64_t start, const std::string& firmware) {
    storage::RunRecord run;
    run.robot_id = robot;
    run.run_id = id;
    run.firmware = firmware;
    run.robot_model = "vac";
    run.started_at_ms = start;
    run.ended_at_ms = start + 1000;
    ASSERT_THAT(repository_->InsertRun(run), IsOk());
  }
  void Put(const storage::ReportBundle& bundle) { ASSERT_THAT(repository_->PutReport(bundle), IsOk()); }
  storage::RunFilter Set(const std::string& set) {
    storage::RunFilter filter;
    filter.parameter_set = set;
    return filter;
  }
};

TEST_F(FleetQueriesTest, StatisticsByDayCarryDayKeysAndThePapersShares) {
  FleetQueries queries(*repository_, "default");
  auto answer = queries.Statistics(kEngineer, Set("default"), storage::GroupBy::kDay);
  ASSERT_THAT(answer, IsOk());
  EXPECT_EQ(answer->total.counts.reports, 3);
  EXPECT_EQ(answer->total.counts.robots, 2);
  EXPECT_DOUBLE_EQ(*answer->total.recovery_per_run, 12.0 / 3.0);
  EXPECT_DOUBLE_EQ(*answer->total.started_localized_share, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(*answer->total.ambiguous_view_share, 7.0 / 30.0);
  ASSERT_EQ(answer->groups.size(), 2u);
  EXPECT_EQ(answer->groups[0].key, "2026-01-01");
  EXPECT_EQ(answer->groups[1].key, "2026-01-02");
  EXPECT_EQ(answer->groups[1].figures.counts.robots, 2);
  EXPECT_FALSE(answer->total.merge_conditional_then_rejected_share)
      << "no merges: the share is absent, not 0";
  EXPECT_EQ(DayKey("-1"), "1969-12-31");
  EXPECT_EQ(DayKey("abc"), "abc");
}

TEST_F(FleetQueriesTest, RobotsSeeOnlyTheirOwnRuns) {
  FleetQueries queries(*repository_, "default");
  auto own = queries.Statistics(kRobotA, Set("default"), std::nullopt);
  ASSERT_THAT(own, IsOk());
  EXPECT_EQ(own->total.counts.reports, 2) << "robot a's two runs, not b's";
  storage::RunFilter other = Set("default");
  other.robot_id = "b";
  auto others = queries.Statistics(kRobotA, other, std::nullopt);
  ASSERT_THAT(others, IsOk());
  EXPECT_EQ(others->total.counts.reports, 0) << "naming another robot finds nothing";
  RunsQuery query;
  auto runs = queries.Runs(kRobotA, query);
  ASSERT_THAT(runs, IsOk());
  ASSERT_EQ(runs->rows.size(), 2u);
  for (const RunRow& row : runs->rows) EXPECT_EQ(row.run.robot_id, "a");
  auto key = queries.Run(kRobotA, "b", "r1");
  EXPECT_EQ(key.status().code(), storage::StatusCode::kNotFound)
      << "another robot's run answers like a missing one";
  auto shared = queries.Run(kEngineer, "", "r1");
  EXPECT_EQ(shared.status().code(), storage::StatusCode::kInvalidArgument)
      << "two robots have r1: name the robot";
  auto compared = queries.Compare(kRobotA, {}, "default", "tuned", 10);
  ASSERT_THAT(compared, IsOk());
  EXPECT_EQ(compared->runs_compared, 2);
}

TEST_F(FleetQueriesTest, ComparisonScoresEveryCountAlikeAndRanksByChangeThenRun) {
  FleetQueries queries(*repository_, "default");
  auto comparison = queries.Compare(kEngineer, {}, "default", "tuned", 10);
  ASSERT_THAT(comparison, IsOk());
  EXPECT_EQ(comparison->runs_compared, 3);
  EXPECT_EQ(comparison->runs_changed, 2);
  EXPECT_FALSE(comparison->scan_truncated);
  ASSERT_EQ(comparison->most_changed.size(), 3u);
  // b/r1: |3 − 6| recoveries + |1 − 3| accepted = 5; a/r1: 1 recovery + 1 for its start localization.
  EXPECT_EQ(comparison->most_changed[0].run.robot_id, "b");
  EXPECT_DOUBLE_EQ(comparison->most_changed[0].change, 3.0 + 2.0);
  EXPECT_EQ(comparison->most_changed[1].run.robot_id, "a");
  EXPECT_DOUBLE_EQ(comparison->most_changed[1].change, 1.0 + 0.0 + 1.0);
  EXPECT_DOUBLE_EQ(comparison->most_changed[2].change, 0.0);
  storage::ReportRecord x, y;
  y.started_localized = true;
  EXPECT_DOUBLE_EQ(ChangeScore(x, y), 1.0) << "a change of start localization weighs one count";
  EXPECT_EQ(comparison->a.counts.reports, 3);
  ASSERT_EQ(comparison->by_firmware.size(), 2u);
  EXPECT_EQ(comparison->by_firmware[1].first, "fw-2");
  EXPECT_EQ(comparison->by_firmware[1].second.second->counts.recovery_created, 3);
  auto top = queries.Compare(kEngineer, {}, "default", "tuned", 1);
  ASSERT_THAT(top, IsOk());
  EXPECT_EQ(top->most_changed.size(), 1u);
  EXPECT_EQ(top->runs_compared, 3) << "top bounds the rows, not the count";
  auto unknown = queries.Compare(kEngineer, {}, "default", "nope", 10);
  EXPECT_THAT(unknown, StatusIs(storage::StatusCode::kNotFound));
  EXPECT_NE(unknown.status().message().find("set_b"), std::string::npos) << unknown.status().message();
  EXPECT_EQ(queries.Compare(kEngineer, {}, "default", "tuned", 0).status().code(),
            storage::StatusCode::kInvalidArgument);
}

TEST_F(FleetQueriesTest, ConfusionMatrixCountsPredictionsAgainstLabels) {
  FleetQueries queries(*repository_, "default");
  // Three regions on a/r1: predicted protrusion (labelled protrusion, then new_space) and one unclassified.
  storage::ReportBundle bundle = Report("a", "r1", "default", 4, true, 2);
  for (const auto& [id, predicted] :
       {std::pair{1, "protrusion"}, std::pair{2, "protrusion"}, std::pair{3, "?"}}) {
    storage::ProtrusionRegionRecord region;
    region.region_id = id;
    region.features_json = "{}";
    region.predicted_class = predicted;
    bundle.protrusion_regions.push_back(region);
  }
  Put(bundle);
  ASSERT_THAT(repository_->LabelProtrusionRegion({"a", "r1"}, "default", 1, "protrusion", "engineer:ana"),
              IsOk());
  ASSERT_THAT(repository_->LabelProtrusionRegion({"a", "r1"}, "default", 2, "new_space", "engineer:ana"),
              IsOk());
  ASSERT_THAT(repository_->LabelProtrusionRegion({"a", "r1"}, "default", 3, "new_space", "engineer:ana"),
              IsOk());
  auto m = queries.Confusion(kEngineer, "default");
  ASSERT_THAT(m, IsOk());
  EXPECT_EQ(m->true_positive, 1);
  EXPECT_EQ(m->false_positive, 1);
  EXPECT_EQ(m->unclassified, 1);
  EXPECT_EQ(m->labelled, 3);
  EXPECT_DOUBLE_EQ(*m->precision, 0.5);
  EXPECT_DOUBLE_EQ(*m->recall, 1.0);
  EXPECT_DOUBLE_EQ(*m->false_positive_rate, 1.0);
  Principal robot_b{"robot:b", Role::kRobot, "b"};
  auto none = queries.Confusion(robot_b, "default");
  ASSERT_THAT(none, IsOk());
  EXPECT_EQ(none->labelled, 0) << "robot b sees no labels of robot a's runs";
  EXPECT_FALSE(none->precision.has_value());
  auto report = queries.Report({"a", "r1"}, "default");
  ASSERT_THAT(report, IsOk());
  EXPECT_EQ(report->protrusion_regions(0).label(), "protrusion") << "the report carries the current labels";
  EXPECT_EQ(queries.Report({"a", "r9"}, "default").status().code(), storage::StatusCode::kNotFound);
}

TEST_F(FleetQueriesTest, RunsPagesCarryTheSetsCountersAndBoundThePageSize) {
  FleetQueries queries(*repository_, "default");
  RunsQuery query;
  query.page_size = 2;
  query.report_set = "tuned";
  query.with_report_sets = true;
  auto first = queries.Runs(kEngineer, query);
  ASSERT_THAT(first, IsOk());
  ASSERT_EQ(first->rows.size(), 2u);
  ASSERT_TRUE(first->rows[0].report);
  EXPECT_EQ(first->rows[0].report->recovery_created, 5);
  EXPECT_TRUE(first->rows[0].report->report.empty()) << "counters only";
  EXPECT_EQ(first->rows[0].report_sets, (std::vector<std::string>{"default", "tuned"}));
  ASSERT_TRUE(first->next);
  query.after = first->next;
  auto second = queries.Runs(kEngineer, query);
  ASSERT_THAT(second, IsOk());
  EXPECT_EQ(second->rows.size(), 1u);
  EXPECT_FALSE(second->next);
  query.page_size = 1001;
  EXPECT_EQ(queries.Runs(kEngineer, query).status().code(), storage::StatusCode::kInvalidArgument);
  auto jobs = queries.Jobs(kEngineer, "all", 0);
  EXPECT_THAT(jobs, StatusIs(storage::StatusCode::kInvalidArgument));
}

}  // namespace
}  // namespace server
