#include "server/map_history.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <tuple>
#include <nlohmann/json.hpp>

#include "analyzer/map_comparison.h"
#include "analyzer/map_metadata.h"
#include "analyzer/map_repair.h"
#include "analyzer/telemetry_codec.h"
#include "fleet/serialization.h"
#include "server/analysis.h"
#include "server/log.h"

namespace server {
namespace {

storage::Result<fleet::v1::MapSnapshot> LoadSnapshot(storage::Repository& repository,
                                                     const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto stored, repository.GetSnapshot(snapshot_id));
  fleet::v1::MapSnapshot snapshot;
  if (!snapshot.ParseFromString(stored.bytes))
    return storage::DataLoss("snapshot " + snapshot_id + " does not parse");
  return snapshot;
}

storage::Result<slamcore::Map> LoadMap(storage::Repository& repository, const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto snapshot, LoadSnapshot(repository, snapshot_id));
  auto map = analyzer::FromProto(snapshot, "snapshot " + snapshot_id);
  if (!map.ok()) return storage::DataLoss(map.status().message());
  return std::move(map).value();
}

/// What findings compare a version with: the map before the version's run, and the server's rerun of it.
struct RunContext {
  slamcore::Map parent;  // empty for a robot's first run
  std::optional<fleet::v1::RunReport> report;
};

/// The map the run started from; empty for a robot's first run (or a version without a run).
storage::Result<slamcore::Map> LoadRunParent(storage::Repository& repository, const storage::RunKey& key) {
  if (key.run_id.empty()) return slamcore::Map{};
  ASSIGN_OR_RETURN(auto run, repository.GetRun(key));
  if (!run.parent_snapshot_id) return slamcore::Map{};
  return LoadMap(repository, *run.parent_snapshot_id);
}

storage::Result<RunContext> LoadRunContext(storage::Repository& repository, const storage::RunKey& key,
                                           const std::string& parameter_set) {
  RunContext context;
  const std::string& run_id = key.run_id;
  if (run_id.empty()) return context;
  ASSIGN_OR_RETURN(auto parent, LoadRunParent(repository, key));
  context.parent = std::move(parent);
  auto report = repository.GetReport(key, parameter_set);
  if (report.ok()) {
    fleet::v1::RunReport parsed;
    if (!parsed.ParseFromString(report->report))
      return storage::DataLoss("report of run " + run_id + " does not parse");
    context.report = std::move(parsed);
  } else if (report.status().code() != storage::StatusCode::kNotFound) {
    return report.status();
  }
  return context;
}

std::vector<fleet::v1::MapFinding> Findings(const slamcore::Map& map, const RunContext& context) {
  return analyzer::FindMapFindings(
      {.map = &map, .run_parent = &context.parent, .report = context.report ? &*context.report : nullptr});
}

/// The records of findings the analysis made; INTERNAL for a finding without a kind or state (a bug there).
/// Kind and state are the records' columns, so the JSON of the rest leaves them out.
storage::Result<std::vector<storage::MapFindingRecord>> ToRecords(
    const std::vector<fleet::v1::MapFinding>& findings) {
  std::vector<storage::MapFindingRecord> records;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  for (const fleet::v1::MapFinding& finding : findings) {
    const std::string name = "finding " + std::to_string(finding.finding_id());
    auto kind = FromProto(finding.finding_kind(), name + " finding_kind");
    auto state = FromProto(finding.finding_state(), name + " finding_state");
    if (!kind.ok()) return storage::Internal(kind.status().message());
    if (!state.ok()) return storage::Internal(state.status().message());
    storage::MapFindingRecord& record = records.emplace_back();
    record.finding_id = finding.finding_id();
    record.kind = *kind;
    record.severity = finding.severity();
    record.summary = finding.summary();
    record.state = *state;
    fleet::v1::MapFinding rest = finding;
    rest.clear_finding_kind();
    rest.clear_finding_state();
    (void)google::protobuf::util::MessageToJsonString(rest, &record.detail_json, options);
  }
  return records;
}

storage::Result<std::vector<fleet::v1::MapFinding>> FromRecords(
    const std::vector<storage::MapFindingRecord>& records) {
  std::vector<fleet::v1::MapFinding> findings;
  // Findings stored before kind and state were enums spell them as strings in their JSON: the columns say.
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  for (const storage::MapFindingRecord& record : records) {
    fleet::v1::MapFinding& finding = findings.emplace_back();
    if (!google::protobuf::util::JsonStringToMessage(record.detail_json, &finding, options).ok()) {
      return storage::DataLoss("finding " + std::to_string(record.finding_id) + " does not parse");
    }
    finding.set_finding_kind(ToProto(record.kind));
    finding.set_finding_state(ToProto(record.state));
  }
  return findings;
}

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

/// "" for a version without an action (uploads).
std::string ActionText(const std::optional<storage::MapAction>& action) {
  return action ? std::string(storage::Name(*action)) : std::string();
}

/// A new version's record with its map's figures. The known area needs a rendering: uploads leave it to
/// the run's analysis (OnRunAnalysed) to keep ingest fast.
storage::Result<storage::MapVersionRecord> NewVersion(const slamcore::Map& map,
                                                      const std::string& snapshot_id, bool with_known_area) {
  const analyzer::MapFigures figures = analyzer::ComputeFigures(map);
  storage::MapVersionRecord record;
  record.snapshot_id = snapshot_id;
  record.nodes = figures.nodes;
  record.edges = figures.edges;
  record.observation_edges = figures.observation_edges;
  record.views = figures.views;
  record.components = figures.components;
  record.chi2 = figures.chi2;
  if (with_known_area) {
    ASSIGN_OR_RETURN(auto area, analyzer::KnownArea(map));
    record.known_area_m2 = area;
  }
  return record;
}

