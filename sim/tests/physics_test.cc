// The simulated physics is right: odometry follows its noise model, slip moves the wheels and not the
// robot, a symmetric object seen from the other side gives observations turned by π, and a look-alike is
// taken for the whole pass. Checked from the
// telemetry a run produces, against its ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>
#include <unordered_map>

#include "sim/run_simulator.h"
#include "test_data.h"
#include "status_matchers.h"

namespace sim {
namespace {

struct NodeTruth {
  SE2 measured_increment;
  SE2 true_pose;
  bool slipping = false;
};

/// Per node: the odometry increment and the true pose that followed it.
std::vector<NodeTruth> NodesOf(const fleet::v1::RunFile& run) {
  std::vector<NodeTruth> nodes;
  for (const fleet::v1::Event& event : run.events()) {
    if (event.has_odometry()) {
      const auto& increment = event.odometry().increment();
      nodes.push_back({SE2(increment.x(), increment.y(), increment.theta()), SE2(), false});
    } else if (event.has_ground_truth() && !nodes.empty()) {
      const auto& pose = event.ground_truth().world_t_robot();
      nodes.back().true_pose = SE2(pose.x(), pose.y(), pose.theta());
      nodes.back().slipping = event.ground_truth().slipping();
    } else if (event.has_kidnap()) {
      nodes.clear();  // keep the test to one continuous stretch
    }
  }
  return nodes;
}

World FirstWorld() {
  const auto worlds = ListWorlds(test_data::Sample() / "floorplans");
  EXPECT_THAT(worlds, IsOk());
  auto world = LoadWorld(worlds->front(), 3);
  EXPECT_THAT(world, IsOk());
  return std::move(world).value();
}

TEST(PhysicsTest, OdometryFollowsTheConfiguredNoiseModel) {
  const World world = FirstWorld();
  SimParams params;
  params.run_minutes = 30.0;
  params.stuck_rate_scale = 0.0;
  params.kidnap_probability = 0.0;
  params.reboot_probability = 0.0;
  RobotSimulator robot(world, params, "robot", "fw", 21);
  const auto outcome = robot.SimulateRun("run", 0.0);
  ASSERT_THAT(outcome, IsOk());
  const std::vector<NodeTruth> nodes = NodesOf(outcome->run);
  ASSERT_GT(nodes.size(), 500u);

  // Straight-driving nodes: measured distance = scale · true distance + N(0, σ²·d).
  double sum_measured = 0, sum_true = 0;
  std::vector<std::pair<double, double>> samples;  // (true distance, measured distance)
  for (std::size_t k = 1; k < nodes.size(); ++k) {
    const SE2 truth = nodes[k - 1].true_pose.inverse() * nodes[k].true_pose;
    const double true_distance = truth.translation().norm();
    if (true_distance < 0.2 || std::abs(truth.theta()) > 0.05) continue;
    samples.emplace_back(true_distance, nodes[k].measured_increment.translation().norm());
    sum_true += true_distance;
    sum_measured += samples.back().second;
  }
  ASSERT_GT(samples.size(), 100u);
  const double scale = sum_measured / sum_true;
  EXPECT_LT(std::abs(scale - 1.0), 5 * params.odometry_scale_error) << "wheel scale " << scale;
  double normalised_variance = 0;
  for (const auto& [true_distance, measured] : samples) {
    normalised_variance += std::pow(measured - scale * true_distance, 2) / true_distance;
  }
  normalised_variance /= static_cast<double>(samples.size());
  const double expected = std::pow(params.odometry_noise_per_metre, 2);
  EXPECT_GT(normalised_variance, 0.6 * expected);
  EXPECT_LT(normalised_variance, 1.6 * expected);
}

TEST(PhysicsTest, SlipTurnsTheWheelsButNotTheRobot) {
  const World world = FirstWorld();
  SimParams params;
  params.run_minutes = 30.0;
  params.stuck_rate_scale = 200.0;  // a wedge on one bump in 20
  params.stuck_creep_share = 0.0;
  params.kidnap_probability = 0.0;
  params.reboot_probability = 0.0;
  RobotSimulator robot(world, params, "robot", "fw", 8);
  const auto outcome = robot.SimulateRun("run", 0.0);
  ASSERT_THAT(outcome, IsOk());
  ASSERT_GT(outcome->stuck_episodes(), 0);
  const std::vector<NodeTruth> nodes = NodesOf(outcome->run);
  int stuck_nodes = 0, moving_nodes = 0;
  for (std::size_t k = 1; k + 1 < nodes.size(); ++k) {
    const double moved = (nodes[k].true_pose.translation() - nodes[k - 1].true_pose.translation()).norm();
    const double claimed = nodes[k].measured_increment.translation().norm();
    if (claimed < 0.2) continue;  // turning in place
    if (nodes[k - 1].slipping && nodes[k].slipping && nodes[k + 1].slipping) {
      // Inside an episode (stuck before, during and after this node): the wheels claim ≥ 0.2 m, the
      // robot did not move at all.
      ++stuck_nodes;
      EXPECT_LT(moved, 1e-9);
    } else if (!nodes[k].slipping) {
      ++moving_nodes;
      EXPECT_NEAR(moved, claimed, 0.15 * claimed + 0.05);
    }
  }
  EXPECT_GT(stuck_nodes, 5);
  EXPECT_GT(moving_nodes, 100);
}

TEST(PhysicsTest, WrongMatchesAreFlippedSymmetricObjectsOrLookAlikes) {
  const World world = FirstWorld();
  SimParams params;
  params.run_minutes = 30.0;
  params.kidnap_probability = 0.0;
  params.reboot_probability = 0.0;
  params.stuck_rate_scale = 0.0;
  params.recognition_failure_probability = 0.0;
  params.lookalike_probability = 0.0;  // only the symmetric flips remain as wrong matches
  params.observation_sigma_theta = 0.01;
  RobotSimulator robot(world, params, "robot", "fw", 4);
  const auto outcome = robot.SimulateRun("run", 0.0);
  ASSERT_THAT(outcome, IsOk());

  // The true relative pose of each observation, from the ground truth at the view's node and now.
  std::unordered_map<std::int64_t, SE2> view_truth;
  SE2 robot_truth;
  SE2 pending_view_pose;
  int flipped = 0, wrong = 0, right = 0;
  std::vector<std::int64_t> views_at_node;
  for (const fleet::v1::Event& event : outcome->run.events()) {
    if (event.has_ground_truth()) {
      const auto& pose = event.ground_truth().world_t_robot();
      robot_truth = SE2(pose.x(), pose.y(), pose.theta());
    } else if (event.has_view_created()) {
      view_truth[event.view_created().view()] = robot_truth;
    } else if (event.has_view_observed()) {
      const auto& observed = event.view_observed();
      const SE2 truth = robot_truth.inverse() * view_truth.at(observed.view());
      const double heading_error =
          std::abs(slamcore::WrapAngle(observed.robot_t_view().theta() - truth.theta()));
      if (observed.truth_wrong()) {
        ++wrong;
        if (std::abs(heading_error - std::numbers::pi) < 0.1) ++flipped;
      } else {
        ++right;
        EXPECT_LT(heading_error, 0.1);
      }
    }
  }
  EXPECT_GT(right, 50);
  EXPECT_GT(wrong, 0);
  EXPECT_EQ(flipped, wrong) << "every wrong match is a symmetric object seen from the other side";
}

// The front-end's look-alike choice holds for a pass (SimParams::lookalike_pass_gap_seconds): the look-alike
// matches come in groups of consecutive wrong observations that agree with each other, at the same share of
// recognitions as when each recognition draws its own. A robot's second and third runs in the home: its
// first creates the views that a look-alike can be matched to.
TEST(PhysicsTest, LookAlikeMatchesComeInPassesAtTheConfiguredShare) {
  const World world = FirstWorld();
  const auto lookalikes = [&](double gap_seconds) {
    SimParams params;
    params.run_minutes = 25.0;
    params.kidnap_probability = params.reboot_probability = 0.0;
    params.stuck_rate_scale = 0.0;
    params.lookalike_probability = 0.3;
    params.lookalike_pass_gap_seconds = gap_seconds;
    RobotSimulator robot(world, params, "robot", "fw", 11);
    RunOutcome total;
    for (int run = 0; run < 3; ++run) {
      auto outcome = robot.SimulateRun("run" + std::to_string(run), 3600.0 * run);
      EXPECT_THAT(outcome, IsOk());
      if (!outcome.ok()) break;
      total.lookalike_candidates += outcome->lookalike_candidates;
      total.lookalike_observations += outcome->lookalike_observations;
      total.lookalike_passes += outcome->lookalike_passes;
    }
    return total;
  };
  const RunOutcome per_recognition = lookalikes(0.0);
  const RunOutcome per_pass = lookalikes(5.0);
  for (const RunOutcome* outcome : {&per_recognition, &per_pass}) {
    ASSERT_GT(outcome->lookalike_candidates, 200);
    const double share = static_cast<double>(outcome->lookalike_observations) / outcome->lookalike_candidates;
    EXPECT_NEAR(share, 0.3, 0.1) << outcome->lookalike_observations << " of "
                                 << outcome->lookalike_candidates;
  }
  EXPECT_EQ(per_recognition.lookalike_passes, per_recognition.lookalike_observations)
      << "without passes each look-alike match stands alone";
  EXPECT_GT(per_pass.lookalike_observations, 1.25 * per_pass.lookalike_passes)
      << per_pass.lookalike_observations << " look-alike matches in " << per_pass.lookalike_passes
      << " passes";
}

// Hostile values of the options fleetsim's flags set are refused by name before a run starts; the bounds
// themselves are accepted.
TEST(SimParamsTest, OutOfRangeOptionsAreRefusedByName) {
  struct Case {
    double SimParams::*field;
    const char* name;
    double low, high;
  };
  const Case cases[] = {{&SimParams::lidar_free_range, "lidar_free_range", 0.0, 20.0},
                        {&SimParams::lookalike_pass_gap_seconds, "lookalike_pass_gap_seconds", 0.0, 600.0},
                        {&SimParams::stuck_rate_scale, "stuck_rate_scale", 0.0, 1000.0},
                        {&SimParams::lookalike_probability, "lookalike_probability", 0.0, 1.0}};
  for (const Case& c : cases) {
    for (const double bound : {c.low, c.high}) {
      SimParams params;
      params.*c.field = bound;
      EXPECT_THAT(params.Validate(), IsOk()) << c.name << " = " << bound;
    }
    for (const double bad :
         {c.low - 1.0, c.high + 1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
      SimParams params;
      params.*c.field = bad;
      EXPECT_THAT(params.Validate(),
                  StatusIs(slamcore::StatusCode::kInvalidArgument, std::string(c.name) + " must be in ["))
          << bad;
    }
  }
}

}  // namespace
}  // namespace sim
