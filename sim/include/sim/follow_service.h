// Robots that follow the service: before each run a robot asks Maps.GetMap for the newest approved version
// of its map and, when there is a newer one than it holds, replaces its on-board map with it (as a real robot
// does); after the run it uploads the run, naming the version it ran on (RunHeader.map_version), and holds
// the version its upload became. Optionally it waits for the run's analysis (and the repair policy) before
// its next run, and a simulated engineer approves pending versions every few runs.
//
// Thread safety: the hooks are called from the fleet's robot threads at once; they share an uploader and a
// client per robot behind a mutex.
#pragma once

#include <functional>
#include <string>

#include "fleet_client/uploader.h"
#include "sim/fleet.h"

namespace sim {

struct FollowServiceOptions {
  fleet_client::UploaderOptions uploader;  // server, TLS, and the token used when robot_token is not set
  /// The token robot `robot_id` uploads and fetches with (its own "robot:<id>" credential).
  std::function<std::string(const std::string& robot_id)> robot_token;
  /// Set: wait for each run's analysis job with this (engineer) token, then take a repaired map at once.
  std::string engineer_token;
  /// > 0: before every run whose index is a multiple of this, the engineer approves the robot's pending
  /// version (a review delayed to that day); needs engineer_token.
  int review_every_runs = 0;
  double analysis_timeout_seconds = 600.0;
};

/// Sets `fleet.before_run` and `fleet.after_run` so every robot of the fleet follows the service.
void FollowService(const FollowServiceOptions& options, FleetOptions& fleet);

}  // namespace sim
