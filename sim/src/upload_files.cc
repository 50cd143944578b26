#include "sim/upload_files.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

namespace sim {

double UploadSummary::Percentile(double p) const {
  if (latencies.empty()) return 0.0;
  const auto index = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(latencies.size() - 1), p / 100.0 * static_cast<double>(latencies.size())));
  return latencies[index];
}

std::string UploadSummary::Summary() const {
  char line[512];
  std::snprintf(line, sizeof line,
                "%d runs: %d uploaded, %d already present, %d failed, %d retried; %llu events in %.2f s "
                "(%.1f runs/s, %.0f events/s); latency p50 %.1f ms, p99 %.1f ms%s%s",
                runs, uploaded, already_present, failed, retried, static_cast<unsigned long long>(events),
                seconds, seconds > 0 ? runs / seconds : 0.0,
                seconds > 0 ? static_cast<double>(events) / seconds : 0.0, 1000 * Percentile(50),
                1000 * Percentile(99), first_error.empty() ? "" : "; first error: ", first_error.c_str());
  return line;
}

std::string UploadSummary::ToJson() const {
  char line[512];
  std::snprintf(
      line, sizeof line,
      "{\"runs\":%d,\"uploaded\":%d,\"already_present\":%d,\"failed\":%d,\"retried\":%d,\"events\":%llu,"
      "\"bytes\":%llu,\"seconds\":%.3f,\"p50_ms\":%.2f,\"p99_ms\":%.2f}",
      runs, uploaded, already_present, failed, retried, static_cast<unsigned long long>(events),
      static_cast<unsigned long long>(bytes), seconds, 1000 * Percentile(50), 1000 * Percentile(99));
  return line;
}

UploadSummary UploadFiles(const std::vector<std::filesystem::path>& paths,
                          const UploadFilesOptions& options) {
  UploadSummary summary;
  // Group by directory: fleetsim writes OUT/<robot>/<run_id>.runpb and run ids sort in run order.
  std::map<std::filesystem::path, std::vector<std::filesystem::path>> groups;
  for (const auto& path : paths) {
    std::error_code error;
    if (std::filesystem::is_directory(path, error)) {
      for (const auto& entry : std::filesystem::recursive_directory_iterator(path, error)) {
        if (entry.is_regular_file() && entry.path().extension() == ".runpb") {
          groups[entry.path().parent_path()].push_back(entry.path());
        }
      }
    } else {
      groups[path.parent_path()].push_back(path);
    }
  }
  std::vector<std::vector<std::filesystem::path>> work;
  for (auto& [directory, files] : groups) {
    std::sort(files.begin(), files.end());
    summary.runs += static_cast<int>(files.size());
    work.push_back(std::move(files));
  }
  Uploader uploader(options.uploader);
  std::mutex mutex;  // guards summary and progress
  std::atomic<std::size_t> next{0};
  int done = 0;
  const auto started = std::chrono::steady_clock::now();
  auto worker = [&] {
    for (std::size_t group = next++; group < work.size(); group = next++) {
      for (const auto& file : work[group]) {
        fleet::v1::RunFile run;
        std::ifstream in(file, std::ios::binary);
        UploadOutcome outcome;
        std::uint64_t size = 0;
        if (!in || !run.ParseFromIstream(&in)) {
          outcome.message = file.string() + ": not a fleet.v1.RunFile";
        } else {
          std::error_code error;
          size = std::filesystem::file_size(file, error);
          outcome = uploader.Upload(run);
          if (!outcome.ok) outcome.message = file.string() + ": " + outcome.message;
        }
        std::lock_guard lock(mutex);
        ++done;
        summary.bytes += size;
        if (outcome.ok) {
          (outcome.already_present ? summary.already_present : summary.uploaded)++;
          summary.events += outcome.events;
          summary.latencies.push_back(outcome.seconds);
        } else {
          ++summary.failed;
          if (summary.first_error.empty()) summary.first_error = outcome.message;
        }
        if (outcome.attempts > 1) ++summary.retried;
        if (options.progress) options.progress(done, summary.runs, outcome);
      }
    }
  };
  std::vector<std::thread> threads;
  const int count = std::max(1, std::min<int>(options.threads, static_cast<int>(work.size())));
  for (int i = 0; i < count; ++i) threads.emplace_back(worker);
  for (auto& thread : threads) thread.join();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::sort(summary.latencies.begin(), summary.latencies.end());
  return summary;
}

}  // namespace sim
