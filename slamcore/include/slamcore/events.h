// The events of one robot run, in the order the robot produced them. Each is what the robot's front-end
// and odometry reported; the Mapper (mapper.h) turns them into a map. Times are seconds on the robot's
// clock and never decrease within a run.
//
// Thread safety: value types.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore {

/// Wheel odometry since the previous node; creates a new node at the composed pose.
struct OdometryEvent {
  double time = 0.0;
  SE2 increment;                                    // previous_T_new
  Matrix3 covariance = Matrix3::Identity() * 1e-4;  // of the increment, left-perturbation tangent (see se2.h)
};

/// The front-end created view `view` at the current node.
struct ViewCreatedEvent {
  double time = 0.0;
  ViewId view = 0;
};

/// The front-end recognised view `view` from the current node: z = robot_T_view.
struct ViewObservedEvent {
  double time = 0.0;
  ViewId view = 0;
  SE2 robot_T_view;
  Matrix3 covariance = Matrix3::Identity() * 1e-2;
};

/// A local occupancy patch attached to the current node. Cells: -1 unknown, 0 free, 100 occupied (as in
/// ROS OccupancyGrid), row-major from the patch origin.
struct LocalMapEvent {
  double time = 0.0;
  double resolution = 0.05;  // metres per cell
  int width = 0;
  int height = 0;
  SE2 node_T_origin;  // the patch's cell (0, 0) corner in the node's frame
  std::vector<std::int8_t> cells;
};

/// The robot lost its position: carried elsewhere, or rebooted. The next node starts a new component.
struct KidnapEvent {
  enum class Cause : std::uint8_t { kKidnap, kReboot };
  double time = 0.0;
  Cause cause = Cause::kKidnap;
};

/// Ground truth from a simulator or a survey, kept aside for evaluation and never used to decide.
struct GroundTruthEvent {
  double time = 0.0;
  SE2 world_T_robot;
};

using Event = std::variant<OdometryEvent, ViewCreatedEvent, ViewObservedEvent, LocalMapEvent, KidnapEvent,
                           GroundTruthEvent>;

}  // namespace slamcore
