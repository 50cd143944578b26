#include "labels_handler.h"

#include "convert.h"
#include "run_lookup.h"
#include "server/log.h"

namespace server {

grpc::Status LabelsHandler::ReportMissing(const storage::RunKey& run, const std::string& set) {
  const std::string& run_id = run.run_id;
  auto report = context_.repository->GetReport(run, set);
  if (report.ok()) return grpc::Status::OK;
  if (report.status().code() != storage::StatusCode::kNotFound) return ToGrpc(report.status());
  return {grpc::StatusCode::NOT_FOUND,
          "run_id: no report for run \"" + run_id + "\" with parameter set \"" + set + "\""};
}

grpc::Status LabelsHandler::ListRegions(grpc::ServerContext* call,
                                        const fleet::v1::ListRegionsRequest* request,
                                        fleet::v1::ListRegionsResponse* response) {
  RpcScope scope(context_.metrics, "Labels/ListRegions");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->run_id().empty()) return scope.Done(InvalidArgument("run_id: required"));
  const std::string set =
      request->parameter_set().empty() ? context_.default_parameter_set : request->parameter_set();
  auto run = ResolveRun(*context_.repository, principal, request->robot_id(), request->run_id());
  if (!run.ok()) return scope.Done(ToGrpc(run.status()));
  auto regions = context_.repository->ListProtrusionRegions(*run, set);
  if (!regions.ok()) return scope.Done(ToGrpc(regions.status()));
  if (regions->empty()) {
    if (grpc::Status missing = ReportMissing(*run, set); !missing.ok()) return scope.Done(missing);
  }
  for (const auto& region : *regions) *response->add_regions() = ToProto(region);
  return scope.Done(grpc::Status::OK);
}

grpc::Status LabelsHandler::LabelRegion(grpc::ServerContext* call,
                                        const fleet::v1::LabelRegionRequest* request,
                                        fleet::v1::LabelRegionResponse* response) {
  RpcScope scope(context_.metrics, "Labels/LabelRegion");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kLabel, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (request->run_id().empty()) return scope.Done(InvalidArgument("run_id: required"));
  if (request->label() != "protrusion" && request->label() != "new_space") {
    return scope.Done(
        InvalidArgument("label: expected \"protrusion\" or \"new_space\", got \"" + request->label() + "\""));
  }
  if (request->region_id() < 0) return scope.Done(InvalidArgument("region_id: must be >= 0"));
  const std::string set =
      request->parameter_set().empty() ? context_.default_parameter_set : request->parameter_set();
  auto run = ResolveRun(*context_.repository, principal, request->robot_id(), request->run_id());
  if (!run.ok()) return scope.Done(ToGrpc(run.status()));
  storage::Status labelled = context_.repository->LabelProtrusionRegion(*run, set, request->region_id(),
                                                                        request->label(), principal.name);
  if (!labelled.ok()) {
    if (labelled.code() == storage::StatusCode::kNotFound) {
      if (grpc::Status missing = ReportMissing(*run, set); !missing.ok()) return scope.Done(missing);
      return scope.Done({grpc::StatusCode::NOT_FOUND,
                         "region_id: run \"" + request->run_id() + "\" has no region " +
                             std::to_string(request->region_id()) + " in set \"" + set + "\""});
    }
    return scope.Done(ToGrpc(labelled));
  }
  auto regions = context_.repository->ListProtrusionRegions(*run, set);
  if (regions.ok()) {
    for (const auto& region : *regions) {
      if (region.region_id == request->region_id()) *response->mutable_region() = ToProto(region);
    }
  }
  log::Info("region_labelled", {{"run_id", request->run_id()},
                                {"robot_id", run->robot_id},
                                {"region", static_cast<long long>(request->region_id())},
                                {"label", request->label()},
                                {"principal", principal.name}});
  return scope.Done(grpc::Status::OK);
}

}  // namespace server
