#include "analyzer/run_analysis.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "sim/run_simulator.h"
#include "slamcore/protrusion_detector.h"
#include "test_data.h"
#include "status_matchers.h"

namespace analyzer {
namespace {

/// Two simulated runs of one robot in a real floor plan: the second starts on the first's map.
std::vector<fleet::v1::RunFile> SimulatedRuns() {
  const auto worlds = sim::ListWorlds(test_data::Sample() / "floorplans");
  EXPECT_THAT(worlds, IsOk());
  static const auto world = sim::LoadWorld(worlds->front(), 11);
  EXPECT_THAT(world, IsOk());
  sim::SimParams params;
  params.run_minutes = 5.0;
  params.stuck_rate_scale = 400.0;  // a wedge on one bump in 10: make sure the second run gets stuck
  sim::RobotSimulator robot(*world, params, "robot-test", "1.0.0", 5);
  std::vector<fleet::v1::RunFile> runs;
  for (int k = 0; k < 2; ++k) {
    auto outcome = robot.SimulateRun("run-" + std::to_string(k), 1.7e9 + 86400.0 * k);
    EXPECT_THAT(outcome, IsOk());
    runs.push_back(outcome->run);
  }
  return runs;
}

TEST(RunAnalysisTest, RerunWithTheRobotsParametersReproducesTheRobotsMap) {
  const auto runs = SimulatedRuns();
  const auto report = AnalyzeRun(runs[1], {});
  ASSERT_THAT(report, IsOk());
  EXPECT_EQ(report->run_id(), "run-1");
  EXPECT_EQ(report->parameter_set(), "default");
  EXPECT_FALSE(report->decisions().empty());
  EXPECT_GE(report->counts().components_created(), 1);
  // The robot ran the same Mapper with the same parameters: the rerun is the same map.
  EXPECT_EQ(report->divergence().robot_nodes(), report->divergence().rerun_nodes());
  EXPECT_EQ(report->divergence().robot_observation_edges(), report->divergence().rerun_observation_edges());
  EXPECT_LT(report->divergence().node_position_rms(), 1e-9);
  ASSERT_TRUE(report->has_ground_truth());
  EXPECT_GT(report->ground_truth().nodes_with_truth(), 100);
  EXPECT_GT(report->ground_truth().correct_observations(), 0);
  EXPECT_LE(report->ground_truth().wrong_observations_accepted(),
            report->ground_truth().wrong_observations());
  EXPECT_EQ(report->feature_names_size(), static_cast<int>(slamcore::ProtrusionFeatureNames().size()));
  for (const auto& region : report->protrusion_regions()) {
    // No model given: the built-in default classes every region.
    EXPECT_TRUE(region.predicted_class() == "protrusion" || region.predicted_class() == "new_space");
    EXPECT_GE(region.probability(), 0.0);
    EXPECT_LE(region.probability(), 1.0);
    EXPECT_EQ(region.bbox_size(), 4);
    EXPECT_TRUE(region.has_truth_protrusion());
  }
  EXPECT_GT(report->rerun_child().nodes_size(), 0);
}

TEST(RunAnalysisTest, MapsDecodedOnceGiveTheSameReport) {
  const auto runs = SimulatedRuns();
  const auto maps = DecodeRunMaps(runs[1]);
  ASSERT_THAT(maps, IsOk());
  EXPECT_GT(maps->parent.graph.num_nodes(), 0u);
  EXPECT_GT(maps->uploaded_child.graph.num_nodes(), maps->parent.graph.num_nodes());
  auto decoded_once = AnalyzeRun(runs[1], *maps, {});
  auto from_the_run = AnalyzeRun(runs[1], {});
  ASSERT_THAT(decoded_once, IsOk());
  ASSERT_THAT(from_the_run, IsOk());
  // Everything but the timings.
  for (fleet::v1::RunReport* report : {&*decoded_once, &*from_the_run}) {
    report->clear_replay_seconds();
    report->clear_detection_seconds();
  }
  EXPECT_EQ(decoded_once->SerializeAsString(), from_the_run->SerializeAsString());
  // The snapshots are not read again: the maps given are the ones replayed from.
  fleet::v1::RunFile without_snapshots = runs[1];
  without_snapshots.clear_parent_snapshot();
  without_snapshots.clear_child_snapshot();
  auto given = AnalyzeRun(without_snapshots, *maps, {});
  ASSERT_THAT(given, IsOk());
  given->clear_replay_seconds();
  given->clear_detection_seconds();
  EXPECT_EQ(given->SerializeAsString(), from_the_run->SerializeAsString());
  EXPECT_EQ(DecodeRunMaps(fleet::v1::RunFile{}).status().code(), slamcore::StatusCode::kInvalidArgument);
}

TEST(RunAnalysisTest, StricterParametersChangeTheDecisions) {
  const auto runs = SimulatedRuns();
  AnalysisOptions strict;
  strict.parameter_set_name = "strict";
  strict.mapper.recovery.min_observations = 50;
  strict.mapper.recovery.min_views = 20;
  const auto report = AnalyzeRun(runs[1], strict);
  ASSERT_THAT(report, IsOk());
  EXPECT_EQ(report->parameter_set(), "strict");
  EXPECT_EQ(report->counts().recovery_accepted(), 0);
}

TEST(RunAnalysisTest, TheBudgetEndsTheReplayWhereItRunsOut) {
  const auto runs = SimulatedRuns();
  ASSERT_GT(runs[1].events_size(), 600);
  AnalysisOptions options;
  int asked = 0;
  options.keep_going = [&]() -> slamcore::Status {
    return ++asked <= 2 ? slamcore::Status::Ok()
                        : slamcore::FailedPrecondition("analysis budget: out of time");
  };
  const auto report = AnalyzeRun(runs[1], options);
  ASSERT_THAT(report, StatusIs(slamcore::StatusCode::kFailedPrecondition));
  // Asked at events 0 and 256 (fine), then at 512: the replay stops there.
  EXPECT_EQ(report.status().message(),
            "analysis budget: out of time (at events[512] of " + std::to_string(runs[1].events_size()) + ")");
  EXPECT_EQ(asked, 3);
  // A budget that always allows changes nothing.
  options.keep_going = [] { return slamcore::Status::Ok(); };
  EXPECT_THAT(AnalyzeRun(runs[1], options), IsOk());
}

TEST(RunAnalysisTest, MalformedTelemetryIsRefusedNamingTheEvent) {
  auto runs = SimulatedRuns();
  fleet::v1::RunFile broken = runs[1];
  int index = -1;
  for (int k = 0; k < broken.events_size(); ++k) {
    if (broken.events(k).has_view_observed()) {
      broken.mutable_events(k)->mutable_view_observed()->set_view(987654321);
      index = k;
      break;
    }
  }
  ASSERT_GE(index, 0);
  const auto report = AnalyzeRun(broken, {});
  ASSERT_THAT(report, StatusIs(slamcore::StatusCode::kInvalidArgument));
  EXPECT_NE(report.status().message().find("events[" + std::to_string(index) + "]"), std::string::npos)
      << report.status().message();
  EXPECT_NE(report.status().message().find("987654321"), std::string::npos) << report.status().message();

  broken = runs[1];
  broken.mutable_header()->set_run_id("");
  EXPECT_EQ(AnalyzeRun(broken, {}).status().message(), "header.run_id: missing");
}

}  // namespace
}  // namespace analyzer
