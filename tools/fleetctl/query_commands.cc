#include "query_commands.h"

#include <cstdio>
#include <map>

namespace fleetctl {
namespace {

std::string Percent(double share) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1f%%", 100 * share);
  return buffer;
}

void PrintFiguresRow(const std::string& key, const fleet::v1::FleetFigures& f) {
  std::printf("%-22s %8lld %6lld %9.2f %9s %9lld %9s %9s %9s %9.3f\n", key.c_str(),
              static_cast<long long>(f.reports()), static_cast<long long>(f.robots()), f.recovery_per_run(),
              Percent(f.recovery_accepted_share()).c_str(), static_cast<long long>(f.recovery_retracted()),
              Percent(f.started_localized_share()).c_str(),
              Percent(f.merge_conditional_then_rejected_share()).c_str(),
              Percent(f.ambiguous_view_share()).c_str(), f.protrusions_per_run());
}

void PrintFiguresHeader() {
  std::printf("%-22s %8s %6s %9s %9s %9s %9s %9s %9s %9s\n", "group", "reports", "robots", "recov/run",
              "recov.acc", "retracted", "localized", "cond.rej", "ambig.vw", "protr/run");
}

}  // namespace

QueryCommands::QueryCommands(CLI::App& app) {
  runs_ = app.add_subcommand("runs", "list runs");
  filter_.Add(runs_);
  runs_->add_option("--limit", limit_, "at most this many runs")->check(CLI::Range(1, 100000));

  report_ = app.add_subcommand("report", "one run's report");
  report_->add_option("run", run_id_, "run id")->required();
  report_->add_option("--robot", run_robot_, "the run's robot (needed when robots share the run id)");
  report_->add_option("--parameter-set", parameter_set_, "parameter set (default: the server's default)");
  report_->add_flag("--with-map", with_map_, "include the rerun's child map (JSON only)");

  stats_ = app.add_subcommand("stats", "fleet statistics (the paper's figures)");
  filter_.Add(stats_);
  stats_->add_option("--group-by", group_by_, "none, day, firmware, robot_model, parameter_set, robot")
      ->check(CLI::IsMember({"none", "day", "firmware", "robot_model", "parameter_set", "robot"}));

  compare_ = app.add_subcommand("compare", "compare two parameter sets run by run");
  compare_->add_option("a", set_a_, "parameter set A")->required();
  compare_->add_option("b", set_b_, "parameter set B")->required();
  compare_->add_option("--top", top_, "runs that changed most")->check(CLI::Range(1, 1000));
  filter_.Add(compare_);
}

std::optional<int> QueryCommands::Run(Client& client, const Global& global) const {
  if (runs_->parsed()) return Runs(client, global);
  if (report_->parsed()) return Report(client, global);
  if (stats_->parsed()) return Stats(client, global);
  if (compare_->parsed()) return Compare(client, global);
  return std::nullopt;
}

int QueryCommands::Runs(Client& client, const Global& global) const {
  fleet::v1::ListRunsResponse all;
  std::string token;
  do {
    fleet::v1::ListRunsRequest request;
    *request.mutable_filter() = filter_.Proto();
    request.set_page_size(std::min(1000, limit_ - all.runs_size()));
    request.set_page_token(token);
    fleet::v1::ListRunsResponse page;
    auto context = client.Context();
    if (grpc::Status status = client.queries->ListRuns(context.get(), request, &page); !status.ok())
      return Fail(status);
    for (auto& run : *page.mutable_runs()) *all.add_runs() = std::move(run);
    token = page.next_page_token();
  } while (!token.empty() && all.runs_size() < limit_);
  all.set_next_page_token(token);
  if (global.json) {
    PrintJson(all);
  } else {
    std::printf("%-28s %-12s %-9s %-20s %10s  %s\n", "run", "robot", "firmware", "started (Unix s)", "bytes",
                "reports");
    for (const auto& run : all.runs()) {
      std::string sets;
      for (const auto& set : run.report_parameter_sets()) sets += (sets.empty() ? "" : ",") + set;
      std::printf("%-28s %-12s %-9s %-20.0f %10lld  %s\n", run.run_id().c_str(), run.robot_id().c_str(),
                  run.firmware().c_str(), run.started_at(), static_cast<long long>(run.telemetry_bytes()),
                  sets.c_str());
    }
  }
  return 0;
}

