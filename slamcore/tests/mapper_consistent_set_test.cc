// The consistent-set check (mapper_consistent_set.cc): the GNC-TLS weight rule with numbers worked by hand,
// and a wrong pass that one pass of the truth could not overrule online, corrected when the run ends.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <tuple>

#include "graduated_non_convexity.h"
#include "mapper_test_util.h"
#include "slamcore/optimizer.h"
#include "test_matchers.h"

namespace slamcore {
namespace {

using ::testing::HasSubstr;
using testing::IsNearlyPose;
using testing::MakeMapper;
using testing::SimulatedRobot;

TEST(TruncatedLeastSquaresWeightTest, InsideOutsideAndTheBlendBetweenAtMuOne) {
  // μ = 1: weight 1 up to s = 1/2, 0 from s = 2, and √(2/s) − 1 between.
  EXPECT_EQ(internal::TruncatedLeastSquaresWeight(0.5, 1.0), 1.0);
  EXPECT_EQ(internal::TruncatedLeastSquaresWeight(2.0, 1.0), 0.0);
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(1.0, 1.0), std::sqrt(2.0) - 1.0, 1e-12);
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(1.5, 1.0), std::sqrt(2.0 / 1.5) - 1.0, 1e-12);
  // The blend is continuous at both ends: √(μ(μ+1)/s) − μ is 1 at s = μ/(μ+1) and 0 at s = (μ+1)/μ.
  for (const double mu : {0.01, 0.3, 4.0}) {
    EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(mu / (mu + 1.0) * (1 + 1e-12), mu), 1.0, 1e-6);
    EXPECT_NEAR(internal::TruncatedLeastSquaresWeight((mu + 1.0) / mu * (1 - 1e-12), mu), 0.0, 1e-6);
  }
}

TEST(TruncatedLeastSquaresWeightTest, TheFirstRoundKeepsEveryMeasurement) {
  // μ₀ = 1/(2·s_max − 1): s_max = 10 gives μ₀ = 1/19, and (μ₀+1)/μ₀ = 20 > 10, so no weight is 0 yet.
  const double mu = internal::InitialControlParameter(10.0);
  EXPECT_NEAR(mu, 1.0 / 19.0, 1e-15);
  EXPECT_GT(internal::TruncatedLeastSquaresWeight(10.0, mu), 0.0);
  // √((1/19)(20/19)/10) − 1/19 = √20/(19·√10) − 1/19 = (√2 − 1)/19.
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(10.0, mu), (std::sqrt(2.0) - 1.0) / 19.0, 1e-12);
}

/// The edges of a graph as (from, to, measurement) triples, to compare graphs built in different orders.
std::multiset<std::tuple<NodeId, NodeId, double, double, double>> EdgeSet(const PoseGraph& graph) {
  std::multiset<std::tuple<NodeId, NodeId, double, double, double>> edges;
  for (const Edge& edge : graph.edges()) {
    edges.emplace(edge.from, edge.to, edge.measurement.x(), edge.measurement.y(), edge.measurement.theta());
  }
  return edges;
}

// A corridor out and back with loose odometry, as in mapper_consistency_test.cc: views 1–3 at x = 0, 1, 2;
// the robot drives to x = 12 and back to x = 2, unsure where by metres. One pass of wrong observations
// claims it stands at x = 4.5 (uninformative: accepted). One later pass of the truth contradicts it; a
// single pass cannot overrule the map online (three are needed), so it waits and is refused at the end.
// Only the two judged together show which fits the odometry: the truth.
void CorridorWithOnePassOfTruth(Mapper& mapper, bool with_wrong_pass) {
  SimulatedRobot robot(mapper);
  constexpr double kOdometryVariance = 0.1;  // per axis and step: σ_x ≈ 1.5 m after 22 steps
  robot.Drive(SE2::Identity(), std::nullopt, kOdometryVariance);
  robot.CreateView(1);
  robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  robot.CreateView(2);
  robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  robot.CreateView(3);
  for (int k = 0; k < 10; ++k) robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  robot.Drive(SE2(0, 0, std::numbers::pi), std::nullopt, kOdometryVariance);
  for (int k = 0; k < 10; ++k) robot.Drive(SE2(1, 0, 0), std::nullopt, kOdometryVariance);
  if (with_wrong_pass) {
    for (const ViewId view : {1, 2, 3}) {
      const SE2 world_T_view(view - 1.0, 0, 0), wrong_world_T_robot(4.5, 0, std::numbers::pi);
      robot.ObserveRaw(view, wrong_world_T_robot.inverse() * world_T_view, 1e-4);
    }
  }
  robot.Wait(25.0);
  for (const ViewId view : {1, 2, 3}) robot.Observe(view, SE2::Identity(), 1e-4);
}