std::int64_t NowMillis() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const storage::MapVersionRecord* Current(const std::vector<storage::MapVersionRecord>& versions) {
  for (auto it = versions.rbegin(); it != versions.rend(); ++it) {
    if (it->approval == storage::MapApproval::kApproved) return &*it;
  }
  return nullptr;
}

/// `version` of a robot's versions, or its current one for 0.
storage::Result<storage::MapVersionRecord> Find(const std::vector<storage::MapVersionRecord>& versions,
                                                const std::string& robot_id, std::int64_t version) {
  if (version < 0)
    return storage::InvalidArgument("version: expected a positive number, or 0 for the current one");
  if (version == 0) {
    const storage::MapVersionRecord* current = Current(versions);
    if (!current) return storage::NotFound("robot " + robot_id + " has no approved map version");
    return *current;
  }
  for (const storage::MapVersionRecord& record : versions) {
    if (record.version == version) return record;
  }
  return storage::NotFound("robot " + robot_id + " has no map version " + std::to_string(version));
}

/// What repairs continue: the newest approved or pending version (rejected and stale ones are side branches).
const storage::MapVersionRecord* Head(const std::vector<storage::MapVersionRecord>& versions) {
  for (auto it = versions.rbegin(); it != versions.rend(); ++it) {
    if (it->approval == storage::MapApproval::kApproved || it->approval == storage::MapApproval::kPending)
      return &*it;
  }
  return nullptr;
}

/// `version` among `versions`, or null.
const storage::MapVersionRecord* FindRecord(const std::vector<storage::MapVersionRecord>& versions,
                                            std::int64_t version) {
  for (const storage::MapVersionRecord& record : versions) {
    if (record.version == version) return &record;
  }
  return nullptr;
}

/// What a map-only version is compared with: the version before the import its chain started from (parents
/// are followed through repairs back to the import). Null when that import was the robot's first version.
const storage::MapVersionRecord* ComparisonReference(const std::vector<storage::MapVersionRecord>& versions,
                                                     const storage::MapVersionRecord& record) {
  const storage::MapVersionRecord* at = &record;
  while (at != nullptr && at->origin != storage::MapOrigin::kImport) {
    if (!at->parent_version) return nullptr;
    at = FindRecord(versions, *at->parent_version);
  }
  if (at == nullptr || !at->parent_version) return nullptr;
  return FindRecord(versions, *at->parent_version);
}

/// Whether `record` is `ancestor` or built on it, following parents.
bool IsBuiltOn(const std::vector<storage::MapVersionRecord>& versions,
               const storage::MapVersionRecord& record, std::int64_t ancestor) {
  for (const storage::MapVersionRecord* at = &record; at != nullptr;
       at = at->parent_version ? FindRecord(versions, *at->parent_version) : nullptr) {
    if (at->version == ancestor) return true;
  }
  return false;
}

/// Both lists in one, by severity (highest first) and numbered from 1 again.
std::vector<fleet::v1::MapFinding> MergeFindings(std::vector<fleet::v1::MapFinding> first,
                                                 const std::vector<fleet::v1::MapFinding>& second) {
  first.insert(first.end(), second.begin(), second.end());
  std::stable_sort(first.begin(), first.end(),
                   [](const fleet::v1::MapFinding& a, const fleet::v1::MapFinding& b) {
                     return a.severity() > b.severity();
                   });
  for (std::size_t i = 0; i < first.size(); ++i) first[i].set_finding_id(static_cast<std::int64_t>(i) + 1);
  return first;
}

/// The previous map of a comparison: its grid and its dock.
struct ComparedMap {
  slamcore::OccupancyGrid grid;
  std::optional<slamcore::SE2> dock;
};

storage::Result<ComparedMap> LoadComparedMap(storage::Repository& repository,
                                             const std::string& snapshot_id) {
  ASSIGN_OR_RETURN(auto snapshot, LoadSnapshot(repository, snapshot_id));
  auto map = analyzer::FromProto(snapshot, "snapshot " + snapshot_id);
  if (!map.ok()) return storage::DataLoss(map.status().message());
  ASSIGN_OR_RETURN(auto grid, analyzer::RenderHomeGrid(*map));
  return ComparedMap{std::move(grid), analyzer::DockOf(snapshot)};
}

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

const char* RepairActionName(const RepairAction& action) {
  static constexpr const char* kNames[] = {"reject_edge", "reject_hypothesis", "cut_finding", "rollback",
                                           "undo"};
  static_assert(std::size(kNames) == std::variant_size_v<RepairAction>);
  return kNames[action.index()];
}

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
  if (name == "reject_edge") return RepairAction{RejectEdge{}};
  if (name == "reject_hypothesis") return RepairAction{RejectHypothesis{}};
  if (name == "cut_finding") return RepairAction{CutFinding{}};
  if (name == "rollback") return RepairAction{Rollback{}};
  if (name == "undo") return RepairAction{Undo{}};
  return storage::InvalidArgument(
      field + ": \"" + name.substr(0, 64) +
      "\" is not an action; expected reject_edge, reject_hypothesis, cut_finding, rollback "
      "or undo");
}

MapPolicy MapPolicyOf(const FleetdConfig& config) {
  return {.auto_repair = config.auto_repair,
          .min_severity = config.auto_repair_min_severity,
          .auto_approve = config.auto_approve,
          .default_parameter_set = config.default_parameter_set,
          .model_name = config.model_name};
}

MapHistory::MapHistory(storage::Repository& repository, MapPolicy policy)
    : repository_(repository), policy_(std::move(policy)) {}

