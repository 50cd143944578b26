#include "reprocessing_handler.h"

#include <algorithm>
#include <thread>

#include "analyzer/parameters.h"
#include "convert.h"
#include "fleet/serialization.h"
#include "server/jobs.h"
#include "server/log.h"

namespace server {
namespace {

bool ValidName(const std::string& name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

/// What a parameter set's name must be; the name given is not echoed (it may be megabytes long).
std::string NameRule(const std::string& field) {
  return field + ": 1-64 characters of [A-Za-z0-9_.-] required";
}

bool Terminal(const std::string& state) {
  return state == "done" || state == "failed" || state == "cancelled";
}

}  // namespace

grpc::Status ReprocessingHandler::StoreParameterSet(storage::Repository& repository,
                                                    const fleet::v1::ParameterSet& set,
                                                    const std::string& field, bool* already_present) {
  if (!ValidName(set.name())) return InvalidArgument(NameRule(field + ".name"));
  if (auto mapper = analyzer::FromProto(set.mapper()); !mapper.ok()) {
    return InvalidArgument(field + ".mapper: " + mapper.status().message());
  }
  storage::ParameterSetRecord record;
  record.name = set.name();
  record.serialized = fleet::SerializeDeterministic(set);
  auto stored = repository.PutParameterSet(record);
  if (!stored.ok()) {
    if (stored.status().code() == storage::StatusCode::kAlreadyExists) {
      return {grpc::StatusCode::ALREADY_EXISTS,
              field + ".name: parameter set \"" + set.name() +
                  "\" is stored with other values; sets are immutable, pick a new name"};
    }
    return ToGrpc(stored.status());
  }
  *already_present = *stored == storage::InsertOutcome::kAlreadyPresent;
  return grpc::Status::OK;
}

grpc::Status ReprocessingHandler::PutParameterSet(grpc::ServerContext* call,
                                                  const fleet::v1::PutParameterSetRequest* request,
                                                  fleet::v1::PutParameterSetResponse* response) {
  RpcScope scope(context_.metrics, "Reprocessing/PutParameterSet");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kReprocess, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (!request->has_parameter_set()) return scope.Done(InvalidArgument("parameter_set: required"));
  bool already = false;
  grpc::Status status =
      StoreParameterSet(*context_.repository, request->parameter_set(), "parameter_set", &already);
  if (status.ok()) {
    response->set_already_present(already);
    log::Info("parameter_set_stored",
              {{"name", request->parameter_set().name()}, {"principal", principal.name}});
  }
  return scope.Done(status);
}

grpc::Status ReprocessingHandler::ListParameterSets(grpc::ServerContext* call,
                                                    const fleet::v1::ListParameterSetsRequest* /*request*/,
                                                    fleet::v1::ListParameterSetsResponse* response) {
  RpcScope scope(context_.metrics, "Reprocessing/ListParameterSets");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  auto names = context_.repository->ListParameterSetNames();
  if (!names.ok()) return scope.Done(ToGrpc(names.status()));
  for (const auto& name : *names) {
    auto record = context_.repository->GetParameterSet(name);
    if (!record.ok()) return scope.Done(ToGrpc(record.status()));
    if (!response->add_parameter_sets()->ParseFromString(record->serialized)) {
      return scope.Done({grpc::StatusCode::DATA_LOSS, "parameter set " + name + " does not parse"});
    }
  }
  return scope.Done(grpc::Status::OK);
}

grpc::Status ReprocessingHandler::LoadJob(std::int64_t job_id, fleet::v1::Job* job) {
  if (job_id <= 0) return InvalidArgument("job_id: must be positive");
  auto record = context_.repository->GetJob(job_id);
  if (!record.ok()) {
    if (record.status().code() == storage::StatusCode::kNotFound) {
      return {grpc::StatusCode::NOT_FOUND, "job_id: no job " + std::to_string(job_id)};
    }
    return ToGrpc(record.status());
  }
  *job = ToProto(*record);
  return grpc::Status::OK;
}

grpc::Status ReprocessingHandler::StartJob(grpc::ServerContext* call,
                                           const fleet::v1::StartJobRequest* request,
                                           fleet::v1::Job* response) {
  RpcScope scope(context_.metrics, "Reprocessing/StartJob");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kReprocess, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->parameter_set().empty()) return scope.Done(InvalidArgument("parameter_set: required"));
  if (!ValidName(request->parameter_set())) return scope.Done(InvalidArgument(NameRule("parameter_set")));
  auto stored = context_.repository->GetParameterSet(request->parameter_set());
  if (!stored.ok()) {
    if (stored.status().code() == storage::StatusCode::kNotFound) {
      return scope.Done({grpc::StatusCode::NOT_FOUND, "parameter_set: no parameter set \"" +
                                                          request->parameter_set() +
                                                          "\"; store it with PutParameterSet first"});
    }
    return scope.Done(ToGrpc(stored.status()));
  }
  auto filter = FromProto(request->filter(), "filter");
  if (!filter.ok()) return scope.Done(ToGrpc(filter.status()));
  storage::NewJob job;
  job.kind = kReprocessJob;
  job.payload = EncodeReprocessPayload({request->parameter_set(), *filter});
  job.max_attempts = 20;  // a coordinator that shuts down hands the job back; that costs an attempt
  if (!filter->robot_id.empty()) job.robot_id = filter->robot_id;
  auto id = context_.repository->EnqueueJob(job);
  if (!id.ok()) return scope.Done(ToGrpc(id.status()));
  if (context_.job_enqueued) context_.job_enqueued();
  log::Info("reprocess_requested", {{"job", static_cast<long long>(*id)},
                                    {"parameter_set", request->parameter_set()},
                                    {"principal", principal.name}});
  return scope.Done(LoadJob(*id, response));
}

grpc::Status ReprocessingHandler::GetJob(grpc::ServerContext* call, const fleet::v1::GetJobRequest* request,
                                         fleet::v1::Job* response) {
  RpcScope scope(context_.metrics, "Reprocessing/GetJob");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  return scope.Done(LoadJob(request->job_id(), response));
}

grpc::Status ReprocessingHandler::ListJobs(grpc::ServerContext* call,
                                           const fleet::v1::ListJobsRequest* request,
                                           fleet::v1::ListJobsResponse* response) {
  RpcScope scope(context_.metrics, "Reprocessing/ListJobs");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->limit() < 0 || request->limit() > 1000)
    return scope.Done(InvalidArgument("limit: expected 0..1000"));
  std::optional<storage::JobState> state;
  if (!request->state().empty()) {
    auto parsed = storage::Parse<storage::JobState>(request->state());
    if (!parsed.ok()) return scope.Done(InvalidArgument("state: " + parsed.status().message()));
    state = *parsed;
  }
  if (!request->kind().empty() && request->kind() != kReprocessJob && request->kind() != kAnalyzeRunJob) {
    return scope.Done(InvalidArgument("kind: unknown \"" + request->kind() + "\" (reprocess, analyze_run)"));
  }
  const int limit = request->limit() == 0 ? 100 : request->limit();
  // Newest first is what people want; storage lists by id ascending, so read generously and keep the tail.
  auto jobs = context_.repository->ListJobs(state, 1000000);
  if (!jobs.ok()) return scope.Done(ToGrpc(jobs.status()));
  for (auto it = jobs->rbegin(); it != jobs->rend() && response->jobs_size() < limit; ++it) {
    if (!request->kind().empty() && it->kind != request->kind()) continue;
    *response->add_jobs() = ToProto(*it);
  }
  return scope.Done(grpc::Status::OK);
}

