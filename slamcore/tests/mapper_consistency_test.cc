// Correlated wrong observations (mapper_consistency.cc): passes, the map's marginal covariance, the joint
// test against the map, and retraction, with numbers worked by hand.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hypothesis.h"
#include "marginal_covariance.h"
#include "mapper_test_util.h"
#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/manhattan_world.h"
#include "slamcore/optimizer.h"
#include "test_data.h"
#include "test_matchers.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::CorridorOutAndBack;
using testing::CorridorParams;
using testing::CountDecisions;
using testing::EdgeSet;
using ::testing::HasSubstr;
using testing::IsNearlyPose;
using testing::LastDecision;
using testing::MakeMapper;
using testing::SimulatedRobot;

internal::HypothesisObservation At(double time, double odometer) {
  return {.robot_node = 0, .view = 1, .view_node = 0, .robot_T_view = {}, .time = time, .odometer = odometer};
}

TEST(PassesTest, ObservationsAreOnePassWhileEachFollowsThePreviousWithinBothGaps) {
  internal::Hypothesis hypothesis;
  // Gaps 20 s and 2 m: t = 0, 5, 24 (19 s after 5) stay one pass; 50 (26 s) starts a second; odometer
  // 12 → 14.5 (2.5 m at t = 51) a third; a lone observation at t = 200 a fourth.
  hypothesis.observations = {At(0, 10), At(5, 11), At(24, 12), At(50, 12), At(51, 14.5), At(200, 15)};
  EXPECT_EQ(internal::CountPasses(hypothesis, 20.0, 2.0), 4);
  // A group of ten consecutive observations, one per second and metre, is one pass however long.
  hypothesis.observations.clear();
  for (int k = 0; k < 10; ++k) hypothesis.observations.push_back(At(k, k));
  EXPECT_EQ(internal::CountPasses(hypothesis, 20.0, 2.0), 1);
  EXPECT_EQ(internal::CountPasses(hypothesis, 0.5, 2.0), 10);
  hypothesis.observations.clear();
  EXPECT_EQ(internal::CountPasses(hypothesis, 20.0, 2.0), 0);
}

TEST(PassesTest, APassCountsOnlyWhenItsFirstObservationConfirms) {
  internal::Hypothesis hypothesis;
  // Passes start at t = 0, 50 and 100; the second's first observation joined through a gate an aliasing
  // offset would have passed (its second one was then tested against a state that already took the
  // first in), so two passes count.
  hypothesis.observations = {At(0, 0), At(50, 10), At(51, 11), At(100, 20)};
  hypothesis.observations[1].confirms = false;
  EXPECT_EQ(internal::CountPasses(hypothesis, 20.0, 2.0), 2);
  hypothesis.observations[1].confirms = true;
  hypothesis.observations[2].confirms = false;  // not the first of its pass: no effect
  EXPECT_EQ(internal::CountPasses(hypothesis, 20.0, 2.0), 3);
}

/// Nodes 0 → 1 → 2 one metre apart along x, each motion edge with left covariance diag(a, a, b).
PoseGraph Chain(double a, double b) {
  PoseGraph graph;
  for (int k = 0; k < 3; ++k) EXPECT_THAT(graph.AddNode(Node{.id = k, .pose = SE2(k, 0, 0)}), IsOk());
  for (int k = 0; k < 2; ++k) {
    Edge edge{.from = k, .to = k + 1, .measurement = SE2(1, 0, 0)};
    edge.information = EdgeInformationFromLeftCovariance(edge.measurement, Vector3(a, a, b).asDiagonal());
    EXPECT_THAT(graph.AddEdge(edge), IsOk());
  }
  return graph;
}

TEST(MarginalCovariancesTest, AChainComposesItsEdgesThroughTheAdjoint) {
  const double a = 0.01, b = 0.002;
  const PoseGraph graph = Chain(a, b);
  const auto marginals = internal::MarginalCovariances::Factorize(graph, 2);
  ASSERT_TRUE(marginals.has_value());
  EXPECT_EQ(marginals->newest_node(), 2);
  // 0_T_2 = 0_T_1 · 1_T_2: Σ = Σ₁ + Adj Σ₂ Adjᵀ with Adj of (1, 0, 0) = [I, (0, −1)ᵀ; 0, 1], so
  // Σ = [[2a, 0, 0], [0, 2a + b, −b], [0, −b, 2b]].
  const internal::PoseGaussian relative = marginals->Relative(0, 2);
  EXPECT_THAT(relative.mean, IsNearlyPose(SE2(2, 0, 0), 1e-12));
  Matrix3 expected;
  expected << 2 * a, 0, 0, 0, 2 * a + b, -b, 0, -b, 2 * b;
  EXPECT_TRUE(relative.covariance.isApprox(expected, 1e-6)) << relative.covariance;
  // From node 1, in its own frame: a single edge.
  EXPECT_TRUE(
      marginals->Relative(1, 2).covariance.isApprox(Vector3(a, a, b).asDiagonal().toDenseMatrix(), 1e-6));
}

