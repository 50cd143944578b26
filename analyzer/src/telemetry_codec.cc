#include "analyzer/telemetry_codec.h"

#include <algorithm>
#include <optional>
#include <sstream>

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <cmath>

namespace analyzer {
namespace {

using slamcore::InvalidArgument;
using slamcore::Matrix3;
using slamcore::Result;
using slamcore::SE2;
using slamcore::Status;

Result<SE2> PoseFromProto(const fleet::v1::Pose2& pose, bool present, const std::string& field) {
  if (!present) return InvalidArgument(field + ": missing");
  if (!std::isfinite(pose.x()) || !std::isfinite(pose.y()) || !std::isfinite(pose.theta())) {
    return InvalidArgument(field + ": not finite");
  }
  return SE2(pose.x(), pose.y(), pose.theta());
}

fleet::v1::Pose2 PoseToProto(const SE2& pose) {
  fleet::v1::Pose2 proto;
  proto.set_x(pose.x());
  proto.set_y(pose.y());
  proto.set_theta(pose.theta());
  return proto;
}

Result<Matrix3> MatrixFromProto(const google::protobuf::RepeatedField<double>& values,
                                const std::string& field) {
  if (values.size() != 9) {
    return InvalidArgument(field + ": expected 9 values, found " + std::to_string(values.size()));
  }
  Matrix3 matrix;
  for (int k = 0; k < 9; ++k) matrix(k / 3, k % 3) = values[k];
  RETURN_IF_ERROR(slamcore::CheckPositiveDefinite(matrix, field.c_str()));
  return matrix;
}

void MatrixToProto(const Matrix3& matrix, google::protobuf::RepeatedField<double>* values) {
  values->Clear();
  for (int k = 0; k < 9; ++k) values->Add(matrix(k / 3, k % 3));
}

std::string Number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

Status CheckTime(double time, const std::string& field) {
  if (!std::isfinite(time) || time < 0.0 || time > kMaxTimeSeconds) {
    return InvalidArgument(field + ": " + Number(time) + " s is outside [0, " + Number(kMaxTimeSeconds) +
                           "] (seconds, run-relative or since 1970)");
  }
  return Status::Ok();
}

Result<slamcore::LocalMapEvent> LocalMapFromProto(const fleet::v1::LocalMap& proto,
                                                  const std::string& field) {
  // A patch's cost is its cells, and the renderer's is its footprint in the map's cells: both are bounded.
  if (!std::isfinite(proto.resolution()) || proto.resolution() < kMinPatchResolution ||
      proto.resolution() > kMaxPatchResolution) {
    return InvalidArgument(field + ".resolution: " + Number(proto.resolution()) + " m/cell is outside [" +
                           Number(kMinPatchResolution) + ", " + Number(kMaxPatchResolution) + "]");
  }
  if (proto.width() <= 0 || proto.height() <= 0 || proto.width() > kMaxPatchSide ||
      proto.height() > kMaxPatchSide) {
    return InvalidArgument(field + ": size " + std::to_string(proto.width()) + "x" +
                           std::to_string(proto.height()) + " is empty or larger than " +
                           std::to_string(kMaxPatchSide) + "x" + std::to_string(kMaxPatchSide) + " cells");
  }
  if (proto.width() * proto.resolution() > kMaxPatchExtent ||
      proto.height() * proto.resolution() > kMaxPatchExtent) {
    return InvalidArgument(field + ": footprint " + Number(proto.width() * proto.resolution()) + " x " +
                           Number(proto.height() * proto.resolution()) + " m is larger than " +
                           Number(kMaxPatchExtent) + " m on a side");
  }
  const auto expected = static_cast<std::size_t>(proto.width()) * static_cast<std::size_t>(proto.height());
  if (proto.cells().size() != expected) {
    return InvalidArgument(field + ".cells: expected " + std::to_string(expected) + " bytes, found " +
                           std::to_string(proto.cells().size()));
  }
  slamcore::LocalMapEvent patch;
  patch.resolution = proto.resolution();
  patch.width = proto.width();
  patch.height = proto.height();
  ASSIGN_OR_RETURN(const auto origin,
                   PoseFromProto(proto.node_t_origin(), proto.has_node_t_origin(), field + ".node_t_origin"));
  patch.node_T_origin = origin;
  patch.cells.resize(expected);
  for (std::size_t k = 0; k < expected; ++k) {
    const auto cell = static_cast<std::int8_t>(proto.cells()[k]);
    if (cell != -1 && (cell < 0 || cell > 100)) {
      return InvalidArgument(field + ".cells[" + std::to_string(k) + "]: " + std::to_string(cell) +
                             " is not -1 (unknown) or 0..100");
    }
    patch.cells[k] = cell;
  }
  return patch;
}

fleet::v1::LocalMap LocalMapToProto(const slamcore::LocalMapEvent& patch) {
  fleet::v1::LocalMap proto;
  proto.set_resolution(patch.resolution);
  proto.set_width(patch.width);
  proto.set_height(patch.height);
  *proto.mutable_node_t_origin() = PoseToProto(patch.node_T_origin);
  proto.set_cells(std::string(patch.cells.begin(), patch.cells.end()));
  return proto;
}

}  // namespace

Result<slamcore::Event> FromProto(const fleet::v1::Event& event, const std::string& field) {
  const double time = event.time();
  RETURN_IF_ERROR(CheckTime(time, field + ".time"));
  switch (event.kind_case()) {
    case fleet::v1::Event::kOdometry: {
      const auto increment = PoseFromProto(event.odometry().increment(), event.odometry().has_increment(),
                                           field + ".odometry.increment");
      RETURN_IF_ERROR(increment.status());
      ASSIGN_OR_RETURN(const auto covariance,
                       MatrixFromProto(event.odometry().covariance(), field + ".odometry.covariance"));
      return slamcore::Event(
          slamcore::OdometryEvent{.time = time, .increment = *increment, .covariance = covariance});
    }
    case fleet::v1::Event::kViewCreated:
      return slamcore::Event(slamcore::ViewCreatedEvent{.time = time, .view = event.view_created().view()});
    case fleet::v1::Event::kViewObserved: {
      const auto& observed = event.view_observed();
      ASSIGN_OR_RETURN(const auto z, PoseFromProto(observed.robot_t_view(), observed.has_robot_t_view(),
                                                   field + ".view_observed.robot_t_view"));
      ASSIGN_OR_RETURN(const auto covariance,
                       MatrixFromProto(observed.covariance(), field + ".view_observed.covariance"));
      return slamcore::Event(slamcore::ViewObservedEvent{
          .time = time, .view = observed.view(), .robot_T_view = z, .covariance = covariance});
    }
    case fleet::v1::Event::kLocalMap: {
      ASSIGN_OR_RETURN(auto patch, LocalMapFromProto(event.local_map(), field + ".local_map"));
      patch.time = time;
      return slamcore::Event(std::move(patch));
    }
    case fleet::v1::Event::kKidnap: {
      const auto cause = event.kidnap().cause() == fleet::v1::Kidnap::CAUSE_REBOOT
                             ? slamcore::KidnapEvent::Cause::kReboot
                             : slamcore::KidnapEvent::Cause::kKidnap;
      return slamcore::Event(slamcore::KidnapEvent{.time = time, .cause = cause});
    }
    case fleet::v1::Event::kGroundTruth: {
      ASSIGN_OR_RETURN(const auto pose, PoseFromProto(event.ground_truth().world_t_robot(),
                                                      event.ground_truth().has_world_t_robot(),
                                                      field + ".ground_truth.world_t_robot"));
      return slamcore::Event(slamcore::GroundTruthEvent{.time = time, .world_T_robot = pose});
    }
    case fleet::v1::Event::KIND_NOT_SET: break;
  }
  return InvalidArgument(field + ": no event kind set");
}

fleet::v1::Event ToProto(const slamcore::Event& event) {
  fleet::v1::Event proto;
  std::visit(
      [&proto](const auto& typed) {
        using T = std::decay_t<decltype(typed)>;
        proto.set_time(typed.time);
        if constexpr (std::is_same_v<T, slamcore::OdometryEvent>) {
          *proto.mutable_odometry()->mutable_increment() = PoseToProto(typed.increment);
          MatrixToProto(typed.covariance, proto.mutable_odometry()->mutable_covariance());
        } else if constexpr (std::is_same_v<T, slamcore::ViewCreatedEvent>) {
          proto.mutable_view_created()->set_view(typed.view);
        } else if constexpr (std::is_same_v<T, slamcore::ViewObservedEvent>) {
          auto* observed = proto.mutable_view_observed();
          observed->set_view(typed.view);
          *observed->mutable_robot_t_view() = PoseToProto(typed.robot_T_view);
          MatrixToProto(typed.covariance, observed->mutable_covariance());
        } else if constexpr (std::is_same_v<T, slamcore::LocalMapEvent>) {
          *proto.mutable_local_map() = LocalMapToProto(typed);
        } else if constexpr (std::is_same_v<T, slamcore::KidnapEvent>) {
          proto.mutable_kidnap()->set_cause(typed.cause == slamcore::KidnapEvent::Cause::kReboot
                                                ? fleet::v1::Kidnap::CAUSE_REBOOT
                                                : fleet::v1::Kidnap::CAUSE_KIDNAP);
        } else if constexpr (std::is_same_v<T, slamcore::GroundTruthEvent>) {
          *proto.mutable_ground_truth()->mutable_world_t_robot() = PoseToProto(typed.world_T_robot);
        }
      },
      event);
  return proto;
}

Result<std::vector<slamcore::Event>> FromProto(
    const google::protobuf::RepeatedPtrField<fleet::v1::Event>& events, const std::string& field) {
  std::vector<slamcore::Event> converted;
  converted.reserve(static_cast<std::size_t>(events.size()));
  for (int k = 0; k < events.size(); ++k) {
    ASSIGN_OR_RETURN(auto event, FromProto(events[k], field + "[" + std::to_string(k) + "]"));
    converted.push_back(std::move(event));
  }
  return converted;
}

Result<slamcore::Map> FromProto(const fleet::v1::MapSnapshot& snapshot, const std::string& field) {
  if (snapshot.format_version() != kTelemetryFormatVersion &&
      !(snapshot.format_version() == 0 && snapshot.nodes_size() == 0)) {
    return InvalidArgument(field + ".format_version: " + std::to_string(snapshot.format_version()) +
                           " is not supported (this program reads version " +
                           std::to_string(kTelemetryFormatVersion) + ")");
  }
  const std::pair<const char*, int> counts[] = {{"nodes", snapshot.nodes_size()},
                                                {"edges", snapshot.edges_size()},
                                                {"views", snapshot.views_size()},
                                                {"local_maps", snapshot.local_maps_size()}};
  for (const auto& [name, count] : counts) {
    const int limit = std::string(name) == "edges" ? kMaxSnapshotEdges : kMaxSnapshotNodes;
    if (count > limit) {
      return InvalidArgument(field + "." + name + ": " + std::to_string(count) + " entries, more than " +
                             std::to_string(limit));
    }
  }
  std::int64_t cells = 0;
  for (const auto& patch : snapshot.local_maps())
    cells += static_cast<std::int64_t>(patch.local_map().cells().size());
  if (cells > kMaxSnapshotCells) {
    return InvalidArgument(field + ".local_maps: " + std::to_string(cells) + " cells in all, more than " +
                           std::to_string(kMaxSnapshotCells));
  }
  slamcore::Map map;
  for (int k = 0; k < snapshot.nodes_size(); ++k) {
    const auto& proto = snapshot.nodes(k);
    const std::string node_field = field + ".nodes[" + std::to_string(k) + "]";
    ASSIGN_OR_RETURN(const auto pose, PoseFromProto(proto.pose(), proto.has_pose(), node_field + ".pose"));
    RETURN_IF_ERROR(CheckTime(proto.time(), node_field + ".time"));
    if (!std::isfinite(proto.odometer()) || proto.odometer() < 0.0) {
      return InvalidArgument(node_field + ".odometer: must be finite and >= 0, found " +
                             Number(proto.odometer()));
    }
    slamcore::Node node{
        .id = proto.id(), .pose = pose, .time = proto.time(), .odometer = proto.odometer(), .fixed = false};
    if (const Status status = map.graph.AddNode(node); !status.ok()) {
      return InvalidArgument(node_field + ": " + status.message());
    }
  }
  for (int k = 0; k < snapshot.views_size(); ++k) {
    const auto& proto = snapshot.views(k);
    const slamcore::View view{.id = proto.id(), .node = proto.node(), .ambiguous = proto.ambiguous()};
    if (const Status status = map.graph.AddView(view); !status.ok()) {
      return InvalidArgument(field + ".views[" + std::to_string(k) + "]: " + status.message());
    }
  }
  for (int k = 0; k < snapshot.edges_size(); ++k) {
    const auto& proto = snapshot.edges(k);
    const std::string edge_field = field + ".edges[" + std::to_string(k) + "]";
    ASSIGN_OR_RETURN(const auto measurement, PoseFromProto(proto.measurement(), proto.has_measurement(),
                                                           edge_field + ".measurement"));
    ASSIGN_OR_RETURN(const auto information,
                     MatrixFromProto(proto.information(), edge_field + ".information"));
    slamcore::Edge edge;
    edge.from = proto.from();
    edge.to = proto.to();
    edge.measurement = measurement;
    edge.information = information;
    edge.kind = proto.kind() == fleet::v1::Edge::KIND_MOTION ? slamcore::EdgeKind::kMotion
                                                             : slamcore::EdgeKind::kObservation;
    if (proto.has_view()) edge.view = proto.view();
    if (proto.has_hypothesis()) edge.hypothesis = proto.hypothesis();
    if (const auto added = map.graph.AddEdge(edge); !added.ok()) {
      return InvalidArgument(edge_field + ": " + added.status().message());
    }
  }
  for (int k = 0; k < snapshot.local_maps_size(); ++k) {
    const auto& proto = snapshot.local_maps(k);
    const std::string map_field = field + ".local_maps[" + std::to_string(k) + "]";
    if (!map.graph.HasNode(proto.node())) {
      return InvalidArgument(map_field + ".node: node " + std::to_string(proto.node()) + " does not exist");
    }
    ASSIGN_OR_RETURN(auto patch, LocalMapFromProto(proto.local_map(), map_field + ".local_map"));
    map.local_maps.insert_or_assign(proto.node(), std::move(patch));
  }
  return map;
}

fleet::v1::MapSnapshot ToProto(const slamcore::Map& map) {
  fleet::v1::MapSnapshot snapshot;
  snapshot.set_format_version(kTelemetryFormatVersion);
  for (const slamcore::Node& node : map.graph.nodes()) {
    auto* proto = snapshot.add_nodes();
    proto->set_id(node.id);
    *proto->mutable_pose() = PoseToProto(node.pose);
    proto->set_time(node.time);
    proto->set_odometer(node.odometer);
  }
  for (const slamcore::View& view : map.graph.views()) {
    auto* proto = snapshot.add_views();
    proto->set_id(view.id);
    proto->set_node(view.node);
    proto->set_ambiguous(view.ambiguous);
  }
  for (const slamcore::Edge& edge : map.graph.edges()) {
    auto* proto = snapshot.add_edges();
    proto->set_from(edge.from);
    proto->set_to(edge.to);
    *proto->mutable_measurement() = PoseToProto(edge.measurement);
    MatrixToProto(edge.information, proto->mutable_information());
    proto->set_kind(edge.kind == slamcore::EdgeKind::kMotion ? fleet::v1::Edge::KIND_MOTION
                                                             : fleet::v1::Edge::KIND_OBSERVATION);
    if (edge.view) proto->set_view(*edge.view);
    if (edge.hypothesis) proto->set_hypothesis(*edge.hypothesis);
  }
  // Local maps in node order, so equal maps serialise to equal bytes (snapshots are content-addressed).
  for (const slamcore::Node& node : map.graph.nodes()) {
    const auto it = map.local_maps.find(node.id);
    if (it == map.local_maps.end()) continue;
    auto* proto = snapshot.add_local_maps();
    proto->set_node(node.id);
    *proto->mutable_local_map() = LocalMapToProto(it->second);
  }
  return snapshot;
}

std::string SerializeDeterministic(const google::protobuf::Message& message) {
  std::string bytes;
  google::protobuf::io::StringOutputStream stream(&bytes);
  google::protobuf::io::CodedOutputStream coded(&stream);
  coded.SetSerializationDeterministic(true);
  message.SerializeToCodedStream(&coded);
  coded.Trim();
  return bytes;
}

std::optional<std::string> FindUnknownField(const google::protobuf::Message& message,
                                            const std::string& field) {
  const google::protobuf::Reflection* reflection = message.GetReflection();
  if (!reflection->GetUnknownFields(message).empty()) return field;
  std::vector<const google::protobuf::FieldDescriptor*> fields;
  reflection->ListFields(message, &fields);
  for (const google::protobuf::FieldDescriptor* descriptor : fields) {
    if (descriptor->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string inner = field + "." + descriptor->name();
    if (descriptor->is_repeated()) {
      for (int k = 0; k < reflection->FieldSize(message, descriptor); ++k) {
        if (auto found = FindUnknownField(reflection->GetRepeatedMessage(message, descriptor, k),
                                          inner + "[" + std::to_string(k) + "]")) {
          return found;
        }
      }
    } else if (auto found = FindUnknownField(reflection->GetMessage(message, descriptor), inner)) {
      return found;
    }
  }
  return std::nullopt;
}

Status ValidateId(const std::string& value, const std::string& field) {
  if (value.empty()) return InvalidArgument(field + ": missing");
  if (value.size() > kMaxIdLength) {
    return InvalidArgument(field + ": longer than " + std::to_string(kMaxIdLength) + " characters");
  }
  const bool valid = std::all_of(value.begin(), value.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == ':' || c == '-';
  });
  if (!valid) return InvalidArgument(field + ": only letters, digits and . _ : - are allowed");
  return Status::Ok();
}

Status ValidateText(const std::string& value, const std::string& field) {
  if (value.size() > kMaxIdLength) {
    return InvalidArgument(field + ": longer than " + std::to_string(kMaxIdLength) + " characters");
  }
  if (std::any_of(value.begin(), value.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; })) {
    return InvalidArgument(field + ": control characters are not allowed");
  }
  return Status::Ok();
}

