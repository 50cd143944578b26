// Parameters of the simulated robots, their sensors and their mishaps, with defaults chosen so a fleet's
// statistics land near the paper's figures (see docs/fleetsim.md for the calibration and how close).
//
// Thread safety: value type.
#pragma once

#include "slamcore/mapper_params.h"
#include "slamcore/status.h"

namespace sim {

struct SimParams {
  // Run
  double run_minutes = 20.0;          // simulated cleaning time per run
  double step_seconds = 0.1;          // physics step
  // Robot
  double robot_radius = 0.17;         // metres
  double speed = 0.25;                // m/s forward
  double turn_rate = 1.2;             // rad/s in place
  double wall_follow_share = 0.3;     // share of the time spent following walls
  // Odometry (differential drive; per-robot systematic error plus random noise per metre / radian)
  double odometry_scale_error = 0.01;     // σ of the per-robot wheel-radius error
  double odometry_noise_per_metre = 0.02; // σ of the distance error, per √m
  double odometry_heading_noise_per_metre = 0.02;  // σ of the heading error from driving, rad per √m
  double odometry_heading_noise_per_radian = 0.03; // σ of the heading error from turning, rad per √rad
  double keyframe_distance = 0.3;     // a node every 0.3 m of travel ...
  double keyframe_rotation = 0.5;     // ... or 0.5 rad of turning
  // Slip and stasis: stuck on a rug edge or under furniture, wheels turning
  double slip_episodes_per_hour = 1.5;
  double slip_min_seconds = 4.0, slip_max_seconds = 20.0;
  // Where a run starts: on the dock, or wherever a person put the robot down and pressed start
  double start_off_dock_probability = 0.7;
  // Kidnaps (carried to another room) and reboots, per run
  double kidnap_probability = 0.25;
  double reboot_probability = 0.08;
  // Camera front-end
  double view_range = 3.0;            // metres
  double view_field_of_view = 2.0;    // radians, centred ahead
  double recognition_probability = 0.2;  // per node and visible view
  double recognition_failure_probability = 0.02;  // a recognised view gets a grossly wrong pose
  double lookalike_probability = 0.15; // a look-alike view is matched instead, when one exists
  double observation_sigma_xy = 0.04; // metres
  double observation_sigma_theta = 0.03;  // radians
  // Local occupancy patches from a short-range sensor
  double patch_range = 1.5;           // metres
  int patch_every_nodes = 2;
  // The robot's own back-end
  slamcore::MapperParams mapper;

  slamcore::Status Validate() const;
};

}  // namespace sim
