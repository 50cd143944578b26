// The error contract of Mapper::Process: bad events are refused with a Status naming the event, and
// leave the Mapper exactly as it was.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "mapper_test_util.h"
#include "slamcore/mapper.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::Describe;
using ::testing::HasSubstr;
using testing::MakeMapper;
using testing::SimulatedRobot;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Everything a caller can observe of a Mapper.
std::string Snapshot(const Mapper& mapper) {
  std::ostringstream text;
  text << Describe(mapper.map().graph) << "local maps " << mapper.map().local_maps.size() << "\ndecisions "
       << mapper.decisions().size() << "\naccepted " << mapper.accepted_observations().size()
       << "\nground truth " << mapper.ground_truth().size() << "\nconditional "
       << mapper.HasConditionalMerge() << "\ncurrent " << mapper.CurrentNode().value_or(-1) << "\n";
  if (mapper.CurrentPose()) text << "pose " << mapper.CurrentPose()->vector().transpose() << "\n";
  return text.str();
}

/// A run at t = 10 with views 1 (node 0) and 2 (node 1), an open recovery hypothesis and a local map.
std::unique_ptr<Mapper> Started() {
  auto mapper = MakeMapper();
  SimulatedRobot robot(*mapper);
  robot.Wait(9.0);
  robot.Drive(SE2::Identity());
  robot.CreateView(1);
  robot.Drive(SE2(1.0, 0.0, 0.0));  // t = 11
  robot.CreateView(2);
  robot.ObserveRaw(1, SE2(3.0, 0.0, 0.0));
  EXPECT_THAT(
      mapper->Process(LocalMapEvent{
          .time = 11.0, .resolution = 0.05, .width = 1, .height = 1, .node_T_origin = SE2(), .cells = {0}}),
      IsOk());
  return mapper;
}

struct BadEvent {
  std::string name;
  Event event;
  StatusCode code;
  std::string message;  // a part of the expected message
};

Matrix3 NotSymmetric() {
  Matrix3 m = Matrix3::Identity();
  m(0, 1) = 0.5;
  return m;
}