MapperParams CorridorParams(bool consistent_set_check) {
  MapperParams params = testing::TestParams();
  params.ambiguity_min_rejections = 1000;  // the test is about the filter, not the ambiguity marks
  params.consistency.consistent_set_check = consistent_set_check;
  return params;
}

TEST(ConsistentSetCheckTest, WithoutItOnePassOfTruthCannotOverruleAnAcceptedWrongPass) {
  auto mapper = MakeMapper(CorridorParams(false));
  CorridorWithOnePassOfTruth(*mapper, true);
  (void)mapper->Finish();
  EXPECT_EQ(mapper->Statistics().recovery_accepted, 1);
  EXPECT_EQ(mapper->Statistics().recovery_retracted, 0);
}

TEST(ConsistentSetCheckTest, AtTheEndOfTheRunTheTruthIsAcceptedAndTheWrongPassRetracted) {
  auto with_wrong = MakeMapper(CorridorParams(true));
  CorridorWithOnePassOfTruth(*with_wrong, true);
  const PoseGraph corrected = with_wrong->Finish().graph;
  auto without = MakeMapper(CorridorParams(true));
  CorridorWithOnePassOfTruth(*without, false);
  const PoseGraph clean = without->Finish().graph;

  const MapperStatistics statistics = with_wrong->Statistics();
  EXPECT_EQ(statistics.recovery_accepted, 2);  // the wrong pass online, the truth by the check
  EXPECT_EQ(statistics.recovery_retracted, 1);
  const Decision* retracted = testing::LastDecision(*with_wrong, DecisionKind::kRetracted);
  ASSERT_NE(retracted, nullptr);
  EXPECT_THAT(retracted->reason, HasSubstr("consistent-set check (the run ended"));
  const Decision* accepted = testing::LastDecision(*with_wrong, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  EXPECT_NE(accepted->hypothesis, retracted->hypothesis);
  EXPECT_THAT(accepted->reason, HasSubstr("largest consistent set"));
  for (const AcceptedObservation& edge : with_wrong->accepted_observations()) {
    EXPECT_NE(edge.hypothesis, retracted->hypothesis);
  }

  // G equals the G of a run that never saw the wrong pass: the same edges, the same optimised poses.
  EXPECT_EQ(EdgeSet(corrected), EdgeSet(clean));
  PoseGraph corrected_optimized = corrected, clean_optimized = clean;
  ASSERT_TRUE(Optimize(corrected_optimized).ok());
  ASSERT_TRUE(Optimize(clean_optimized).ok());
  for (const Node& node : clean_optimized.nodes()) {
    EXPECT_THAT(corrected_optimized.node(node.id).pose, IsNearlyPose(node.pose, 1e-6)) << "node " << node.id;
  }
  EXPECT_NEAR(corrected_optimized.node(corrected_optimized.num_nodes() - 1).pose.x(), 2.0, 0.05);
}

TEST(ConsistentSetCheckTest, ItsFieldsAreValidated) {
  const auto refused = [](auto change) {
    MapperParams params;
    change(params);
    return params.Validate();
  };
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.consistent_set_confidence = 1.0; }).message(),
              HasSubstr("consistency.consistent_set_confidence"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.consistent_set_growth = 1.0; }).message(),
              HasSubstr("consistency.consistent_set_growth"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_kept_refused = -1; }).message(),
              HasSubstr("consistency.max_kept_refused"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.gnc_max_iterations = 0; }).message(),
              HasSubstr("consistency.gnc_max_iterations"));
}

}  // namespace
}  // namespace slamcore
