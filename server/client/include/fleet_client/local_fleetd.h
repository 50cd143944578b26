// A fleetd process on this machine, a child of this one, for an experiment, a benchmark or a test: loopback on
// free ports (the addresses it prints on stdout's first line), its SQLite file and its log (stderr) in a
// directory, the bootstrap admin token through the environment (never on the command line). Stop (or
// destruction) sends SIGTERM and waits for it.
//
// Thread safety: use one LocalFleetd from one thread. Start forks; the child runs only `in_child` and exec.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "slamcore/status.h"

namespace fleet_client {

struct LocalFleetdOptions {
  std::filesystem::path binary;     // the fleetd executable
  std::filesystem::path directory;  // created when missing; holds fleet.db and fleetd.log
  /// After the defaults `--db sqlite:DIRECTORY/fleet.db --listen 127.0.0.1:0 --http 127.0.0.1:0`; a flag named
  /// here replaces the default of that name (`--http ""`: no HTTP listener).
  std::vector<std::string> flags;
  std::string admin_token;         // FLEETD_BOOTSTRAP_ADMIN_TOKEN in the child's environment; empty: not set
  std::function<void()> in_child;  // runs in the child just before exec (e.g. to enter a mount namespace)
};

class LocalFleetd {
 public:
  LocalFleetd() = default;
  LocalFleetd(const LocalFleetd&) = delete;
  LocalFleetd& operator=(const LocalFleetd&) = delete;
  ~LocalFleetd();

  /// Starts fleetd and reads the addresses it prints first. FAILED_PRECONDITION naming the binary, or the log
  /// and what fleetd printed, when it does not start (the child is then stopped).
  slamcore::Status Start(const LocalFleetdOptions& options);
  /// SIGTERM, then wait for it: its exit status, -1 when it was not running or ended by a signal.
  int Stop();

  bool running() const { return pid_ > 0; }
  int pid() const { return pid_; }
  const std::string& grpc_address() const { return grpc_; }
  const std::string& http_address() const { return http_; }  // empty without an HTTP listener
  const std::filesystem::path& log_path() const { return log_path_; }

 private:
  int pid_ = -1;
  std::string grpc_, http_;
  std::filesystem::path log_path_;
};

/// fleetd beside the running executable (the build puts every program in one bin/ directory).
std::filesystem::path FleetdBesideThisProgram();

/// "<principal>.<64 hex digits from /dev/urandom>": a fresh token for a fleetd of one's own.
std::string RandomToken(const std::string& principal);

}  // namespace fleet_client
