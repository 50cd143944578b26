// Each robot's map history (docs/formats/map-versions.md): what ingest, the analysis workers, the Maps gRPC
// service and the dashboard do with map versions, in one place.
//
//   upload      → StoreUpload: the run's child map becomes the robot's newest version; approved when it was
//                 built on the current approved map, stale when on an older one (the robot is told)
//   analysis    → OnRunAnalysed: findings from the default set's report; the repair policy may act on them
//   engineers   → Repair (reject an edge or hypothesis, cut a protrusion, roll back, undo), Review (approve or
//                 reject a pending version), Export (map_server PGM + YAML, g2o, ValetudoMap JSON), Import (a map
//                 made elsewhere, compared with the version before it; cut a new region of it, or roll it back)
//   robots      → Fetch: the current approved version, or "up to date"
//
// Every new version is appended with its findings in one transaction that checks the robot's newest version
// (storage::Repository::AppendMapVersion), so concurrent repairs of one map never interleave: the later one
// gets ABORTED and must look again. Versions never change; undo makes a new version holding the earlier
// map's very bytes (the same content-addressed snapshot).
//
// Thread safety: stateless apart from the repository (thread-safe); use from any thread.
#pragma once

#include <array>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fleet/v1/maps.pb.h"
#include "fleet/v1/report.pb.h"
#include "fleet/v1/telemetry.pb.h"
#include "server/config.h"
#include "slamcore/mapper.h"
#include "storage/repository.h"

namespace server {

struct MapPolicy {
  /// "none"; "cut_protrusions": after analysis, cut open protrusion findings out of the newest version;
  /// "repair_findings": also reject the hypothesis of an unconfirmed-hypothesis finding and the edge of a
  /// high-residual one, and roll back to the map before the run when such a finding cannot be repaired.
  /// Only findings of at least `min_severity` are acted on.
  std::string auto_repair = "none";
  double min_severity = 0.0;
  /// "views": only the protrusions the run's own views show (a slip seen, analyzer::ClassifyRegions) are
  /// cut — the map-only model's calls stay open for an engineer, since on robot-drawn maps it also calls real
  /// new floor a protrusion (README "Erroneous protrusions": cutting them all took about six square metres
  /// of real floor for each square metre of false floor in fleetsim's lifelong homes); "any": every one.
  std::string protrusions = "views";
  /// Policy repairs are approved at once (robots get them on their next GetMap) instead of waiting for review.
  bool auto_approve = false;
  std::string default_parameter_set = "default";
  /// The active version of this model classes the regions of imported maps, as it does runs' regions.
  std::string model_name = "protrusion";
};

MapPolicy MapPolicyOf(const FleetdConfig& config);

struct UploadOutcome {
  bool already_present = false;      // the same run was stored before (a retried upload)
  std::int64_t analysis_job_id = 0;  // 0 when it was already present
  std::int64_t version = 0;          // the version the run's child map became
  std::int64_t current_version = 0;  // the robot's current approved version after the upload
  bool outdated = false;             // the run was built on a map older than the current one
};

/// What a repair does (the Maps.RepairMap oneof; the dashboard's "action" with its fields).
struct RejectEdge {
  std::int64_t from = 0, to = 0;
  std::optional<std::int64_t> view;
};
struct RejectHypothesis {
  std::int64_t hypothesis = 0;
};
struct CutFinding {
  std::int64_t finding_id = 0;
};
struct Rollback {};
struct Undo {};
using RepairAction = std::variant<RejectEdge, RejectHypothesis, CutFinding, Rollback, Undo>;

/// A visitor from lambdas, one per alternative: std::visit(Overloaded{[](const RejectEdge&) {...}, ...}, action).
template <typename... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <typename... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

/// "reject_edge", "reject_hypothesis", "cut_finding", "rollback", "undo" (the oneof's and the dashboard's names).
const char* RepairActionName(const RepairAction& action);
/// The action a name stands for, with default fields; INVALID_ARGUMENT naming `field` for any other name.
storage::Result<RepairAction> RepairActionNamed(const std::string& name, const std::string& field);
/// How a version made by `action` records it (a cut_finding is recorded as a cut_region).
storage::MapAction RecordedAction(const RepairAction& action);

// The wire's enums (maps.proto) for storage's (records.h): value i of a storage enum is value i + 1 of the proto
// one, 0 being UNSPECIFIED. FromProto answers INVALID_ARGUMENT naming `field` for UNSPECIFIED or an unknown value.
fleet::v1::MapOrigin ToProto(storage::MapOrigin origin);
fleet::v1::MapApproval ToProto(storage::MapApproval approval);
fleet::v1::MapAction ToProto(std::optional<storage::MapAction> action);  // none: UNSPECIFIED
fleet::v1::FindingKind ToProto(storage::FindingKind kind);
fleet::v1::FindingState ToProto(storage::FindingState state);
storage::Result<storage::MapOrigin> FromProto(fleet::v1::MapOrigin origin, const std::string& field);
storage::Result<storage::MapApproval> FromProto(fleet::v1::MapApproval approval, const std::string& field);
storage::Result<storage::MapAction> FromProto(fleet::v1::MapAction action, const std::string& field);
storage::Result<storage::FindingKind> FromProto(fleet::v1::FindingKind kind, const std::string& field);
storage::Result<storage::FindingState> FromProto(fleet::v1::FindingState state, const std::string& field);
/// The lower-case name of a wire value (storage's one table; the dashboard's JSON); "" for UNSPECIFIED.
template <typename ProtoEnum>
std::string_view NameOf(ProtoEnum value) {
  auto known = FromProto(value, "");
  return known.ok() ? storage::Name(*known) : std::string_view();
}

struct RepairRequest {
  std::string robot_id;
  std::int64_t base_version = 0;
  RepairAction action;
  std::string reason;
  bool approve = false;
  std::string requested_by;  // principal name or "policy:<name>"
};

struct MapVersionDetail {
  fleet::v1::MapVersion version;
  std::vector<fleet::v1::MapFinding> findings;
  std::optional<fleet::v1::MapMetadata> metadata;  // imported maps: rooms, path, poses, walls, zones
};

class MapHistory {
 public:
  MapHistory(storage::Repository& repository, MapPolicy policy);