TEST(MapperErrorsTest, BadEventsAreRefusedAndChangeNothing) {
  const Matrix3 id = Matrix3::Identity() * 1e-2;
  const std::vector<BadEvent> cases = {
      {"unknown view", ViewObservedEvent{.time = 12.5, .view = 7, .robot_T_view = SE2(), .covariance = id},
       StatusCode::kNotFound, "ViewObservedEvent at t=12.5: view 7 does not exist"},
      {"duplicate view", ViewCreatedEvent{.time = 12.0, .view = 2}, StatusCode::kInvalidArgument,
       "ViewCreatedEvent at t=12: view 2 already exists"},
      {"odometry time backwards", OdometryEvent{.time = 10.5, .increment = SE2(), .covariance = id},
       StatusCode::kFailedPrecondition, "OdometryEvent at t=10.5: time goes backwards"},
      {"view time backwards", ViewCreatedEvent{.time = 1.0, .view = 9}, StatusCode::kFailedPrecondition,
       "ViewCreatedEvent at t=1: time goes backwards"},
      {"observation time backwards",
       ViewObservedEvent{.time = 3.0, .view = 1, .robot_T_view = SE2(), .covariance = id},
       StatusCode::kFailedPrecondition, "time goes backwards"},
      {"ground truth time backwards", GroundTruthEvent{.time = 3.0, .world_T_robot = SE2()},
       StatusCode::kFailedPrecondition, "GroundTruthEvent at t=3"},
      {"kidnap time backwards", KidnapEvent{.time = 3.0, .cause = KidnapEvent::Cause::kReboot},
       StatusCode::kFailedPrecondition, "KidnapEvent at t=3"},
      {"NaN time", OdometryEvent{.time = kNan, .increment = SE2(), .covariance = id},
       StatusCode::kInvalidArgument, "time is not finite"},
      {"NaN increment", OdometryEvent{.time = 12.0, .increment = SE2(kNan, 0, 0), .covariance = id},
       StatusCode::kInvalidArgument, "OdometryEvent at t=12: increment has a NaN"},
      {"infinite increment angle",
       OdometryEvent{.time = 12.0, .increment = SE2(0, 0, kInf), .covariance = id},
       StatusCode::kInvalidArgument, "increment"},
      {"infinite odometry covariance",
       OdometryEvent{.time = 12.0, .increment = SE2(), .covariance = Matrix3::Identity() * kInf},
       StatusCode::kInvalidArgument, "covariance has a NaN or infinite entry"},
      {"asymmetric covariance", OdometryEvent{.time = 12.0, .increment = SE2(), .covariance = NotSymmetric()},
       StatusCode::kInvalidArgument, "covariance is not symmetric"},
      {"indefinite covariance",
       ViewObservedEvent{.time = 12.0,
                         .view = 1,
                         .robot_T_view = SE2(),
                         .covariance = Vector3(1e-2, -1e-2, 1e-2).asDiagonal()},
       StatusCode::kInvalidArgument, "ViewObservedEvent at t=12: covariance is not positive definite"},
      {"zero covariance",
       ViewObservedEvent{.time = 12.0, .view = 1, .robot_T_view = SE2(), .covariance = Matrix3::Zero()},
       StatusCode::kInvalidArgument, "not positive definite"},
      {"NaN observation",
       ViewObservedEvent{.time = 12.0, .view = 1, .robot_T_view = SE2(0, kNan, 0), .covariance = id},
       StatusCode::kInvalidArgument, "robot_T_view has a NaN"},
      {"NaN ground truth", GroundTruthEvent{.time = 12.0, .world_T_robot = SE2(kNan, 0, 0)},
       StatusCode::kInvalidArgument, "GroundTruthEvent at t=12: world_T_robot"},
      {"unknown kidnap cause", KidnapEvent{.time = 12.0, .cause = static_cast<KidnapEvent::Cause>(7)},
       StatusCode::kInvalidArgument, "unknown cause 7"},
      {"local map size",
       LocalMapEvent{.time = 12.0,
                     .resolution = 0.05,
                     .width = 2,
                     .height = 2,
                     .node_T_origin = SE2(),
                     .cells = {0, 0, 0}},
       StatusCode::kInvalidArgument, "LocalMapEvent at t=12: has 3 cells"},
      {"local map cell",
       LocalMapEvent{
           .time = 12.0, .resolution = 0.05, .width = 1, .height = 1, .node_T_origin = SE2(), .cells = {101}},
       StatusCode::kInvalidArgument, "cell 0 is 101"},
      {"local map resolution",
       LocalMapEvent{
           .time = 12.0, .resolution = kNan, .width = 1, .height = 1, .node_T_origin = SE2(), .cells = {0}},
       StatusCode::kInvalidArgument, "resolution"},
      {"local map origin",
       LocalMapEvent{.time = 12.0,
                     .resolution = 0.05,
                     .width = 1,
                     .height = 1,
                     .node_T_origin = SE2(kInf, 0, 0),
                     .cells = {0}},
       StatusCode::kInvalidArgument, "node_T_origin"},
  };
  for (const BadEvent& bad : cases) {
    auto mapper = Started();
    const std::string before = Snapshot(*mapper);
    const Status status = mapper->Process(bad.event);
    ASSERT_FALSE(status.ok()) << bad.name;
    EXPECT_EQ(status.code(), bad.code) << bad.name << ": " << status.ToString();
    EXPECT_THAT(status.message(), HasSubstr(bad.message)) << bad.name;
    EXPECT_EQ(Snapshot(*mapper), before) << bad.name;
    // The time of the refused event was not taken either: an event at t = 11 is still accepted.
    EXPECT_THAT(mapper->Process(OdometryEvent{.time = 11.0, .increment = SE2(), .covariance = id}), IsOk())
        << bad.name;
  }
}

TEST(MapperErrorsTest, EventsNeedingANodeAreRefusedBeforeTheFirstNodeAndAfterAKidnap) {
  const Matrix3 id = Matrix3::Identity() * 1e-2;
  const std::vector<Event> need_a_node = {
      ViewCreatedEvent{.time = 5.0, .view = 1},
      ViewObservedEvent{.time = 5.0, .view = 1, .robot_T_view = SE2(), .covariance = id},
      LocalMapEvent{
          .time = 5.0, .resolution = 0.05, .width = 1, .height = 1, .node_T_origin = SE2(), .cells = {0}},
  };
  for (const Event& event : need_a_node) {
    auto empty = MakeMapper();
    const std::string before = Snapshot(*empty);
    const Status status = empty->Process(event);
    EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition) << status.ToString();
    EXPECT_THAT(status.message(), HasSubstr("at t=5: no node yet"));
    EXPECT_EQ(Snapshot(*empty), before);
  }
  auto mapper = Started();
  ASSERT_THAT(mapper->Process(KidnapEvent{.time = 12.0, .cause = KidnapEvent::Cause::kKidnap}), IsOk());
  const std::string before = Snapshot(*mapper);
  const Status status = mapper->Process(ViewCreatedEvent{.time = 12.0, .view = 3});
  EXPECT_THAT(status, StatusIs(StatusCode::kFailedPrecondition));
  EXPECT_THAT(status.message(), HasSubstr("KidnapEvent"));
  EXPECT_EQ(Snapshot(*mapper), before);
}

TEST(MapperErrorsTest, ParentMapWithALocalMapAtAMissingNodeIsRefused) {
  Map parent;
  parent.local_maps[42] = LocalMapEvent{};
  const auto mapper = Mapper::Create(MapperParams{}, std::move(parent));
  ASSERT_FALSE(mapper.ok());
  EXPECT_THAT(mapper.status().message(), HasSubstr("node 42"));
}

}  // namespace
}  // namespace slamcore
