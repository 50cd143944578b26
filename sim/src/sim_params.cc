#include "sim/sim_params.h"

#include <cmath>
#include <sstream>
#include <string>

namespace sim {

slamcore::Status SimParams::Validate() const {
  auto positive = [](double value, const char* name) -> slamcore::Status {
    if (!(value > 0.0) || !std::isfinite(value)) {
      return slamcore::InvalidArgument(std::string(name) + " must be positive, found " +
                                       std::to_string(value));
    }
    return slamcore::Status::Ok();
  };
  auto within = [](double value, double low, double high, const char* name) -> slamcore::Status {
    if (!(value >= low && value <= high)) {  // NaN fails too
      std::ostringstream message;
      message << name << " must be in [" << low << ", " << high << "], found " << value;
      return slamcore::InvalidArgument(message.str());
    }
    return slamcore::Status::Ok();
  };
  auto probability = [&](double value, const char* name) { return within(value, 0.0, 1.0, name); };
  RETURN_IF_ERROR(positive(run_minutes, "run_minutes"));
  RETURN_IF_ERROR(positive(step_seconds, "step_seconds"));
  RETURN_IF_ERROR(positive(robot_radius, "robot_radius"));
  RETURN_IF_ERROR(positive(speed, "speed"));
  RETURN_IF_ERROR(positive(turn_rate, "turn_rate"));
  RETURN_IF_ERROR(positive(keyframe_distance, "keyframe_distance"));
  RETURN_IF_ERROR(positive(keyframe_rotation, "keyframe_rotation"));
  RETURN_IF_ERROR(positive(view_range, "view_range"));
  RETURN_IF_ERROR(positive(view_field_of_view, "view_field_of_view"));
  RETURN_IF_ERROR(positive(observation_sigma_xy, "observation_sigma_xy"));
  RETURN_IF_ERROR(positive(observation_sigma_theta, "observation_sigma_theta"));
  RETURN_IF_ERROR(positive(tof_min_range, "tof_min_range"));
  RETURN_IF_ERROR(positive(lidar_min_range, "lidar_min_range"));
  RETURN_IF_ERROR(positive(tof_field_of_view, "tof_field_of_view"));
  RETURN_IF_ERROR(positive(stuck_min_seconds, "stuck_min_seconds"));
  if (tof_max_range < tof_min_range || lidar_max_range < lidar_min_range || lidar_max_range > 20.0) {
    return slamcore::InvalidArgument(
        "sensor ranges: each model's max must be at least its min, and a lidar at most 20 m");
  }
  if (tof_field_of_view > 2 * 3.14159265358979)
    return slamcore::InvalidArgument("tof_field_of_view must be at most 2π");
  RETURN_IF_ERROR(probability(lidar_share, "lidar_share"));
  RETURN_IF_ERROR(probability(wall_wedge_probability, "wall_wedge_probability"));
  RETURN_IF_ERROR(probability(stuck_creep_share, "stuck_creep_share"));
  RETURN_IF_ERROR(probability(wall_follow_share, "wall_follow_share"));
  RETURN_IF_ERROR(probability(start_off_dock_probability, "start_off_dock_probability"));
  RETURN_IF_ERROR(probability(kidnap_probability, "kidnap_probability"));
  RETURN_IF_ERROR(probability(reboot_probability, "reboot_probability"));
  RETURN_IF_ERROR(probability(recognition_probability, "recognition_probability"));
  RETURN_IF_ERROR(probability(recognition_failure_probability, "recognition_failure_probability"));
  RETURN_IF_ERROR(probability(lookalike_probability, "lookalike_probability"));
  RETURN_IF_ERROR(within(lidar_free_range, 0.0, 20.0, "lidar_free_range"));
  RETURN_IF_ERROR(within(lookalike_pass_gap_seconds, 0.0, 600.0, "lookalike_pass_gap_seconds"));
  RETURN_IF_ERROR(within(stuck_rate_scale, 0.0, 1000.0, "stuck_rate_scale"));
  if (!(stuck_mean_extra_seconds >= 0.0 && stuck_max_seconds >= stuck_min_seconds &&
        stuck_max_seconds <= 3600.0)) {
    return slamcore::InvalidArgument("stuck durations: mean extra ≥ 0 and min ≤ max ≤ 3600 s expected");
  }
  if (!(stuck_heading_drift_per_metre >= 0.0)) {
    return slamcore::InvalidArgument("stuck_heading_drift_per_metre must not be negative");
  }
  if (odometry_scale_error < 0.0 || odometry_noise_per_metre < 0.0 ||
      odometry_heading_noise_per_metre < 0.0 || odometry_heading_noise_per_radian < 0.0) {
    return slamcore::InvalidArgument("odometry noise parameters must not be negative");
  }
  if (patch_every_nodes < 1 || lidar_patch_every_nodes < 1) {
    return slamcore::InvalidArgument("patch_every_nodes and lidar_patch_every_nodes must be at least 1");
  }
  return mapper.Validate();
}

slamcore::MapperParams UnprotectedMapperParams() {
  slamcore::MapperParams params;
  params.conditional_merge = false;
  params.merge_conditional = {.min_observations = 1, .min_views = 1};
  params.merge_full = {.min_observations = 1, .min_views = 1};
  params.recovery = {.min_observations = 1, .min_views = 1};
  params.consistency.enabled = false;
  params.correct_slip_from_views = false;
  return params;
}

}  // namespace sim