storage::Result<UploadMapOutcome> MapHistory::RecordUpload(const storage::RunRecord& run,
                                                           const slamcore::Map& child,
                                                           const std::string& uploader) {
  if (!run.child_snapshot_id) return storage::InvalidArgument("run " + run.run_id + " has no child map");
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(run.robot_id));
  const storage::MapVersionRecord* current = Current(versions);
  ASSIGN_OR_RETURN(auto record, NewVersion(child, *run.child_snapshot_id, /*with_known_area=*/false));
  record.robot_id = run.robot_id;
  record.origin = storage::MapOrigin::kUpload;
  record.run_id = run.run_id;
  record.created_by = uploader.empty() ? "robot:" + run.robot_id : uploader;
  // Only the robot's own uploads (and an admin's) become its map unreviewed: an engineer's upload for a robot
  // is a map a person made, and goes through review like a repair.
  const bool needs_review = uploader.rfind("engineer:", 0) == 0;
  const std::string parent = run.parent_snapshot_id.value_or("");
  for (auto it = versions.rbegin(); it != versions.rend() && !parent.empty(); ++it) {
    if (it->snapshot_id == parent) {
      record.parent_version = it->version;
      break;
    }
  }
  // Built on the current map (or there is none yet): this is the robot's map now. Built on an older one: kept
  // in the history, but the robot should take the current version instead.
  const bool outdated = current != nullptr && current->snapshot_id != parent;
  record.approval = outdated       ? storage::MapApproval::kStale
                    : needs_review ? storage::MapApproval::kPending
                                   : storage::MapApproval::kApproved;
  if (!outdated && !needs_review) {
    record.approved_by = record.created_by;
    record.approved_at_ms = run.ended_at_ms;
  }
  // Findings on the map alone for now; OnRunAnalysed adds those that need the server's rerun.
  ASSIGN_OR_RETURN(auto findings, ToRecords(analyzer::FindMapFindings({.map = &child})));
  ASSIGN_OR_RETURN(auto appended, repository_.AppendMapVersion(record, std::nullopt, findings));
  UploadMapOutcome outcome;
  outcome.version = appended.version;
  const std::int64_t newest_before = versions.empty() ? 0 : versions.back().version;
  if (appended.approval == storage::MapApproval::kApproved && appended.version > newest_before) {
    outcome.current_version = appended.version;  // just made, on the current map: it is the current one now
  } else {
    // Stale, or a retried upload's earlier version: the current map is whatever the history says now.
    ASSIGN_OR_RETURN(auto after, repository_.ListMapVersions(run.robot_id));
    const storage::MapVersionRecord* now_current = Current(after);
    outcome.current_version = now_current ? now_current->version : 0;
  }
  outcome.outdated = outcome.current_version != appended.version;
  return outcome;
}

storage::Status MapHistory::OnRunAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report) {
  if (report.parameter_set() != policy_.default_parameter_set) return storage::Status::Ok();
  const std::string& run_id = run.run_id;
  auto version = repository_.GetMapVersionOfRun(run);
  if (version.status().code() == storage::StatusCode::kNotFound) return storage::Status::Ok();
  RETURN_IF_ERROR(version.status());
  ASSIGN_OR_RETURN(auto loaded, LoadMap(repository_, version->snapshot_id));
  ASSIGN_OR_RETURN(auto context, LoadRunContext(repository_, run, report.parameter_set()));
  context.report = report;
  const std::vector<fleet::v1::MapFinding> findings = Findings(loaded, context);
  ASSIGN_OR_RETURN(auto known_area, analyzer::KnownArea(loaded));
  ASSIGN_OR_RETURN(auto records, ToRecords(findings));
  RETURN_IF_ERROR(
      repository_.UpdateMapVersionHealth(version->robot_id, version->version, known_area, records));

  if (policy_.auto_repair == "none") return storage::Status::Ok();
  const std::string requested_by = "policy:" + policy_.auto_repair;
  const bool all_findings = policy_.auto_repair == "repair_findings";
  std::int64_t base = version->version;
  // Each repair makes a new version whose findings are recomputed, so the next finding is looked up in it;
  // a finding is tried once (by what it names), and a run's map is repaired at most kMaxPolicyRepairs times.
  constexpr int kMaxPolicyRepairs = 8;
  std::set<std::string> tried;
  std::vector<fleet::v1::MapFinding> open = findings;
  for (int repairs = 0; repairs < kMaxPolicyRepairs; ++repairs) {
    const fleet::v1::MapFinding* next = nullptr;
    std::string key;
    for (const fleet::v1::MapFinding& finding : open) {
      if (finding.finding_state() != fleet::v1::FINDING_STATE_OPEN ||
          finding.severity() < policy_.min_severity) {
        continue;
      }
      const fleet::v1::FindingKind kind = finding.finding_kind();
      const bool repairable = kind == fleet::v1::FINDING_KIND_PROTRUSION ||
                              (all_findings && (kind == fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS ||
                                                kind == fleet::v1::FINDING_KIND_HIGH_RESIDUAL_EDGE));
      key = std::string(NameOf(kind)) + ":" + std::to_string(finding.hypothesis()) + ":" +
            std::to_string(finding.edge_from()) + ":" + std::to_string(finding.edge_to()) + ":" +
            finding.summary();
      if (repairable && !tried.contains(key)) {
        next = &finding;
        break;
      }
    }
    if (next == nullptr) break;
    tried.insert(key);
    RepairRequest repair;
    repair.robot_id = version->robot_id;
    repair.base_version = base;
    if (next->finding_kind() == fleet::v1::FINDING_KIND_PROTRUSION) {
      repair.action = CutFinding{next->finding_id()};
    } else if (next->finding_kind() == fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS) {
      repair.action = RejectHypothesis{next->hypothesis()};
    } else {
      repair.action = RejectEdge{.from = next->edge_from(), .to = next->edge_to(), .view = std::nullopt};
    }
    repair.reason = "policy " + policy_.auto_repair + ": " + next->summary();
    repair.approve = policy_.auto_approve;
    repair.requested_by = requested_by;
    auto repaired = Repair(repair);
    if (!repaired.ok() && all_findings && repaired.status().code() != storage::StatusCode::kAborted) {
      // The map breaks where it cannot be repaired finding by finding: back to the map before this run.
      RepairRequest rollback = repair;
      rollback.action = Rollback{};
      rollback.reason = "policy " + policy_.auto_repair + ": " + next->summary() +
                        " could not be repaired (" + repaired.status().ToString() + ")";
      repaired = Repair(rollback);
      if (repaired.ok()) break;
    }
    // The robot's map moved on meanwhile (ABORTED): the newer version gets its own analysis.
    if (!repaired.ok()) {
      log::Warn("auto_repair_skipped", {{"run_id", run_id},
                                        {"finding", static_cast<long long>(next->finding_id())},
                                        {"error", repaired.status().ToString()}});
      break;
    }
    base = repaired->version.version();
    open = std::move(repaired->findings);
  }
  return storage::Status::Ok();
}

