// What a simulated robot (and the lifelong experiment's simulated engineer) asks fleetd besides uploads:
// the newest approved map (Maps.StreamMap: GetMap's answer in parts), an analysis job's end, a review of a
// pending version, a token.
// A failed call is the project's status of gRPC's code (fleet/status_codes.h: UNAVAILABLE is kUnavailable, …),
// its message naming the call and gRPC's status ("Maps.StreamMap: UNAVAILABLE: …").
//
// Thread safety: one ServiceClient may be used from several threads (the gRPC stubs are thread-safe).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "fleet/v1/maps.pb.h"
#include "fleet/v1/telemetry.pb.h"
#include "slamcore/status.h"

namespace sim {

struct FetchedMap {
  bool up_to_date = true;           // the robot holds the current version already (or none is approved)
  fleet::v1::MapVersion version;    // the current approved version (empty when none)
  fleet::v1::MapSnapshot snapshot;  // unless up to date
};

class ServiceClient {
 public:
  /// `tls_ca`: a PEM file to trust (TLS), empty for plaintext.
  ServiceClient(const std::string& server, const std::string& tls_ca = "");
  ~ServiceClient();

  /// Maps.StreamMap as `robot_id` holding `held_version` (a map of at most fleet_client::kDefaultMaxMapBytes);
  /// no approved map yet is "up to date" (nothing to take).
  slamcore::Result<FetchedMap> FetchMap(const std::string& token, const std::string& robot_id,
                                        std::int64_t held_version);
  /// Polls Reprocessing.GetJob until the job is done; FAILED_PRECONDITION when it failed or was cancelled,
  /// INTERNAL after `timeout_seconds`.
  slamcore::Status WaitForJob(const std::string& token, std::int64_t job_id, double timeout_seconds = 600.0);
  /// An engineer's review that trusts every proposal: each pending version, oldest first, is approved (the
  /// server carries a repair that a later upload overtook onto the current version); one the server cannot
  /// carry forward (FAILED_PRECONDITION) is rejected instead. Returns the version the last approval made
  /// current, 0 when nothing was approved.
  slamcore::Result<std::int64_t> ApprovePending(const std::string& token, const std::string& robot_id);
  /// Admin.SetCredential: a new token for `principal`.
  slamcore::Result<std::string> MintToken(const std::string& admin_token, const std::string& principal);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sim
