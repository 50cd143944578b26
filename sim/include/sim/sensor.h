// The robot's ranging sensor and the local occupancy patches it produces. A patch is what the sensor sees
// from the robot's TRUE pose, expressed in the robot's frame: attached to a node, it is drawn wherever the
// node's estimated pose puts it, so a stuck robot's nodes, marching on with the wheels, repeat the true
// surroundings at false places (paper IV-C).
//
// Thread safety: free functions on values.
#pragma once

#include <random>
#include <string>

#include "sim/sim_params.h"
#include "sim/world.h"
#include "slamcore/events.h"

namespace sim {

inline constexpr const char* kTofModel = "fleetsim-tof";      // a front time-of-flight sensor
inline constexpr const char* kLidarModel = "fleetsim-lidar";  // a spinning lidar

struct RangeSensor {
  std::string model;   // the robot model reported in the run header: "fleetsim-tof" or "fleetsim-lidar"
  double range = 1.5;  // metres
  double field_of_view = 1.92;  // radians, centred ahead
  int rays = 40;                // evenly spread over the field of view (a lidar: one per degree)
  double resolution = 0.05;     // of its patches, m per cell: a lidar's are 0.10 m (its long rays would
                                // otherwise make a lifelong map too large to upload in one message)
  /// How far along a ray free space is marked (hits are marked at any range): a mapping front-end's usable
  /// range (GMapping's maxUrange). Far free space drawn at a node whose heading is a few degrees off lands
  /// beyond the walls; SimParams::lidar_free_range sets it for lidars. 0: the whole range.
  double free_range = 0.0;
};

/// The sensor of a new robot: its model by SimParams::lidar_share, its range uniform in the model's interval.
RangeSensor DrawSensor(const SimParams& params, std::mt19937_64& random);

/// The patch the sensor sees from `world_T_robot`: free along each ray up to its first hit (occupied) or its
/// free range, the robot's footprint free, cropped to the cells it knows; cell (0, 0) lies at node_T_origin in
/// the robot's frame, at the sensor's resolution.
slamcore::LocalMapEvent ScanAt(const Grid& grid, const SE2& world_T_robot, const RangeSensor& sensor,
                               double robot_radius, double time);

}  // namespace sim
