#include "server/analysis.h"

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analyzer/parameters.h"
#include "analyzer/run_analysis.h"
#include "fleet/v1/telemetry.pb.h"

namespace server {

storage::ReportBundle ToReportBundle(const fleet::v1::RunReport& report) {
  storage::ReportBundle bundle;
  storage::ReportRecord& record = bundle.report;
  record.robot_id = report.robot_id();
  record.run_id = report.run_id();
  record.parameter_set = report.parameter_set();
  record.recovery_created = report.counts().recovery_created();
  record.recovery_accepted = report.counts().recovery_accepted();
  record.recovery_retracted = report.counts().recovery_retracted();
  record.merge_created = report.counts().merge_created();
  record.merge_conditionally_accepted = report.counts().merge_conditionally_accepted();
  record.merge_conditional_then_rejected = report.counts().merge_conditional_then_rejected();
  record.views_total = report.views_total();
  record.views_ambiguous = report.ambiguous_views_size();
  record.started_localized = report.started_localized();
  record.protrusions_found = report.protrusions_found();
  record.report = report.SerializeAsString();

  // Rows for hypothesis-level decisions only; every direct edge stays in the report blob.
  std::int64_t sequence = 0;
  for (const auto& decision : report.decisions()) {
    ++sequence;
    if (decision.kind() == "direct_edge" || decision.kind() == "hypothesis_updated") continue;
    storage::DecisionRecord row;
    row.sequence = sequence;
    row.time_s = decision.time();
    row.kind = decision.hypothesis_kind().empty() ? "map" : decision.hypothesis_kind();
    row.outcome = decision.kind();
    row.subject_id = decision.hypothesis() >= 0 ? decision.hypothesis() : decision.view();
    row.detail = decision.reason();
    bundle.decisions.push_back(std::move(row));
  }
  for (std::int64_t view : report.ambiguous_views()) {
    storage::AmbiguousViewRecord row;
    row.view_id = view;
    bundle.ambiguous_views.push_back(row);
  }
  for (const auto& region : report.protrusion_regions()) {
    storage::ProtrusionRegionRecord row;
    row.region_id = region.id();
    if (region.bbox_size() == 4) {
      row.bbox = {static_cast<double>(region.bbox(0)), static_cast<double>(region.bbox(1)),
                  static_cast<double>(region.bbox(0) + region.bbox(2)),
                  static_cast<double>(region.bbox(1) + region.bbox(3))};
    }
    nlohmann::json features = nlohmann::json::object();
    for (int i = 0; i < region.features_size() && i < report.feature_names_size(); ++i) {
      features[report.feature_names(i)] = region.features(i);
    }
    row.features_json = features.dump();
    row.predicted_class = region.predicted_class();
    row.probability = region.probability();
    row.decided_by = region.decided_by();
    bundle.protrusion_regions.push_back(std::move(row));
  }
  return bundle;
}

storage::Result<std::unique_ptr<slamcore::ProtrusionClassifier>> LoadClassifier(const std::string& bytes) {
  ASSIGN_OR_RETURN(auto loaded, slamcore::ProtrusionClassifier::LoadFromBytes(bytes));
  return loaded;
}

std::shared_ptr<const slamcore::ProtrusionClassifier> DefaultClassifier() {
  auto loaded = slamcore::DefaultProtrusionClassifier();
  if (!loaded.ok()) {
    // Only a corrupt build gets here; regions then stay unclassified and the log says why.
    std::fprintf(stderr, "fleetd: %s\n", loaded.status().ToString().c_str());
    return nullptr;
  }
  return *loaded;
}

ClassifierCache::ClassifierCache(storage::Repository& repository, std::string model_name)
    : repository_(repository), model_name_(std::move(model_name)) {}

std::shared_ptr<const slamcore::ProtrusionClassifier> ClassifierCache::Get() {
  std::lock_guard lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (now - checked_ < std::chrono::seconds(3)) return classifier_;
  checked_ = now;
  auto active = repository_.GetActiveModel(model_name_);
  if (!active.ok()) {
    classifier_ = DefaultClassifier();
    version_ = 0;
    return classifier_;
  }
  if (active->version == version_ && classifier_) return classifier_;
  auto loaded = LoadClassifier(active->bytes);
  if (!loaded.ok()) {
    std::fprintf(
        stderr, "fleetd: model %s v%lld does not load (the built-in default classifies instead): %s\n",
        model_name_.c_str(), static_cast<long long>(active->version), loaded.status().ToString().c_str());
    classifier_ = DefaultClassifier();
    version_ = 0;
    return classifier_;
  }
  version_ = active->version;
  classifier_ = std::shared_ptr<const slamcore::ProtrusionClassifier>(std::move(loaded).value());
  return classifier_;
}

storage::Result<AnalysisResult> AnalyzeStoredRun(storage::Repository& repository, const storage::RunKey& key,
                                                 const std::string& parameter_set,
                                                 const slamcore::ProtrusionClassifier* classifier,
                                                 const AnalysisBudget& budget) {
  const auto started = std::chrono::steady_clock::now();
  const std::string& run_id = key.run_id;
  ASSIGN_OR_RETURN(auto run, repository.GetRun(key));
  if (run.telemetry_pruned_at_ms) {
    return storage::FailedPrecondition(
        "run " + run_id + " of robot " + key.robot_id +
        ": its events were pruned by retention (--retain-runs-days); nothing to rerun");
  }
  fleet::v1::RunFile file;
  if (!file.ParseFromString(run.telemetry))
    return storage::DataLoss("run " + run_id + ": telemetry does not parse");
  if (run.parent_snapshot_id) {
    ASSIGN_OR_RETURN(auto snapshot, repository.GetSnapshot(*run.parent_snapshot_id));
    if (!file.mutable_parent_snapshot()->ParseFromString(snapshot.bytes)) {
      return storage::DataLoss("snapshot " + *run.parent_snapshot_id + " does not parse");
    }
  }
  if (run.child_snapshot_id) {
    ASSIGN_OR_RETURN(auto snapshot, repository.GetSnapshot(*run.child_snapshot_id));
    if (!file.mutable_child_snapshot()->ParseFromString(snapshot.bytes)) {
      return storage::DataLoss("snapshot " + *run.child_snapshot_id + " does not parse");
    }
  }
  ASSIGN_OR_RETURN(auto stored_set, repository.GetParameterSet(parameter_set));
  fleet::v1::ParameterSet set;
  if (!set.ParseFromString(stored_set.serialized)) {
    return storage::DataLoss("parameter set " + parameter_set + " does not parse");
  }
  ASSIGN_OR_RETURN(auto mapper, analyzer::FromProto(set.mapper()));

  analyzer::AnalysisOptions options;
  options.parameter_set_name = parameter_set;
  options.mapper = mapper;
  options.classifier = classifier;
  options.keep_rerun_child = true;
  const auto deadline = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(budget.max_seconds));
  options.keep_going = [&]() -> slamcore::Status {
    if (budget.max_seconds > 0.0 && std::chrono::steady_clock::now() > deadline) {
      std::ostringstream message;
      message << "analysis budget: run " << run_id << " took longer than " << budget.max_seconds
              << " s (--analysis-budget-seconds)";
      return slamcore::FailedPrecondition(message.str());
    }
    if (budget.cancelled && budget.cancelled())
      return slamcore::FailedPrecondition("analysis budget: job cancelled");
    return slamcore::Status::Ok();
  };
  ASSIGN_OR_RETURN(auto maps, analyzer::DecodeRunMaps(file));
  ASSIGN_OR_RETURN(auto report, analyzer::AnalyzeRun(file, maps, options));
  report.set_parameter_set(parameter_set);
  // The stored identity, whatever the telemetry's header says.
  report.set_robot_id(run.robot_id);
  report.set_run_id(run.run_id);
  const storage::ReportBundle bundle = ToReportBundle(report);
  RETURN_IF_ERROR(repository.PutReport(bundle));
  AnalysisResult result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  result.regions = static_cast<std::int64_t>(bundle.protrusion_regions.size());
  result.report = std::move(report);
  result.maps = std::move(maps);
  result.child_snapshot_id = run.child_snapshot_id.value_or("");
  return result;
}

}  // namespace server
