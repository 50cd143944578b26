// Starts and stops a fleetd process of its own for an experiment: a fresh SQLite file in `directory`,
// loopback on free ports, a random bootstrap admin token through the environment (never on the command
// line), its log beside the database. Stop (or destruction) sends SIGTERM and waits.
//
// Thread safety: use from one thread.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "slamcore/status.h"

namespace sim {

class FleetdLauncher {
 public:
  FleetdLauncher() = default;
  FleetdLauncher(const FleetdLauncher&) = delete;
  FleetdLauncher& operator=(const FleetdLauncher&) = delete;
  ~FleetdLauncher();

  /// Starts `binary --db sqlite:DIR/fleet.db --listen 127.0.0.1:0 --http 127.0.0.1:0 EXTRA…` and reads the
  /// addresses it prints first. FAILED_PRECONDITION naming the binary or the log when it does not start.
  slamcore::Status Start(const std::filesystem::path& binary, const std::filesystem::path& directory,
                         const std::vector<std::string>& extra);
  /// SIGTERM, then wait for it; true when it exited cleanly.
  bool Stop();

  const std::string& grpc_address() const { return grpc_; }
  const std::string& admin_token() const { return admin_token_; }

 private:
  int pid_ = -1;
  std::string grpc_, admin_token_;
};

/// fleetd beside the running executable (the build puts fleetsim and fleetd in one bin/ directory).
std::filesystem::path FleetdBesideThisProgram();

}  // namespace sim
