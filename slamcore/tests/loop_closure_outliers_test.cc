// The wrong-loop-closure generator behind slamtool corrupt-g2o and the filter benchmark: its modes place what
// they promise, and options without a bound are refused naming the bound.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "slamcore/loop_closure_outliers.h"
#include "slamcore/manhattan_world.h"
#include "slamcore/optimizer.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using ::testing::HasSubstr;

/// 60 poses along x with odometry, and true loop closures k → k + 40 for k = 10..14 (a second pass).
PoseGraph Corridor() {
  PoseGraph graph;
  for (int k = 0; k < 60; ++k) EXPECT_THAT(graph.AddNode(Node{.id = k, .pose = SE2(k % 40, 0, 0)}), IsOk());
  for (int k = 0; k + 1 < 60; ++k)
    EXPECT_THAT(graph.AddEdge(Edge{.from = k, .to = k + 1, .measurement = SE2(1, 0, 0)}), IsOk());
  for (int k = 10; k < 15; ++k) {
    EXPECT_THAT(
        graph.AddEdge(Edge{
            .from = k, .to = k + 40, .measurement = SE2(0.01 * k, 0, 0), .kind = EdgeKind::kObservation}),
        IsOk());
  }
  return graph;
}

TEST(LoopClosureOutliersTest, FirstPutsEveryGroupBeforeTheFirstTrueClosureNearItsEarlierEnd) {
  OutlierOptions options;
  options.mode = OutlierOptions::Mode::kFirst;
  options.group_size = 3;
  options.count = 20;
  const auto corrupted = AddLoopClosureOutliers(Corridor(), options);
  ASSERT_THAT(corrupted, IsOk());
  ASSERT_EQ(corrupted->outliers.size(), 60u);
  for (const auto& [from, to] : corrupted->outliers) {
    // Near vertices 7..17 (within the group size of 10..14) the first true closure arrives at vertex 50.
    if (from >= 7 && from <= 17) EXPECT_LT(to, 50) << from << " → " << to;
    EXPECT_GE(to, from + 2);
  }
}

TEST(LoopClosureOutliersTest, ShiftedRepeatsATrueClosuresMeasurementAFewVerticesAway) {
  OutlierOptions options;
  options.mode = OutlierOptions::Mode::kShifted;
  options.group_size = 2;
  options.count = 10;
  const auto corrupted = AddLoopClosureOutliers(Corridor(), options);
  ASSERT_THAT(corrupted, IsOk());
  std::set<std::pair<NodeId, NodeId>> wrong(corrupted->outliers.begin(), corrupted->outliers.end());
  int checked = 0;
  for (const Edge& edge : corrupted->graph.edges()) {
    if (!wrong.contains({edge.from, edge.to})) continue;
    // A true closure k → k + 40 (k = 10..14) with its earlier end moved by 3–10 vertices and its measurement
    // kept; the group's second pair follows one vertex later at both ends.
    const long shift = edge.from - (edge.to - 40);
    EXPECT_GE(std::abs(shift), 3) << edge.from << " → " << edge.to;
    EXPECT_LE(std::abs(shift), 10) << edge.from << " → " << edge.to;
    EXPECT_NEAR(edge.measurement.y(), 0.0, 1e-12);
    EXPECT_GE(edge.measurement.x(), 0.1 - 1e-12);
    EXPECT_LE(edge.measurement.x(), 0.14 + 1e-12);
    ++checked;
  }
  EXPECT_EQ(checked, 20);
}

