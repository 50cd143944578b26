// Analysis of stored runs (docs/architecture.md "Data flow of one run", step 2) on top of analyzer::AnalyzeRun:
// load the run and its snapshots from storage, replay with a stored parameter set, store the report.
//
// Thread safety: AnalyzeStoredRun and ToReportBundle are free of shared state; ClassifierCache is safe
// from many threads (one mutex).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "analyzer/run_analysis.h"
#include "fleet/v1/report.pb.h"
#include "slamcore/protrusion_classifier.h"
#include "storage/repository.h"

namespace server {

/// The rows storage keeps for a report (counters, decisions, ambiguous views, regions) plus the report.
storage::ReportBundle ToReportBundle(const fleet::v1::RunReport& report);

/// A classifier model from storage (bytes = the model file).
storage::Result<std::unique_ptr<slamcore::ProtrusionClassifier>> LoadClassifier(const std::string& bytes);

/// slamcore's built-in default model (docs/protrusion-data.md), which classes regions whenever no model
/// is active; null only if the build's model is corrupt (logged).
std::shared_ptr<const slamcore::ProtrusionClassifier> DefaultClassifier();

/// The active version of one model, reloaded when the active version changes (checked every few seconds).
class ClassifierCache {
 public:
  ClassifierCache(storage::Repository& repository, std::string model_name);
  /// The active classifier; the built-in default when none is active or the active one does not load.
  std::shared_ptr<const slamcore::ProtrusionClassifier> Get();

 private:
  storage::Repository& repository_;
  const std::string model_name_;
  std::mutex mutex_;  // guards the members below
  std::int64_t version_ = 0;
  std::shared_ptr<const slamcore::ProtrusionClassifier> classifier_;
  std::chrono::steady_clock::time_point checked_{};
};

struct AnalysisResult {
  double seconds = 0.0;
  std::int64_t regions = 0;
  fleet::v1::RunReport report;    // as stored
  analyzer::RunMaps maps;         // the run's parent map and uploaded map, decoded once for the replay
  std::string child_snapshot_id;  // where the uploaded map is stored ("" when the run has none)
};

/// NOT_FOUND when the run or parameter set is missing, FAILED_PRECONDITION when retention pruned its events,
/// INVALID_ARGUMENT when the telemetry is refused by
/// the replay, DATA_LOSS when stored bytes do not parse.
/// What one analysis may take: at most `max_seconds` of replay and rendering (<= 0: no limit), and it stops
/// when `cancelled()` says so. Either ends it with FAILED_PRECONDITION ("analysis budget: ...").
struct AnalysisBudget {
  double max_seconds = 0.0;
  std::function<bool()> cancelled;
};

storage::Result<AnalysisResult> AnalyzeStoredRun(storage::Repository& repository, const storage::RunKey& run,
                                                 const std::string& parameter_set,
                                                 const slamcore::ProtrusionClassifier* classifier,
                                                 const AnalysisBudget& budget = {});

}  // namespace server
