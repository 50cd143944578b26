#include "server/map_history.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "analyzer/map_comparison.h"
#include "analyzer/map_metadata.h"
#include "analyzer/map_repair.h"
#include "analyzer/telemetry_codec.h"
#include "fleet/serialization.h"
#include "server/analysis.h"
#include "server/log.h"
#include "map_history_support.h"

namespace server {

using namespace map_history_internal;

namespace {

/// Whether a protrusion finding rests on the run's own views (its evidence says so), not on the map-only
/// model alone.
bool SeenByViews(const fleet::v1::MapFinding& finding) {
  const auto evidence = nlohmann::json::parse(finding.evidence_json(), nullptr, /*allow_exceptions=*/false);
  return evidence.is_object() && evidence.value("decided_by", std::string()) == "views";
}

}  // namespace

MapPolicy MapPolicyOf(const FleetdConfig& config) {
  return {.auto_repair = config.auto_repair,
          .min_severity = config.auto_repair_min_severity,
          .protrusions = config.auto_repair_protrusions,
          .auto_approve = config.auto_approve,
          .default_parameter_set = config.default_parameter_set,
          .model_name = config.model_name};
}

MapHistory::MapHistory(storage::Repository& repository, MapPolicy policy)
    : repository_(repository), policy_(std::move(policy)) {}

storage::Result<UploadOutcome> MapHistory::StoreUpload(storage::UploadBundle upload,
                                                       const slamcore::Map& child,
                                                       const std::string& uploader,
                                                       const storage::MapVersionRecord* parent_version) {
  const storage::RunRecord& run = upload.run;
  if (!run.child_snapshot_id) return storage::InvalidArgument("run " + run.run_id + " has no child map");
  // Index probes, not the robot's history: an upload costs the same on a map's first day and its thousandth.
  ASSIGN_OR_RETURN(const std::optional<storage::MapVersionRecord> current,
                   repository_.GetCurrentMapVersion(run.robot_id));
  ASSIGN_OR_RETURN(auto record, NewVersion(child, *run.child_snapshot_id, /*with_known_area=*/false));
  record.robot_id = run.robot_id;
  record.origin = storage::MapOrigin::kUpload;
  record.run_id = run.run_id;
  record.created_by = uploader.empty() ? "robot:" + run.robot_id : uploader;
  // Only the robot's own uploads (and an admin's) become its map unreviewed: an engineer's upload for a robot
  // is a map a person made, and goes through review like a repair.
  const bool needs_review = uploader.rfind("engineer:", 0) == 0;
  const std::string parent = run.parent_snapshot_id.value_or("");
  if (parent_version != nullptr) {
    record.parent_version = parent_version->version;
  } else if (!parent.empty()) {
    ASSIGN_OR_RETURN(const auto found, repository_.FindMapVersionOfSnapshot(run.robot_id, parent));
    if (found) record.parent_version = found->version;
  }
  // Built on the current map (or there is none yet): this is the robot's map now. Built on an older one: kept
  // in the history, but the robot should take the current version instead.
  const bool outdated = current.has_value() && current->snapshot_id != parent;
  record.approval = outdated       ? storage::MapApproval::kStale
                    : needs_review ? storage::MapApproval::kPending
                                   : storage::MapApproval::kApproved;
  if (!outdated && !needs_review) {
    record.approved_by = record.created_by;
    record.approved_at_ms = run.ended_at_ms;
  }
  // Findings on the map alone for now; OnRunAnalysed adds those that need the server's rerun.
  ASSIGN_OR_RETURN(upload.findings, ToRecords(analyzer::FindMapFindings({.map = &child})));
  upload.map_version = std::move(record);
  ASSIGN_OR_RETURN(const storage::StoredUpload stored, repository_.StoreUpload(upload));
  UploadOutcome outcome;
  outcome.already_present = stored.run == storage::InsertOutcome::kAlreadyPresent;
  outcome.analysis_job_id = stored.analysis_job_id;
  outcome.version = stored.map_version.version;
  if (stored.map_version.approval == storage::MapApproval::kApproved && !outcome.already_present) {
    // Just made (a new run's version is made in its transaction), on the current map: the current one now.
    outcome.current_version = stored.map_version.version;
  } else {
    // Stale, pending, or a retried upload's earlier version: the current map is whatever the history says now.
    ASSIGN_OR_RETURN(const auto now_current, repository_.GetCurrentMapVersion(run.robot_id));
    outcome.current_version = now_current ? now_current->version : 0;
  }
  outcome.outdated = outcome.current_version != stored.map_version.version;
  return outcome;
}

storage::Result<std::optional<storage::MapVersionRecord>> MapHistory::UploadVersionToJudge(
    const storage::RunKey& run, const fleet::v1::RunReport& report) {
  if (report.parameter_set() != policy_.default_parameter_set)
    return std::optional<storage::MapVersionRecord>();
  auto version = repository_.GetMapVersionOfRun(run);
  if (version.status().code() == storage::StatusCode::kNotFound)
    return std::optional<storage::MapVersionRecord>();
  RETURN_IF_ERROR(version.status());
  return std::optional<storage::MapVersionRecord>(std::move(version).value());
}

storage::Status MapHistory::OnRunAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report) {
  ASSIGN_OR_RETURN(const auto version, UploadVersionToJudge(run, report));
  if (!version) return storage::Status::Ok();
  ASSIGN_OR_RETURN(auto loaded, LoadMap(repository_, version->snapshot_id));
  // The stored report is not read: it is `report`, which the findings are made from.
  ASSIGN_OR_RETURN(auto run_parent, LoadRunParent(repository_, run));
  return OnUploadAnalysed(run, report, *version, loaded, run_parent);
}