grpc::Status ReprocessingHandler::CancelJob(grpc::ServerContext* call,
                                            const fleet::v1::CancelJobRequest* request,
                                            fleet::v1::Job* response) {
  RpcScope scope(context_.metrics, "Reprocessing/CancelJob");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kReprocess, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->job_id() <= 0) return scope.Done(InvalidArgument("job_id: must be positive"));
  storage::Status cancelled = context_.repository->CancelJob(request->job_id());
  if (!cancelled.ok()) {
    if (cancelled.code() == storage::StatusCode::kNotFound) {
      return scope.Done({grpc::StatusCode::NOT_FOUND, "job_id: no job " + std::to_string(request->job_id())});
    }
    if (cancelled.code() == storage::StatusCode::kFailedPrecondition) {
      return scope.Done({grpc::StatusCode::FAILED_PRECONDITION,
                         "job_id: job " + std::to_string(request->job_id()) + " already finished"});
    }
    return scope.Done(ToGrpc(cancelled));
  }
  log::Info("job_cancelled",
            {{"job", static_cast<long long>(request->job_id())}, {"principal", principal.name}});
  return scope.Done(LoadJob(request->job_id(), response));
}

grpc::Status ReprocessingHandler::WatchJob(grpc::ServerContext* call, const fleet::v1::GetJobRequest* request,
                                           grpc::ServerWriter<fleet::v1::Job>* writer) {
  RpcScope scope(context_.metrics, "Reprocessing/WatchJob");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  fleet::v1::Job last;
  bool first = true;
  while (true) {
    fleet::v1::Job job;
    if (grpc::Status status = LoadJob(request->job_id(), &job); !status.ok()) return scope.Done(status);
    const bool changed = first || job.state() != last.state() ||
                         job.progress_done() != last.progress_done() ||
                         job.progress_total() != last.progress_total();
    if (changed) {
      if (!writer->Write(job)) return scope.Done({grpc::StatusCode::CANCELLED, "watcher went away"});
      last = job;
      first = false;
    }
    if (Terminal(job.state())) return scope.Done(grpc::Status::OK);
    for (int i = 0; i < 4; ++i) {
      if (call->IsCancelled())
        return scope.Done({grpc::StatusCode::CANCELLED, "cancelled or deadline exceeded"});
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
}

}  // namespace server
