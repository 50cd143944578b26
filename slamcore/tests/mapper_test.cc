// The Mapper's core decisions (paper III-B): nodes from odometry, the direct gate, recovery hypotheses,
// acceptance with competitor deletion, and expiry. Expected numbers are worked out in the comments.
#include "slamcore/mapper.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "mapper_test_util.h"
#include "test_matchers.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::CountDecisions;
using ::testing::HasSubstr;
using testing::IsNearlyPose;
using testing::MakeMapper;
using testing::SimulatedRobot;

TEST(MapperTest, OdometryBuildsAChainOfNodesJoinedByMotionEdges) {
  auto mapper = MakeMapper();
  EXPECT_FALSE(mapper->CurrentNode().has_value());
  EXPECT_FALSE(mapper->CurrentPose().has_value());
  const Matrix3 covariance = Vector3(1e-4, 2e-4, 4e-4).asDiagonal();
  for (int i = 0; i < 3; ++i) {
    ASSERT_THAT(
        mapper->Process(OdometryEvent{
            .time = double(i), .increment = SE2(1.0, 0.0, std::numbers::pi / 2), .covariance = covariance}),
        IsOk());
  }
  const PoseGraph& graph = mapper->map().graph;
  ASSERT_EQ(graph.num_nodes(), 3u);
  // The first node sits at the identity; then (1, 0, π/2), then (1, 0, π/2)·(1, 0, π/2) = (1, 1, π).
  EXPECT_THAT(graph.node(0).pose, IsNearlyPose(SE2(0.0, 0.0, 0.0), 1e-12));
  EXPECT_THAT(graph.node(1).pose, IsNearlyPose(SE2(1.0, 0.0, std::numbers::pi / 2), 1e-12));
  EXPECT_THAT(graph.node(2).pose, IsNearlyPose(SE2(1.0, 1.0, std::numbers::pi), 1e-12));
  EXPECT_DOUBLE_EQ(graph.node(2).odometer, 2.0);
  EXPECT_DOUBLE_EQ(graph.node(2).time, 2.0);
  ASSERT_EQ(graph.num_edges(), 2u);
  EXPECT_EQ(graph.edges()[1].from, 1);
  EXPECT_EQ(graph.edges()[1].to, 2);
  EXPECT_EQ(graph.edges()[1].kind, EdgeKind::kMotion);
  // Ω = Adj_zᵀ Σ⁻¹ Adj_z (optimizer.h): with Adj_z = [0 −1 0; 1 0 −1; 0 0 1] and Σ⁻¹ = diag(1e4, 5e3, 2.5e3),
  // worked by hand.
  const Matrix3 expected_motion_information =
      (Matrix3() << 5e3, 0.0, -5e3, 0.0, 1e4, 0.0, -5e3, 0.0, 7.5e3).finished();
  EXPECT_TRUE(graph.edges()[1].information.isApprox(expected_motion_information, 1e-9))
      << graph.edges()[1].information;
  EXPECT_EQ(graph.NumComponents(), 1u);
  EXPECT_EQ(mapper->CurrentNode(), 2);
  EXPECT_THAT(*mapper->CurrentPose(), IsNearlyPose(SE2(1.0, 1.0, std::numbers::pi), 1e-12));
  EXPECT_EQ(CountDecisions(*mapper, DecisionKind::kComponentCreated), 1);
  EXPECT_EQ(mapper->Statistics().components_created, 1);
}

