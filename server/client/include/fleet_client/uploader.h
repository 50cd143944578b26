// Uploads runs to fleetd like a robot: one client stream per run (header, event chunks, parent snapshot
// unless the server already holds it, child snapshot; each snapshot in parts of at most
// `snapshot_part_bytes`, as a lifelong map outgrows one gRPC message), retried with exponential backoff on
// UNAVAILABLE (e.g. the database is full or read-only), DEADLINE_EXCEEDED, RESOURCE_EXHAUSTED (rate and in-flight
// limits) and ABORTED — safe because ingest is idempotent by run id. Never retried: what can never succeed,
// INVALID_ARGUMENT (also a run over --max-run-bytes or --max-events-per-run), PERMISSION_DENIED, … and
// gRPC's own RESOURCE_EXHAUSTED for one message over the server's size limit. gRPC stays in uploader.cc.
//
// Thread safety: an Uploader may be used from several threads at once (the gRPC stub is thread-safe; the
// set of snapshot ids the server holds has its own mutex).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "fleet/v1/telemetry.pb.h"

namespace fleet_client {

struct UploaderOptions {
  std::string server;  // host:port
  std::string token;   // "<principal>.<secret>"
  std::string tls_ca;  // PEM file: use TLS, trusting this CA; empty: plaintext
  int max_attempts = 6;
  std::chrono::milliseconds initial_backoff{200};
  int events_per_chunk = 1000;
  std::size_t snapshot_part_bytes = 4 << 20;  // below fleetd's default max_message_bytes (16 MiB)
  double deadline_seconds = 120.0;            // per attempt
};

struct UploadOutcome {
  bool ok = false;
  int code = 0;         // grpc::StatusCode of the last attempt
  std::string message;  // "UNAVAILABLE: ..." when !ok
  std::string run_id;
  bool already_present = false;
  std::string child_snapshot_id;
  std::uint64_t events = 0;
  int attempts = 0;
  double seconds = 0.0;              // wall time including retries
  std::int64_t analysis_job_id = 0;  // the server's answer (service.proto UploadRunResponse)
  std::int64_t map_version = 0, current_map_version = 0;
  bool map_outdated = false;
};

class Uploader {
 public:
  explicit Uploader(const UploaderOptions& options);
  ~Uploader();
  UploadOutcome Upload(const fleet::v1::RunFile& run);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// The token in `path` (one line; surrounding whitespace dropped), or nullopt with `error` naming what is
/// wrong (unreadable, empty, several lines). Keeps tokens off command lines.
std::optional<std::string> ReadTokenFile(const std::string& path, std::string* error);

/// True when a failed attempt with this status may succeed if sent again unchanged.
bool RetryableUpload(int code, const std::string& message);

/// Hex SHA-256 of the deterministic serialization: the id fleetd gives a snapshot.
std::string SnapshotId(const fleet::v1::MapSnapshot& snapshot);

}  // namespace fleet_client
