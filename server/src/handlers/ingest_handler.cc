#include "ingest_handler.h"

#include <algorithm>
#include <optional>

#include "analyzer/telemetry_codec.h"
#include "fleet/serialization.h"
#include "server/jobs.h"
#include "server/log.h"

namespace server {
namespace {

// A snapshot may come in parts, consecutive messages of its kind merged in order (a protobuf merge: repeated
// fields concatenated): a robot's map outgrows one message long before a run outgrows max_run_bytes. The
// first part is moved in whole.
void AddSnapshotPart(fleet::v1::MapSnapshot* part, fleet::v1::MapSnapshot* snapshot,
                     bool have_earlier_parts) {
  if (have_earlier_parts) {
    snapshot->MergeFrom(*part);
  } else {
    *snapshot = std::move(*part);
  }
}

}  // namespace

grpc::Status IngestHandler::UploadRun(grpc::ServerContext* call,
                                      grpc::ServerReader<fleet::v1::UploadRunRequest>* reader,
                                      fleet::v1::UploadRunResponse* response) {
  RpcScope scope(context_.metrics, "Ingest/UploadRun");
  grpc::Status status = Upload(call, reader, response);
  if (!status.ok()) {
    context_.metrics->Increment("fleetd_ingest_runs_total", "outcome=\"rejected\"");
    log::Info("upload_rejected",
              {{"code", static_cast<int>(status.error_code())}, {"error", status.error_message()}});
  }
  return scope.Done(status);
}

grpc::Status IngestHandler::Upload(grpc::ServerContext* call,
                                   grpc::ServerReader<fleet::v1::UploadRunRequest>* reader,
                                   fleet::v1::UploadRunResponse* response) {
  Principal principal;
  if (grpc::Status denied = Authorize(context_, call, Permission::kUpload, &principal); !denied.ok())
    return denied;
  IngestAdmission::Ticket in_flight;  // this stream's slot and buffered bytes, given back when the call ends
  if (context_.admission != nullptr) {
    if (grpc::Status refused = context_.admission->Admit(principal.name, in_flight); !refused.ok())
      return refused;
  }

  fleet::v1::RunFile run;
  bool have_header = false, have_parent = false, have_child = false;
  std::int64_t bytes = 0, index = 0;
  fleet::v1::UploadRunRequest message;
  for (; reader->Read(&message); ++index) {
    const std::string where = "message[" + std::to_string(index) + "]";
    const auto message_bytes = static_cast<std::int64_t>(message.ByteSizeLong());
    bytes += message_bytes;
    // Limits a run can never fit are INVALID_ARGUMENT (clients do not retry); a full server is
    // RESOURCE_EXHAUSTED (clients retry later).
    if (bytes > context_.limits.max_run_bytes) {
      return InvalidArgument(where + ": upload exceeds max_run_bytes (" +
                             std::to_string(context_.limits.max_run_bytes) + "); nothing was stored");
    }
    if (context_.admission != nullptr) {
      if (grpc::Status refused = in_flight.Reserve(message_bytes); !refused.ok()) return refused;
    }
    if (have_child && message.part_case() != fleet::v1::UploadRunRequest::kChildSnapshot)
      return InvalidArgument(where + ": nothing but further parts of child_snapshot may follow it");
    if (auto unknown = analyzer::FindUnknownField(message, where)) {
      return InvalidArgument(*unknown +
                             ": carries bytes that are no field of fleet.v1 (trailing or unknown data)");
    }
    if (!have_header && message.part_case() != fleet::v1::UploadRunRequest::kHeader) {
      return InvalidArgument(where + ": the first message must be a header");
    }
    switch (message.part_case()) {
      case fleet::v1::UploadRunRequest::kHeader: {
        if (have_header) return InvalidArgument(where + ".header: a second header");
        if (slamcore::Status valid = analyzer::Validate(message.header()); !valid.ok()) {
          return InvalidArgument(valid.message());
        }
        if (principal.role == Role::kRobot && message.header().robot_id() != principal.id) {
          return {grpc::StatusCode::PERMISSION_DENIED, "header.robot_id: " + principal.name +
                                                           " may upload only its own runs, not robot \"" +
                                                           message.header().robot_id() + "\""};
        }
        if (message.header().event_count() > static_cast<std::uint64_t>(context_.limits.max_events_per_run)) {
          return InvalidArgument("header.event_count: " + std::to_string(message.header().event_count()) +
                                 " events exceed max_events_per_run (" +
                                 std::to_string(context_.limits.max_events_per_run) + ")");
        }
        *run.mutable_header() = std::move(*message.mutable_header());
        have_header = true;
        break;
      }
      case fleet::v1::UploadRunRequest::kEvents: {
        if (have_parent) return InvalidArgument(where + ".events: events must come before the snapshots");
        if (run.events_size() + message.events().events_size() > context_.limits.max_events_per_run) {
          return InvalidArgument(where + ".events: the run exceeds max_events_per_run (" +
                                 std::to_string(context_.limits.max_events_per_run) + ")");
        }
        for (auto& event : *message.mutable_events()->mutable_events()) *run.add_events() = std::move(event);
        break;
      }
      // Snapshots may come in parts (AddSnapshotPart); the byte bounds above count every part.
      case fleet::v1::UploadRunRequest::kParentSnapshot:
        AddSnapshotPart(message.mutable_parent_snapshot(), run.mutable_parent_snapshot(), have_parent);
        have_parent = true;
        break;
      case fleet::v1::UploadRunRequest::kChildSnapshot:
        AddSnapshotPart(message.mutable_child_snapshot(), run.mutable_child_snapshot(), have_child);
        have_child = true;
        break;
      case fleet::v1::UploadRunRequest::PART_NOT_SET:
        return InvalidArgument(where + ": empty message (no header, events or snapshot set)");
    }
  }
  if (call->IsCancelled())
    return {grpc::StatusCode::CANCELLED, "upload cancelled by the client; nothing stored"};
  // gRPC ends a stream's reads at a message that does not parse as it ends them at the stream's end: say
  // both, naming the message (only when refusing: an upload that went through builds no such text).
  const auto ended_before = [index] {
    return "the stream ended before message[" + std::to_string(index) +
           "] (or it did not parse as an UploadRunRequest: a string field holding bytes that are not "
           "UTF-8, or bytes that are no such message)";
  };
  if (!have_header) return InvalidArgument("header: " + ended_before());
  if (!have_child) {
    return InvalidArgument("child_snapshot: missing; " + ended_before() + " and nothing was stored");
  }

  // Validate everything before storing anything.
  fleet::v1::RunHeader& header = *run.mutable_header();
  if (header.event_count() != static_cast<std::uint64_t>(run.events_size())) {
    return InvalidArgument("header.event_count: the header announces " +
                           std::to_string(header.event_count()) + " events, the stream carried " +
                           std::to_string(run.events_size()));
  }
  if (auto events = analyzer::FromProto(run.events(), "events"); !events.ok()) {
    return InvalidArgument(events.status().message());
  }
  if (have_parent) {
    if (auto parsed = analyzer::FromProto(run.parent_snapshot(), "parent_snapshot"); !parsed.ok()) {
      return InvalidArgument(parsed.status().message());
    }
  }
  auto child_map = analyzer::FromProto(run.child_snapshot(), "child_snapshot");
  if (!child_map.ok()) return InvalidArgument(child_map.status().message());
  if (run.child_snapshot().nodes_size() == 0) return InvalidArgument("child_snapshot: has no nodes");

  // The parent map: sent (an empty one means "first run"), or named by id and already stored.
  std::string parent_bytes, parent_id;
  std::optional<storage::MapVersionRecord> parent_version;  // looked up here for a parent named by id
  if (have_parent && run.parent_snapshot().nodes_size() > 0) {
    parent_bytes = fleet::SerializeDeterministic(run.parent_snapshot());
    parent_id = Sha256Hex(parent_bytes);
    if (!header.parent_snapshot_id().empty() && header.parent_snapshot_id() != parent_id) {
      return InvalidArgument("parent_snapshot: its SHA-256 " + parent_id +
                             " differs from header.parent_snapshot_id " + header.parent_snapshot_id());
    }
  } else if (!header.parent_snapshot_id().empty()) {
    parent_id = header.parent_snapshot_id();
    // Named by id only, a parent must come from this robot's own map history: another robot's snapshot
    // (its customer's home) answers exactly like one the server does not hold.
    const grpc::Status not_held{grpc::StatusCode::FAILED_PRECONDITION,
                                "header.parent_snapshot_id: snapshot " + parent_id +
                                    " is not stored for robot " + header.robot_id() +
                                    "; send parent_snapshot in the stream"};
    auto holder = context_.repository->FindMapVersionOfSnapshot(header.robot_id(), parent_id);
    if (!holder.ok()) return ToGrpc(holder.status());
    // A version's snapshot is stored (AppendMapVersion checks), so there is no need to read it.
    if (!holder->has_value()) return not_held;
    parent_version = std::move(holder).value();
  }
  header.set_parent_snapshot_id(parent_id);  // the stored run names its parent the same way on every retry

  // One transaction stores the robot, the maps, the run, its analysis job and the child map's version: a
  // crash or an error leaves all of it or none.
  storage::UploadBundle upload;
  upload.robot.robot_id = header.robot_id();
  upload.robot.robot_model = header.robot_model();
  upload.robot.firmware = header.firmware();
  if (!parent_bytes.empty()) upload.snapshots.push_back(std::move(parent_bytes));
  upload.snapshots.push_back(fleet::SerializeDeterministic(run.child_snapshot()));
  storage::RunRecord& record = upload.run;
  record.run_id = header.run_id();
  record.robot_id = header.robot_id();
  record.firmware = header.firmware();
  record.robot_model = header.robot_model();
  record.started_at_ms = ToMillis(header.started_at());
  record.ended_at_ms = ToMillis(header.ended_at());
  if (!parent_id.empty()) record.parent_snapshot_id = parent_id;
  record.child_snapshot_id = Sha256Hex(upload.snapshots.back());
  fleet::v1::RunFile telemetry;
  *telemetry.mutable_header() = header;
  *telemetry.mutable_events() = std::move(*run.mutable_events());
  record.telemetry = fleet::SerializeDeterministic(telemetry);
  upload.analysis_job.kind = kAnalyzeRunJob;
  upload.analysis_job.payload =
      EncodeAnalyzePayload({record.robot_id, record.run_id, context_.default_parameter_set});
  upload.analysis_job.robot_id = record.robot_id;
  const std::string run_id = record.run_id, robot_id = record.robot_id, child_id = *record.child_snapshot_id;

  auto stored = MapHistory(*context_.repository, context_.map_policy)
                    .StoreUpload(std::move(upload), *child_map, principal.name,
                                 parent_version ? &*parent_version : nullptr);
  if (!stored.ok()) {
    if (stored.status().code() == storage::StatusCode::kAlreadyExists) {
      return {grpc::StatusCode::ALREADY_EXISTS, "header.run_id: run \"" + run_id + "\" of robot " + robot_id +
                                                    " is stored with a different payload"};
    }
    return ToGrpc(stored.status());
  }
  const bool already = stored->already_present;
  response->set_run_id(run_id);
  response->set_already_present(already);
  response->set_parent_snapshot_id(parent_id);
  response->set_child_snapshot_id(child_id);
  response->set_events_stored(static_cast<std::uint64_t>(telemetry.events_size()));
  response->set_analysis_job_id(stored->analysis_job_id);
  response->set_map_version(stored->version);
  response->set_current_map_version(stored->current_version);
  response->set_map_outdated(stored->outdated);
  context_.metrics->Increment("fleetd_ingest_runs_total",
                              already ? "outcome=\"already_present\"" : "outcome=\"stored\"");
  context_.metrics->Increment("fleetd_ingest_bytes_total", "", static_cast<double>(bytes));
  if (!already) {
    context_.metrics->Increment("fleetd_ingest_events_total", "", telemetry.events_size());
    if (context_.job_enqueued) context_.job_enqueued();
  }
  log::Info("run_uploaded", {{"run_id", run_id},
                             {"robot_id", robot_id},
                             {"principal", principal.name},
                             {"events", telemetry.events_size()},
                             {"bytes", static_cast<long long>(bytes)},
                             {"already_present", already}});
  return grpc::Status::OK;
}

}  // namespace server