TEST(MapperTest, ExactObservationInTheCurrentComponentIsADirectEdge) {
  auto mapper = MakeMapper();
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  robot.Drive(SE2(1.0, 0.0, 0.0));
  robot.Observe(1);  // z = (−1, 0, 0)
  ASSERT_EQ(mapper->accepted_observations().size(), 1u);
  EXPECT_EQ(mapper->accepted_observations()[0].robot_node, 1);
  EXPECT_EQ(mapper->accepted_observations()[0].view, 1);
  EXPECT_EQ(mapper->accepted_observations()[0].hypothesis, -1);
  const Edge& edge = mapper->map().graph.edges().back();
  EXPECT_EQ(edge.kind, EdgeKind::kObservation);
  EXPECT_EQ(edge.from, 1);
  EXPECT_EQ(edge.to, 0);
  EXPECT_EQ(edge.view, 1);
  EXPECT_THAT(edge.measurement, IsNearlyPose(SE2(-1.0, 0.0, 0.0), 1e-12));
  // Ω = Adj_zᵀ Σ⁻¹ Adj_z with Adj_z = [1 0 0; 0 1 1; 0 0 1] for z = (−1, 0, 0) and Σ⁻¹ = 100·I.
  const Matrix3 expected_information = (Matrix3() << 100, 0, 0, 0, 100, 100, 0, 100, 200).finished();
  EXPECT_TRUE(edge.information.isApprox(expected_information, 1e-9)) << edge.information;
  EXPECT_EQ(mapper->Statistics().direct_edges, 1);
  EXPECT_EQ(mapper->decisions().back().kind, DecisionKind::kDirectEdge);
  EXPECT_EQ(mapper->decisions().back().view, 1);
  EXPECT_EQ(mapper->decisions().back().node, 1);
}

// Node 0 at the origin holds view 1; one step of (1, 0, 0) with Σ = 1e-4 I gives the robot a relative
// covariance Adj_T Σ Adj_Tᵀ with T = (−1, 0, 0): 1e-4 [1 0 0; 0 2 1; 0 1 1]. The prediction is
// ẑ = (−1, 0, 0); observing z = (−1 + dx, 0, 0) gives R = (dx, 0, 0), whose Adjoint keeps the x row
// (1, 0, 0), so Σ_R's x row is (1e-4 + 1e-2, 0, 0) and d² = dx² / 0.0101. The gate 11.34 is crossed at
// dx = √(11.34 · 0.0101) = 0.3384: 0.33 gives d² = 10.78 (direct edge), 0.35 gives 12.13 (recovery).
DecisionKind DecisionForOffset(double dx) {
  auto mapper = MakeMapper();
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  robot.Drive(SE2(1.0, 0.0, 0.0));
  robot.ObserveRaw(1, SE2(-1.0 + dx, 0.0, 0.0), 1e-2);
  const Decision& last = mapper->decisions().back();
  return last.kind;
}

TEST(MapperTest, DirectGateIsTheMahalanobisTestOfEquationFour) {
  EXPECT_EQ(DecisionForOffset(0.33), DecisionKind::kDirectEdge);
  EXPECT_EQ(DecisionForOffset(-0.33), DecisionKind::kDirectEdge);
  EXPECT_EQ(DecisionForOffset(0.35), DecisionKind::kHypothesisCreated);
  EXPECT_EQ(DecisionForOffset(-0.35), DecisionKind::kHypothesisCreated);
}

TEST(MapperTest, OdometryUncertaintyWidensTheGate) {
  // Ten steps instead of one: Σ_rel's x variance is 10·1e-4 (pure x motion adds nothing to x from θ),
  // so the gate for dx grows to √(11.34 · (1e-3 + 1e-2)) = 0.3532 and an offset of 0.345 passes.
  auto mapper = MakeMapper();
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  for (int i = 0; i < 10; ++i) robot.Drive(SE2(0.1, 0.0, 0.0));
  robot.ObserveRaw(1, SE2(-1.0 + 0.345, 0.0, 0.0), 1e-2);
  EXPECT_EQ(mapper->decisions().back().kind, DecisionKind::kDirectEdge);
  EXPECT_EQ(DecisionForOffset(0.345), DecisionKind::kHypothesisCreated);  // one step: the narrow gate
}

