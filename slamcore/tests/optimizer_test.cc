#include "slamcore/optimizer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

#include "slamcore/graph_io.h"
#include "test_matchers.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::IsNearlyPose;
using testing::NumericJacobian;

TEST(EdgeErrorTest, ZeroWhenPosesAgreeWithMeasurement) {
  const SE2 from(1.0, 2.0, 0.3), measurement(0.5, -0.2, 0.1);
  EXPECT_TRUE(EdgeError(from, from * measurement, measurement).isZero(1e-12));
}

TEST(EdgeErrorTest, JacobiansMatchNumeric) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Vector3 from(value(random), value(random), value(random));
    const Vector3 to(value(random), value(random), value(random));
    const SE2 measurement(value(random), value(random), value(random));
    Matrix3 d_from, d_to;
    EdgeError(SE2(from.x(), from.y(), from.z()), SE2(to.x(), to.y(), to.z()), measurement, &d_from, &d_to);
    const auto error_of = [&](const Vector3& a, const Vector3& b) {
      return EdgeError(SE2(a.x(), a.y(), a.z()), SE2(b.x(), b.y(), b.z()), measurement);
    };
    const auto numeric_from =
        NumericJacobian<3, 3>([&](const Vector3& a) -> Vector3 { return error_of(a, to); }, from);
    const auto numeric_to =
        NumericJacobian<3, 3>([&](const Vector3& b) -> Vector3 { return error_of(from, b); }, to);
    EXPECT_TRUE(d_from.isApprox(numeric_from, 1e-6)) << d_from << "\n" << numeric_from;
    EXPECT_TRUE(d_to.isApprox(numeric_to, 1e-6));
  }
}

/// A square loop of four nodes, odometry perturbed, closed by one observation edge.
PoseGraph SquareLoop(NodeId first_id, double odometry_bias) {
  PoseGraph graph;
  const SE2 step(1.0, 0.0, std::numbers::pi / 2);
  SE2 pose = SE2::Identity();
  for (int k = 0; k < 4; ++k) {
    Node node;
    node.id = first_id + k;
    node.pose = pose;
    EXPECT_THAT(graph.AddNode(node), IsOk());
    pose = pose * SE2(1.0 + odometry_bias, 0.0, std::numbers::pi / 2);
  }
  for (int k = 0; k < 4; ++k) {
    Edge edge;
    edge.from = first_id + k;
    edge.to = first_id + (k + 1) % 4;
    edge.measurement = step;
    edge.kind = k < 3 ? EdgeKind::kMotion : EdgeKind::kObservation;
    EXPECT_THAT(graph.AddEdge(edge), IsOk());
  }
  return graph;
}

TEST(OptimizerTest, ConsistentLoopReachesZeroChi2AndKeepsTheAnchor) {
  PoseGraph graph = SquareLoop(0, 0.2);
  ASSERT_GT(Chi2(graph), 0.01);
  const auto summary = Optimize(graph);
  ASSERT_THAT(summary, IsOk());
  EXPECT_NEAR(summary->final_chi2, 0.0, 1e-10);
  EXPECT_TRUE(summary->converged);
  EXPECT_THAT(graph.node(0).pose, IsNearlyPose(SE2::Identity(), 1e-12));
  EXPECT_THAT(graph.node(2).pose, IsNearlyPose(SE2(1.0, 1.0, std::numbers::pi), 1e-6));
}

TEST(OptimizerTest, FixesTheGaugePerComponentAndCanOptimiseOneComponent) {
  PoseGraph graph = SquareLoop(0, 0.2);
  const PoseGraph second = SquareLoop(10, -0.1);
  for (const Node& node : second.nodes()) {
    Node moved = node;
    moved.pose = SE2(5.0, 5.0, 0.5) * node.pose;
    ASSERT_THAT(graph.AddNode(moved), IsOk());
  }
  for (const Edge& edge : second.edges()) ASSERT_THAT(graph.AddEdge(edge), IsOk());
  ASSERT_EQ(graph.NumComponents(), 2u);
  const SE2 second_anchor = graph.node(10).pose;
  const SE2 untouched = graph.node(12).pose;

  OptimizerOptions only_first;
  only_first.component = 0;
  const auto first_summary = Optimize(graph, only_first);
  ASSERT_THAT(first_summary, IsOk());
  EXPECT_NEAR(first_summary->final_chi2, 0.0, 1e-10);
  EXPECT_THAT(graph.node(12).pose, IsNearlyPose(untouched, 0.0));
  EXPECT_GT(Chi2(graph, graph.ComponentOf(10)), 0.01);

  const auto all = Optimize(graph);
  ASSERT_THAT(all, IsOk());
  EXPECT_NEAR(all->final_chi2, 0.0, 1e-10);
  EXPECT_THAT(graph.node(10).pose, IsNearlyPose(second_anchor, 1e-12));
  EXPECT_THAT(graph.node(0).pose, IsNearlyPose(SE2::Identity(), 1e-12));
}

TEST(OptimizerTest, RobustLossLimitsAWrongLoopClosure) {
  // A straight corridor of 20 nodes with exact odometry and one wildly wrong loop closure.
  auto build = [] {
    PoseGraph graph;
    for (int k = 0; k < 20; ++k) {
      Node node;
      node.id = k;
      node.pose = SE2(k, 0.0, 0.0);
      EXPECT_THAT(graph.AddNode(node), IsOk());
      if (k > 0) {
        Edge edge;
        edge.from = k - 1;
        edge.to = k;
        edge.measurement = SE2(1.0, 0.0, 0.0);
        edge.information = Matrix3::Identity() * 100.0;
        EXPECT_THAT(graph.AddEdge(edge), IsOk());
      }
    }
    Edge wrong;
    wrong.from = 0;
    wrong.to = 19;
    wrong.measurement = SE2(2.0, 3.0, 1.0);
    wrong.kind = EdgeKind::kObservation;
    EXPECT_THAT(graph.AddEdge(wrong), IsOk());
    return graph;
  };
  PoseGraph plain = build(), robust = build();
  ASSERT_THAT(Optimize(plain), IsOk());
  OptimizerOptions cauchy;
  cauchy.robust_loss = RobustLoss::kCauchy;
  ASSERT_THAT(Optimize(robust, cauchy), IsOk());
  const double plain_error = (plain.node(19).pose.translation() - Vector2(19.0, 0.0)).norm();
  const double robust_error = (robust.node(19).pose.translation() - Vector2(19.0, 0.0)).norm();
  EXPECT_GT(plain_error, 0.1);
  EXPECT_LT(robust_error, plain_error / 3.0);
}

TEST(OptimizerTest, RejectsBadOptions) {
  PoseGraph graph = SquareLoop(0, 0.1);
  OptimizerOptions options;
  options.relative_cost_decrease = 0.0;
  EXPECT_EQ(Optimize(graph, options).status().code(), StatusCode::kInvalidArgument);
  options = {};
  options.max_iterations = 0;
  EXPECT_EQ(Optimize(graph, options).status().code(), StatusCode::kInvalidArgument);
  options = {};
  options.component = 42;
  EXPECT_EQ(Optimize(graph, options).status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace slamcore
