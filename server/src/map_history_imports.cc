// MapHistory for maps made elsewhere: Import (a ValetudoMap or map_server map compared with the version
// before it), the findings of such map-only versions, their repairs, and Export.
#include "map_history_support.h"

#include <algorithm>
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

using namespace map_history_internal;

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
