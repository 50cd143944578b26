// Parameters of the simulated robots, their sensors and their mishaps, with defaults chosen so a fleet's
// statistics land near the paper's figures (see docs/fleetsim.md for the calibration and how close).
//
// Thread safety: value type.
#pragma once

#include "sim/world.h"
#include "slamcore/mapper_params.h"
#include "slamcore/status.h"

namespace sim {

struct SimParams {
  // Run
  double run_minutes = 20.0;  // simulated cleaning time per run
  double step_seconds = 0.1;  // physics step
  // Robot
  double robot_radius = 0.17;      // metres
  double speed = 0.25;             // m/s forward
  double turn_rate = 1.2;          // rad/s in place
  double wall_follow_share = 0.3;  // share of the time spent following walls
  // Odometry (differential drive; per-robot systematic error plus random noise per metre / radian)
  double odometry_scale_error = 0.01;               // σ of the per-robot wheel-radius error
  double odometry_noise_per_metre = 0.02;           // σ of the distance error, per √m
  double odometry_heading_noise_per_metre = 0.02;   // σ of the heading error from driving, rad per √m
  double odometry_heading_noise_per_radian = 0.03;  // σ of the heading error from turning, rad per √rad
  double keyframe_distance = 0.3;                   // a node every 0.3 m of travel ...
  double keyframe_rotation = 0.5;                   // ... or 0.5 rad of turning
  // Stuck robots (docs/fleetsim.md "Stuck robots"): an episode starts only at a contact, with a
  // probability per contact event; while stuck the wheels keep turning in the pushing direction (odometry
  // runs on, its heading drifting), the robot stays put (or creeps), and the robot's stasis detection and
  // escape (back off and turn) end the episode after min + an exponential time, at most max seconds.
  // Rugs and low furniture carry their own probability (FloorFeature::catch_probability, by HomeClutter).
  double wall_wedge_probability = 1.0 / 4000;  // per bump into a wall or fixture: wedged, pushing on
  double stuck_rate_scale = 1.0;               // multiplies every per-contact probability (0: never stuck)
  double stuck_min_seconds = 3.0, stuck_mean_extra_seconds = 7.0, stuck_max_seconds = 45.0;
  double stuck_heading_drift_per_metre =
      0.15;                         // σ of the claimed turn rate while stuck (one wheel grips less)
  double stuck_creep_share = 0.02;  // the robot truly moves this share of the claimed distance, where free
  HomeClutter home_clutter = HomeClutter::kTypical;
  // Where a run starts: on the dock, or wherever a person put the robot down and pressed start
  double start_off_dock_probability = 0.7;
  // Kidnaps (carried to another room) and reboots, per run
  double kidnap_probability = 0.25;
  double reboot_probability = 0.08;
  // Camera front-end
  double view_range = 3.0;                        // metres
  double view_field_of_view = 2.0;                // radians, centred ahead
  double recognition_probability = 0.2;           // per node and visible view
  double recognition_failure_probability = 0.02;  // a recognised view gets a grossly wrong pose
  double lookalike_probability = 0.15;            // a look-alike view is matched instead, when one exists
  // Look-alike choices by pass: recognitions of one landmark less than this apart see it from nearly the
  // same viewpoint, so the choice drawn at a pass's first recognition holds until the next gap — one pass
  // past a second identical basin is a run of wrong observations that agree with each other. 0 (the
  // default, which the fleet figures are calibrated with): drawn for every recognition, independently.
  double lookalike_pass_gap_seconds = 0.0;
  double observation_sigma_xy = 0.04;     // metres
  double observation_sigma_theta = 0.03;  // radians
  // Local occupancy patches from the robot's ranging sensor, by robot model: a front time-of-flight sensor
  // (short range, a cone ahead) or a spinning lidar (long range, all around); each robot draws its model
  // (lidar with probability lidar_share) and its range (uniform in the model's interval).
  double lidar_share = 0.5;
  double tof_min_range = 1.0, tof_max_range = 1.5;  // metres
  double tof_field_of_view = 1.92;                  // radians (110°), centred ahead
  double lidar_min_range = 4.0, lidar_max_range = 6.0;
  double lidar_free_range = 0.0;    // metres along a ray that a lidar's patch marks free (0: its whole range)
  int patch_every_nodes = 2;        // a ToF patch every 2 nodes (0.6 m) ...
  int lidar_patch_every_nodes = 6;  // ... a lidar patch every 6 (1.8 m: its 4–6 m overlap anyway)
  // Ground truth of the protrusion detector's regions, per run (RunOutcome)
  bool label_regions = true;
  bool keep_truth_pairs = false;  // also keep the parent/child pair with per-cell truth
  // The robot's own back-end
  slamcore::MapperParams mapper;

  slamcore::Status Validate() const;
};

/// Robot firmware without the paper's protection: a merge or loop closure on the first observation, no
/// conditional stage, no checks against the map's own uncertainty, no slip correction (the lifelong experiment's
/// regime "none").
slamcore::MapperParams UnprotectedMapperParams();

}  // namespace sim