// Wheel stasis: the robot stands at x = 1 while odometry claims it reached x = 2. Views 1 (node 0, x = 0)
// and 2 (node 1, x = 1). Odometry is loose (σ² = 1e-2), observations tight (σ² = 1e-4). The counting rules
// of III-B alone; with the map checks the same recovery needs more passes (mapper_consistency_test.cc).
class RecoveryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mapper_ = MakeMapper(testing::CountsOnlyParams());
    robot_ = std::make_unique<SimulatedRobot>(*mapper_);
    robot_->Drive(SE2::Identity(), std::nullopt, 1e-2);
    robot_->CreateView(1);
    robot_->Drive(SE2(1.0, 0.0, 0.0), std::nullopt, 1e-2);
    robot_->CreateView(2);
    robot_->Drive(SE2::Identity(), SE2(1.0, 0.0, 0.0), 1e-2);  // node 2: believed x = 2, truly x = 1
  }
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<SimulatedRobot> robot_;
};

TEST_F(RecoveryTest, ThreeObservationsOfTwoViewsAreAcceptedAndCompetitorsRejected) {
  // View 1 seen at (−1, 0, 0) but predicted at (−2, 0, 0): d² ≈ 1 / (2e-2 + 1e-4) ≈ 50, outside the gate.
  robot_->Observe(1, SE2::Identity(), 1e-4);
  EXPECT_EQ(mapper_->decisions().back().kind, DecisionKind::kHypothesisCreated);
  const std::int64_t recovery = mapper_->decisions().back().hypothesis;
  // A wild observation that agrees with nothing starts a competitor.
  robot_->ObserveRaw(1, SE2(3.0, 3.0, 1.0), 1e-4);
  EXPECT_EQ(mapper_->decisions().back().kind, DecisionKind::kHypothesisCreated);
  const std::int64_t competitor = mapper_->decisions().back().hypothesis;
  EXPECT_NE(recovery, competitor);
  // View 2, expressed in view 1's frame with v_T_ref = (−1, 0, 0), agrees with the first hypothesis.
  robot_->Observe(2, SE2::Identity(), 1e-4);
  EXPECT_EQ(mapper_->decisions().back().kind, DecisionKind::kHypothesisUpdated);
  EXPECT_EQ(mapper_->decisions().back().hypothesis, recovery);
  EXPECT_TRUE(mapper_->accepted_observations().empty());
  robot_->Observe(1, SE2::Identity(), 1e-4);  // 3 observations of 2 views: accepted

  const MapperStatistics statistics = mapper_->Statistics();
  EXPECT_EQ(statistics.recovery_created, 2);
  EXPECT_EQ(statistics.recovery_accepted, 1);
  EXPECT_EQ(statistics.recovery_rejected, 1);
  EXPECT_EQ(statistics.direct_edges, 0);
  const Decision* rejected = testing::LastDecision(*mapper_, DecisionKind::kRejected);
  ASSERT_NE(rejected, nullptr);
  EXPECT_EQ(rejected->hypothesis, competitor);
  EXPECT_THAT(rejected->reason, HasSubstr("competitor"));
  // One edge per observation, all at node 2 where they were made, in order.
  ASSERT_EQ(mapper_->accepted_observations().size(), 3u);
  for (const AcceptedObservation& accepted : mapper_->accepted_observations()) {
    EXPECT_EQ(accepted.robot_node, 2);
    EXPECT_EQ(accepted.hypothesis, recovery);
  }
  EXPECT_EQ(mapper_->accepted_observations()[1].view, 2);
  EXPECT_EQ(mapper_->map().graph.num_edges(), 5u);

  // Optimised: along x only, with x0 = 0 fixed, w = 1/1e-2 for motion and u = 1/1e-4 for observations,
  // minimise w[(x1 − 1)² + (x2 − x1 − 1)²] + u[2(x2 − 1)² + (x1 − x2)²]: normal equations below.
  const double w = 1e2, u = 1e4;
  Eigen::Matrix2d normal;
  normal << 2 * w + u, -w - u, -w - u, w + 3 * u;
  const Eigen::Vector2d rhs(w - w, w + 2 * u);
  const Eigen::Vector2d x = normal.ldlt().solve(rhs);
  EXPECT_NEAR(mapper_->map().graph.node(1).pose.x(), x[0], 1e-6);
  EXPECT_NEAR(mapper_->map().graph.node(2).pose.x(), x[1], 1e-6);
  EXPECT_NEAR(mapper_->map().graph.node(2).pose.x(), 1.0, 0.02);  // close to the truth

  // Re-anchored: the next exact observation passes the gate at once.
  robot_->Observe(2, SE2::Identity(), 1e-4);
  EXPECT_EQ(mapper_->decisions().back().kind, DecisionKind::kDirectEdge);
}

