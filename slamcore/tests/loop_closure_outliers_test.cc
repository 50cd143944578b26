// The wrong-loop-closure generator behind slamtool corrupt-g2o and the filter benchmark: its modes place what
// they promise, and options without a bound are refused naming the bound.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "slamcore/loop_closure_outliers.h"
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

TEST(LoopClosureOutliersTest, UnboundedOptionsAreRefused) {
  const PoseGraph graph = Corridor();
  OutlierOptions huge_group;
  huge_group.group_size = 1001;
  EXPECT_THAT(AddLoopClosureOutliers(graph, huge_group).status().message(), HasSubstr("at most 1000"));
  OutlierOptions too_many;
  too_many.total_edges = 100 * 60 + 1;
  EXPECT_THAT(AddLoopClosureOutliers(graph, too_many).status().message(),
              HasSubstr("more than 100 per vertex"));
  OutlierOptions bad_share;
  bad_share.single_fraction = 1.5;
  EXPECT_THAT(AddLoopClosureOutliers(graph, bad_share).status().message(), HasSubstr("single_fraction"));
  EXPECT_THAT(ParseOutlierMode("grouped").status().message(),
              HasSubstr("expected random, local, first or shifted"));
  EXPECT_EQ(*ParseOutlierMode("shifted"), OutlierOptions::Mode::kShifted);
}

}  // namespace
}  // namespace slamcore
