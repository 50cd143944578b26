#include "maps_handler.h"

#include <algorithm>
#include <string>
#include <vector>

#include "analyzer/telemetry_codec.h"
#include "convert.h"
#include "fleet/snapshot_parts.h"

namespace server {

grpc::Status MapsHandler::ListMapVersions(grpc::ServerContext* call,
                                          const fleet::v1::ListMapVersionsRequest* request,
                                          fleet::v1::ListMapVersionsResponse* response) {
  RpcScope scope(context_.metrics, "Maps/ListMapVersions");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return scope.Done(denied);
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  std::int64_t current = 0, head = 0;
  auto versions = history_.List(request->robot_id(), &current, &head);
  if (!versions.ok()) return scope.Done(ToGrpc(versions.status()));
  for (auto& version : *versions) *response->add_versions() = std::move(version);
  response->set_current_version(current);
  response->set_head_version(head);
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::ListRobots(grpc::ServerContext* call, const fleet::v1::ListRobotsRequest* request,
                                     fleet::v1::ListRobotsResponse* response) {
  RpcScope scope(context_.metrics, "Maps/ListRobots");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return scope.Done(denied);
  if (request->page_size() < 0 || request->page_size() > storage::kMaxRobotPage) {
    return scope.Done(InvalidArgument("page_size: expected 1.." + std::to_string(storage::kMaxRobotPage) +
                                      " (0: " + std::to_string(storage::RobotSummaryQuery().limit) +
                                      "), got " + std::to_string(request->page_size())));
  }
  if (!request->after_robot_id().empty()) {
    if (auto bad = analyzer::ValidateId(request->after_robot_id(), "after_robot_id"); !bad.ok())
      return scope.Done(InvalidArgument(bad.message()));
  }
  storage::RobotSummaryQuery query;
  query.after_robot_id = request->after_robot_id();
  if (request->page_size() != 0) query.limit = request->page_size();
  query.only_pending = request->only_pending();
  auto page = context_.repository->ListRobotSummaries(query);
  if (!page.ok()) return scope.Done(ToGrpc(page.status()));
  for (const storage::RobotMapSummary& summary : page->robots) *response->add_robots() = ToProto(summary);
  if (page->more) response->set_next_after_robot_id(page->robots.back().robot.robot_id);
  response->set_total(page->total);
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::GetMapVersion(grpc::ServerContext* call,
                                        const fleet::v1::GetMapVersionRequest* request,
                                        fleet::v1::GetMapVersionResponse* response) {
  RpcScope scope(context_.metrics, "Maps/GetMapVersion");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return scope.Done(denied);
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  auto detail = history_.Get(request->robot_id(), request->version(),
                             request->include_snapshot() ? response->mutable_snapshot() : nullptr);
  if (!detail.ok()) return scope.Done(ToGrpc(detail.status()));
  *response->mutable_version() = std::move(detail->version);
  for (auto& finding : detail->findings) *response->add_findings() = std::move(finding);
  if (detail->metadata) *response->mutable_metadata() = std::move(*detail->metadata);
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::RepairMap(grpc::ServerContext* call, const fleet::v1::RepairMapRequest* request,
                                    fleet::v1::RepairMapResponse* response) {
  RpcScope scope(context_.metrics, "Maps/RepairMap");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRepairMap, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  if (request->base_version() <= 0)
    return scope.Done(InvalidArgument("base_version: required (the version repaired)"));
  RepairRequest repair;
  repair.robot_id = request->robot_id();
  repair.base_version = request->base_version();
  repair.reason = request->reason();
  repair.approve = request->approve();
  repair.requested_by = principal.name;
  switch (request->action_case()) {
    case fleet::v1::RepairMapRequest::kRejectEdge: {
      RejectEdge edge{request->reject_edge().from(), request->reject_edge().to(), std::nullopt};
      if (request->reject_edge().has_view()) edge.view = request->reject_edge().view();
      repair.action = edge;
      break;
    }
    case fleet::v1::RepairMapRequest::kRejectHypothesis:
      repair.action = RejectHypothesis{request->reject_hypothesis()};
      break;
    case fleet::v1::RepairMapRequest::kCutFinding: repair.action = CutFinding{request->cut_finding()}; break;
    case fleet::v1::RepairMapRequest::kRollback: repair.action = Rollback{}; break;
    case fleet::v1::RepairMapRequest::kUndo: repair.action = Undo{}; break;
    case fleet::v1::RepairMapRequest::ACTION_NOT_SET:
      return scope.Done(
          InvalidArgument("action: set one of reject_edge, reject_hypothesis, cut_finding, rollback, undo"));
  }
  auto repaired = history_.Repair(repair);
  if (!repaired.ok()) return scope.Done(ToGrpc(repaired.status()));
  *response->mutable_version() = std::move(repaired->version);
  for (auto& finding : repaired->findings) *response->add_findings() = std::move(finding);
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::ReviewMapVersion(grpc::ServerContext* call,
                                           const fleet::v1::ReviewMapVersionRequest* request,
                                           fleet::v1::MapVersion* response) {
  RpcScope scope(context_.metrics, "Maps/ReviewMapVersion");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRepairMap, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  if (request->version() <= 0) return scope.Done(InvalidArgument("version: required"));
  auto reviewed =
      history_.Review(request->robot_id(), request->version(), request->approve(), principal.name);
  if (!reviewed.ok()) return scope.Done(ToGrpc(reviewed.status()));
  *response = std::move(reviewed).value();
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::AnswerMapRequest(grpc::ServerContext* call, const fleet::v1::GetMapRequest& request,
                                           bool streamed, fleet::v1::GetMapResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kFetchMap, &principal); !denied.ok()) {
    return denied;
  }
  if (auto bad = analyzer::ValidateId(request.robot_id(), "robot_id"); !bad.ok()) {
    return InvalidArgument(bad.message());
  }
  if (streamed && request.part_bytes() != 0 &&
      (request.part_bytes() < kMinMapPartBytes || request.part_bytes() > kMaxMapPartBytes)) {
    return InvalidArgument("part_bytes: expected " + std::to_string(kMinMapPartBytes) + ".." +
                           std::to_string(kMaxMapPartBytes) + " (0: " + std::to_string(kDefaultMapPartBytes) +
                           "), got " + std::to_string(request.part_bytes()));
  }
  if (principal.role == Role::kRobot && principal.id != request.robot_id()) {
    return {grpc::StatusCode::PERMISSION_DENIED,
            principal.name + " may fetch only its own map, not robot " + request.robot_id() + "'s"};
  }
  bool up_to_date = false;
  auto current =
      history_.Fetch(request.robot_id(), request.held_version(), &up_to_date, response->mutable_snapshot());
  if (!current.ok()) return ToGrpc(current.status());
  response->set_up_to_date(up_to_date);
  *response->mutable_version() = std::move(current).value();
  return grpc::Status::OK;
}

grpc::Status MapsHandler::GetMap(grpc::ServerContext* call, const fleet::v1::GetMapRequest* request,
                                 fleet::v1::GetMapResponse* response) {
  RpcScope scope(context_.metrics, "Maps/GetMap");
  return scope.Done(AnswerMapRequest(call, *request, /*streamed=*/false, response));
}

grpc::Status MapsHandler::StreamMap(grpc::ServerContext* call, const fleet::v1::GetMapRequest* request,
                                    grpc::ServerWriter<fleet::v1::GetMapResponse>* writer) {
  RpcScope scope(context_.metrics, "Maps/StreamMap");
  fleet::v1::GetMapResponse whole;
  if (grpc::Status answered = AnswerMapRequest(call, *request, /*streamed=*/true, &whole); !answered.ok()) {
    return scope.Done(answered);
  }
  std::vector<fleet::v1::MapSnapshot> parts;
  if (whole.has_snapshot()) {
    parts = fleet::SnapshotParts(
        std::move(*whole.mutable_snapshot()),
        static_cast<std::size_t>(request->part_bytes() != 0 ? request->part_bytes() : kDefaultMapPartBytes));
    whole.clear_snapshot();
  }
  // The first message: the answer's own fields and the first part; then one message per further part.
  for (std::size_t k = 0; k < std::max<std::size_t>(parts.size(), 1); ++k) {
    fleet::v1::GetMapResponse message;
    if (k == 0) message = std::move(whole);
    if (k < parts.size()) *message.mutable_snapshot() = std::move(parts[k]);
    if (!writer->Write(message)) {
      return scope.Done({grpc::StatusCode::CANCELLED, "the client left before the map's part " +
                                                          std::to_string(k + 1) + " of " +
                                                          std::to_string(parts.size())});
    }
  }
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::ExportMap(grpc::ServerContext* call, const fleet::v1::ExportMapRequest* request,
                                    fleet::v1::ExportMapResponse* response) {
  RpcScope scope(context_.metrics, "Maps/ExportMap");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRead, &principal); !denied.ok())
    return scope.Done(denied);
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  auto files = history_.Export(request->robot_id(), request->version(), request->format());
  if (!files.ok()) return scope.Done(ToGrpc(files.status()));
  for (auto& file : *files) *response->add_files() = std::move(file);
  return scope.Done(grpc::Status::OK);
}

grpc::Status MapsHandler::ImportMap(grpc::ServerContext* call, const fleet::v1::ImportMapRequest* request,
                                    fleet::v1::ImportMapResponse* response) {
  RpcScope scope(context_.metrics, "Maps/ImportMap");
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kRepairMap, &principal); !denied.ok()) {
    return scope.Done(denied);
  }
  if (auto bad = analyzer::ValidateId(request->robot_id(), "robot_id"); !bad.ok()) {
    return scope.Done(InvalidArgument(bad.message()));
  }
  if (!request->has_snapshot()) return scope.Done(InvalidArgument("snapshot: required (the imported map)"));
  if (request->source().size() > 1024) return scope.Done(InvalidArgument("source: longer than 1024 bytes"));
  if (request->reason().size() > 4096) return scope.Done(InvalidArgument("reason: longer than 4096 bytes"));
  auto imported = history_.Import(request->robot_id(), request->snapshot(), request->metadata(),
                                  request->source(), request->reason(), request->approve(), principal.name);
  if (!imported.ok()) return scope.Done(ToGrpc(imported.status()));
  *response->mutable_version() = std::move(imported).value();
  return scope.Done(grpc::Status::OK);
}

}  // namespace server
