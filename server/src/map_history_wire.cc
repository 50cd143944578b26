// MapHistory's wire forms (declared in server/map_history.h): a version record as the proto's MapVersion,
// the states' proto enums to and from storage's, and the repair actions' names.
#include <iterator>
#include <string>

#include "map_history_support.h"

namespace server {
namespace {

// Each proto enum lists storage's values in their order after its UNSPECIFIED = 0
// (MapStatesTest.WireValuesAreStoragesNamesUpperCased holds them together).
template <typename ProtoEnum, typename StorageEnum>
ProtoEnum ToWire(StorageEnum value) {
  return static_cast<ProtoEnum>(static_cast<int>(value) + 1);
}

template <typename StorageEnum, std::size_t N, typename ProtoEnum>
storage::Result<StorageEnum> FromWire(ProtoEnum value, const std::array<StorageEnum, N>& values,
                                      const std::string& field) {
  const int index = static_cast<int>(value) - 1;
  if (index < 0 || index >= static_cast<int>(N)) {
    const std::string what =
        value == ProtoEnum{} ? "unspecified" : std::to_string(value) + " is not a known value";
    return storage::InvalidArgument(field + ": " + what);
  }
  return values[static_cast<std::size_t>(index)];
}

// Every repair action, default-constructed, in the variant's order, and its spelling at the same index.
const RepairAction kRepairActions[] = {RejectEdge{}, RejectHypothesis{}, CutFinding{}, Rollback{}, Undo{}};
constexpr const char* kRepairActionNames[] = {"reject_edge", "reject_hypothesis", "cut_finding", "rollback",
                                              "undo"};
static_assert(std::size(kRepairActionNames) == std::variant_size_v<RepairAction>);

}  // namespace

fleet::v1::MapVersion ToProto(const storage::MapVersionRecord& record, bool current) {
  fleet::v1::MapVersion proto;
  proto.set_robot_id(record.robot_id);
  proto.set_version(record.version);
  proto.set_parent_version(record.parent_version.value_or(0));
  proto.set_snapshot_id(record.snapshot_id);
  proto.set_version_origin(ToProto(record.origin));
  proto.set_run_id(record.run_id);
  proto.set_version_action(ToProto(record.action));
  proto.set_action_detail(record.action_detail);
  proto.set_created_by(record.created_by);
  proto.set_reason(record.reason);
  proto.set_created_at(static_cast<double>(record.created_at_ms) / 1000.0);
  proto.set_approval_state(ToProto(record.approval));
  proto.set_approved_by(record.approved_by);
  proto.set_approved_at(static_cast<double>(record.approved_at_ms) / 1000.0);
  proto.set_nodes(record.nodes);
  proto.set_edges(record.edges);
  proto.set_observation_edges(record.observation_edges);
  proto.set_views(record.views);
  proto.set_components(record.components);
  proto.set_known_area_m2(record.known_area_m2);
  proto.set_open_findings(record.open_findings);
  proto.set_current(current);
  proto.set_chi2(record.chi2);
  return proto;
}

const char* RepairActionName(const RepairAction& action) { return kRepairActionNames[action.index()]; }

storage::MapAction RecordedAction(const RepairAction& action) {
  return std::visit(Overloaded{[](const RejectEdge&) { return storage::MapAction::kRejectEdge; },
                               [](const RejectHypothesis&) { return storage::MapAction::kRejectHypothesis; },
                               [](const CutFinding&) { return storage::MapAction::kCutRegion; },
                               [](const Rollback&) { return storage::MapAction::kRollback; },
                               [](const Undo&) { return storage::MapAction::kUndo; }},
                    action);
}

fleet::v1::MapOrigin ToProto(storage::MapOrigin origin) { return ToWire<fleet::v1::MapOrigin>(origin); }
fleet::v1::MapApproval ToProto(storage::MapApproval approval) {
  return ToWire<fleet::v1::MapApproval>(approval);
}
fleet::v1::MapAction ToProto(std::optional<storage::MapAction> action) {
  return action ? ToWire<fleet::v1::MapAction>(*action) : fleet::v1::MAP_ACTION_UNSPECIFIED;
}
fleet::v1::FindingKind ToProto(storage::FindingKind kind) { return ToWire<fleet::v1::FindingKind>(kind); }
fleet::v1::FindingState ToProto(storage::FindingState state) {
  return ToWire<fleet::v1::FindingState>(state);
}

storage::Result<storage::MapOrigin> FromProto(fleet::v1::MapOrigin origin, const std::string& field) {
  return FromWire(origin, storage::kMapOrigins, field);
}
storage::Result<storage::MapApproval> FromProto(fleet::v1::MapApproval approval, const std::string& field) {
  return FromWire(approval, storage::kMapApprovals, field);
}
storage::Result<storage::MapAction> FromProto(fleet::v1::MapAction action, const std::string& field) {
  return FromWire(action, storage::kMapActions, field);
}
storage::Result<storage::FindingKind> FromProto(fleet::v1::FindingKind kind, const std::string& field) {
  return FromWire(kind, storage::kFindingKinds, field);
}
storage::Result<storage::FindingState> FromProto(fleet::v1::FindingState state, const std::string& field) {
  return FromWire(state, storage::kFindingStates, field);
}

storage::Result<RepairAction> RepairActionNamed(const std::string& name, const std::string& field) {
  for (const RepairAction& action : kRepairActions) {
    if (name == RepairActionName(action)) return action;
  }
  std::string expected;
  for (std::size_t i = 0; i < std::size(kRepairActionNames); ++i) {
    expected += i == 0 ? "" : i + 1 == std::size(kRepairActionNames) ? " or " : ", ";
    expected += kRepairActionNames[i];
  }
  return storage::InvalidArgument(field + ": \"" + name.substr(0, 64) + "\" is not an action; expected " +
                                  expected);
}

}  // namespace server