storage::Result<std::vector<fleet::v1::MapVersion>> MapHistory::List(const std::string& robot_id,
                                                                     std::int64_t* current_version,
                                                                     std::int64_t* head_version) {
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(robot_id));
  const storage::MapVersionRecord* current = Current(versions);
  *current_version = current ? current->version : 0;
  const storage::MapVersionRecord* head = Head(versions);
  *head_version = head ? head->version : 0;
  std::vector<fleet::v1::MapVersion> out;
  for (const storage::MapVersionRecord& record : versions) out.push_back(ToProto(record, &record == current));
  return out;
}

storage::Result<std::array<double, 4>> MapHistory::CutBox(const std::string& robot_id, std::int64_t version,
                                                          std::int64_t finding_id) {
  ASSIGN_OR_RETURN(auto detail, Get(robot_id, version));
  for (const fleet::v1::MapFinding& finding : detail.findings) {
    if (finding.finding_id() != finding_id) continue;
    if (finding.world_bbox_size() != 4) {
      return storage::InvalidArgument("finding " + std::to_string(finding_id) + " is a " +
                                      std::string(NameOf(finding.finding_kind())) +
                                      ", not a region that can be cut");
    }
    return std::array<double, 4>{finding.world_bbox(0), finding.world_bbox(1), finding.world_bbox(2),
                                 finding.world_bbox(3)};
  }
  return storage::NotFound("version " + std::to_string(version) + " has no finding " +
                           std::to_string(finding_id));
}

storage::Result<storage::MapVersionRecord> MapHistory::Resolve(const std::string& robot_id,
                                                               std::int64_t version) {
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(robot_id));
  return Find(versions, robot_id, version);
}

storage::Result<MapVersionDetail> MapHistory::Get(const std::string& robot_id, std::int64_t version,
                                                  fleet::v1::MapSnapshot* snapshot) {
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(robot_id));
  const storage::MapVersionRecord* current = Current(versions);
  ASSIGN_OR_RETURN(auto record, Find(versions, robot_id, version));
  MapVersionDetail detail;
  detail.version = ToProto(record, current && current->version == record.version);
  ASSIGN_OR_RETURN(auto findings, repository_.ListMapFindings(robot_id, record.version));
  ASSIGN_OR_RETURN(auto parsed, FromRecords(findings));
  detail.findings = std::move(parsed);
  if (snapshot) {
    ASSIGN_OR_RETURN(auto loaded, LoadSnapshot(repository_, record.snapshot_id));
    *snapshot = std::move(loaded);
  }
  ASSIGN_OR_RETURN(auto metadata, repository_.GetMapMetadata(robot_id, record.version));
  if (!metadata.empty()) {
    detail.metadata.emplace();
    if (!detail.metadata->ParseFromString(metadata)) {
      return storage::DataLoss("metadata of map version " + std::to_string(record.version) +
                               " does not parse");
    }
  }
  return detail;
}