TEST(MapperTest, WithoutOptimisationRecoveryEdgesAreAddedButPosesKept) {
  MapperParams params = testing::CountsOnlyParams();
  params.optimize_after_accept = false;
  auto mapper = MakeMapper(params);
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity(), std::nullopt, 1e-2);
  robot.CreateView(1);
  robot.Drive(SE2(1.0, 0.0, 0.0), std::nullopt, 1e-2);
  robot.CreateView(2);
  robot.Drive(SE2::Identity(), SE2(1.0, 0.0, 0.0), 1e-2);
  robot.Observe(1, SE2::Identity(), 1e-4);
  robot.Observe(2, SE2::Identity(), 1e-4);
  robot.Observe(2, SE2::Identity(), 1e-4);
  EXPECT_EQ(mapper->Statistics().recovery_accepted, 1);
  EXPECT_EQ(mapper->map().graph.num_edges(), 5u);
  EXPECT_THAT(mapper->map().graph.node(2).pose, IsNearlyPose(SE2(2.0, 0.0, 0.0), 1e-12));
}

TEST_F(RecoveryTest, HypothesisExpiresAfterTheTimeLimit) {
  robot_->Observe(1, SE2::Identity(), 1e-4);
  ASSERT_EQ(mapper_->Statistics().recovery_created, 1);
  const double created = robot_->time();
  // Standing still: 120 s is not yet "more than 120 s".
  ASSERT_THAT(mapper_->Process(GroundTruthEvent{.time = created + 120.0, .world_T_robot = SE2()}), IsOk());
  EXPECT_EQ(mapper_->Statistics().recovery_expired, 0);
  ASSERT_THAT(mapper_->Process(GroundTruthEvent{.time = created + 120.5, .world_T_robot = SE2()}), IsOk());
  EXPECT_EQ(mapper_->Statistics().recovery_expired, 1);
  EXPECT_THAT(mapper_->decisions().back().reason, HasSubstr(" s"));
  EXPECT_EQ(mapper_->decisions().back().kind, DecisionKind::kExpired);
}

TEST_F(RecoveryTest, ADroppedHypothesisSaysWhatItHeldAgainstWhatAcceptanceNeeds) {
  // A place seen once (as every loop closure of SE-Sync's MIT graph is): the log says why it never counted.
  robot_->Observe(1, SE2::Identity(), 1e-4);
  for (int i = 0; i < 9; ++i) robot_->Drive(SE2(1.0, 0.0, 0.0), std::nullopt, 1e-2);
  ASSERT_EQ(mapper_->Statistics().recovery_expired, 1);
  const Decision* expired = testing::LastDecision(*mapper_, DecisionKind::kExpired);
  ASSERT_NE(expired, nullptr);
  EXPECT_THAT(expired->reason, HasSubstr("; it held 1 observation of 1 view, acceptance needs 3 of 2"));
}

TEST_F(RecoveryTest, HypothesisExpiresAfterTheDistanceLimit) {
  robot_->Observe(1, SE2::Identity(), 1e-4);
  // 8 m: not more than hypothesis_expiry_distance yet (1-s steps, far from the time limit).
  for (int i = 0; i < 8; ++i) robot_->Drive(SE2(1.0, 0.0, 0.0), std::nullopt, 1e-2);
  EXPECT_EQ(mapper_->Statistics().recovery_expired, 0);
  robot_->Drive(SE2(0.5, 0.0, 0.0), std::nullopt, 1e-2);
  EXPECT_EQ(mapper_->Statistics().recovery_expired, 1);
  EXPECT_THAT(mapper_->decisions().back().reason, HasSubstr(" m"));
}