TEST(MarginalCovariancesTest, ALoopMakesTwoPlacesSurerOfEachOtherThanOdometry) {
  const double a = 0.01, b = 0.002;
  PoseGraph graph = Chain(a, b);
  // A loop closure 0 → 2 with covariance C: in a linear problem the two paths combine as
  // (Σ_chain⁻¹ + C⁻¹)⁻¹.
  const Matrix3 closure_covariance = Vector3(0.004, 0.004, 0.001).asDiagonal();
  Edge closure{.from = 0, .to = 2, .measurement = SE2(2, 0, 0), .kind = EdgeKind::kObservation};
  closure.information = EdgeInformationFromLeftCovariance(closure.measurement, closure_covariance);
  ASSERT_THAT(graph.AddEdge(closure), IsOk());
  const auto marginals = internal::MarginalCovariances::Factorize(graph, 0);
  ASSERT_TRUE(marginals.has_value());
  Matrix3 chain;
  chain << 2 * a, 0, 0, 0, 2 * a + b, -b, 0, -b, 2 * b;
  const Matrix3 expected = (chain.inverse() + closure_covariance.inverse()).inverse();
  EXPECT_TRUE(marginals->Relative(0, 2).covariance.isApprox(expected, 1e-6))
      << marginals->Relative(0, 2).covariance;
}

// The premise of the Mapper's map test from stale marginals (MapPredictionBound): an edge added to G only
// adds information, so the covariance between two places factorised before it is no smaller than after.
TEST(MarginalCovariancesTest, AnAddedEdgeNeverMakesTwoPlacesLessSureOfEachOther) {
  PoseGraph graph = Chain(0.01, 0.002);
  ASSERT_THAT(graph.AddNode(Node{.id = 3, .pose = SE2(2.0, 1.0, 0.3)}), IsOk());
  Edge up{.from = 2, .to = 3, .measurement = SE2(0.0, 1.0, 0.3)};
  up.information = EdgeInformationFromLeftCovariance(up.measurement, Vector3(0.01, 0.01, 0.002).asDiagonal());
  ASSERT_THAT(graph.AddEdge(up), IsOk());
  const auto before = internal::MarginalCovariances::Factorize(graph, 3);
  ASSERT_TRUE(before.has_value());
  Edge closure{.from = 3, .to = 1, .measurement = SE2(-1.0, -1.0, -0.3), .kind = EdgeKind::kObservation};
  closure.information = EdgeInformationFromLeftCovariance(closure.measurement, Matrix3::Identity() * 0.05);
  ASSERT_THAT(graph.AddEdge(closure), IsOk());
  const auto after = internal::MarginalCovariances::Factorize(graph, 3);
  ASSERT_TRUE(after.has_value());
  for (const NodeId node : {0, 1, 2}) {
    const Matrix3 shrink = before->Relative(3, node).covariance - after->Relative(3, node).covariance;
    const Eigen::SelfAdjointEigenSolver<Matrix3> eigen(shrink);
    EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-12) << "node " << node << "\n" << shrink;
    EXPECT_GT(shrink.trace(), 1e-4) << "node " << node;  // and the closure did make them surer
  }
}

// The leave-one-out χ² of a closure that disagrees with the odometry by 0.3 m along x, both with variance
// σ² = 0.01 on every axis: at the optimum node 1 sits halfway (x = 1.15) and each residual is 0.15 m; node 1's
// variance along x is σ²/2, so the closure's residual has variance σ² − σ²/2 and d² = 0.15² / 0.005 = 4.5 —
// the 0.3 m disagreement against its variance 2σ², i.e. the closure against what the odometry alone predicts
// (its own fitted χ², 0.15² / σ² = 2.25, is half that). y and θ are testable (the odometry predicts them too)
// and carry no residual.
TEST(MarginalCovariancesTest, TheLeaveOneOutChi2JudgesAnEdgeAgainstWhatTheOthersPredict) {
  PoseGraph graph;
  ASSERT_THAT(graph.AddNode(Node{.id = 0, .pose = SE2::Identity()}), IsOk());
  ASSERT_THAT(graph.AddNode(Node{.id = 1, .pose = SE2(1.15, 0, 0)}), IsOk());
  ASSERT_THAT(graph.AddNode(Node{.id = 2, .pose = SE2(5, 0, 0)}), IsOk());  // another component
  const auto edge = [](NodeId to, double x, EdgeKind kind) {
    Edge made;
    made.from = 0;
    made.to = to;
    made.measurement = SE2(x, 0, 0);
    made.information = Matrix3::Identity() / 0.01;
    made.kind = kind;
    return made;
  };
  ASSERT_THAT(graph.AddEdge(edge(1, 1.0, EdgeKind::kMotion)), IsOk());
  ASSERT_THAT(graph.AddEdge(edge(1, 1.3, EdgeKind::kObservation)), IsOk());
  const auto marginals = internal::MarginalCovariances::Factorize(graph, 1);
  ASSERT_TRUE(marginals.has_value());
  const Edge* closure[] = {&graph.edges()[1]};
  const std::optional<internal::EdgeSetChi2> test = internal::LeaveOneOutChi2(graph, *marginals, closure);
  ASSERT_TRUE(test.has_value());
  EXPECT_NEAR(test->chi2, 4.5, 1e-9);
  EXPECT_EQ(test->dof, 3);
  EXPECT_NEAR(EdgeChi2(graph, graph.edges()[1]), 2.25, 1e-9);

  const Edge elsewhere = edge(2, 5.0, EdgeKind::kObservation);
  const Edge* outside[] = {&elsewhere};
  EXPECT_FALSE(internal::LeaveOneOutChi2(graph, *marginals, outside).has_value());

  // A node that only a judged edge holds: nothing else predicts its three directions, so they are not
  // testable and drop out (the residual covariance there is σ² − σ² = 0) — d² and the degrees of freedom
  // are the closure's alone.
  ASSERT_THAT(graph.AddNode(Node{.id = 3, .pose = SE2(2.0, 0, 0)}), IsOk());
  ASSERT_THAT(graph.AddEdge(edge(3, 2.0, EdgeKind::kObservation)), IsOk());
  const auto with_leaf = internal::MarginalCovariances::Factorize(graph, 1);
  ASSERT_TRUE(with_leaf.has_value());
  const Edge* closure_and_leaf[] = {&graph.edges()[1], &graph.edges()[2]};
  const auto judged = internal::LeaveOneOutChi2(graph, *with_leaf, closure_and_leaf);
  ASSERT_TRUE(judged.has_value());
  EXPECT_NEAR(judged->chi2, 4.5, 1e-9);
  EXPECT_EQ(judged->dof, 3);
}