bool IsSnapshotId(const std::string& value) {
  return value.size() == 64 && std::all_of(value.begin(), value.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

Status Validate(const fleet::v1::RunHeader& header) {
  if (header.format_version() != kTelemetryFormatVersion) {
    return InvalidArgument("header.format_version: " + std::to_string(header.format_version()) +
                           " is not supported (this program reads version " +
                           std::to_string(kTelemetryFormatVersion) + ")");
  }
  RETURN_IF_ERROR(ValidateId(header.robot_id(), "header.robot_id"));
  RETURN_IF_ERROR(ValidateId(header.run_id(), "header.run_id"));
  RETURN_IF_ERROR(ValidateText(header.firmware(), "header.firmware"));
  RETURN_IF_ERROR(ValidateText(header.robot_model(), "header.robot_model"));
  RETURN_IF_ERROR(ValidateText(header.home_id(), "header.home_id"));
  if (!header.parent_snapshot_id().empty() && !IsSnapshotId(header.parent_snapshot_id())) {
    return InvalidArgument("header.parent_snapshot_id: expected 64 lowercase hex characters (SHA-256)");
  }
  for (const auto& [value, name] : {std::pair{header.started_at(), "header.started_at"},
                                    std::pair{header.ended_at(), "header.ended_at"}}) {
    if (!std::isfinite(value) || value < kEarliestRunSeconds || value > kLatestRunSeconds) {
      return InvalidArgument(std::string(name) + ": " + Number(value) +
                             " is outside 2000-01-01..2100-01-01 (seconds since 1970, UTC)");
    }
  }
  if (header.ended_at() < header.started_at()) return InvalidArgument("header.ended_at: before started_at");
  if (header.map_version() < 0) {
    return InvalidArgument("header.map_version: " + std::to_string(header.map_version()) +
                           " is negative (0: none)");
  }
  return Status::Ok();
}

}  // namespace analyzer
