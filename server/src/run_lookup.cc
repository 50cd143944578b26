#include "run_lookup.h"

#include <utility>

#include "analyzer/telemetry_codec.h"

namespace server {

storage::Result<storage::RunKey> ResolveRun(storage::Repository& repository, const Principal& caller,
                                            const std::string& robot_id, const std::string& run_id) {
  if (run_id.empty()) return storage::InvalidArgument("run_id: required");
  // Ids that no upload can have are refused by their syntax, not looked up (a 20 kB id came back in a
  // NOT_FOUND message too large for the reply's metadata).
  for (const auto& [value, field] : {std::pair{&run_id, "run_id"}, std::pair{&robot_id, "robot_id"}}) {
    if (value->empty()) continue;
    if (const slamcore::Status bad = analyzer::ValidateId(*value, field); !bad.ok()) {
      return storage::InvalidArgument(bad.message());
    }
  }
  if (caller.role == Role::kRobot) {
    if (!robot_id.empty() && robot_id != caller.id) return storage::NotFound("run " + run_id + ": not found");
    return storage::RunKey{caller.id, run_id};
  }
  if (!robot_id.empty()) return storage::RunKey{robot_id, run_id};
  ASSIGN_OR_RETURN(auto robots, repository.ListRunRobots(run_id, 2));
  if (robots.empty()) return storage::NotFound("run_id: no run \"" + run_id + "\"");
  if (robots.size() > 1) {
    return storage::InvalidArgument("run_id: robots " + robots[0] + ", " + robots[1] +
                                    " (and maybe more) each have a run \"" + run_id +
                                    "\"; name the robot (robot_id, or ?robot= over HTTP)");
  }
  return storage::RunKey{robots.front(), run_id};
}

}  // namespace server