// The Mapper's map test with its marginals updated by the edges added since their factorisation decides as
// with a fresh factorisation every time, on graphs without wrong closures: a generated city (whose loop
// closures are judged by the map test hundreds of times, most of them with edges added since) and Intel
// (Vertigo) from data/. The update's own arithmetic is held to a fresh factorisation above.
TEST(MapTestMarginalsTest, AnOutlierFreeReplayDecidesAsWithAFreshFactorisationEachTime) {
  const Result<ManhattanWorld> world = GenerateManhattanWorld({.poses = 2000, .seed = 3});
  ASSERT_THAT(world, IsOk());
  TEST_DATA_FILE_OR_SKIP(intel_path, "posegraphs/vertigo/intel.g2o");
  const Result<PoseGraph> intel = ReadPoseGraph(intel_path);
  ASSERT_THAT(intel, IsOk());
  for (const PoseGraph* graph : {&world->graph, &*intel}) {
    MapperParams updated, refactorised;
    refactorised.consistency.max_marginal_update_nodes = 0;
    const Result<ReplayResult> with_update = ReplayPoseGraph(*graph, updated);
    const Result<ReplayResult> without = ReplayPoseGraph(*graph, refactorised);
    ASSERT_THAT(with_update, IsOk());
    ASSERT_THAT(without, IsOk());
    EXPECT_EQ(with_update->accepted, without->accepted);
    EXPECT_EQ(with_update->rejected, without->rejected);
    EXPECT_NEAR(with_update->final_chi2, without->final_chi2, 1e-9 * without->final_chi2);
    EXPECT_GT(with_update->accepted.size(),
              0.85 * static_cast<double>(with_update->accepted.size() + with_update->rejected.size()));
  }
}

// At most `cap` edges, evenly spaced from the first; all of them when there are no more.
TEST(MarginalCovariancesTest, EvenlySpacedKeepsAtMostTheCap) {
  std::vector<Edge> edges(10);
  std::vector<const Edge*> all;
  for (const Edge& edge : edges) all.push_back(&edge);
  EXPECT_EQ(internal::EvenlySpaced(all, 4), (std::vector<const Edge*>{all[0], all[2], all[5], all[7]}));
  EXPECT_EQ(internal::EvenlySpaced(all, 60), all);
}

/// A 6 × 6 grid of slightly perturbed poses, node id row · 6 + column, every neighbour pair an edge.
constexpr int kSide = 6;
PoseGraph Grid() {
  PoseGraph graph;
  const auto id = [](int row, int column) { return row * kSide + column; };
  for (int row = 0; row < kSide; ++row) {
    for (int column = 0; column < kSide; ++column) {
      const double wobble = 0.01 * ((row * 7 + column * 3) % 5);
      EXPECT_THAT(
          graph.AddNode(Node{.id = id(row, column), .pose = SE2(column + wobble, row - wobble, wobble)}),
          IsOk());
    }
  }
  for (int row = 0; row < kSide; ++row) {
    for (int column = 0; column < kSide; ++column) {
      for (const auto& [to_row, to_column] : {std::pair{row, column + 1}, std::pair{row + 1, column}}) {
        if (to_row >= kSide || to_column >= kSide) continue;
        Edge edge;
        edge.from = id(row, column);
        edge.to = id(to_row, to_column);
        edge.measurement = to_row == row ? SE2(1, 0, 0) : SE2(0, 1, 0);
        edge.information =
            EdgeInformationFromLeftCovariance(edge.measurement, Vector3(0.01, 0.02, 0.003).asDiagonal());
        EXPECT_THAT(graph.AddEdge(edge), IsOk());
      }
    }
  }
  return graph;
}

