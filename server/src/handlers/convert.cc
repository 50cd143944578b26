#include "convert.h"

#include <cmath>
#include <cstdio>
#include <ctime>

#include "server/jobs.h"
#include "server/map_history.h"

namespace server {
namespace {

std::int64_t Millis(double seconds) { return static_cast<std::int64_t>(std::llround(seconds * 1000.0)); }

}  // namespace

storage::Result<storage::RunFilter> FromProto(const fleet::v1::RunFilter& filter, const std::string& field) {
  storage::RunFilter out;
  out.robot_id = filter.robot_id();
  out.firmware = filter.firmware();
  out.robot_model = filter.robot_model();
  out.parameter_set = filter.parameter_set();
  constexpr double kLimit = 1e11;  // year ~5000: keeps milliseconds in int64
  if (filter.has_started_from()) {
    if (!std::isfinite(filter.started_from()) || std::fabs(filter.started_from()) > kLimit) {
      return storage::InvalidArgument(field + ".started_from: must be finite Unix seconds");
    }
    out.started_from_ms = Millis(filter.started_from());
  }
  if (filter.has_started_before()) {
    if (!std::isfinite(filter.started_before()) || std::fabs(filter.started_before()) > kLimit) {
      return storage::InvalidArgument(field + ".started_before: must be finite Unix seconds");
    }
    out.started_before_ms = Millis(filter.started_before());
  }
  if (out.started_from_ms && out.started_before_ms && *out.started_before_ms < *out.started_from_ms) {
    return storage::InvalidArgument(field + ".started_before: earlier than started_from");
  }
  return out;
}

fleet::v1::RunFilter ToProto(const storage::RunFilter& filter) {
  fleet::v1::RunFilter out;
  out.set_robot_id(filter.robot_id);
  out.set_firmware(filter.firmware);
  out.set_robot_model(filter.robot_model);
  out.set_parameter_set(filter.parameter_set);
  if (filter.started_from_ms) out.set_started_from(static_cast<double>(*filter.started_from_ms) / 1000.0);
  if (filter.started_before_ms)
    out.set_started_before(static_cast<double>(*filter.started_before_ms) / 1000.0);
  return out;
}

fleet::v1::FleetFigures ToProto(const Figures& figures) {
  const storage::FleetStatistics& s = figures.counts;
  fleet::v1::FleetFigures f;
  f.set_reports(s.reports);
  f.set_robots(s.robots);
  f.set_recovery_created(s.recovery_created);
  f.set_recovery_accepted(s.recovery_accepted);
  f.set_merge_created(s.merge_created);
  f.set_merge_conditionally_accepted(s.merge_conditionally_accepted);
  f.set_merge_conditional_then_rejected(s.merge_conditional_then_rejected);
  f.set_views_total(s.views_total);
  f.set_views_ambiguous(s.views_ambiguous);
  f.set_started_localized(s.started_localized);
  f.set_protrusions_found(s.protrusions_found);
  f.set_recovery_retracted(s.recovery_retracted);
  // proto3 doubles cannot be absent: a share without a denominator is 0 on the wire (null over HTTP).
  f.set_recovery_per_run(figures.recovery_per_run.value_or(0.0));
  f.set_recovery_accepted_share(figures.recovery_accepted_share.value_or(0.0));
  f.set_started_localized_share(figures.started_localized_share.value_or(0.0));
  f.set_merge_conditional_then_rejected_share(figures.merge_conditional_then_rejected_share.value_or(0.0));
  f.set_ambiguous_view_share(figures.ambiguous_view_share.value_or(0.0));
  f.set_protrusions_per_run(figures.protrusions_per_run.value_or(0.0));
  f.set_recovery_retracted_share(figures.recovery_retracted_share.value_or(0.0));
  return f;
}

fleet::v1::FleetFigures Delta(const fleet::v1::FleetFigures& a, const fleet::v1::FleetFigures& b) {
  fleet::v1::FleetFigures f;
  f.set_reports(b.reports() - a.reports());
  f.set_robots(b.robots() - a.robots());
  f.set_recovery_created(b.recovery_created() - a.recovery_created());
  f.set_recovery_accepted(b.recovery_accepted() - a.recovery_accepted());
  f.set_merge_created(b.merge_created() - a.merge_created());
  f.set_merge_conditionally_accepted(b.merge_conditionally_accepted() - a.merge_conditionally_accepted());
  f.set_merge_conditional_then_rejected(b.merge_conditional_then_rejected() -
                                        a.merge_conditional_then_rejected());
  f.set_views_total(b.views_total() - a.views_total());
  f.set_views_ambiguous(b.views_ambiguous() - a.views_ambiguous());
  f.set_started_localized(b.started_localized() - a.started_localized());
  f.set_protrusions_found(b.protrusions_found() - a.protrusions_found());
  f.set_recovery_retracted(b.recovery_retracted() - a.recovery_retracted());
  f.set_recovery_per_run(b.recovery_per_run() - a.recovery_per_run());
  f.set_recovery_accepted_share(b.recovery_accepted_share() - a.recovery_accepted_share());
  f.set_started_localized_share(b.started_localized_share() - a.started_localized_share());
  f.set_merge_conditional_then_rejected_share(b.merge_conditional_then_rejected_share() -
                                              a.merge_conditional_then_rejected_share());
  f.set_ambiguous_view_share(b.ambiguous_view_share() - a.ambiguous_view_share());
  f.set_protrusions_per_run(b.protrusions_per_run() - a.protrusions_per_run());
  f.set_recovery_retracted_share(b.recovery_retracted_share() - a.recovery_retracted_share());
  return f;
}

fleet::v1::Job ToProto(const storage::JobRecord& job) {
  fleet::v1::Job out;
  out.set_job_id(job.job_id);
  out.set_kind(job.kind);
  out.set_state(std::string(storage::Name(job.state)));
  out.set_progress_done(job.progress_done);
  out.set_progress_total(job.progress_total);
  out.set_last_error(job.last_error);
  out.set_attempts(job.attempts);
  out.set_created_at(static_cast<double>(job.created_at_ms) / 1000.0);
  out.set_updated_at(static_cast<double>(job.updated_at_ms) / 1000.0);
  out.set_parent_job_id(job.parent_job_id.value_or(0));
  out.set_robot_id(job.robot_id.value_or(""));
  if (job.kind == kReprocessJob) {
    if (auto payload = DecodeReprocessPayload(job.payload); payload.ok()) {
      out.set_parameter_set(payload->parameter_set);
      *out.mutable_filter() = ToProto(payload->filter);
    }
  } else if (job.kind == kAnalyzeRunJob) {
    if (auto payload = DecodeAnalyzePayload(job.payload); payload.ok()) {
      out.set_parameter_set(payload->parameter_set);
      out.set_run_id(payload->run_id);
    }
    if (job.progress_total == 0) {
      out.set_progress_total(1);
      out.set_progress_done(job.state == storage::JobState::kDone ? 1 : 0);
    }
  }
  return out;
}

fleet::v1::Region ToProto(const storage::ProtrusionRegionRecord& region) {
  fleet::v1::Region out;
  out.set_run_id(region.run_id);
  out.set_robot_id(region.robot_id);
  out.set_parameter_set(region.parameter_set);
  out.set_region_id(region.region_id);
  out.add_bbox(region.bbox.min_x);
  out.add_bbox(region.bbox.min_y);
  out.add_bbox(region.bbox.max_x);
  out.add_bbox(region.bbox.max_y);
  out.set_features_json(region.features_json);
  out.set_predicted_class(region.predicted_class);
  out.set_probability(region.probability);
  out.set_label(region.label.value_or(""));
  out.set_labelled_by(region.labelled_by.value_or(""));
  out.set_decided_by(region.decided_by);
  return out;
}

fleet::v1::RobotMapSummary ToProto(const storage::RobotMapSummary& summary) {
  fleet::v1::RobotMapSummary out;
  out.set_robot_id(summary.robot.robot_id);
  out.set_robot_model(summary.robot.robot_model);
  out.set_firmware(summary.robot.firmware);
  out.set_versions(summary.versions);
  out.set_current_version(summary.current_version);
  out.set_pending_versions(summary.pending_versions);
  if (summary.newest_approval) out.set_newest_approval(ToProto(*summary.newest_approval));
  out.set_newest_open_findings(summary.newest_open_findings);
  return out;
}

}  // namespace server