int QueryCommands::Report(Client& client, const Global& global) const {
  fleet::v1::GetRunReportRequest request;
  request.set_run_id(run_id_);
  request.set_robot_id(run_robot_);
  request.set_parameter_set(parameter_set_);
  request.set_include_rerun_child(with_map_);
  fleet::v1::GetRunReportResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.queries->GetRunReport(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  const auto& r = response.report();
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf("run %s  robot %s  firmware %s  parameter set %s\n", r.run_id().c_str(), r.robot_id().c_str(),
              r.firmware().c_str(), r.parameter_set().c_str());
  std::printf("recovery hypotheses: %d created, %d accepted (%d later retracted), %d expired, %d rejected\n",
              r.counts().recovery_created(), r.counts().recovery_accepted(), r.counts().recovery_retracted(),
              r.counts().recovery_expired(), r.counts().recovery_rejected());
  std::printf("merge hypotheses:    %d created, %d conditionally accepted (%d later rejected), %d accepted\n",
              r.counts().merge_created(), r.counts().merge_conditionally_accepted(),
              r.counts().merge_conditional_then_rejected(), r.counts().merge_accepted());
  std::printf("started localized: %s; relocalization: conditional %.1f s, full %.1f s (-1: never)\n",
              r.started_localized() ? "yes" : "no", r.seconds_to_conditional_relocalization(),
              r.seconds_to_full_relocalization());
  std::printf("views: %d, ambiguous: %d; protrusion regions: %d, protrusions: %d\n", r.views_total(),
              r.ambiguous_views_size(), r.protrusion_regions_size(), r.protrusions_found());
  std::printf("divergence from the robot's map: %d vs %d nodes, node RMS %.3f m\n",
              r.divergence().robot_nodes(), r.divergence().rerun_nodes(), r.divergence().node_position_rms());
  if (r.has_ground_truth()) {
    std::printf("ground truth: trajectory RMSE %.3f m; wrong observations accepted %d/%d\n",
                r.ground_truth().trajectory_rmse(), r.ground_truth().wrong_observations_accepted(),
                r.ground_truth().wrong_observations());
  }
  std::printf("timings: replay %.3f s, detection %.3f s\n", r.replay_seconds(), r.detection_seconds());
  return 0;
}

int QueryCommands::Stats(Client& client, const Global& global) const {
  static const std::map<std::string, fleet::v1::GroupBy> kGroups = {
      {"none", fleet::v1::GROUP_BY_NONE},
      {"day", fleet::v1::GROUP_BY_DAY},
      {"firmware", fleet::v1::GROUP_BY_FIRMWARE},
      {"robot_model", fleet::v1::GROUP_BY_ROBOT_MODEL},
      {"parameter_set", fleet::v1::GROUP_BY_PARAMETER_SET},
      {"robot", fleet::v1::GROUP_BY_ROBOT}};
  fleet::v1::GetFleetStatisticsRequest request;
  *request.mutable_filter() = filter_.Proto();
  request.set_group_by(kGroups.at(group_by_));
  fleet::v1::GetFleetStatisticsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.queries->GetFleetStatistics(context.get(), request, &response);
      !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintFiguresHeader();
  for (const auto& group : response.groups()) PrintFiguresRow(group.key(), group.figures());
  PrintFiguresRow("total", response.total());
  return 0;
}

int QueryCommands::Compare(Client& client, const Global& global) const {
  fleet::v1::CompareParameterSetsRequest request;
  *request.mutable_filter() = filter_.Proto();
  request.set_set_a(set_a_);
  request.set_set_b(set_b_);
  request.set_top(top_);
  fleet::v1::CompareParameterSetsResponse response;
  auto context = client.Context(300);
  if (grpc::Status status = client.queries->CompareParameterSets(context.get(), request, &response);
      !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  PrintFiguresHeader();
  PrintFiguresRow(set_a_, response.a());
  PrintFiguresRow(set_b_, response.b());
  PrintFiguresRow("delta (b - a)", response.delta());
  std::printf("\n%lld runs compared, %lld changed%s; most changed:\n",
              static_cast<long long>(response.runs_compared()),
              static_cast<long long>(response.runs_changed()),
              response.scan_truncated() ? " (the first runs only: narrow the filter to see the rest)" : "");
  for (const auto& run : response.most_changed()) {
    std::printf(
        "  %-28s change %5.0f  recovery acc %lld→%lld  merges %lld→%lld  ambiguous %lld→%lld  protrusions "
        "%lld→%lld\n",
        run.run_id().c_str(), run.change(), static_cast<long long>(run.a().recovery_accepted()),
        static_cast<long long>(run.b().recovery_accepted()), static_cast<long long>(run.a().merge_created()),
        static_cast<long long>(run.b().merge_created()), static_cast<long long>(run.a().views_ambiguous()),
        static_cast<long long>(run.b().views_ambiguous()),
        static_cast<long long>(run.a().protrusions_found()),
        static_cast<long long>(run.b().protrusions_found()));
  }
  return 0;
}

}  // namespace fleetctl
