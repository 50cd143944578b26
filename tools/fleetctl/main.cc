// fleetctl: the engineers' and operators' CLI to fleetd.
//
//   fleetctl [--server HOST:PORT] [--token-file F | $FLEET_TOKEN_FILE | $FLEET_TOKEN | --token T] [--tls-ca PEM] COMMAND ...
//     upload PATH...                 .runpb files or directories (robots in parallel, retries)
//     runs [filters] [--limit N]     list runs
//     report RUN [--robot R] [--parameter-set S]   one run's report (--robot when robots share the run id)
//     stats [filters] [--group-by day|firmware|robot_model|parameter_set|robot]
//     compare A B [filters]          two parameter sets, fleet-wide and run by run
//     params put FILE | params list  parameter sets (JSON, see analyzer/parameters.h)
//     reprocess --parameter-set S [filters] [--no-wait]   with a progress bar
//     jobs [--state S] | job ID | cancel ID
//     regions RUN | label RUN REGION LABEL         (both take --robot R too)
//     models train NAME [--classifier K] | models eval NAME [--version V] | models activate NAME V | models list NAME
//     credentials PRINCIPAL | credentials rotate|revoke PRINCIPAL | credentials list   tokens (credential_commands.h)
//     robots delete R --confirm R | audit         erasure and the audit log (admins; admin_commands.h)
//     maps list|show|repair|approve|reject|get|export   map history (map_commands.h)
//     import valetudo|map-server FILE... --robot R       maps made elsewhere into the history (import_commands.h)
// Every command takes --json: one JSON object on stdout instead of a table. Exit status 0 on success, 1 on
// an RPC error (printed as "fleetctl: CODE: message"), 2 on usage errors.
#include <CLI/CLI.hpp>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <unistd.h>

#include "admin_commands.h"
#include "analyzer/parameters.h"
#include "client.h"
#include "credential_commands.h"
#include "fleet/v1/service.grpc.pb.h"
#include "import_commands.h"
#include "map_commands.h"
#include "sim/upload_files.h"
#include "sim/uploader.h"

namespace {

using fleetctl::Client;
using fleetctl::Fail;
using fleetctl::Global;
using fleetctl::PrintJson;

struct Filter {
  std::string robot, firmware, model, parameter_set;
  double from = 0, before = 0;
  void Add(CLI::App* command) {
    command->add_option("--robot", robot, "robot id");
    command->add_option("--firmware", firmware, "firmware version");
    command->add_option("--model", model, "robot model");
    command->add_option("--parameter-set", parameter_set, "parameter set");
    command->add_option("--from", from, "started at or after (Unix seconds)");
    command->add_option("--before", before, "started before (Unix seconds)");
  }
  fleet::v1::RunFilter Proto() const {
    fleet::v1::RunFilter filter;
    filter.set_robot_id(robot);
    filter.set_firmware(firmware);
    filter.set_robot_model(model);
    filter.set_parameter_set(parameter_set);
    if (from != 0) filter.set_started_from(from);
    if (before != 0) filter.set_started_before(before);
    return filter;
  }
};

std::string Percent(double share) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1f%%", 100 * share);
  return buffer;
}

void PrintFiguresRow(const std::string& key, const fleet::v1::FleetFigures& f) {
  std::printf("%-22s %8lld %6lld %9.2f %9s %9lld %9s %9s %9s %9.3f\n", key.c_str(), static_cast<long long>(f.reports()),
              static_cast<long long>(f.robots()), f.recovery_per_run(), Percent(f.recovery_accepted_share()).c_str(),
              static_cast<long long>(f.recovery_retracted()), Percent(f.started_localized_share()).c_str(),
              Percent(f.merge_conditional_then_rejected_share()).c_str(), Percent(f.ambiguous_view_share()).c_str(),
              f.protrusions_per_run());
}

void PrintFiguresHeader() {
  std::printf("%-22s %8s %6s %9s %9s %9s %9s %9s %9s %9s\n", "group", "reports", "robots", "recov/run", "recov.acc",
              "retracted", "localized", "cond.rej", "ambig.vw", "protr/run");
}

