#include "dashboard_json.h"

#include "server/jobs.h"

namespace server::dashboard_json {

using json = nlohmann::json;

json Optional(const std::optional<double>& value) { return value ? json(*value) : json(nullptr); }

json FiguresJson(const Figures& f) {
  const storage::FleetStatistics& s = f.counts;
  return json{
      {"reports", s.reports},
      {"robots", s.robots},
      {"recovery_created", s.recovery_created},
      {"recovery_accepted", s.recovery_accepted},
      {"merge_created", s.merge_created},
      {"merge_conditionally_accepted", s.merge_conditionally_accepted},
      {"merge_conditional_then_rejected", s.merge_conditional_then_rejected},
      {"views_total", s.views_total},
      {"views_ambiguous", s.views_ambiguous},
      {"started_localized", s.started_localized},
      {"protrusions_found", s.protrusions_found},
      {"recovery_retracted", s.recovery_retracted},
      {"recovery_per_run", Optional(f.recovery_per_run)},
      {"recovery_accepted_share", Optional(f.recovery_accepted_share)},
      {"started_localized_share", Optional(f.started_localized_share)},
      {"merge_conditional_then_rejected_share", Optional(f.merge_conditional_then_rejected_share)},
      {"ambiguous_view_share", Optional(f.ambiguous_view_share)},
      {"protrusions_per_run", Optional(f.protrusions_per_run)},
      {"recovery_retracted_share", Optional(f.recovery_retracted_share)},
  };
}

json GroupsJson(const std::vector<FiguresGroup>& groups) {
  json rows = json::array();
  for (const FiguresGroup& group : groups) {
    json row = FiguresJson(group.figures);
    row["key"] = group.key;
    rows.push_back(std::move(row));
  }
  return rows;
}

json RunJson(const storage::RunRecord& run) {
  return json{{"run_id", run.run_id},
              {"robot_id", run.robot_id},
              {"firmware", run.firmware},
              {"robot_model", run.robot_model},
              {"started_at_ms", run.started_at_ms},
              {"ended_at_ms", run.ended_at_ms},
              {"parent_snapshot_id", run.parent_snapshot_id ? json(*run.parent_snapshot_id) : json(nullptr)},
              {"child_snapshot_id", run.child_snapshot_id ? json(*run.child_snapshot_id) : json(nullptr)},
              {"telemetry_size", run.telemetry_size},
              {"telemetry_pruned_at_ms",
               run.telemetry_pruned_at_ms ? json(*run.telemetry_pruned_at_ms) : json(nullptr)}};
}

json ReportCountersJson(const storage::ReportRecord& report) {
  return json{{"parameter_set", report.parameter_set},
              {"recovery_created", report.recovery_created},
              {"recovery_accepted", report.recovery_accepted},
              {"recovery_retracted", report.recovery_retracted},
              {"merge_created", report.merge_created},
              {"merge_conditionally_accepted", report.merge_conditionally_accepted},
              {"merge_conditional_then_rejected", report.merge_conditional_then_rejected},
              {"views_total", report.views_total},
              {"views_ambiguous", report.views_ambiguous},
              {"started_localized", report.started_localized},
              {"protrusions_found", report.protrusions_found}};
}

json RegionJson(const storage::ProtrusionRegionRecord& region) {
  json features = json::object();
  if (!region.features_json.empty()) {
    features = json::parse(region.features_json, nullptr, /*allow_exceptions=*/false);
    if (features.is_discarded()) features = json::object();
  }
  return json{{"run_id", region.run_id},
              {"robot_id", region.robot_id},
              {"parameter_set", region.parameter_set},
              {"region_id", region.region_id},
              // x, y, width, height in child image cells (y down), as the map images are drawn.
              {"bbox",
               {region.bbox.min_x, region.bbox.min_y, region.bbox.max_x - region.bbox.min_x,
                region.bbox.max_y - region.bbox.min_y}},
              {"features", features},
              {"predicted_class", region.predicted_class},
              {"probability", region.probability},
              {"decided_by", region.decided_by},
              {"label", region.label ? json(*region.label) : json(nullptr)},
              {"labelled_by", region.labelled_by ? json(*region.labelled_by) : json(nullptr)}};
}

json JobJson(const storage::JobRecord& job) {
  json out{{"job_id", job.job_id},
           {"kind", job.kind},
           {"state", std::string(storage::Name(job.state))},
           {"attempts", job.attempts},
           {"max_attempts", job.max_attempts},
           {"progress_done", job.progress_done},
           {"progress_total", job.progress_total},
           {"last_error", job.last_error},
           {"created_at_ms", job.created_at_ms},
           {"updated_at_ms", job.updated_at_ms},
           {"parent_job_id", job.parent_job_id ? json(*job.parent_job_id) : json(nullptr)},
           {"lease_owner", job.lease_owner ? json(*job.lease_owner) : json(nullptr)},
           {"robot_id", job.robot_id ? json(*job.robot_id) : json(nullptr)}};
  if (job.kind == kReprocessJob) {
    if (auto payload = DecodeReprocessPayload(job.payload); payload.ok()) {
      out["parameter_set"] = payload->parameter_set;
      out["filter"] = json{{"robot_id", payload->filter.robot_id}, {"firmware", payload->filter.firmware}};
    }
  } else if (job.kind == kAnalyzeRunJob) {
    if (auto payload = DecodeAnalyzePayload(job.payload); payload.ok()) {
      out["parameter_set"] = payload->parameter_set;
      out["run_id"] = payload->run_id;
    }
  }
  return out;
}

}  // namespace server::dashboard_json
