// Test support: a real fleetd process on loopback (temp SQLite file), its addresses from stdout's first
// line, a tiny HTTP GET, and the simulated runs the tests upload.
#pragma once

#include <grpcpp/grpcpp.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fleet/v1/service.grpc.pb.h"

namespace fleetd_test {

class FleetdProcess {
 public:
  /// Starts fleetd with `--db sqlite:DIR/fleet.db --listen 127.0.0.1:0 --http 127.0.0.1:0` plus `extra`;
  /// the bootstrap admin token comes through the environment. `in_child` runs in the child just before exec
  /// (e.g. to change the environment or enter a mount namespace).
  explicit FleetdProcess(std::vector<std::string> extra = {}, std::function<void()> in_child = {});
  ~FleetdProcess();
  bool ok() const { return pid_ > 0 && !grpc_.empty(); }
  int pid() const { return pid_; }
  const std::string& grpc_address() const { return grpc_; }
  const std::string& http_address() const { return http_; }
  const std::filesystem::path& directory() const { return directory_; }
  /// SIGTERM and wait; returns the exit status (or -1).
  int Stop();
  std::shared_ptr<grpc::Channel> Channel() const;

  static const std::string& AdminToken();

 private:
  std::filesystem::path directory_;
  int pid_ = -1;
  std::string grpc_, http_;
};

/// GET http://address/path (Host: address, with `token` as a bearer token when given); returns the status
/// code and fills body.
int HttpGet(const std::string& address, const std::string& path, std::string* body,
            const std::string& token = "");

/// Sends `request` as is to `address` (IPv4 host:port) and returns the whole response ("" when it failed).
std::string HttpRaw(const std::string& address, const std::string& request);

/// A new token for `principal` ("engineer:alice", "robot:r1"), minted with the bootstrap admin token.
std::string IssueToken(fleet::v1::Admin::Stub& admin, const std::string& principal);
/// The token of "robot:<robot_id>", minted on first use and reused for the process (one fleetd per test binary).
std::string RobotToken(fleet::v1::Admin::Stub& admin, const std::string& robot_id);
/// How many runs Queries.ListRuns shows `token` (one page of up to 1000).
int CountRuns(fleet::v1::Queries::Stub& queries, const std::string& token);

/// Small simulated runs (robots × runs of `minutes`), generated once per process and cached.
const std::vector<fleet::v1::RunFile>& SimulatedRuns();

struct UploadOptions {
  int events_per_chunk = 400;
  bool send_parent = true;         // send the parent snapshot in the stream
  std::string parent_id;           // header.parent_snapshot_id to send
  int cancel_after_messages = -1;  // cut the stream after this many messages
  bool send_child = true;
};

grpc::Status Upload(fleet::v1::Ingest::Stub& stub, const std::string& token, const fleet::v1::RunFile& run,
                    fleet::v1::UploadRunResponse* response, const UploadOptions& options = {});

/// grpc.health.v1.Health/Check (empty service name) on `channel`: 1 SERVING, 2 NOT_SERVING, -1 when the call
/// failed.
int HealthStatus(const std::shared_ptr<grpc::Channel>& channel);

/// A client context with the bearer token and a deadline.
std::unique_ptr<grpc::ClientContext> Context(const std::string& token, int deadline_seconds = 30);

}  // namespace fleetd_test
