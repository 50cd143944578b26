// Which run a request names. A run is (robot, run id): each robot has its own run ids, so robot A can never
// take or reach robot B's run by its id. Requests name a run by its id and, optionally, its robot.
//
// Thread safety: free functions; the repository is thread-safe.
#pragma once

#include <string>

#include "server/auth.h"
#include "storage/repository.h"

namespace server {

/// A robot caller names only its own runs: another robot's run answers NOT_FOUND exactly like a missing
/// one (`robot_id`, when given, must be the caller's). Engineers and admins name the robot, or give the run
/// id alone when one robot has a run of that id (several: INVALID_ARGUMENT asking for the robot; none:
/// NOT_FOUND). The key is returned without reading the run itself.
storage::Result<storage::RunKey> ResolveRun(storage::Repository& repository, const Principal& caller,
                                            const std::string& robot_id, const std::string& run_id);

}  // namespace server