storage::Result<MapVersionDetail> MapHistory::Repair(const RepairRequest& request) {
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(request.robot_id));
  if (request.base_version <= 0)
    return storage::InvalidArgument("base_version: the version repaired is required");
  ASSIGN_OR_RETURN(auto base, Find(versions, request.robot_id, request.base_version));
  // Fail fast on a base that is not the head; AppendMapVersion checks again, atomically, at the end.
  const storage::MapVersionRecord* head = Head(versions);
  if (head == nullptr || head->version != base.version) {
    const bool side_branch =
        base.approval == storage::MapApproval::kRejected || base.approval == storage::MapApproval::kStale;
    return storage::Aborted("version " + std::to_string(base.version) + " of robot " + request.robot_id +
                            " is " +
                            (side_branch ? std::string(storage::Name(base.approval)) + ", not" : "not") +
                            " the version repairs start from" +
                            (head ? " (version " + std::to_string(head->version) + " is)" : std::string()));
  }
  // A map without a run (an import, or a repair of one) has no pose graph to edit: it is repaired against the
  // map before the import. Undo works the same for both.
  if (base.run_id.empty() && !std::holds_alternative<Undo>(request.action)) {
    return RepairMapOnly(request, base, versions);
  }
  ASSIGN_OR_RETURN(auto loaded, LoadMap(repository_, base.snapshot_id));
  ASSIGN_OR_RETURN(auto context,
                   LoadRunContext(repository_, {base.robot_id, base.run_id}, policy_.default_parameter_set));
  const std::set<slamcore::NodeId> run_nodes = analyzer::NodesAddedByRun(loaded, context.parent);

  /// The repaired map and how its version records it: an edit's new map, or an earlier stored one (rollback, undo).
  struct Repaired {
    std::optional<slamcore::Map> map;  // none: the map stored as snapshot_id
    std::string snapshot_id;
    RepairRecord record;
  };
  std::string detail;  // what an edit did, in words (the analyzer's edits fill it)
  const auto stored_edit = [&](storage::Result<slamcore::Map> edit) -> storage::Result<Repaired> {
    ASSIGN_OR_RETURN(auto edited, std::move(edit));
    ASSIGN_OR_RETURN(auto stored,
                     repository_.PutSnapshot(fleet::SerializeDeterministic(analyzer::ToProto(edited))));
    return Repaired{std::move(edited), stored,
                    RecordOf(request, storage::MapOrigin::kRepair, detail, base.version)};
  };
  const auto apply = Overloaded{
      [&](const RejectEdge& edge) {
        return stored_edit(analyzer::RejectEdge(loaded, edge.from, edge.to, edge.view, &detail));
      },
      [&](const RejectHypothesis& rejected) {
        return stored_edit(analyzer::RejectHypothesis(loaded, run_nodes, rejected.hypothesis, &detail));
      },
      [&](const CutFinding& cut) -> storage::Result<Repaired> {
        ASSIGN_OR_RETURN(auto box, CutBox(request.robot_id, request.base_version, cut.finding_id));
        return stored_edit(analyzer::CutRegion(loaded, run_nodes, box, &detail));
      },
      [&](const Rollback&) -> storage::Result<Repaired> {
        ASSIGN_OR_RETURN(auto run, repository_.GetRun({base.robot_id, base.run_id}));
        if (!run.parent_snapshot_id) {
          return storage::FailedPrecondition(
              "version " + std::to_string(base.version) +
              " was made by the robot's first run: there is no parent map to roll back to");
        }
        return Repaired{std::nullopt, *run.parent_snapshot_id,
                        RecordOf(request, storage::MapOrigin::kRollback,
                                 "back to the map before run " + base.run_id, base.version)};
      },
      [&](const Undo&) -> storage::Result<Repaired> {
        const bool repaired_version = base.origin != storage::MapOrigin::kUpload && base.parent_version;
        const storage::MapVersionRecord* earlier =
            repaired_version ? FindRecord(versions, *base.parent_version) : nullptr;
        if (earlier == nullptr) {
          return storage::FailedPrecondition(
              "version " + std::to_string(base.version) +
              " is an upload, not a repair: nothing to undo (roll back instead)");
        }
        return Repaired{
            std::nullopt, earlier->snapshot_id,
            RecordOf(request, storage::MapOrigin::kUndo,
                     "undid version " + std::to_string(base.version) + " (" + ActionText(base.action) +
                         "): the map of version " + std::to_string(earlier->version) + " again",
                     earlier->version)};
      }};
  ASSIGN_OR_RETURN(Repaired repaired, std::visit(apply, request.action));
  if (!repaired.map) {
    ASSIGN_OR_RETURN(auto restored, LoadMap(repository_, repaired.snapshot_id));
    repaired.map = std::move(restored);
  }

  // Rolling back leaves the run's nodes behind: its findings no longer apply.
  const bool rolled_back = repaired.record.origin == storage::MapOrigin::kRollback;
  RunContext findings_context = rolled_back ? RunContext{} : std::move(context);
  if (rolled_back) findings_context.parent = *repaired.map;
  return AppendRepair(repaired.record, base, *repaired.map, repaired.snapshot_id,
                      Findings(*repaired.map, findings_context));
}

MapHistory::RepairRecord MapHistory::RecordOf(const RepairRequest& request, storage::MapOrigin origin,
                                              std::string detail, std::int64_t metadata_of) {
  RepairRecord record;
  record.origin = origin;
  record.action = RecordedAction(request.action);
  record.detail = std::move(detail);
  record.created_by = request.requested_by;
  record.reason = request.reason;
  if (request.approve) record.approved_by = request.requested_by;
  record.requested_by = request.requested_by;
  record.expected_head = request.base_version;
  record.metadata_of = metadata_of;
  return record;
}

storage::Result<MapVersionDetail> MapHistory::AppendRepair(
    const RepairRecord& made, const storage::MapVersionRecord& base, const slamcore::Map& repaired,
    const std::string& snapshot_id, const std::vector<fleet::v1::MapFinding>& findings) {
  ASSIGN_OR_RETURN(auto record, NewVersion(repaired, snapshot_id, /*with_known_area=*/true));
  ASSIGN_OR_RETURN(auto metadata, repository_.GetMapMetadata(base.robot_id, made.metadata_of));
  record.metadata = std::move(metadata);
  record.robot_id = base.robot_id;
  record.parent_version = base.version;
  record.origin = made.origin;
  record.run_id = base.run_id;
  record.action = made.action;
  record.action_detail = made.detail;
  record.created_by = made.created_by;
  record.reason = made.reason;
  const bool approved = made.approved_by.has_value();
  record.approval = approved ? storage::MapApproval::kApproved : storage::MapApproval::kPending;
  if (approved) {
    record.approved_by = *made.approved_by;
    record.approved_at_ms = NowMillis();
  }
  record.supersedes_pending = made.supersedes_pending;
  ASSIGN_OR_RETURN(auto finding_records, ToRecords(findings));
  ASSIGN_OR_RETURN(auto appended, repository_.AppendMapVersion(record, made.expected_head, finding_records));
  log::Info("map_repaired", {{"robot_id", base.robot_id},
                             {"base_version", static_cast<long long>(base.version)},
                             {"version", static_cast<long long>(appended.version)},
                             {"action", ActionText(made.action)},
                             {"detail", made.detail},
                             {"by", made.requested_by},
                             {"approved", approved}});
  MapVersionDetail result;
  result.version = ToProto(appended, approved);
  result.findings = findings;
  if (!record.metadata.empty()) {
    result.metadata.emplace();
    (void)result.metadata->ParseFromString(record.metadata);  // bytes this server stored a moment ago
  }
  return result;
}