TEST_F(RecoveryTest, FinishExpiresOpenHypotheses) {
  robot_->Observe(1, SE2::Identity(), 1e-4);
  const Map map = mapper_->Finish();
  EXPECT_EQ(map.graph.num_nodes(), 3u);
  EXPECT_EQ(map.graph.num_edges(), 2u);  // the hypothesis's observation never became an edge
}

TEST(MapperTest, KidnapStartsANewComponentAndRejectsOpenHypotheses) {
  auto mapper = MakeMapper();
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  robot.Drive(SE2(1.0, 0.0, 0.0));
  robot.ObserveRaw(1, SE2(5.0, 0.0, 0.0));  // fails the gate: a recovery hypothesis
  robot.Kidnap(SE2(10.0, 10.0, 0.0));
  EXPECT_EQ(mapper->Statistics().recovery_rejected, 1);
  robot.Drive(SE2(1.0, 0.0, 0.0));
  EXPECT_EQ(mapper->map().graph.NumComponents(), 2u);
  EXPECT_THAT(mapper->map().graph.node(2).pose, IsNearlyPose(SE2(), 1e-12));
  EXPECT_EQ(mapper->Statistics().components_created, 2);
  EXPECT_THAT(mapper->decisions().back().reason, HasSubstr("kidnap"));
  // View 1 is now in another component: observing it goes to the merge filter.
  robot.Observe(1);
  EXPECT_EQ(mapper->decisions().back().hypothesis_kind, HypothesisKind::kMerge);
}

TEST(MapperTest, GroundTruthIsKeptAsideByNode) {
  auto mapper = MakeMapper();
  ASSERT_THAT(mapper->Process(GroundTruthEvent{.time = 0.0, .world_T_robot = SE2(1, 2, 3)}), IsOk());
  ASSERT_THAT(mapper->Process(
                  OdometryEvent{.time = 1.0, .increment = SE2(), .covariance = Matrix3::Identity() * 1e-4}),
              IsOk());
  ASSERT_THAT(mapper->Process(
                  OdometryEvent{.time = 2.0, .increment = SE2(), .covariance = Matrix3::Identity() * 1e-4}),
              IsOk());
  ASSERT_THAT(mapper->Process(GroundTruthEvent{.time = 2.0, .world_T_robot = SE2(4, 5, 0)}), IsOk());
  ASSERT_THAT(mapper->Process(GroundTruthEvent{.time = 2.5, .world_T_robot = SE2(6, 7, 0)}), IsOk());
  EXPECT_THAT(mapper->ground_truth().at(0), IsNearlyPose(SE2(1, 2, 3), 1e-12));
  EXPECT_THAT(mapper->ground_truth().at(1), IsNearlyPose(SE2(4, 5, 0), 1e-12));
  EXPECT_EQ(mapper->decisions().size(), 1u);  // ground truth decides nothing
}

TEST(MapperTest, LocalMapsAttachToTheCurrentNode) {
  auto mapper = MakeMapper();
  ASSERT_THAT(mapper->Process(
                  OdometryEvent{.time = 0.0, .increment = SE2(), .covariance = Matrix3::Identity() * 1e-4}),
              IsOk());
  ASSERT_THAT(mapper->Process(
                  OdometryEvent{.time = 1.0, .increment = SE2(), .covariance = Matrix3::Identity() * 1e-4}),
              IsOk());
  LocalMapEvent patch{
      .time = 1.0, .resolution = 0.1, .width = 2, .height = 1, .node_T_origin = SE2(), .cells = {-1, 100}};
  ASSERT_THAT(mapper->Process(patch), IsOk());
  ASSERT_EQ(mapper->map().local_maps.count(1), 1u);
  EXPECT_EQ(mapper->map().local_maps.at(1).cells, (std::vector<std::int8_t>{-1, 100}));
}

}  // namespace
}  // namespace slamcore