// Joint reads H⁻¹ from the sparse factor along elimination-tree paths; on a graph with many loops (a 6 × 6
// grid of slightly perturbed poses, every neighbour pair an edge) its blocks must equal the dense inverse
// of H = Σ Jᵀ Ω J assembled here from the same edge Jacobians, the gauge node's rows and columns zero.
TEST(MarginalCovariancesTest, JointEqualsTheDenseInverseOnAGraphWithManyLoops) {
  const PoseGraph graph = Grid();
  const int unknowns = 3 * (kSide * kSide - 1);  // node 0 is the gauge
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(unknowns, unknowns);
  for (const Edge& edge : graph.edges()) {
    Matrix3 d_from, d_to;
    EdgeError(graph.node(edge.from).pose, graph.node(edge.to).pose, edge.measurement, &d_from, &d_to);
    const std::pair<NodeId, const Matrix3*> ends[] = {{edge.from, &d_from}, {edge.to, &d_to}};
    for (const auto& [a, jacobian_a] : ends) {
      for (const auto& [b, jacobian_b] : ends) {
        if (a == 0 || b == 0) continue;
        information.block<3, 3>(3 * (a - 1), 3 * (b - 1)) +=
            jacobian_a->transpose() * edge.information * *jacobian_b;
      }
    }
  }
  const Eigen::MatrixXd covariance = information.inverse();
  const auto marginals = internal::MarginalCovariances::Factorize(graph, 0);
  ASSERT_TRUE(marginals.has_value());
  const std::vector<NodeId> nodes = {35, 0, 7, 14, 30, 5, 21};  // corners, the gauge, the middle
  const Eigen::MatrixXd joint = marginals->Joint(nodes);
  for (std::size_t a = 0; a < nodes.size(); ++a) {
    for (std::size_t b = 0; b < nodes.size(); ++b) {
      const Eigen::Matrix3d expected =
          nodes[a] == 0 || nodes[b] == 0
              ? Eigen::Matrix3d::Zero()
              : Eigen::Matrix3d(covariance.block<3, 3>(3 * (nodes[a] - 1), 3 * (nodes[b] - 1)));
      const Eigen::Matrix3d actual = joint.block<3, 3>(3 * static_cast<int>(a), 3 * static_cast<int>(b));
      EXPECT_LT((actual - expected).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + expected.cwiseAbs().maxCoeff()))
          << "nodes " << nodes[a] << ", " << nodes[b] << "\nexpected\n"
          << expected << "\nactual\n"
          << actual;
    }
  }
}