  /// Stores an upload (its robot, maps, run and analysis job, filled in by ingest) with the run's child map
  /// as the robot's newest version, all in one transaction (storage::Repository::StoreUpload); idempotent by
  /// run id (a retried upload gets the same version). `uploader`: the principal that sent the run
  /// ("robot:<id>" or empty: the robot itself). An engineer's upload for a robot is recorded as the
  /// engineer's and waits for review ("pending"); an admin's is recorded as the admin's.
  /// `parent_version`: the version holding the run's parent snapshot when the caller has already looked it
  /// up (ingest does, for a parent named by id); otherwise StoreUpload looks it up.
  storage::Result<UploadOutcome> StoreUpload(storage::UploadBundle upload, const slamcore::Map& child,
                                             const std::string& uploader = "",
                                             const storage::MapVersionRecord* parent_version = nullptr);
  /// Called by the worker after storing a report; acts only on the default set's report of an upload version.
  /// Reads the version's map and the run's parent map from storage.
  storage::Status OnRunAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report);
  /// The maps the analysis already decoded: the run's parent map and, as stored under
  /// `child_snapshot_id`, the map the robot uploaded (the upload version's map).
  struct AnalysedMaps {
    const slamcore::Map& parent;
    const slamcore::Map& uploaded_child;
    std::string child_snapshot_id;
  };
  /// The same without reading or decoding the maps again: the worker has them from the analysis. A version
  /// whose snapshot is not `child_snapshot_id` is still read from storage.
  storage::Status OnRunAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report,
                                const AnalysedMaps& maps);

  /// Versions oldest first, `current` marked; current_version 0 when none is approved; head_version: what
  /// repairs start from (the newest approved or pending version), 0 when none.
  storage::Result<std::vector<fleet::v1::MapVersion>> List(const std::string& robot_id,
                                                           std::int64_t* current_version,
                                                           std::int64_t* head_version);
  /// `version` 0: the current one. With the snapshot when `snapshot` is not null.
  storage::Result<MapVersionDetail> Get(const std::string& robot_id, std::int64_t version,
                                        fleet::v1::MapSnapshot* snapshot = nullptr);
  /// INVALID_ARGUMENT for a repair that changes nothing, ABORTED when base_version is not the head.
  storage::Result<MapVersionDetail> Repair(const RepairRequest& request);
  /// Approves or rejects a pending version. Approving a pending repair that the robot's next upload overtook
  /// (it ran on the map before the repair) carries the repair onto the current version
  /// (analyzer::CarryRepairForward): the answer is that new, approved version (origin repair, the pending
  /// one's action, "carried forward from version N" in its detail), and the pending one becomes stale.
  /// FAILED_PRECONDITION, naming why, when it cannot be carried (a rollback or undo, a current version not
  /// built on the repair's base, or nothing of the repair still applies): reject it, or repair the current one.
  storage::Result<fleet::v1::MapVersion> Review(const std::string& robot_id, std::int64_t version,
                                                bool approve, const std::string& reviewed_by);
  /// NOT_FOUND when the robot has no approved map. `snapshot` is filled unless up to date.
  storage::Result<fleet::v1::MapVersion> Fetch(const std::string& robot_id, std::int64_t held_version,
                                               bool* up_to_date, fleet::v1::MapSnapshot* snapshot);
  /// The nodes of a version's `map` that `run_id` (the run the version's chain started from) added: only
  /// hypotheses of that run can be rejected as a whole.
  storage::Result<std::set<slamcore::NodeId>> NodesAddedByRun(const storage::RunKey& run,
                                                              const slamcore::Map& map);
  /// A map made elsewhere becomes the robot's newest version (origin import, parent: the head version), approved
  /// when `approve`, else pending; the robot is registered when new. INVALID_ARGUMENT names what is wrong with
  /// the snapshot (it must hold at least one node with a local map) or the metadata (analyzer::ValidateMetadata);
  /// nothing is stored then. The metadata (rooms, path, poses, zones) is kept with the version. Its findings
  /// compare it with the head (analyzer::CompareGrids): alignment, new and lost regions.
  storage::Result<fleet::v1::MapVersion> Import(const std::string& robot_id,
                                                const fleet::v1::MapSnapshot& snapshot,
                                                const fleet::v1::MapMetadata& metadata,
                                                const std::string& source, const std::string& reason,
                                                bool approve, const std::string& requested_by);
  /// `format` "map_server", "g2o" or "valetudo" (with the version's metadata); files are named
  /// "<robot>-v<version>.<ext>".
  storage::Result<std::vector<fleet::v1::ExportedFile>> Export(const std::string& robot_id,
                                                               std::int64_t version,
                                                               const std::string& format);

 private:
  /// The upload version whose health the run's `report` decides: none for another set's report, or for a
  /// run that recorded no map version.
  storage::Result<std::optional<storage::MapVersionRecord>> UploadVersionToJudge(
      const storage::RunKey& run, const fleet::v1::RunReport& report);
  /// OnRunAnalysed once the upload version `version` of the run, its map and the run's parent map are known.
  storage::Status OnUploadAnalysed(const storage::RunKey& run, const fleet::v1::RunReport& report,
                                   const storage::MapVersionRecord& version, const slamcore::Map& map,
                                   const slamcore::Map& run_parent);
  storage::Result<storage::MapVersionRecord> Resolve(const std::string& robot_id, std::int64_t version);
  /// The box of a version's finding that a cut removes; INVALID_ARGUMENT when the finding has none.
  storage::Result<std::array<double, 4>> CutBox(const std::string& robot_id, std::int64_t version,
                                                std::int64_t finding_id);
  /// Repairs of a version without a run (an import, or a repair of one): rollback to the map before the
  /// import, or cut a new region of it back to the previous map's cells.
  storage::Result<MapVersionDetail> RepairMapOnly(const RepairRequest& request,
                                                  const storage::MapVersionRecord& base,
                                                  const std::vector<storage::MapVersionRecord>& versions);
  /// How a new version made from a base records what made it: a repair request's own, or a pending repair's
  /// carried onto a later version (Review).
  struct RepairRecord {
    storage::MapOrigin origin = storage::MapOrigin::kRepair;
    std::optional<storage::MapAction> action;
    std::string detail;
    std::string created_by, reason;
    std::optional<std::string> approved_by;  // approved at once by; none: pending review
    std::string requested_by;        // who asked (logged): the requester, or the reviewer of a carried repair
    std::int64_t expected_head = 0;  // AppendMapVersion fails with ABORTED when the head moved from it
    std::optional<std::int64_t>
        supersedes_pending;        // the carried repair, marked stale in the same transaction
    std::int64_t metadata_of = 0;  // the version whose metadata the new one keeps (whose map it derives from)
  };
  /// How the version that `request` makes (by `origin`; `detail`: what was done, in words) is recorded.
  static RepairRecord RecordOf(const RepairRequest& request, storage::MapOrigin origin, std::string detail,
                               std::int64_t metadata_of);
  /// Appends `repaired` (stored as `snapshot_id`) as the new version made from `base`, recorded as `made`
  /// says, with `findings`.
  storage::Result<MapVersionDetail> AppendRepair(const RepairRecord& made,
                                                 const storage::MapVersionRecord& base,
                                                 const slamcore::Map& repaired,
                                                 const std::string& snapshot_id,
                                                 const std::vector<fleet::v1::MapFinding>& findings);
  /// Review's approval of `pending` once `current` (newer) overtook it.
  storage::Result<fleet::v1::MapVersion> ApproveOvertaken(
      const std::vector<storage::MapVersionRecord>& versions, const storage::MapVersionRecord& pending,
      const storage::MapVersionRecord& current, const std::string& reviewed_by);
  /// Findings of a map-only version's `snapshot`: its comparison with `reference` (when there is one).
  storage::Result<std::vector<fleet::v1::MapFinding>> MapOnlyFindings(
      const fleet::v1::MapSnapshot& snapshot, const slamcore::Map& map,
      const storage::MapVersionRecord* reference);

  storage::Repository& repository_;
  const MapPolicy policy_;
};

fleet::v1::MapVersion ToProto(const storage::MapVersionRecord& record, bool current);

}  // namespace server