// On a grid world a look-alike a few vertices along, or a local outlier a few vertices long, can be the
// truth itself; such an edge is not wrong. Each outlier says whether it agrees with the input's optimum
// within χ²₃(0.999) at its information, and the score leaves those out.
TEST(LoopClosureOutliersTest, OutliersThatAgreeWithTheInputsOptimumAreMarkedAndNotScored) {
  const Result<ManhattanWorld> world = GenerateManhattanWorld({.poses = 1500, .seed = 3});
  ASSERT_THAT(world, IsOk());
  PoseGraph optimum = world->graph;
  ASSERT_THAT(Optimize(optimum), IsOk());
  int agreeing = 0;
  for (const OutlierOptions::Mode mode : {OutlierOptions::Mode::kShifted, OutlierOptions::Mode::kLocal}) {
    OutlierOptions options{.mode = mode, .group_size = mode == OutlierOptions::Mode::kShifted ? 10 : 1};
    options.total_edges = CountLoopClosures(world->graph);
    const auto corrupted = AddLoopClosureOutliers(world->graph, options);
    ASSERT_THAT(corrupted, IsOk());
    ASSERT_EQ(corrupted->agrees_with_optimum.size(), corrupted->outliers.size());
    for (std::size_t k = 0; k < corrupted->outliers.size(); ++k) {
      const Edge& edge = corrupted->graph.edges()[corrupted->first_outlier_edge + k];
      EXPECT_EQ(corrupted->agrees_with_optimum[k], EdgeChi2(optimum, edge) <= 16.27)
          << edge.from << " → " << edge.to << ": χ² " << EdgeChi2(optimum, edge);
      agreeing += corrupted->agrees_with_optimum[k] ? 1 : 0;
    }
    // Scored on a replay that accepted every closure: the agreeing ones count neither way.
    ReplayResult all_accepted;
    for (std::size_t k = 0; k < corrupted->graph.num_edges(); ++k) {
      const Edge& edge = corrupted->graph.edges()[k];
      if (edge.kind == EdgeKind::kObservation) all_accepted.accepted_edges.push_back(k);
    }
    const FilterScore score =
        ScoreReplay(all_accepted, corrupted->first_outlier_edge, corrupted->agrees_with_optimum);
    const int marked = static_cast<int>(
        std::count(corrupted->agrees_with_optimum.begin(), corrupted->agrees_with_optimum.end(), true));
    EXPECT_EQ(score.agreeing_accepted, marked);
    EXPECT_EQ(score.wrong_accepted, static_cast<int>(corrupted->outliers.size()) - marked);
  }
  EXPECT_GT(agreeing, 0) << "this world has outliers that are the truth itself";
}

TEST(LoopClosureOutliersTest, UnboundedOptionsAreRefused) {
  const PoseGraph graph = Corridor();
  OutlierOptions huge_group;
  huge_group.group_size = 1001;
  EXPECT_THAT(AddLoopClosureOutliers(graph, huge_group).status().message(), HasSubstr("at most 1000"));
  OutlierOptions too_many;
  too_many.total_edges = 100 * 60 + 1;
  EXPECT_THAT(AddLoopClosureOutliers(graph, too_many).status().message(),
              HasSubstr("more than 100 wrong edges per vertex"));
  // Counted in groups as well (a count of 10⁸ groups ended slamtool with bad_alloc).
  OutlierOptions too_many_groups;
  too_many_groups.count = 100'000'000;
  EXPECT_THAT(AddLoopClosureOutliers(graph, too_many_groups).status().message(),
              HasSubstr("more than 100 wrong edges per vertex"));
  OutlierOptions upside_down;
  upside_down.group_size = 10;
  upside_down.max_group_size = 2;
  EXPECT_THAT(AddLoopClosureOutliers(graph, upside_down).status().message(),
              HasSubstr("smaller than the smallest"));
  OutlierOptions bad_share;
  bad_share.single_fraction = 1.5;
  EXPECT_THAT(AddLoopClosureOutliers(graph, bad_share).status().message(), HasSubstr("single_fraction"));
  EXPECT_THAT(ParseOutlierMode("grouped").status().message(),
              HasSubstr("expected random, local, first or shifted"));
  EXPECT_EQ(*ParseOutlierMode("shifted"), OutlierOptions::Mode::kShifted);
}

}  // namespace
}  // namespace slamcore