// The map test's marginals updated by the edges added since their factorisation must be what a new
// factorisation gives at the same poses: the grid factorised, then a chain of ten nodes driven from its
// newest node (35), closures from three of them onto the grid (one onto the gauge, node 0) and one between
// two grid nodes. Relative covariances between chain nodes (touched by an edge or not) and grid nodes equal
// those of G factorised afresh; past the node cap, or with a node the chain does not reach, there is no update.
TEST(MarginalCovariancesTest, EdgesAddedSinceTheFactorisationUpdateItsMarginalsExactly) {
  PoseGraph graph = Grid();
  const auto stale = internal::MarginalCovariances::Factorize(graph, 35);
  ASSERT_TRUE(stale.has_value());
  const auto edge = [&](NodeId from, NodeId to, EdgeKind kind, const Vector3& sigma2) {
    Edge made;
    made.from = from;
    made.to = to;
    made.measurement = graph.node(from).pose.inverse() * graph.node(to).pose * SE2(0.02, -0.01, 0.005);
    made.information = EdgeInformationFromLeftCovariance(made.measurement, sigma2.asDiagonal());
    made.kind = kind;
    return made;
  };
  for (NodeId id = 36; id <= 45; ++id) {
    const SE2 step(0.5, 0.05 * static_cast<double>(id % 3), 0.1);
    ASSERT_THAT(graph.AddNode(Node{.id = id, .pose = graph.node(id - 1).pose * step}), IsOk());
    ASSERT_THAT(graph.AddEdge(edge(id - 1, id, EdgeKind::kMotion, Vector3(0.004, 0.002, 0.001))), IsOk());
  }
  const auto chain_only = internal::MarginalCovariances::Factorize(graph, 45);
  ASSERT_TRUE(chain_only.has_value());
  for (const auto& [from, to] : {std::pair{38, 7}, std::pair{42, 21}, std::pair{45, 0}, std::pair{14, 30}}) {
    ASSERT_THAT(graph.AddEdge(edge(from, to, EdgeKind::kObservation, Vector3(0.03, 0.03, 0.004))), IsOk());
  }
  const auto fresh = internal::MarginalCovariances::Factorize(graph, 45);
  ASSERT_TRUE(fresh.has_value());
  for (const auto& [a, b] : {std::pair{45, 5}, std::pair{40, 14}, std::pair{45, 38}, std::pair{42, 0}}) {
    const std::optional<Matrix3> updated =
        internal::RelativeCovarianceWithEdgesSince(graph, *stale, a, b, 48);
    ASSERT_TRUE(updated.has_value()) << a << " → " << b;
    const Matrix3 expected = fresh->Relative(a, b).covariance;
    EXPECT_LT((*updated - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff())
        << a << " → " << b << "\nexpected\n"
        << expected << "\nupdated\n"
        << *updated;
    // And the closures did tell: without them the covariance is another.
    EXPECT_GT((chain_only->Relative(a, b).covariance - expected).cwiseAbs().maxCoeff(),
              1e-2 * expected.cwiseAbs().maxCoeff());
  }
  // Nodes touched: 7, 21, 14, 30 and 35 of the grid (0 is held), 38, 42, 45 and 40 of the chain.
  EXPECT_TRUE(internal::RelativeCovarianceWithEdgesSince(graph, *stale, 40, 14, 9).has_value());
  EXPECT_FALSE(internal::RelativeCovarianceWithEdgesSince(graph, *stale, 40, 14, 8).has_value());
  // A node the chain does not reach (47 follows 45 with no 46) leaves the update's shape.
  ASSERT_THAT(graph.AddNode(Node{.id = 47, .pose = SE2(9, 9, 0)}), IsOk());
  ASSERT_THAT(graph.AddEdge(edge(47, 3, EdgeKind::kObservation, Vector3(0.03, 0.03, 0.004))), IsOk());
  EXPECT_FALSE(internal::RelativeCovarianceWithEdgesSince(graph, *stale, 45, 5, 48).has_value());
}

// Wheel stasis as in mapper_test.cc's RecoveryTest: the robot stands at x = 1 while odometry (σ² = 1e-2 per
// axis and step) claims x = 2; exact observations (σ² = 1e-4) of views 1 (x = 0) and 2 (x = 1).
class StasisTest : public ::testing::Test {
 protected:
  void Start(const MapperParams& params) {
    mapper_ = MakeMapper(params);
    robot_ = std::make_unique<SimulatedRobot>(*mapper_);
    robot_->Drive(SE2::Identity(), std::nullopt, 1e-2);
    robot_->CreateView(1);
    robot_->Drive(SE2(1.0, 0.0, 0.0), std::nullopt, 1e-2);
    robot_->CreateView(2);
    robot_->Drive(SE2::Identity(), SE2(1.0, 0.0, 0.0), 1e-2);
  }
  void OnePass() {
    robot_->Observe(1, SE2::Identity(), 1e-4);
    robot_->Observe(2, SE2::Identity(), 1e-4);
    robot_->Observe(1, SE2::Identity(), 1e-4);
  }
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<SimulatedRobot> robot_;
};

TEST_F(StasisTest, OnePassAgainstTheMapIsNotEnoughAndASecondPassIs) {
  MapperParams params = testing::TestParams();
  params.consistency.min_passes_against_map = 2;
  Start(params);
  OnePass();
  // The map puts view 1 two metres behind the robot, sure to σ² = 2e-2 (two motion edges along x; the
  // variance factor is not used without redundancy); the hypothesis says one metre, fused from three
  // observations: d² ≈ 1² / (2e-2 + 1e-4/3 + …) ≈ 50 > 16.27 — inconsistent, so it waits for a pass.
  EXPECT_EQ(mapper_->Statistics().recovery_accepted, 0);
  EXPECT_TRUE(mapper_->accepted_observations().empty());
  const Decision& last = mapper_->decisions().back();
  EXPECT_EQ(last.kind, DecisionKind::kHypothesisUpdated);
  // 25 s later (beyond the 20 s pass gap) the robot sees the views again: an independent pass.
  robot_->Wait(25.0);
  OnePass();
  EXPECT_EQ(mapper_->Statistics().recovery_accepted, 1);
  const Decision* accepted = LastDecision(*mapper_, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  EXPECT_THAT(accepted->reason, HasSubstr("inconsistent"));
  EXPECT_THAT(accepted->reason, HasSubstr("2 of 2 passes"));
  EXPECT_NEAR(mapper_->map().graph.node(2).pose.x(), 1.0, 0.02);
}

// The same two passes, but between them the robot turned on the spot with odometry so poor (σ = 1 m per
// axis) that when it sees the views again the hypothesis could be anywhere within metres: the second pass
// joins through a gate that a 1 m aliasing offset would have passed too (σ² ≈ 1 > 1² / 7.81), so it
// confirms nothing and the hypothesis still has one pass against the map.
TEST_F(StasisTest, APassThatJoinsThroughAGateAnAliasingOffsetWouldPassConfirmsNothing) {
  MapperParams params = testing::TestParams();
  params.consistency.min_passes_against_map = 2;
  Start(params);
  OnePass();
  robot_->Drive(SE2::Identity(), std::nullopt, 1.0);
  robot_->Wait(25.0);
  OnePass();
  // Without the turn on the spot the second pass is accepted (OnePassAgainstTheMapIsNotEnough… above).
  EXPECT_EQ(mapper_->Statistics().recovery_accepted, 0);
  EXPECT_EQ(mapper_->Statistics().recovery_created, 1);  // the second pass joined the first's hypothesis
  bool unconfirmed_join = false;
  for (const Decision& decision : mapper_->decisions()) {
    unconfirmed_join = unconfirmed_join || decision.reason.find("confirms nothing") != std::string::npos;
  }
  EXPECT_TRUE(unconfirmed_join);
}

// Between the two passes the robot drives on and closes a loop the direct gate accepts: the marginals
// factorised at the first pass are stale, but only information was added since, so they still bound the
// map's covariance from above, and the second pass is judged inconsistent from them without refactorising.
TEST_F(StasisTest, AfterADirectEdgeTheMapTestUsesTheStaleMarginalsAsABound) {
  MapperParams params = testing::TestParams();
  params.consistency.min_passes_against_map = 2;
  params.direct_max_position_sigma = 1.0;  // the stasis left the robot σ ≈ 0.5 m unsure of itself
  Start(params);
  OnePass();
  ASSERT_EQ(mapper_->Statistics().recovery_accepted, 0);
  robot_->Wait(25.0);
  robot_->Drive(SE2(1.0, 0.0, 0.0));
  robot_->CreateView(3);
  robot_->Drive(SE2(0.5, 0.0, 0.0));
  robot_->Drive(SE2(0.5, 0.0, 0.0));
  const int direct_before = mapper_->Statistics().direct_edges;
  robot_->Observe(3, SE2::Identity(), 1e-4);
  ASSERT_EQ(mapper_->Statistics().direct_edges, direct_before + 1);
  robot_->Drive(SE2(-2.0, 0.0, 0.0));
  OnePass();
  EXPECT_EQ(mapper_->Statistics().recovery_accepted, 1);
  const Decision* accepted = LastDecision(*mapper_, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  EXPECT_THAT(accepted->reason, HasSubstr("d²≥"));
  EXPECT_THAT(accepted->reason, HasSubstr("2 of 2 passes"));
  EXPECT_NEAR(mapper_->map().graph.node(2).pose.x(), 1.0, 0.02);
}

// Odometry that declares far more noise than it has (exact motion reported with σ² = 0.02 per axis and
// step). Once the map has loops enough to show it (redundancy ≥ 30, and with exact odometry and
// observations χ² = 0, so the variance factor is clamped at min_variance_factor = 0.01), Σ_rel is scaled
// by it: after ten more steps the robot is σ_y ≈ 2.8 m unsure by the declared noise (heading variance 0.02
// per step carried over ten steps of 1 m, 0.02 · (1² + … + 10²) = 7.7, plus 0.02 per step across), ≈ 0.28 m
// by the noise met — under the 0.5 m limit — and an exact observation becomes a direct edge instead of
// going to the recovery filter as "too uncertain". The first stretch's 13 closures give redundancy 39.
std::unique_ptr<Mapper> RunWithOverstatedOdometry(const MapperParams& params) {
  auto mapper = MakeMapper(params);
  SimulatedRobot robot(*mapper);
  constexpr double kDeclared = 0.02;
  robot.Drive(SE2::Identity(), std::nullopt, kDeclared);
  robot.CreateView(1);
  // Two stretches of twelve views, each ended by a recovery (the robot too unsure for direct edges) whose
  // map test factorises the marginals; after the first, the views behind are observed as direct edges.
  ViewId next_view = 2;
  for (int stretch = 0; stretch < 2; ++stretch) {
    for (int k = 0; k < 12; ++k) {
      robot.Drive(SE2(1.0, 0.0, 0.0), std::nullopt, kDeclared);
      robot.CreateView(next_view++);
    }
    robot.Drive(SE2(1.0, 0.0, 0.0), std::nullopt, kDeclared);
    for (const ViewId view : {next_view - 1, next_view - 2, next_view - 3})
      robot.Observe(view, SE2::Identity(), 1e-4);
    if (stretch == 0) {
      for (ViewId view = 1; view <= 10; ++view) robot.Observe(view, SE2::Identity(), 1e-4);
    }
  }
  for (int k = 0; k < 10; ++k) robot.Drive(SE2(1.0, 0.0, 0.0), std::nullopt, kDeclared);
  robot.Observe(next_view - 1, SE2::Identity(), 1e-4);
  return mapper;
}

TEST(DeclaredNoiseTest, TheMapsVarianceFactorScalesTheRobotsUncertaintyForTheDirectGate) {
  MapperParams params = testing::TestParams();
  params.consistency.min_passes_uninformative = 1;  // each stretch's recovery is accepted at its first pass
  params.consistency.verify_after_optimization = false;
  const auto scaled = RunWithOverstatedOdometry(params);
  ASSERT_NE(scaled, nullptr);
  ASSERT_EQ(scaled->Statistics().recovery_accepted, 2);
  EXPECT_EQ(scaled->decisions().back().kind, DecisionKind::kDirectEdge) << scaled->decisions().back().reason;

  params.consistency.min_redundancy_for_scaling = 1 << 30;  // never scaled: the declared noise stands
  const auto declared = RunWithOverstatedOdometry(params);
  ASSERT_NE(declared, nullptr);
  ASSERT_EQ(declared->Statistics().recovery_accepted, 2);
  const Decision& last = declared->decisions().back();
  EXPECT_EQ(last.kind, DecisionKind::kHypothesisCreated);
  EXPECT_THAT(last.reason, HasSubstr("robot too uncertain"));
}

TEST_F(StasisTest, TheMapTestReportsItsChi2) {
  MapperParams params = testing::TestParams();
  params.consistency.min_passes_against_map = 1;  // accepted at once, so the decision carries the test
  params.consistency.verify_after_optimization = false;
  Start(params);
  OnePass();
  const Decision* accepted = LastDecision(*mapper_, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  // Hand-computed bound: d² = 1 / (2e-2 + Σ_G,xx) with Σ_G,xx ≤ 1e-4 ⇒ 49.5 ≤ d² ≤ 50.
  const std::size_t at = accepted->reason.find("d²=");
  ASSERT_NE(at, std::string::npos) << accepted->reason;
  const double chi2 = std::stod(accepted->reason.substr(at + std::string("d²=").size()));
  EXPECT_GE(chi2, 49.5);
  EXPECT_LE(chi2, 50.0);
}

// The corridor of mapper_test_util.h: one wrong pass, then three later passes of the truth that contradict
// it; accepting them retracts the wrong one.
TEST(RetractionTest, LaterPassesRetractAnAcceptedWrongPassAndGIsAsIfItNeverWasAccepted) {
  auto with_wrong = MakeMapper(CorridorParams());
  CorridorOutAndBack(*with_wrong, true, 3);
  auto without = MakeMapper(CorridorParams());
  CorridorOutAndBack(*without, false, 3);

  const MapperStatistics statistics = with_wrong->Statistics();
  EXPECT_EQ(statistics.recovery_accepted, 2);
  EXPECT_EQ(statistics.recovery_retracted, 1);
  const Decision* retracted = LastDecision(*with_wrong, DecisionKind::kRetracted);
  ASSERT_NE(retracted, nullptr);
  EXPECT_EQ(retracted->hypothesis_kind, HypothesisKind::kRecovery);
  // One hypothesis's three passes overrule the map (the contest needs contradictions from other places).
  EXPECT_THAT(retracted->reason, HasSubstr("leave-one-out"));
  // The wrong hypothesis was the first accepted one; its edges left G and accepted_observations().
  const Decision* first_accepted = nullptr;
  for (const Decision& decision : with_wrong->decisions()) {
    if (decision.kind == DecisionKind::kAccepted) {
      first_accepted = &decision;
      break;
    }
  }
  ASSERT_NE(first_accepted, nullptr);
  EXPECT_EQ(retracted->hypothesis, first_accepted->hypothesis);
  for (const AcceptedObservation& edge : with_wrong->accepted_observations()) {
    EXPECT_NE(edge.hypothesis, retracted->hypothesis);
  }

  // G equals G never having accepted it: the same edges, and the same poses once both are optimised.
  PoseGraph retracted_graph = with_wrong->map().graph, clean_graph = without->map().graph;
  EXPECT_EQ(EdgeSet(retracted_graph), EdgeSet(clean_graph));
  ASSERT_THAT(Optimize(retracted_graph), IsOk());
  ASSERT_THAT(Optimize(clean_graph), IsOk());
  ASSERT_EQ(retracted_graph.num_nodes(), clean_graph.num_nodes());
  for (const Node& node : clean_graph.nodes()) {
    EXPECT_THAT(retracted_graph.node(node.id).pose, IsNearlyPose(node.pose, 1e-6)) << "node " << node.id;
  }
  EXPECT_NEAR(clean_graph.node(clean_graph.num_nodes() - 1).pose.x(), 2.0, 0.05);
}

// Contested acceptances. The corridor's wrong pass is accepted on a test that cannot tell (the robot is
// σ_x ≈ 1.5 m unsure after 22 loose steps); each true pass then fails the map test against the map it placed
// (2.5 m off, the robot sure to centimetres since). Here the true passes are 130 s apart, beyond the 120 s
// expiry, so each is a hypothesis of its own, one pass each: the map is never overruled by one hypothesis's
// three passes. The second true pass agrees with the first (same views, the robot has not moved: innovation
// 0), so two passes contradict the wrong one's one; without it the second fits the map (the robot at x = 2
// by its exact odometry), so the wrong one is retracted and the second accepted.
void CorridorWithSeparatePasses(Mapper& mapper, std::optional<SE2> second_pass_claims,
                                bool with_look_alike = true) {
  SimulatedRobot robot(mapper);
  constexpr double kOdometryVariance = 0.1;
  robot.Drive(SE2::Identity(), std::nullopt, kOdometryVariance);
  for (const ViewId view : {1, 2, 3}) {
    robot.CreateView(view);
    robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  }
  for (int k = 0; k < 9; ++k) robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  robot.Drive(SE2(0, 0, std::numbers::pi), std::nullopt, kOdometryVariance);
  for (int k = 0; k < 10; ++k) robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  const auto pass_as_if_at = [&](const SE2& world_T_robot) {
    for (const ViewId view : {1, 2, 3})
      robot.ObserveRaw(view, world_T_robot.inverse() * SE2(view - 1.0, 0, 0), 1e-4);
  };
  if (with_look_alike) pass_as_if_at(SE2(4.5, 0, std::numbers::pi));
  robot.Wait(25.0);
  pass_as_if_at(robot.truth());
  robot.Wait(130.0);
  pass_as_if_at(second_pass_claims.value_or(robot.truth()));
}

TEST(ContestTest, TwoLaterPassesThatAgreeRetractAnAcceptanceTheMapTestCouldNotTell) {
  auto mapper = MakeMapper(CorridorParams());
  CorridorWithSeparatePasses(*mapper, std::nullopt);
  const MapperStatistics statistics = mapper->Statistics();
  EXPECT_EQ(statistics.recovery_created, 3);
  EXPECT_EQ(statistics.recovery_accepted, 2);
  EXPECT_EQ(statistics.recovery_retracted, 1);
  const Decision* retracted = LastDecision(*mapper, DecisionKind::kRetracted);
  ASSERT_NE(retracted, nullptr);
  EXPECT_EQ(retracted->hypothesis, 0);  // the look-alike's
  EXPECT_THAT(retracted->reason, HasSubstr("contested: 2 later passes (hypotheses 1 2)"));
  EXPECT_THAT(retracted->reason, HasSubstr("against its 1"));
  EXPECT_THAT(retracted->reason, HasSubstr(") and was accepted"));
  const Decision* accepted = LastDecision(*mapper, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  EXPECT_EQ(accepted->hypothesis, 2);
  EXPECT_THAT(accepted->reason, HasSubstr("consistent, uninformative"));
  // The retraction stands only with the challenger accepted in its place, and the log says it in that order.
  EXPECT_EQ(accepted - retracted, 1);
  for (const AcceptedObservation& edge : mapper->accepted_observations()) EXPECT_NE(edge.hypothesis, 0);
  // The robot's node is where its exact odometry says, x = 2, not at the look-alike's 4.5.
  const NodeId robot = *mapper->CurrentNode();
  EXPECT_NEAR(mapper->map().graph.node(robot).pose.x(), 2.0, 0.05);
  // By the end of the run (its consistent-set check takes the first true pass back in) G holds the same edges
  // as a run that never saw the look-alike.
  auto never_fooled = MakeMapper(CorridorParams());
  CorridorWithSeparatePasses(*never_fooled, std::nullopt, /*with_look_alike=*/false);
  EXPECT_EQ(EdgeSet(mapper->Finish().graph), EdgeSet(never_fooled->Finish().graph));
  const Decision* taken_back = LastDecision(*mapper, DecisionKind::kAccepted);
  ASSERT_NE(taken_back, nullptr);
  EXPECT_EQ(taken_back->hypothesis, 1);
  EXPECT_THAT(taken_back->reason, HasSubstr("consistent-set check (the run ended"));

  MapperParams params = CorridorParams();
  params.consistency.max_contest_trials = 0;  // the what-if baseline: each true pass alone waits, and expires
  auto baseline = MakeMapper(params);
  CorridorWithSeparatePasses(*baseline, std::nullopt);
  EXPECT_EQ(baseline->Statistics().recovery_retracted, 0);
  EXPECT_EQ(baseline->Statistics().recovery_accepted, 1);
  EXPECT_NEAR(baseline->map().graph.node(*baseline->CurrentNode()).pose.x(), 4.5, 0.05);
}

// The second contradiction claims yet another place (x = 0.5): it does not agree with the first (1.5 m apart,
// both sure to centimetres), so each contradicting pass stands alone, one against one, and nothing is
// retracted.
TEST(ContestTest, ContradictionsThatDisagreeWithEachOtherRetractNothing) {
  auto mapper = MakeMapper(CorridorParams());
  CorridorWithSeparatePasses(*mapper, SE2(0.5, 0, std::numbers::pi));
  EXPECT_EQ(mapper->Statistics().recovery_retracted, 0);
  EXPECT_EQ(mapper->Statistics().recovery_accepted, 1);
  EXPECT_NEAR(mapper->map().graph.node(*mapper->CurrentNode()).pose.x(), 4.5, 0.05);
}

TEST(ConsistencyParamsTest, EveryNewFieldIsValidated) {
  const auto refused = [](auto change) {
    MapperParams params;
    change(params);
    return params.Validate();
  };
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.pass_gap_seconds = 0; }).message(),
              HasSubstr("consistency.pass_gap_seconds"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.map_gate_chi2 = std::nan(""); }).message(),
              HasSubstr("consistency.map_gate_chi2"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.retraction_confidence = 1.0; }).message(),
              HasSubstr("consistency.retraction_confidence"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_open_hypotheses = 0; }).message(),
              HasSubstr("consistency.max_open_hypotheses"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_continuation_edges = -1; }).message(),
              HasSubstr("consistency.max_continuation_edges"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_contest_trials = -1; }).message(),
              HasSubstr("consistency.max_contest_trials"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_edges_judged = 0; }).message(),
              HasSubstr("consistency.max_edges_judged"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_marginal_update_nodes = 257; }).message(),
              HasSubstr("consistency.max_marginal_update_nodes"));
  EXPECT_THAT(MapperParams{}.Validate(), IsOk());
}

TEST(ConsistencyParamsTest, OpenHypothesesAreCapped) {
  MapperParams params = testing::TestParams();
  params.consistency.max_open_hypotheses = 3;
  auto mapper = MakeMapper(params);
  SimulatedRobot robot(*mapper);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  robot.Drive(SE2(1, 0, 0));
  // Five wild observations that agree with nothing: five hypotheses, of which the two stalest expire.
  for (int k = 0; k < 5; ++k) {
    robot.Wait(1.0);
    robot.ObserveRaw(1, SE2(3.0 * k + 5, 0, 0), 1e-4);
  }
  EXPECT_EQ(mapper->Statistics().recovery_created, 5);
  EXPECT_EQ(mapper->Statistics().recovery_expired, 2);
  EXPECT_THAT(LastDecision(*mapper, DecisionKind::kExpired)->reason,
              HasSubstr("more than 3 open hypotheses"));
}

}  // namespace
}  // namespace slamcore