storage::Status MapHistory::OnRunAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report,
                                          const AnalysedMaps& maps) {
  ASSIGN_OR_RETURN(const auto version, UploadVersionToJudge(run, report));
  if (!version) return storage::Status::Ok();
  if (version->snapshot_id == maps.child_snapshot_id)
    return OnUploadAnalysed(run, report, *version, maps.uploaded_child, maps.parent);
  ASSIGN_OR_RETURN(auto loaded, LoadMap(repository_, version->snapshot_id));
  return OnUploadAnalysed(run, report, *version, loaded, maps.parent);
}

storage::Status MapHistory::OnUploadAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report,
                                             const storage::MapVersionRecord& version,
                                             const slamcore::Map& map, const slamcore::Map& run_parent) {
  const std::string& run_id = run.run_id;
  const std::vector<fleet::v1::MapFinding> findings =
      analyzer::FindMapFindings({.map = &map, .run_parent = &run_parent, .report = &report});
  ASSIGN_OR_RETURN(auto known_area, analyzer::KnownArea(map));
  ASSIGN_OR_RETURN(auto records, ToRecords(findings));
  RETURN_IF_ERROR(repository_.UpdateMapVersionHealth(version.robot_id, version.version, known_area, records));

  if (policy_.auto_repair == "none") return storage::Status::Ok();
  const std::string requested_by = "policy:" + policy_.auto_repair;
  const bool all_findings = policy_.auto_repair == "repair_findings";
  std::int64_t base = version.version;
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
      const bool repairable = (kind == fleet::v1::FINDING_KIND_PROTRUSION &&
                               (policy_.protrusions == "any" || SeenByViews(finding))) ||
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
    repair.robot_id = version.robot_id;
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
  if (version < 0)
    return storage::InvalidArgument("version: expected a positive number, or 0 for the current one");
  if (version > 0) return repository_.GetMapVersion(robot_id, version);
  // The current version, as a robot asks for it before every run: an index probe, not its history.
  ASSIGN_OR_RETURN(auto current, repository_.GetCurrentMapVersion(robot_id));
  if (!current) return storage::NotFound("robot " + robot_id + " has no approved map version");
  return *std::move(current);
}

storage::Result<MapVersionDetail> MapHistory::Get(const std::string& robot_id, std::int64_t version,
                                                  fleet::v1::MapSnapshot* snapshot) {
  ASSIGN_OR_RETURN(auto record, Resolve(robot_id, version));
  bool is_current = version == 0;
  if (!is_current && record.approval == storage::MapApproval::kApproved) {
    ASSIGN_OR_RETURN(const auto current, repository_.GetCurrentMapVersion(robot_id));
    is_current = current && current->version == record.version;
  }
  MapVersionDetail detail;
  detail.version = ToProto(record, is_current);
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
  const storage::MapVersionRecord* found = FindRecord(versions, request.base_version);
  if (found == nullptr) {
    return storage::NotFound("robot " + request.robot_id + " has no map version " +
                             std::to_string(request.base_version));
  }
  const storage::MapVersionRecord base = *found;
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

}  // namespace server