storage::Result<fleet::v1::MapVersion> MapHistory::Review(const std::string& robot_id, std::int64_t version,
                                                          bool approve, const std::string& reviewed_by) {
  if (approve) {
    ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(robot_id));
    const storage::MapVersionRecord* pending = FindRecord(versions, version);
    const storage::MapVersionRecord* current = Current(versions);
    if (pending != nullptr && pending->approval == storage::MapApproval::kPending && current != nullptr &&
        current->version > version) {
      return ApproveOvertaken(versions, *pending, *current, reviewed_by);
    }
  }
  ASSIGN_OR_RETURN(auto reviewed, repository_.ReviewMapVersion(robot_id, version, approve, reviewed_by));
  log::Info("map_reviewed", {{"robot_id", robot_id},
                             {"version", static_cast<long long>(version)},
                             {"approved", approve},
                             {"by", reviewed_by}});
  // ReviewMapVersion approves only when no newer version is approved (under the robot's lock), so an approved
  // version is the robot's current one; a rejected one never is.
  return ToProto(reviewed, reviewed.approval == storage::MapApproval::kApproved);
}

storage::Result<fleet::v1::MapVersion> MapHistory::ApproveOvertaken(
    const std::vector<storage::MapVersionRecord>& versions, const storage::MapVersionRecord& pending,
    const storage::MapVersionRecord& current, const std::string& reviewed_by) {
  const std::string overtaken = "version " + std::to_string(pending.version) + " of robot " +
                                pending.robot_id + " was overtaken by version " +
                                std::to_string(current.version);
  const std::string instead =
      "; reject it, or repair version " + std::to_string(current.version) + " instead";
  if (pending.origin != storage::MapOrigin::kRepair) {
    return storage::FailedPrecondition(overtaken + ": a " + std::string(storage::Name(pending.origin)) +
                                       " cannot be carried onto a later map (it would drop the runs since)" +
                                       instead);
  }
  const storage::MapVersionRecord* base =
      pending.parent_version ? FindRecord(versions, *pending.parent_version) : nullptr;
  if (base == nullptr || !IsBuiltOn(versions, current, base->version) || current.run_id.empty()) {
    return storage::FailedPrecondition(overtaken + ", which is not a run's map built on version " +
                                       (base ? std::to_string(base->version) : std::string("?")) +
                                       ", the one the repair was made on" + instead);
  }
  ASSIGN_OR_RETURN(const slamcore::Map base_map, LoadMap(repository_, base->snapshot_id));
  ASSIGN_OR_RETURN(const slamcore::Map pending_map, LoadMap(repository_, pending.snapshot_id));
  ASSIGN_OR_RETURN(const slamcore::Map current_map, LoadMap(repository_, current.snapshot_id));
  std::string carried_detail;
  auto carried = analyzer::CarryRepairForward(base_map, pending_map, current_map, &carried_detail);
  if (!carried.ok())
    return storage::FailedPrecondition(overtaken + ": " + carried.status().message() + instead);
  ASSIGN_OR_RETURN(const std::string stored,
                   repository_.PutSnapshot(fleet::SerializeDeterministic(analyzer::ToProto(*carried))));
  ASSIGN_OR_RETURN(const RunContext context, LoadRunContext(repository_, {current.robot_id, current.run_id},
                                                            policy_.default_parameter_set));
  // The pending repair's own version, now made on the current one: its action, author and reason, approved by
  // the reviewer; the pending one is superseded (stale) in the same transaction.
  const storage::MapVersionRecord* head = Head(versions);
  const RepairRecord record{.origin = storage::MapOrigin::kRepair,
                            .action = pending.action,
                            .detail = "carried forward from version " + std::to_string(pending.version) +
                                      " (" + pending.action_detail + "): " + carried_detail,
                            .created_by = pending.created_by,
                            .reason = pending.reason,
                            .approved_by = reviewed_by,
                            .requested_by = reviewed_by,
                            .expected_head = head ? head->version : 0,
                            .supersedes_pending = pending.version,
                            .metadata_of = current.version};
  ASSIGN_OR_RETURN(const MapVersionDetail appended,
                   AppendRepair(record, current, *carried, stored, Findings(*carried, context)));
  log::Info("map_repair_carried_forward", {{"robot_id", pending.robot_id},
                                           {"pending_version", static_cast<long long>(pending.version)},
                                           {"onto_version", static_cast<long long>(current.version)},
                                           {"version", static_cast<long long>(appended.version.version())},
                                           {"by", reviewed_by}});
  return appended.version;
}

storage::Result<fleet::v1::MapVersion> MapHistory::Fetch(const std::string& robot_id,
                                                         std::int64_t held_version, bool* up_to_date,
                                                         fleet::v1::MapSnapshot* snapshot) {
  ASSIGN_OR_RETURN(auto current, Resolve(robot_id, 0));
  *up_to_date = held_version == current.version;
  if (!*up_to_date) {
    ASSIGN_OR_RETURN(auto loaded, LoadSnapshot(repository_, current.snapshot_id));
    *snapshot = std::move(loaded);
  }
  return ToProto(current, true);
}

storage::Result<std::set<slamcore::NodeId>> MapHistory::NodesAddedByRun(const storage::RunKey& run,
                                                                        const slamcore::Map& map) {
  ASSIGN_OR_RETURN(auto parent, LoadRunParent(repository_, run));
  return analyzer::NodesAddedByRun(map, parent);
}

