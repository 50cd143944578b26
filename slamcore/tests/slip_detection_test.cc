// Wheel slip from the map's own views: the path through a seen wall, the view that stood still, and the
// motions that must not be mistaken for either.
#include "slamcore/slip_detection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "status_matchers.h"

namespace slamcore {
namespace {

using ::testing::ElementsAre;
using ::testing::Field;
using ::testing::IsEmpty;

constexpr std::int8_t kFree = 0, kWall = 100, kUnseen = -1;

/// A square patch of `half_m` around its node, each cell's state given by `state(x, y)` in the node frame.
LocalMapEvent Patch(double half_m, const std::function<std::int8_t(double, double)>& state) {
  LocalMapEvent patch;
  patch.resolution = 0.05;
  patch.width = patch.height = static_cast<int>(std::lround(2 * half_m / patch.resolution));
  patch.node_T_origin = SE2(-half_m, -half_m, 0.0);
  for (int row = 0; row < patch.height; ++row) {
    for (int col = 0; col < patch.width; ++col)
      patch.cells.push_back(state(-half_m + (col + 0.5) * 0.05, -half_m + (row + 0.5) * 0.05));
  }
  return patch;
}

/// What a front sensor sees `wall_ahead_m` in front of a wall across its way: floor up to it, the wall,
/// nothing behind it.
LocalMapEvent FacingWall(double wall_ahead_m) {
  return Patch(1.5, [=](double x, double y) {
    if (x < -0.2 || std::abs(y) > 0.6) return kUnseen;
    if (x < wall_ahead_m) return kFree;
    return x < wall_ahead_m + 0.05 ? kWall : kUnseen;
  });
}

/// A chain of nodes at `poses` joined by motion edges, with `views[k]` at node k where it is set.
Map Chain(const std::vector<SE2>& poses, const std::vector<std::optional<LocalMapEvent>>& views) {
  Map map;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const NodeId id = static_cast<NodeId>(k);
    EXPECT_THAT(map.graph.AddNode(Node{.id = id, .pose = poses[k]}), IsOk());
    if (k > 0) {
      EXPECT_THAT(map.graph.AddEdge(Edge{.from = id - 1,
                                         .to = id,
                                         .measurement = poses[k - 1].inverse() * poses[k],
                                         .information = Matrix3::Identity(),
                                         .kind = EdgeKind::kMotion,
                                         .view = std::nullopt,
                                         .hypothesis = std::nullopt}),
                  IsOk());
    }
    if (k < views.size() && views[k]) map.local_maps.emplace(id, *views[k]);
  }
  return map;
}

TEST(SlipDetectionTest, NodesCarriedThroughTheWallTheRobotFacedAreFound) {
  // Touching a wall 0.2 m ahead, the wheels turn on: odometry places nodes every 0.3 m through it, and the
  // sensor keeps seeing the same wall 0.2 m ahead.
  std::vector<SE2> poses;
  std::vector<std::optional<LocalMapEvent>> views;
  for (int k = 0; k < 6; ++k) {
    poses.emplace_back(0.3 * k, 0.0, 0.0);
    views.push_back(k % 2 == 0 ? std::optional(FacingWall(0.2)) : std::nullopt);
  }
  const auto findings = FindSlipNodes(Chain(poses, views));
  ASSERT_THAT(findings, IsOk());
  ASSERT_EQ(findings->size(), 5u);
  for (std::size_t k = 0; k < findings->size(); ++k) {
    EXPECT_EQ((*findings)[k].node, static_cast<NodeId>(k + 1));
    EXPECT_EQ((*findings)[k].evidence, SlipEvidence::kPathThroughWall);
    EXPECT_EQ((*findings)[k].judged_against, static_cast<NodeId>(2 * (k / 2)));
  }
}

TEST(SlipDetectionTest, DrivingUpToAWallAndTurningAwayIsNoSlip) {
  // The wall is 1.0 m ahead at the start; the robot stops 0.2 m short of it and turns along it.
  const std::vector<SE2> poses = {SE2(0.0, 0.0, 0.0), SE2(0.3, 0.0, 0.0),      SE2(0.6, 0.0, 0.0),
                                  SE2(0.8, 0.0, 0.0), SE2(0.8, 0.0, M_PI / 2), SE2(0.8, 0.3, M_PI / 2)};
  const std::vector<std::optional<LocalMapEvent>> views = {FacingWall(1.0), std::nullopt, FacingWall(0.4),
                                                           std::nullopt,    std::nullopt, std::nullopt};
  const auto findings = FindSlipNodes(Chain(poses, views));
  ASSERT_THAT(findings, IsOk());
  EXPECT_THAT(*findings, IsEmpty());
}

/// A lidar's view of a 5 m × 5 m room from the point (x, y) inside it.
LocalMapEvent RoomSeenFrom(double x, double y = 0.0) {
  return Patch(3.0, [=](double px, double py) {
    const double wx = px + x, wy = py + y;
    if (std::abs(wx) > 2.55 || std::abs(wy) > 2.55) return kUnseen;
    return (std::abs(wx) > 2.5 || std::abs(wy) > 2.5) ? kWall : kFree;
  });
}

TEST(SlipDetectionTest, AViewThatStoodStillWhileOdometryMovedIsFound) {
  // Lifted on a rug in the middle of the room: the wheels claim 1.8 m, the lidar sees the room from where
  // it was. Node 6's view agrees with node 0's at node 0's pose, not 1.8 m further.
  std::vector<SE2> poses;
  for (int k = 0; k <= 6; ++k) poses.emplace_back(0.3 * k, 0.0, 0.0);
  const auto findings =
      FindSlipNodes(Chain(poses, {RoomSeenFrom(0.0), {}, {}, {}, {}, {}, RoomSeenFrom(0.0)}));
  ASSERT_THAT(findings, IsOk());
  EXPECT_THAT(*findings, ElementsAre(AllOf(Field(&SlipFinding::node, 6),
                                           Field(&SlipFinding::evidence, SlipEvidence::kViewStoodStill),
                                           Field(&SlipFinding::judged_against, 0))));
  // The same motion, made for real: the later view sees the room from 1.8 m further.
  const auto moved = FindSlipNodes(Chain(poses, {RoomSeenFrom(0.0), {}, {}, {}, {}, {}, RoomSeenFrom(1.8)}));
  ASSERT_THAT(moved, IsOk());
  EXPECT_THAT(*moved, IsEmpty());
}

TEST(SlipDetectionTest, ARobotThatMovedPartOfTheWayIsPlacedWhereItsWheelsLostGrip) {
  // The wheels claim 1.8 m across the room, diagonally; the robot made 0.6 m of it before the rug lifted
  // it. Its view agrees with the earlier one only 0.6 m along the claimed motion: that is where it stood.
  const double diagonal = std::sqrt(0.5);
  std::vector<SE2> poses;
  for (int k = 0; k <= 6; ++k) poses.emplace_back(0.3 * k * diagonal, 0.3 * k * diagonal, 0.0);
  const auto stopped_after = [&](double metres) {
    return FindSlipNodes(Chain(
        poses, {RoomSeenFrom(0.0), {}, {}, {}, {}, {}, RoomSeenFrom(metres * diagonal, metres * diagonal)}));
  };
  const auto findings = stopped_after(0.6);
  ASSERT_THAT(findings, IsOk());
  ASSERT_EQ(findings->size(), 1u);
  const SlipFinding& finding = findings->front();
  EXPECT_EQ(finding.node, 6);
  EXPECT_EQ(finding.evidence, SlipEvidence::kViewStoodStill);
  EXPECT_EQ(finding.judged_against, 0);
  // Placements are 0.1 m apart along the motion, and a wall within a cell (0.05 m on each axis) agrees, so
  // the neighbouring placement can tie with the true one; the first of a tie is taken.
  EXPECT_NEAR(finding.judge_T_stood.x(), 0.5 * diagonal, 1e-9);
  EXPECT_NEAR(finding.judge_T_stood.y(), 0.5 * diagonal, 1e-9);
  EXPECT_NEAR(finding.judge_T_stood.theta(), 0.0, 1e-12);
  // Stopped 0.2 m short (1.6 m of 1.8): less than min_still_motion_m (0.25 m) short, so nothing.
  const auto nearly = stopped_after(1.6);
  ASSERT_THAT(nearly, IsOk());
  EXPECT_THAT(*nearly, IsEmpty());
}

TEST(SlipDetectionTest, AShortRangeViewOfAWallAheadIsJudgedBothWays) {
  // A front sensor sees a wall 1 m ahead, and the wheels claim 0.6 m toward it (the path stops short of the
  // wall). Placed 0.6 m on, the later view's wall falls in the earlier view's shadow, where nothing can be
  // judged; but the earlier view's wall then falls on the later view's floor, 0.4 m in front of it.
  const std::vector<SE2> poses = {SE2(0.0, 0.0, 0.0), SE2(0.3, 0.0, 0.0), SE2(0.6, 0.0, 0.0)};
  int landed = 0;
  EXPECT_EQ(WallAgreement(FacingWall(1.0), FacingWall(1.0), poses[2], &landed), 0.0);
  EXPECT_EQ(landed, 0);  // one way alone: no judgement
  const auto stuck = FindSlipNodes(Chain(poses, {FacingWall(1.0), {}, FacingWall(1.0)}));
  ASSERT_THAT(stuck, IsOk());
  EXPECT_THAT(*stuck, ElementsAre(AllOf(Field(&SlipFinding::node, 2),
                                        Field(&SlipFinding::evidence, SlipEvidence::kViewStoodStill),
                                        Field(&SlipFinding::judged_against, 0))));
  // Driven for real, the wall is 0.4 m ahead of the later view.
  const auto moved = FindSlipNodes(Chain(poses, {FacingWall(1.0), {}, FacingWall(0.4)}));
  ASSERT_THAT(moved, IsOk());
  EXPECT_THAT(*moved, IsEmpty());
}

TEST(SlipDetectionTest, WhereOdometryPutsTheViewBeyondAllJudgementAShorterStepJudges) {
  // A front sensor sees a wall ahead with a step in it (1 m away to the right, 0.6 m to the left); the
  // wheels claim 1.5 m sideways (the robot stuck, its odometry carried off) along the wall, so the path
  // crosses nothing. 1.5 m on, neither view's walls land on the other's seen cells; part of the way, the
  // step lands on floor.
  const auto step_ahead = Patch(1.5, [](double x, double y) {
    if (x < -0.2 || std::abs(y) > 0.6) return kUnseen;
    const double wall_x = y < 0.0 ? 1.0 : 0.6;
    if (x < wall_x) return kFree;
    return x < wall_x + 0.05 ? kWall : kUnseen;
  });
  const std::vector<SE2> poses = {SE2(0.0, 0.0, 0.0), SE2(0.0, 0.75, 0.0), SE2(0.0, 1.5, 0.0)};
  int landed = 0;
  (void)WallAgreement(step_ahead, step_ahead, poses[2], &landed);
  EXPECT_EQ(landed, 0);
  (void)WallAgreement(step_ahead, step_ahead, poses[2].inverse(), &landed);
  EXPECT_EQ(landed, 0);
  const auto findings = FindSlipNodes(Chain(poses, {step_ahead, {}, step_ahead}));
  ASSERT_THAT(findings, IsOk());
  ASSERT_EQ(findings->size(), 1u);
  EXPECT_EQ(findings->front().node, 2);
  EXPECT_EQ(findings->front().evidence, SlipEvidence::kViewStoodStill);
  EXPECT_NEAR(findings->front().judge_T_stood.translation().norm(), 0.0, 1e-12);
}

TEST(SlipDetectionTest, AViewFullOfWallsIsJudgedOnABoundedSampleOfThem) {
  // 100 × 100 wall cells (an upload may hold up to 2048²): 4096 of them, evenly spaced, are tried.
  const LocalMapEvent solid = Patch(2.5, [](double, double) { return kWall; });
  ASSERT_EQ(solid.cells.size(), 10000u);
  int landed = 0;
  EXPECT_EQ(WallAgreement(solid, solid, SE2(), &landed), 1.0);
  EXPECT_EQ(landed, 4096);
}

TEST(SlipDetectionTest, AFeaturelessCorridorAlongTheMotionClaimsNothing) {
  // Walls 0.6 m to either side, running along the motion: every view looks the same wherever the robot is,
  // so the views cannot tell whether it moved.
  const LocalMapEvent corridor = Patch(3.0, [](double, double y) {
    if (std::abs(y) > 0.65) return kUnseen;
    return std::abs(y) > 0.6 ? kWall : kFree;
  });
  std::vector<SE2> poses;
  for (int k = 0; k <= 6; ++k) poses.emplace_back(0.3 * k, 0.0, 0.0);
  const auto findings = FindSlipNodes(Chain(poses, {corridor, {}, {}, {}, {}, {}, corridor}));
  ASSERT_THAT(findings, IsOk());
  EXPECT_THAT(*findings, IsEmpty());
}

TEST(SlipDetectionTest, ChainsFollowMotionEdgesOnly) {
  // Two runs in one map: the second starts beyond the first run's wall, with no motion edge between them
  // (the robot was carried there), so nothing crosses that wall.
  Map map = Chain({SE2(0.0, 0.0, 0.0), SE2(0.1, 0.0, 0.0)}, {FacingWall(0.2), std::nullopt});
  ASSERT_THAT(map.graph.AddNode(Node{.id = 10, .pose = SE2(1.0, 0.0, 0.0)}), IsOk());
  ASSERT_THAT(map.graph.AddNode(Node{.id = 11, .pose = SE2(1.3, 0.0, 0.0)}), IsOk());
  ASSERT_THAT(map.graph.AddEdge(Edge{.from = 10,
                                     .to = 11,
                                     .measurement = SE2(0.3, 0.0, 0.0),
                                     .information = Matrix3::Identity(),
                                     .kind = EdgeKind::kMotion,
                                     .view = std::nullopt,
                                     .hypothesis = std::nullopt}),
              IsOk());
  const auto findings = FindSlipNodes(map);
  ASSERT_THAT(findings, IsOk());
  EXPECT_THAT(*findings, IsEmpty());
}

TEST(SlipDetectionTest, AMalformedPatchIsNoView) {
  LocalMapEvent torn = FacingWall(0.2);
  torn.cells.resize(torn.cells.size() / 2);  // fewer cells than width × height
  const auto findings = FindSlipNodes(Chain({SE2(0.0, 0.0, 0.0), SE2(0.3, 0.0, 0.0)}, {torn, std::nullopt}));
  ASSERT_THAT(findings, IsOk());
  EXPECT_THAT(*findings, IsEmpty());
}

TEST(SlipDetectionTest, RefusesParametersOutsideTheirRange) {
  const Map map = Chain({SE2()}, {});
  SlipDetectionParams params;
  params.max_path_m = 0.0;
  EXPECT_THAT(FindSlipNodes(map, params), StatusIs(StatusCode::kInvalidArgument, "max_path_m"));
  params = {};
  params.min_still_agreement = 1.5;
  EXPECT_THAT(FindSlipNodes(map, params), StatusIs(StatusCode::kInvalidArgument, "min_still_agreement"));
  params = {};
  params.min_wall_cells = 0;
  EXPECT_THAT(FindSlipNodes(map, params), StatusIs(StatusCode::kInvalidArgument, "min_wall_cells"));
}

/// A robot driving +x toward a wall at x = 1.5 in 0.3 m steps, each node's local map seen from its true x
/// (`true_x[k]`) while odometry claims the 0.3 m steps: its nodes' estimated x after the run.
std::vector<double> EstimatedXAfter(const std::vector<double>& true_x, bool correct,
                                    MapperStatistics* stats) {
  MapperParams params;
  params.correct_slip_from_views = correct;
  auto mapper = Mapper::Create(params);
  EXPECT_THAT(mapper, IsOk());
  for (std::size_t k = 0; k < true_x.size(); ++k) {
    const double time = static_cast<double>(k);
    const SE2 step = k == 0 ? SE2() : SE2(0.3, 0.0, 0.0);
    EXPECT_THAT((*mapper)->Process(OdometryEvent{.time = time, .increment = step}), IsOk());
    LocalMapEvent view = FacingWall(1.5 - true_x[k]);
    view.time = time;
    EXPECT_THAT((*mapper)->Process(view), IsOk());
  }
  *stats = (*mapper)->Statistics();
  std::vector<double> x;
  for (std::size_t k = 0; k < true_x.size(); ++k) x.push_back((*mapper)->PoseOf(static_cast<NodeId>(k)).x());
  return x;
}

TEST(SlipCorrectionTest, NodesStayWhereTheirViewsStoodWhileTheWheelsTurnOn) {
  // Three steps to x = 0.6, then stuck there while odometry claims six more (to x = 2.4, through the wall).
  const std::vector<double> true_x = {0.0, 0.3, 0.6, 0.6, 0.6, 0.6, 0.6, 0.6, 0.6};
  MapperStatistics stats;
  const std::vector<double> uncorrected = EstimatedXAfter(true_x, /*correct=*/false, &stats);
  EXPECT_NEAR(uncorrected.back(), 2.4, 1e-6);
  EXPECT_EQ(stats.slip_corrections, 0);
  const std::vector<double> corrected = EstimatedXAfter(true_x, /*correct=*/true, &stats);
  // Each stuck node is judged against the node before it, whose view stood at the same place: placed at
  // 0, 0.1, 0.2 and 0.3 m along the claimed step, the wall 0.9 m ahead agrees at 0 only.
  EXPECT_EQ(stats.slip_corrections, 6);
  for (std::size_t k = 0; k < true_x.size(); ++k) EXPECT_NEAR(corrected[k], true_x[k], 1e-6) << "node " << k;
}

TEST(SlipCorrectionTest, ARobotThatMovesAsOdometrySaysIsLeftAlone) {
  const std::vector<double> true_x = {0.0, 0.3, 0.6, 0.9, 1.2};
  MapperStatistics stats;
  const std::vector<double> x = EstimatedXAfter(true_x, /*correct=*/true, &stats);
  EXPECT_EQ(stats.slip_corrections, 0);
  for (std::size_t k = 0; k < true_x.size(); ++k) EXPECT_NEAR(x[k], true_x[k], 1e-6) << "node " << k;
}

}  // namespace
}  // namespace slamcore
