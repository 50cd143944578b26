#include "slamcore/linear_initialization.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <numbers>

#include "slamcore/graph_io.h"
#include "test_data.h"
#include "test_matchers.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::IsNearlyPose;

TEST(LinearInitializationTest, RecoversNoiseFreeGraphExactly) {
  // ring_groundTruth.g2o: ground-truth poses with noise-free edges. Scrambling the poses and initialising
  // must give the ground truth back, anchored at node 0 (to the file's six printed decimals).
  TEST_DATA_FILE_OR_SKIP(ring_truth, "posegraphs/vertigo/ring_groundTruth.g2o");
  const auto truth = ReadPoseGraph(ring_truth);
  ASSERT_THAT(truth, IsOk());
  PoseGraph scrambled = *truth;
  for (Node& node : scrambled.mutable_nodes()) {
    if (node.id != 0) node.pose = SE2(0.1 * static_cast<double>(node.id), -3.0, 2.0);
  }
  ASSERT_THAT(InitializeLinear(scrambled), IsOk());
  for (const Node& node : truth->nodes())
    EXPECT_THAT(scrambled.node(node.id).pose, IsNearlyPose(node.pose, 1e-4));
}

TEST(LinearInitializationTest, UnwrapsHeadingsAcrossPi) {
  // A loop of 8 nodes turning 45° each step, so headings cross ±π; one observation edge closes it.
  PoseGraph graph;
  const SE2 step(1.0, 0.0, std::numbers::pi / 4);
  SE2 truth = SE2(3.0, 1.0, 3.0);  // anchor near +π
  std::vector<SE2> expected;
  for (int k = 0; k < 8; ++k) {
    Node node;
    node.id = k;
    node.pose = k == 0 ? truth : SE2::Identity();
    ASSERT_THAT(graph.AddNode(node), IsOk());
    expected.push_back(truth);
    truth = truth * step;
  }
  for (int k = 0; k < 8; ++k) {
    Edge edge;
    edge.from = k;
    edge.to = (k + 1) % 8;
    edge.measurement = step;
    edge.kind = k < 7 ? EdgeKind::kMotion : EdgeKind::kObservation;
    ASSERT_THAT(graph.AddEdge(edge), IsOk());
  }
  ASSERT_THAT(InitializeLinear(graph), IsOk());
  for (int k = 0; k < 8; ++k)
    EXPECT_THAT(graph.node(k).pose, IsNearlyPose(expected[k], 1e-9)) << "node " << k;
}

TEST(LinearInitializationTest, UnknownComponentIsNotFound) {
  PoseGraph graph;
  EXPECT_EQ(InitializeLinear(graph, 5).code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace slamcore