storage::Result<fleet::v1::MapVersion> MapHistory::Import(const std::string& robot_id,
                                                          const fleet::v1::MapSnapshot& snapshot,
                                                          const fleet::v1::MapMetadata& metadata,
                                                          const std::string& source,
                                                          const std::string& reason, bool approve,
                                                          const std::string& requested_by) {
  RETURN_IF_ERROR(analyzer::ValidateMetadata(metadata));
  ASSIGN_OR_RETURN(auto map, analyzer::FromProto(snapshot, "snapshot"));
  if (map.local_maps.empty()) {
    return storage::InvalidArgument(
        "snapshot: no local map on any node; an imported map needs its occupancy grid");
  }
  if (const fleet::v1::ImportedMapInfo& info = snapshot.imported(); snapshot.has_imported()) {
    if (info.format() != "valetudo" && info.format() != "map_server") {
      return storage::InvalidArgument("snapshot.imported.format: \"" + info.format().substr(0, 64) +
                                      "\", expected \"valetudo\" or \"map_server\"");
    }
    for (const auto& [name, has, pose] : {std::tuple{"dock", info.has_dock(), info.dock()},
                                          std::tuple{"robot", info.has_robot(), info.robot()}}) {
      if (has && !(std::isfinite(pose.x()) && std::isfinite(pose.y()) && std::isfinite(pose.theta()) &&
                   std::abs(pose.x()) < 1e6 && std::abs(pose.y()) < 1e6)) {
        return storage::InvalidArgument(std::string("snapshot.imported.") + name +
                                        ": not a finite pose within 1000 km");
      }
    }
  }
  if (auto robot = repository_.GetRobot(robot_id); robot.status().code() == storage::StatusCode::kNotFound) {
    storage::RobotRecord robot_record;
    robot_record.robot_id = robot_id;
    robot_record.registered_at_ms = NowMillis();
    RETURN_IF_ERROR(repository_.PutRobot(robot_record));
  } else if (!robot.ok()) {
    return robot.status();
  }
  fleet::v1::MapSnapshot stored_snapshot = analyzer::ToProto(map);
  if (snapshot.has_imported())
    *stored_snapshot.mutable_imported() = snapshot.imported();  // dock, robot: kept
  ASSIGN_OR_RETURN(auto stored, repository_.PutSnapshot(fleet::SerializeDeterministic(stored_snapshot)));
  ASSIGN_OR_RETURN(auto versions, repository_.ListMapVersions(robot_id));
  const storage::MapVersionRecord* head = Head(versions);
  ASSIGN_OR_RETURN(auto findings, MapOnlyFindings(stored_snapshot, map, head));
  ASSIGN_OR_RETURN(auto record, NewVersion(map, stored, /*with_known_area=*/true));
  record.robot_id = robot_id;
  if (head) record.parent_version = head->version;
  record.origin = storage::MapOrigin::kImport;
  record.action = storage::MapAction::kImport;
  if (analyzer::HasContent(metadata)) record.metadata = fleet::SerializeDeterministic(metadata);
  record.action_detail = source;
  record.created_by = requested_by;
  record.reason = reason;
  record.approval = approve ? storage::MapApproval::kApproved : storage::MapApproval::kPending;
  if (approve) {
    record.approved_by = requested_by;
    record.approved_at_ms = NowMillis();
  }
  ASSIGN_OR_RETURN(auto finding_records, ToRecords(findings));
  ASSIGN_OR_RETURN(auto appended,
                   repository_.AppendMapVersion(record, head ? std::optional(head->version) : std::nullopt,
                                                finding_records));
  log::Info("map_imported", {{"robot_id", robot_id},
                             {"version", static_cast<long long>(appended.version)},
                             {"source", source},
                             {"by", requested_by},
                             {"approved", approve}});
  return ToProto(appended, approve);
}

storage::Result<std::vector<fleet::v1::MapFinding>> MapHistory::MapOnlyFindings(
    const fleet::v1::MapSnapshot& snapshot, const slamcore::Map& map,
    const storage::MapVersionRecord* reference) {
  std::vector<fleet::v1::MapFinding> findings = analyzer::FindMapFindings({.map = &map});
  if (reference == nullptr) return findings;
  ASSIGN_OR_RETURN(auto previous, LoadComparedMap(repository_, reference->snapshot_id));
  ASSIGN_OR_RETURN(auto grid, analyzer::RenderHomeGrid(map));
  // Regions are classed by the active model, as runs' regions are (AnalyzeStoredRun); none active: the
  // built-in default.
  std::shared_ptr<const slamcore::ProtrusionClassifier> classifier;
  if (auto active = repository_.GetActiveModel(policy_.model_name); active.ok()) {
    ASSIGN_OR_RETURN(auto loaded, LoadClassifier(active->bytes));
    classifier = std::move(loaded);
  } else if (active.status().code() != storage::StatusCode::kNotFound) {
    return active.status();
  } else {
    classifier = DefaultClassifier();
  }
  auto comparison = analyzer::CompareGrids(previous.grid, grid, previous.dock, analyzer::DockOf(snapshot),
                                           classifier.get());
  if (!comparison.ok()) {
    // Nothing to align by (a map without walls, another resolution): the version is kept, and says so.
    fleet::v1::MapFinding& finding = findings.emplace_back();
    finding.set_finding_kind(fleet::v1::FINDING_KIND_MISALIGNED);
    finding.set_severity(0.9);
    finding.set_finding_state(fleet::v1::FINDING_STATE_OPEN);
    finding.set_summary("not compared with version " + std::to_string(reference->version) + ": " +
                        comparison.status().message());
    return MergeFindings(std::move(findings), {});
  }
  return MergeFindings(std::move(findings), analyzer::ComparisonFindings(*comparison, reference->version));
}

