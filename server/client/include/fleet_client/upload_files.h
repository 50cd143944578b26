// Uploading .runpb files (fleet.v1.RunFile) to fleetd: files or directories (searched recursively), one
// robot's runs in order (so a run's parent map is on the server before the run that builds on it: the
// uploader then names it by id instead of sending it), different robots in parallel. Used by
// `fleetsim --upload` and `fleetctl upload`.
//
// Thread safety: UploadFiles runs its own threads; call it from one thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fleet_client/uploader.h"

namespace fleet_client {

struct UploadFilesOptions {
  UploaderOptions uploader;
  int threads = 4;
  /// Called after each run (from upload threads, serialised): done, total, the outcome.
  std::function<void(int, int, const UploadOutcome&)> progress;
};

struct UploadSummary {
  int runs = 0, uploaded = 0, already_present = 0, failed = 0, retried = 0;
  std::uint64_t events = 0;
  std::uint64_t bytes = 0;  // file sizes
  double seconds = 0.0;
  std::vector<double> latencies;  // seconds per run, sorted
  std::string first_error;
  double Percentile(double p) const;
  std::string Summary() const;  // one line for people
  std::string ToJson() const;   // one line
};

UploadSummary UploadFiles(const std::vector<std::filesystem::path>& paths, const UploadFilesOptions& options);

}  // namespace fleet_client