void ProgressBar(const fleet::v1::Job& job) {
  if (!isatty(fileno(stderr))) {
    std::fprintf(stderr, "job %lld %s %lld/%lld\n", static_cast<long long>(job.job_id()), job.state().c_str(),
                 static_cast<long long>(job.progress_done()), static_cast<long long>(job.progress_total()));
    return;
  }
  const int width = 40;
  const long long total = std::max<long long>(1, job.progress_total());
  const int filled = static_cast<int>(width * std::min<long long>(job.progress_done(), total) / total);
  std::fprintf(stderr, "\r[%.*s%*s] %lld/%lld runs  %s   ", filled, "########################################",
               width - filled, "", static_cast<long long>(job.progress_done()),
               static_cast<long long>(job.progress_total()), job.state().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"fleetctl: command-line client of fleetd"};
  app.require_subcommand(1);
  Global global;
  std::string token_file;
  if (const char* token = std::getenv("FLEET_TOKEN")) global.token = token;
  if (const char* file = std::getenv("FLEET_TOKEN_FILE")) token_file = file;
  if (const char* server = std::getenv("FLEET_SERVER")) global.server = server;
  if (const char* ca = std::getenv("FLEET_TLS_CA")) global.tls_ca = ca;
  app.add_option("--server", global.server, "fleetd address host:port (default $FLEET_SERVER or 127.0.0.1:50051)");
  app.add_option("--token", global.token,
                 "bearer token (default $FLEET_TOKEN); visible to other users in the process list: prefer "
                 "--token-file or the environment");
  app.add_option("--token-file", token_file, "read the bearer token from this file (default $FLEET_TOKEN_FILE)");
  app.add_option("--tls-ca", global.tls_ca, "PEM CA file: connect with TLS (default $FLEET_TLS_CA)");
  app.add_flag("--json", global.json, "print one JSON object instead of a table");
  app.fallthrough();

  std::vector<std::string> upload_paths;
  int upload_threads = 4;
  auto* upload = app.add_subcommand("upload", "upload .runpb files or directories");
  upload->add_option("paths", upload_paths, "files or directories")->required();
  upload->add_option("--threads", upload_threads, "parallel streams")->check(CLI::Range(1, 256));

  Filter filter;
  int limit = 100;
  auto* runs = app.add_subcommand("runs", "list runs");
  filter.Add(runs);
  runs->add_option("--limit", limit, "at most this many runs")->check(CLI::Range(1, 100000));

  std::string run_id, run_robot, parameter_set;
  bool with_map = false;
  auto* report = app.add_subcommand("report", "one run's report");
  report->add_option("run", run_id, "run id")->required();
  report->add_option("--robot", run_robot, "the run's robot (needed when robots share the run id)");
  report->add_option("--parameter-set", parameter_set, "parameter set (default: the server's default)");
  report->add_flag("--with-map", with_map, "include the rerun's child map (JSON only)");

  std::string group_by = "none";
  auto* stats = app.add_subcommand("stats", "fleet statistics (the paper's figures)");
  filter.Add(stats);
  stats->add_option("--group-by", group_by, "none, day, firmware, robot_model, parameter_set, robot")
      ->check(CLI::IsMember({"none", "day", "firmware", "robot_model", "parameter_set", "robot"}));

  std::string set_a, set_b;
  int top = 10;
  auto* compare = app.add_subcommand("compare", "compare two parameter sets run by run");
  compare->add_option("a", set_a, "parameter set A")->required();
  compare->add_option("b", set_b, "parameter set B")->required();
  compare->add_option("--top", top, "runs that changed most")->check(CLI::Range(1, 1000));
  filter.Add(compare);

  auto* params = app.add_subcommand("params", "parameter sets");
  params->require_subcommand(1);
  std::string params_file;
  auto* params_put = params->add_subcommand("put", "store a parameter set from a JSON file");
  params_put->add_option("file", params_file, "JSON file")->required();
  auto* params_list = params->add_subcommand("list", "list parameter sets");

  bool no_wait = false;
  auto* reprocess = app.add_subcommand("reprocess", "reanalyse runs with a parameter set");
  std::string reprocess_set;
  reprocess->add_option("--with", reprocess_set, "parameter set to analyse with")->required();
  reprocess->add_option("--robot", filter.robot, "robot id");
  reprocess->add_option("--firmware", filter.firmware, "firmware");
  reprocess->add_option("--model", filter.model, "robot model");
  reprocess->add_option("--only-with-set", filter.parameter_set, "only runs that have a report of this set");
  reprocess->add_option("--from", filter.from, "started at or after (Unix seconds)");
  reprocess->add_option("--before", filter.before, "started before (Unix seconds)");
  reprocess->add_flag("--no-wait", no_wait, "start the job and return");

  std::string state;
  std::int64_t job_id = 0;
  auto* jobs = app.add_subcommand("jobs", "list jobs");
  jobs->add_option("--state", state, "queued, leased, done, failed, cancelled");
  jobs->add_option("--limit", limit, "at most this many");
  auto* job = app.add_subcommand("job", "one job");
  job->add_option("id", job_id, "job id")->required();
  auto* cancel = app.add_subcommand("cancel", "cancel a job");
  cancel->add_option("id", job_id, "job id")->required();

  std::int64_t region_id = 0;
  std::string label_value;
  auto* regions = app.add_subcommand("regions", "protrusion regions of a run");
  regions->add_option("run", run_id, "run id")->required();
  regions->add_option("--robot", run_robot, "the run's robot (needed when robots share the run id)");
  regions->add_option("--parameter-set", parameter_set, "parameter set");
  auto* label = app.add_subcommand("label", "label a protrusion region");
  label->add_option("run", run_id, "run id")->required();
  label->add_option("--robot", run_robot, "the run's robot (needed when robots share the run id)");
  label->add_option("region", region_id, "region id")->required();
  label->add_option("label", label_value, "protrusion or new_space")->required();
  label->add_option("--parameter-set", parameter_set, "parameter set");

  auto* label_from_truth = app.add_subcommand(
      "label-from-truth", "label every region whose run carries simulator ground truth (fleetsim) with that truth");
  label_from_truth->add_option("--parameter-set", parameter_set, "parameter set");

  auto* models = app.add_subcommand("models", "protrusion classifier models");
  models->require_subcommand(1);
  std::string model_name, classifier;
  std::int64_t version = 0;
  auto* train = models->add_subcommand("train", "train from labelled regions");
  train->add_option("name", model_name, "model name, e.g. protrusion")->required();
  train->add_option("--classifier", classifier, "decision_tree, random_forest, svm");
  train->add_option("--parameter-set", parameter_set, "labelled regions of this set only");
  auto* eval = models->add_subcommand("eval", "evaluate on labelled regions");
  eval->add_option("name", model_name, "model name")->required();
  eval->add_option("--version", version, "version (default: active)");
  eval->add_option("--parameter-set", parameter_set, "labelled regions of this set only");
  auto* activate = models->add_subcommand("activate", "make a version active");
  activate->add_option("name", model_name, "model name")->required();
  activate->add_option("version", version, "version")->required();
  auto* models_list = models->add_subcommand("list", "versions of a model");
  models_list->add_option("name", model_name, "model name")->required();

  fleetctl::CredentialCommands credential_commands(app);
  fleetctl::MapCommands map_commands(app);
  fleetctl::ImportCommands import_commands(app);
  fleetctl::AdminCommands admin_commands(app);

  CLI11_PARSE(app, argc, argv);
  if (!token_file.empty()) {
    std::string error;
    auto token = sim::ReadTokenFile(token_file, &error);
    if (!token) {
      std::cerr << "fleetctl: " << error << "\n";
      return 2;
    }
    global.token = *token;
  }
  Client client(global);
  if (const std::optional<int> status = credential_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = admin_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = map_commands.Run(client, global)) return *status;
  if (const std::optional<int> status = import_commands.Run(client, global)) return *status;

  if (*upload) {
    sim::UploadFilesOptions options;
    options.uploader.server = global.server;
    options.uploader.token = global.token;
    options.uploader.tls_ca = global.tls_ca;
    options.threads = upload_threads;
    const bool interactive = isatty(fileno(stderr)) && !global.json;
    options.progress = [interactive](int done, int total, const sim::UploadOutcome& outcome) {
      if (!outcome.ok) std::fprintf(stderr, "%sfleetctl: %s\n", interactive ? "\n" : "", outcome.message.c_str());
      if (interactive) std::fprintf(stderr, "\ruploaded %d/%d runs", done, total);
    };
    std::vector<std::filesystem::path> paths(upload_paths.begin(), upload_paths.end());
    const sim::UploadSummary summary = sim::UploadFiles(paths, options);
    if (interactive) std::fprintf(stderr, "\n");
    if (global.json) {
      std::cout << summary.ToJson() << "\n";
    } else {
      std::cout << summary.Summary() << "\n";
    }
    return summary.failed == 0 && summary.runs > 0 ? 0 : 1;
  }
  if (*runs) {
    fleet::v1::ListRunsResponse all;
    std::string token;
    do {
      fleet::v1::ListRunsRequest request;
      *request.mutable_filter() = filter.Proto();
      request.set_page_size(std::min(1000, limit - all.runs_size()));
      request.set_page_token(token);
      fleet::v1::ListRunsResponse page;
      auto context = client.Context();
      if (grpc::Status status = client.queries->ListRuns(context.get(), request, &page); !status.ok()) return Fail(status);
      for (auto& run : *page.mutable_runs()) *all.add_runs() = std::move(run);
      token = page.next_page_token();
    } while (!token.empty() && all.runs_size() < limit);
    all.set_next_page_token(token);
    if (global.json) {
      PrintJson(all);
    } else {
      std::printf("%-28s %-12s %-9s %-20s %10s  %s\n", "run", "robot", "firmware", "started (Unix s)", "bytes", "reports");
      for (const auto& run : all.runs()) {
        std::string sets;
        for (const auto& set : run.report_parameter_sets()) sets += (sets.empty() ? "" : ",") + set;
        std::printf("%-28s %-12s %-9s %-20.0f %10lld  %s\n", run.run_id().c_str(), run.robot_id().c_str(),
                    run.firmware().c_str(), run.started_at(), static_cast<long long>(run.telemetry_bytes()), sets.c_str());
      }
    }
    return 0;
  }
  if (*report) {
    fleet::v1::GetRunReportRequest request;
    request.set_run_id(run_id);
    request.set_robot_id(run_robot);
    request.set_parameter_set(parameter_set);
    request.set_include_rerun_child(with_map);
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
    std::printf("divergence from the robot's map: %d vs %d nodes, node RMS %.3f m\n", r.divergence().robot_nodes(),
                r.divergence().rerun_nodes(), r.divergence().node_position_rms());
    if (r.has_ground_truth()) {
      std::printf("ground truth: trajectory RMSE %.3f m; wrong observations accepted %d/%d\n",
                  r.ground_truth().trajectory_rmse(), r.ground_truth().wrong_observations_accepted(),
                  r.ground_truth().wrong_observations());
    }
    std::printf("timings: replay %.3f s, detection %.3f s\n", r.replay_seconds(), r.detection_seconds());
    return 0;
  }
  if (*stats) {
    static const std::map<std::string, fleet::v1::GroupBy> kGroups = {
        {"none", fleet::v1::GROUP_BY_NONE},         {"day", fleet::v1::GROUP_BY_DAY},
        {"firmware", fleet::v1::GROUP_BY_FIRMWARE}, {"robot_model", fleet::v1::GROUP_BY_ROBOT_MODEL},
        {"parameter_set", fleet::v1::GROUP_BY_PARAMETER_SET}, {"robot", fleet::v1::GROUP_BY_ROBOT}};
    fleet::v1::GetFleetStatisticsRequest request;
    *request.mutable_filter() = filter.Proto();
    request.set_group_by(kGroups.at(group_by));
    fleet::v1::GetFleetStatisticsResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.queries->GetFleetStatistics(context.get(), request, &response); !status.ok()) {
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
  if (*compare) {
    fleet::v1::CompareParameterSetsRequest request;
    *request.mutable_filter() = filter.Proto();
    request.set_set_a(set_a);
    request.set_set_b(set_b);
    request.set_top(top);
    fleet::v1::CompareParameterSetsResponse response;
    auto context = client.Context(300);
    if (grpc::Status status = client.queries->CompareParameterSets(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
      return 0;
    }
    PrintFiguresHeader();
    PrintFiguresRow(set_a, response.a());
    PrintFiguresRow(set_b, response.b());
    PrintFiguresRow("delta (b - a)", response.delta());
    std::printf("\n%lld runs compared, %lld changed; most changed:\n", static_cast<long long>(response.runs_compared()),
                static_cast<long long>(response.runs_changed()));
    for (const auto& run : response.most_changed()) {
      std::printf("  %-28s change %5.0f  recovery acc %lld→%lld  merges %lld→%lld  ambiguous %lld→%lld  protrusions %lld→%lld\n",
                  run.run_id().c_str(), run.change(), static_cast<long long>(run.a().recovery_accepted()),
                  static_cast<long long>(run.b().recovery_accepted()), static_cast<long long>(run.a().merge_created()),
                  static_cast<long long>(run.b().merge_created()), static_cast<long long>(run.a().views_ambiguous()),
                  static_cast<long long>(run.b().views_ambiguous()), static_cast<long long>(run.a().protrusions_found()),
                  static_cast<long long>(run.b().protrusions_found()));
    }
    return 0;
  }
  if (*params_put) {
    auto set = analyzer::ReadParameterSetFile(params_file);
    if (!set.ok()) {
      std::cerr << "fleetctl: " << set.status().ToString() << "\n";
      return 2;
    }
    fleet::v1::PutParameterSetRequest request;
    *request.mutable_parameter_set() = *set;
    fleet::v1::PutParameterSetResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.reprocessing->PutParameterSet(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      std::cout << "parameter set " << set->name() << (response.already_present() ? " already stored" : " stored") << "\n";
    }
    return 0;
  }
  if (*params_list) {
    fleet::v1::ListParameterSetsResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.reprocessing->ListParameterSets(context.get(), {}, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      for (const auto& set : response.parameter_sets()) std::cout << set.name() << "  " << set.description() << "\n";
    }
    return 0;
  }
  if (*reprocess) {
    fleet::v1::StartJobRequest request;
    *request.mutable_filter() = filter.Proto();
    request.set_parameter_set(reprocess_set);
    fleet::v1::Job started;
    auto context = client.Context();
    if (grpc::Status status = client.reprocessing->StartJob(context.get(), request, &started); !status.ok()) {
      return Fail(status);
    }
    if (no_wait) {
      if (global.json) {
        PrintJson(started);
      } else {
        std::cout << "job " << started.job_id() << " started\n";
      }
      return 0;
    }
    fleet::v1::GetJobRequest watch;
    watch.set_job_id(started.job_id());
    auto watch_context = client.Context(24 * 3600);
    auto reader = client.reprocessing->WatchJob(watch_context.get(), watch);
    fleet::v1::Job update, last = started;
    while (reader->Read(&update)) {
      if (!global.json) ProgressBar(update);
      last = update;
    }
    if (!global.json && isatty(fileno(stderr))) std::fprintf(stderr, "\n");
    if (grpc::Status status = reader->Finish(); !status.ok()) return Fail(status);
    if (global.json) {
      PrintJson(last);
    } else {
      std::cout << "job " << last.job_id() << " " << last.state() << ": " << last.progress_done() << "/"
                << last.progress_total() << " runs analysed with " << reprocess_set << "\n";
    }
    return last.state() == "done" ? 0 : 1;
  }
  if (*jobs) {
    fleet::v1::ListJobsRequest request;
    request.set_state(state);
    request.set_limit(std::min(limit, 1000));
    fleet::v1::ListJobsResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.reprocessing->ListJobs(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
      return 0;
    }
    std::printf("%8s %-12s %-10s %-16s %12s  %s\n", "job", "kind", "state", "parameter set", "progress", "run/error");
    for (const auto& j : response.jobs()) {
      std::printf("%8lld %-12s %-10s %-16s %5lld/%-6lld  %s\n", static_cast<long long>(j.job_id()), j.kind().c_str(),
                  j.state().c_str(), j.parameter_set().c_str(), static_cast<long long>(j.progress_done()),
                  static_cast<long long>(j.progress_total()), j.last_error().empty() ? j.run_id().c_str() : j.last_error().c_str());
    }
    return 0;
  }
  if (*job || *cancel) {
    fleet::v1::Job response;
    auto context = client.Context();
    grpc::Status status;
    if (*job) {
      fleet::v1::GetJobRequest request;
      request.set_job_id(job_id);
      status = client.reprocessing->GetJob(context.get(), request, &response);
    } else {
      fleet::v1::CancelJobRequest request;
      request.set_job_id(job_id);
      status = client.reprocessing->CancelJob(context.get(), request, &response);
    }
    if (!status.ok()) return Fail(status);
    if (global.json) {
      PrintJson(response);
    } else {
      std::printf("job %lld %s %s: %lld/%lld %s\n", static_cast<long long>(response.job_id()), response.kind().c_str(),
                  response.state().c_str(), static_cast<long long>(response.progress_done()),
                  static_cast<long long>(response.progress_total()), response.last_error().c_str());
    }
    return 0;
  }
  if (*regions) {
    fleet::v1::ListRegionsRequest request;
    request.set_run_id(run_id);
    request.set_robot_id(run_robot);
    request.set_parameter_set(parameter_set);
    fleet::v1::ListRegionsResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.labels->ListRegions(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
      return 0;
    }
    std::printf("%6s %-12s %6s %-12s %-10s %s\n", "region", "predicted", "p", "label", "by", "bbox (cells)");
    for (const auto& r : response.regions()) {
      std::printf("%6lld %-12s %6.2f %-12s %-10s [%g %g %g %g]\n", static_cast<long long>(r.region_id()),
                  r.predicted_class().c_str(), r.probability(), r.label().c_str(), r.labelled_by().c_str(), r.bbox(0),
                  r.bbox(1), r.bbox(2), r.bbox(3));
    }
    return 0;
  }
  if (*label) {
    fleet::v1::LabelRegionRequest request;
    request.set_run_id(run_id);
    request.set_robot_id(run_robot);
    request.set_parameter_set(parameter_set);
    request.set_region_id(region_id);
    request.set_label(label_value);
    fleet::v1::LabelRegionResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.labels->LabelRegion(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      std::cout << "region " << region_id << " of " << run_id << " labelled " << label_value << "\n";
    }
    return 0;
  }
  if (*label_from_truth) {
    // Runs page by page; each report says which regions are slip artefacts by the simulator's truth.
    int labelled = 0, runs_seen = 0;
    std::string token;
    do {
      fleet::v1::ListRunsRequest list;
      *list.mutable_filter() = filter.Proto();
      list.set_page_size(500);
      list.set_page_token(token);
      fleet::v1::ListRunsResponse page;
      if (grpc::Status status = client.CallRetrying(
              [&](grpc::ClientContext* context) { return client.queries->ListRuns(context, list, &page); });
          !status.ok()) {
        return Fail(status);
      }
      for (const auto& run : page.runs()) {
        ++runs_seen;
        fleet::v1::GetRunReportRequest request;
        request.set_run_id(run.run_id());
        request.set_robot_id(run.robot_id());
        request.set_parameter_set(parameter_set);
        fleet::v1::GetRunReportResponse response;
        if (grpc::Status status = client.CallRetrying([&](grpc::ClientContext* context) {
              return client.queries->GetRunReport(context, request, &response);
            });
            !status.ok()) {
          if (status.error_code() == grpc::StatusCode::NOT_FOUND) continue;  // not analysed yet
          return Fail(status);
        }
        for (const auto& region : response.report().protrusion_regions()) {
          if (!region.has_truth_protrusion()) continue;
          fleet::v1::LabelRegionRequest label_request;
          label_request.set_run_id(run.run_id());
          label_request.set_robot_id(run.robot_id());
          label_request.set_parameter_set(parameter_set);
          label_request.set_region_id(region.id());
          label_request.set_label(region.truth_protrusion() ? "protrusion" : "new_space");
          fleet::v1::LabelRegionResponse label_response;
          if (grpc::Status status = client.CallRetrying([&](grpc::ClientContext* context) {
                return client.labels->LabelRegion(context, label_request, &label_response);
              });
              !status.ok()) {
            return Fail(status);
          }
          ++labelled;
        }
      }
      token = page.next_page_token();
    } while (!token.empty());
    std::cout << labelled << " regions of " << runs_seen << " runs labelled from ground truth\n";
    return 0;
  }
  if (*train) {
    fleet::v1::TrainModelRequest request;
    request.set_name(model_name);
    request.set_classifier(classifier);
    request.set_parameter_set(parameter_set);
    fleet::v1::TrainModelResponse response;
    auto context = client.Context(3600);
    if (grpc::Status status = client.models->TrainModel(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      const auto& cv = response.cross_validation();
      std::printf("model %s version %lld (%s) from %lld regions; ", model_name.c_str(),
                  static_cast<long long>(response.model().version()), response.model().classifier().c_str(),
                  static_cast<long long>(response.training_regions()));
      if (cv.folds() >= 2) {
        std::printf("%d-fold CV precision %.3f recall %.3f FPR %.3f\n", cv.folds(), cv.precision(), cv.recall(),
                    cv.false_positive_rate());
      } else {
        std::printf("not cross-validated (too few labelled runs of each class to hold out)\n");
      }
    }
    return 0;
  }
  if (*eval) {
    fleet::v1::EvaluateModelRequest request;
    request.set_name(model_name);
    request.set_version(version);
    request.set_parameter_set(parameter_set);
    fleet::v1::EvaluateModelResponse response;
    auto context = client.Context(600);
    if (grpc::Status status = client.models->EvaluateModel(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      const auto& e = response.evaluation();
      std::printf("model %s v%lld on %lld regions: precision %.3f recall %.3f FPR %.3f accuracy %.3f\n",
                  model_name.c_str(), static_cast<long long>(response.model().version()),
                  static_cast<long long>(response.regions()), e.precision(), e.recall(), e.false_positive_rate(),
                  e.accuracy());
    }
    return 0;
  }
  if (*activate) {
    fleet::v1::ActivateModelRequest request;
    request.set_name(model_name);
    request.set_version(version);
    fleet::v1::Model response;
    auto context = client.Context();
    if (grpc::Status status = client.models->ActivateModel(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
    } else {
      std::cout << "model " << model_name << " version " << version << " is active\n";
    }
    return 0;
  }
  if (*models_list) {
    fleet::v1::ListModelsRequest request;
    request.set_name(model_name);
    fleet::v1::ListModelsResponse response;
    auto context = client.Context();
    if (grpc::Status status = client.models->ListModels(context.get(), request, &response); !status.ok()) {
      return Fail(status);
    }
    if (global.json) {
      PrintJson(response);
      return 0;
    }
    for (const auto& m : response.models()) {
      std::printf("%s v%lld %-14s threshold %.2f%s\n", m.name().c_str(), static_cast<long long>(m.version()),
                  m.classifier().c_str(), m.threshold(), m.active() ? "  (active)" : "");
    }
    return 0;
  }
  return 2;
}