storage::Result<MapVersionDetail> MapHistory::RepairMapOnly(
    const RepairRequest& request, const storage::MapVersionRecord& base,
    const std::vector<storage::MapVersionRecord>& versions) {
  const std::string name = "version " + std::to_string(base.version);
  const auto* cut_finding = std::get_if<CutFinding>(&request.action);
  const bool rollback = std::holds_alternative<Rollback>(request.action);
  if (!rollback && cut_finding == nullptr) {
    return storage::FailedPrecondition(
        name + " is a map without a run (imported): \"" + RepairActionName(request.action) +
        "\" does not apply; rollback, cut_finding of a new_region and undo do");
  }
  const storage::MapVersionRecord* reference = ComparisonReference(versions, base);
  if (reference == nullptr) {
    return storage::FailedPrecondition(
        name + " comes from the robot's first imported map: there is no earlier map to " +
        (rollback ? "roll back to" : "cut back to"));
  }
  if (rollback) {
    ASSIGN_OR_RETURN(auto restored, LoadMap(repository_, reference->snapshot_id));
    ASSIGN_OR_RETURN(auto restored_snapshot, LoadSnapshot(repository_, reference->snapshot_id));
    ASSIGN_OR_RETURN(auto findings, MapOnlyFindings(restored_snapshot, restored, reference));
    const std::string detail =
        "back to version " + std::to_string(reference->version) + ", the map before the import";
    return AppendRepair(RecordOf(request, storage::MapOrigin::kRollback, detail, reference->version), base,
                        restored, reference->snapshot_id, findings);
  }
  // cut_finding: the finding must be a new region of this version; its cells take the previous map's values.
  ASSIGN_OR_RETURN(auto detail, Get(request.robot_id, base.version));
  const fleet::v1::MapFinding* finding = nullptr;
  for (const fleet::v1::MapFinding& candidate : detail.findings) {
    if (candidate.finding_id() == cut_finding->finding_id) finding = &candidate;
  }
  if (finding == nullptr)
    return storage::NotFound(name + " has no finding " + std::to_string(cut_finding->finding_id));
  if (finding->finding_kind() != fleet::v1::FINDING_KIND_NEW_REGION) {
    return storage::InvalidArgument("finding " + std::to_string(cut_finding->finding_id) + " is a " +
                                    std::string(NameOf(finding->finding_kind())) +
                                    ", not a new_region that can be cut");
  }
  const nlohmann::json evidence = nlohmann::json::parse(finding->evidence_json(), nullptr, false);
  if (!evidence.is_object() || !evidence.contains("region_id") ||
      !evidence["region_id"].is_number_integer()) {
    return storage::DataLoss("finding " + std::to_string(cut_finding->finding_id) +
                             ": evidence has no region_id");
  }
  const int region_id = evidence["region_id"].get<int>();
  ASSIGN_OR_RETURN(auto base_snapshot, LoadSnapshot(repository_, base.snapshot_id));
  ASSIGN_OR_RETURN(auto base_map, LoadMap(repository_, base.snapshot_id));
  ASSIGN_OR_RETURN(auto previous, LoadComparedMap(repository_, reference->snapshot_id));
  ASSIGN_OR_RETURN(auto grid, analyzer::RenderHomeGrid(base_map));
  // The comparison again (deterministic: the same regions and ids as when the finding was made).
  ASSIGN_OR_RETURN(auto comparison, analyzer::CompareGrids(previous.grid, grid, previous.dock,
                                                           analyzer::DockOf(base_snapshot), nullptr));
  const slamcore::ProtrusionRegion* region = nullptr;
  for (const analyzer::ChangedRegion& changed : comparison.new_regions) {
    if (changed.region.id == region_id) region = &changed.region;
  }
  if (region == nullptr)
    return storage::DataLoss(name + " no longer shows region " + std::to_string(region_id));
  const slamcore::Map repaired = analyzer::MapOfGrid(
      slamcore::RepairChild(comparison.aligned_previous, grid, {region}, slamcore::RepairMode::kCutOut));
  fleet::v1::MapSnapshot repaired_snapshot = analyzer::ToProto(repaired);
  *repaired_snapshot.mutable_imported() = base_snapshot.imported();
  ASSIGN_OR_RETURN(auto stored, repository_.PutSnapshot(fleet::SerializeDeterministic(repaired_snapshot)));
  ASSIGN_OR_RETURN(auto findings, MapOnlyFindings(repaired_snapshot, repaired, reference));
  return AppendRepair(
      RecordOf(request, storage::MapOrigin::kRepair,
               "cut new region " + std::to_string(region_id) + " (" + std::to_string(region->cells.size()) +
                   " cells) back to version " + std::to_string(reference->version) + "'s cells",
               base.version),
      base, repaired, stored, findings);
}

storage::Result<std::vector<fleet::v1::ExportedFile>> MapHistory::Export(const std::string& robot_id,
                                                                         std::int64_t version,
                                                                         const std::string& format) {
  ASSIGN_OR_RETURN(auto record, Resolve(robot_id, version));
  ASSIGN_OR_RETURN(auto snapshot, LoadSnapshot(repository_, record.snapshot_id));
  auto loaded = analyzer::FromProto(snapshot, "snapshot " + record.snapshot_id);
  if (!loaded.ok()) return storage::DataLoss(loaded.status().message());
  // The metadata kept with the version; versions without (map_server imports) still hand back their poses.
  ASSIGN_OR_RETURN(auto stored, repository_.GetMapMetadata(robot_id, record.version));
  fleet::v1::MapMetadata metadata;
  if (!metadata.ParseFromString(stored))
    return storage::DataLoss("metadata of map version " + std::to_string(record.version) + " does not parse");
  if (!analyzer::HasContent(metadata) && snapshot.has_imported())
    metadata = analyzer::MetadataOfImported(snapshot.imported());
  ASSIGN_OR_RETURN(
      auto files,
      analyzer::ExportMap(*loaded, format, robot_id + "-v" + std::to_string(record.version), &metadata));
  return files;
}

}  // namespace server
