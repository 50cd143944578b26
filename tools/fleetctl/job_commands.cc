#include "job_commands.h"

#include <unistd.h>

#include <cstdio>

#include "analyzer/parameters.h"

namespace fleetctl {
namespace {

void ProgressBar(const fleet::v1::Job& job) {
  if (!isatty(fileno(stderr))) {
    std::fprintf(stderr, "job %lld %s %lld/%lld\n", static_cast<long long>(job.job_id()), job.state().c_str(),
                 static_cast<long long>(job.progress_done()), static_cast<long long>(job.progress_total()));
    return;
  }
  const int width = 40;
  const long long total = std::max<long long>(1, job.progress_total());
  const int filled = static_cast<int>(width * std::min<long long>(job.progress_done(), total) / total);
  std::fprintf(stderr, "\r[%.*s%*s] %lld/%lld runs  %s   ", filled,
               "########################################", width - filled, "",
               static_cast<long long>(job.progress_done()), static_cast<long long>(job.progress_total()),
               job.state().c_str());
}

}  // namespace

JobCommands::JobCommands(CLI::App& app) {
  auto* params = app.add_subcommand("params", "parameter sets");
  params->require_subcommand(1);
  params_put_ = params->add_subcommand("put", "store a parameter set from a JSON file");
  params_put_->add_option("file", params_file_, "JSON file")->required();
  params_list_ = params->add_subcommand("list", "list parameter sets");

  reprocess_ = app.add_subcommand("reprocess", "reanalyse runs with a parameter set");
  reprocess_->add_option("--with", reprocess_set_, "parameter set to analyse with")->required();
  reprocess_->add_option("--robot", filter_.robot, "robot id");
  reprocess_->add_option("--firmware", filter_.firmware, "firmware");
  reprocess_->add_option("--model", filter_.model, "robot model");
  reprocess_->add_option("--only-with-set", filter_.parameter_set,
                         "only runs that have a report of this set");
  reprocess_->add_option("--from", filter_.from, "started at or after (Unix seconds)");
  reprocess_->add_option("--before", filter_.before, "started before (Unix seconds)");
  reprocess_->add_flag("--no-wait", no_wait_, "start the job and return");

  jobs_ = app.add_subcommand("jobs", "list jobs");
  jobs_->add_option("--state", state_, "queued, leased, done, failed, cancelled");
  jobs_->add_option("--limit", limit_, "at most this many");
  job_ = app.add_subcommand("job", "one job");
  job_->add_option("id", job_id_, "job id")->required();
  cancel_ = app.add_subcommand("cancel", "cancel a job");
  cancel_->add_option("id", job_id_, "job id")->required();
}

std::optional<int> JobCommands::Run(Client& client, const Global& global) const {
  if (params_put_->parsed()) return PutParameterSet(client, global);
  if (params_list_->parsed()) return ListParameterSets(client, global);
  if (reprocess_->parsed()) return Reprocess(client, global);
  if (jobs_->parsed()) return ListJobs(client, global);
  if (job_->parsed() || cancel_->parsed()) return OneJob(client, global);
  return std::nullopt;
}

int JobCommands::PutParameterSet(Client& client, const Global& global) const {
  auto set = analyzer::ReadParameterSetFile(params_file_);
  if (!set.ok()) {
    std::cerr << "fleetctl: " << set.status().ToString() << "\n";
    return 2;
  }
  fleet::v1::PutParameterSetRequest request;
  *request.mutable_parameter_set() = *set;
  fleet::v1::PutParameterSetResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.reprocessing->PutParameterSet(context.get(), request, &response);
      !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    std::cout << "parameter set " << set->name()
              << (response.already_present() ? " already stored" : " stored") << "\n";
  }
  return 0;
}

int JobCommands::ListParameterSets(Client& client, const Global& global) const {
  fleet::v1::ListParameterSetsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.reprocessing->ListParameterSets(context.get(), {}, &response);
      !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
  } else {
    for (const auto& set : response.parameter_sets())
      std::cout << set.name() << "  " << set.description() << "\n";
  }
  return 0;
}

int JobCommands::Reprocess(Client& client, const Global& global) const {
  fleet::v1::StartJobRequest request;
  *request.mutable_filter() = filter_.Proto();
  request.set_parameter_set(reprocess_set_);
  fleet::v1::Job started;
  auto context = client.Context();
  if (grpc::Status status = client.reprocessing->StartJob(context.get(), request, &started); !status.ok()) {
    return Fail(status);
  }
  if (no_wait_) {
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
              << last.progress_total() << " runs analysed with " << reprocess_set_ << "\n";
  }
  return last.state() == "done" ? 0 : 1;
}

int JobCommands::ListJobs(Client& client, const Global& global) const {
  fleet::v1::ListJobsRequest request;
  request.set_state(state_);
  request.set_limit(std::min(limit_, 1000));
  fleet::v1::ListJobsResponse response;
  auto context = client.Context();
  if (grpc::Status status = client.reprocessing->ListJobs(context.get(), request, &response); !status.ok()) {
    return Fail(status);
  }
  if (global.json) {
    PrintJson(response);
    return 0;
  }
  std::printf("%8s %-12s %-10s %-16s %12s  %s\n", "job", "kind", "state", "parameter set", "progress",
              "run/error");
  for (const auto& j : response.jobs()) {
    std::printf("%8lld %-12s %-10s %-16s %5lld/%-6lld  %s\n", static_cast<long long>(j.job_id()),
                j.kind().c_str(), j.state().c_str(), j.parameter_set().c_str(),
                static_cast<long long>(j.progress_done()), static_cast<long long>(j.progress_total()),
                j.last_error().empty() ? j.run_id().c_str() : j.last_error().c_str());
  }
  return 0;
}

int JobCommands::OneJob(Client& client, const Global& global) const {
  fleet::v1::Job response;
  auto context = client.Context();
  grpc::Status status;
  if (job_->parsed()) {
    fleet::v1::GetJobRequest request;
    request.set_job_id(job_id_);
    status = client.reprocessing->GetJob(context.get(), request, &response);
  } else {
    fleet::v1::CancelJobRequest request;
    request.set_job_id(job_id_);
    status = client.reprocessing->CancelJob(context.get(), request, &response);
  }
  if (!status.ok()) return Fail(status);
  if (global.json) {
    PrintJson(response);
  } else {
    std::printf("job %lld %s %s: %lld/%lld %s\n", static_cast<long long>(response.job_id()),
                response.kind().c_str(), response.state().c_str(),
                static_cast<long long>(response.progress_done()),
                static_cast<long long>(response.progress_total()), response.last_error().c_str());
  }
  return 0;
}

}  // namespace fleetctl
