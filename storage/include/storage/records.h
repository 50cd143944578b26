// Plain records that storage keeps. No protobuf here: the analyzer and server translate at their boundary.
// Byte payloads (telemetry, snapshots, reports, parameter sets, models) are std::string used as a byte
// string, so serialized protos pass straight through. Times are milliseconds since the Unix epoch (UTC).
//
// Thread safety: value types.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "storage/status.h"

namespace storage {

// Closed sets of states kept on records. Each has one name table (storage/src/record_names.cc): Name() gives
// the lower-case spelling stored in its TEXT column (and shown on the dashboard), Parse<E>() reads it back,
// INVALID_ARGUMENT naming the value for any other spelling. Reads of a stored value outside the set fail with
// DATA_LOSS instead of guessing.

/// How a map version was made.
enum class MapOrigin { kUpload, kRepair, kRollback, kUndo, kImport };
inline constexpr std::array kMapOrigins{MapOrigin::kUpload, MapOrigin::kRepair, MapOrigin::kRollback,
                                        MapOrigin::kUndo, MapOrigin::kImport};
std::string_view Name(MapOrigin origin);  // "upload", "repair", "rollback", "undo", "import"

/// Whether robots may get a map version.
enum class MapApproval { kApproved, kPending, kRejected, kStale };
inline constexpr std::array kMapApprovals{MapApproval::kApproved, MapApproval::kPending,
                                          MapApproval::kRejected, MapApproval::kStale};
std::string_view Name(MapApproval approval);  // "approved", "pending", "rejected", "stale"

/// What a repair (or an import) did to make a version; uploads have none.
enum class MapAction { kRejectEdge, kRejectHypothesis, kCutRegion, kRollback, kUndo, kImport };
inline constexpr std::array kMapActions{MapAction::kRejectEdge, MapAction::kRejectHypothesis,
                                        MapAction::kCutRegion,  MapAction::kRollback,
                                        MapAction::kUndo,       MapAction::kImport};
std::string_view Name(
    MapAction action);  // "reject_edge", "reject_hypothesis", "cut_region", "rollback", "undo",
                        // "import"

/// Whether a finding still asks for a repair.
enum class FindingState { kOpen, kResolved, kInfo };
inline constexpr std::array kFindingStates{FindingState::kOpen, FindingState::kResolved, FindingState::kInfo};
std::string_view Name(FindingState state);  // "open", "resolved" (the version no longer shows it), "info"
                                            // (evidence, nothing to repair)

/// What a finding is about (docs/formats/map-versions.md "Findings").
enum class FindingKind {
  kHighResidualEdge,
  kUnconfirmedHypothesis,
  kUndoneMerge,
  kRetractedHypothesis,
  kProtrusion,
  kAmbiguousView,
  kAlignment,  // imported versions: their comparison with the map before
  kMisaligned,
  kNewRegion,
  kLostRegion,
};
inline constexpr std::array kFindingKinds{FindingKind::kHighResidualEdge, FindingKind::kUnconfirmedHypothesis,
                                          FindingKind::kUndoneMerge,      FindingKind::kRetractedHypothesis,
                                          FindingKind::kProtrusion,       FindingKind::kAmbiguousView,
                                          FindingKind::kAlignment,        FindingKind::kMisaligned,
                                          FindingKind::kNewRegion,        FindingKind::kLostRegion};
std::string_view Name(FindingKind kind);  // "high_residual_edge", "unconfirmed_hypothesis", ...

enum class JobState { kQueued, kLeased, kDone, kFailed, kCancelled };
inline constexpr std::array kJobStates{JobState::kQueued, JobState::kLeased, JobState::kDone,
                                       JobState::kFailed, JobState::kCancelled};
std::string_view Name(JobState state);  // "queued", "leased", "done", "failed", "cancelled"

/// The value of E that `name` spells; INVALID_ARGUMENT naming `name` and the spellings expected otherwise.
/// Defined for MapOrigin, MapApproval, MapAction, FindingState, FindingKind and JobState.
template <typename E>
Result<E> Parse(std::string_view name);
template <>
Result<MapOrigin> Parse<MapOrigin>(std::string_view name);
template <>
Result<MapApproval> Parse<MapApproval>(std::string_view name);
template <>
Result<MapAction> Parse<MapAction>(std::string_view name);
template <>
Result<FindingState> Parse<FindingState>(std::string_view name);
template <>
Result<FindingKind> Parse<FindingKind>(std::string_view name);
template <>
Result<JobState> Parse<JobState>(std::string_view name);

struct RobotRecord {
  std::string robot_id;
  std::string robot_model;
  std::string firmware;
  std::int64_t registered_at_ms = 0;
};

/// A principal's credential as listed to admins: never its secret or hash.
struct CredentialRecord {
  std::string principal;
  std::int64_t updated_at_ms = 0;  // minted, rotated or revoked at
  bool revoked = false;
};

/// Credentials changed after an epoch (SetCredential and RevokeCredential each take the next epoch).
struct CredentialChanges {
  std::int64_t epoch = 0;               // the newest change returned (or the `since` asked with)
  std::vector<std::string> principals;  // changed after `since`, oldest change first
  bool truncated = false;  // more changes than the limit, or an erased credential (DeleteRobot): drop every
                           // cached token
};

/// A write transaction the database could not take (full, read-only, unreachable).
struct WriteFailure {
  std::int64_t at_ms = 0;
  std::string message;
};

/// A run's identity: run ids are the robot's own, so two robots may use the same one (robot A can never take
/// robot B's run id).
struct RunKey {
  std::string robot_id;
  std::string run_id;
};

/// One uploaded run. Identity is (robot_id, run_id); storing the same run twice keeps one.
struct RunRecord {
  std::string run_id;
  std::string robot_id;  // must name a stored robot
  std::string firmware;
  std::string robot_model;
  std::int64_t started_at_ms = 0;
  std::int64_t ended_at_ms = 0;
  std::optional<std::string> parent_snapshot_id;  // must name a stored snapshot when set
  std::optional<std::string> child_snapshot_id;   // must name a stored snapshot when set
  std::string telemetry;            // raw event stream; ListRuns leaves it empty (see telemetry_size)
  std::int64_t telemetry_size = 0;  // filled on read: uncompressed size in bytes
  // Filled on read: when retention pruned the run's events (telemetry is then empty); the run's metadata,
  // reports and map versions stay.
  std::optional<std::int64_t> telemetry_pruned_at_ms;

  RunKey key() const { return RunKey{robot_id, run_id}; }
};

/// A map snapshot, content-addressed: snapshot_id is the lowercase hex SHA-256 of bytes.
struct SnapshotRecord {
  std::string snapshot_id;
  std::string bytes;
};

/// The summary of one run analysed with one parameter set: (run_id, parameter_set) is the key, so
/// reprocessing results sit beside the originals. The counters are columns so that fleet statistics
/// aggregate in the database; `report` is the full report, opaque to storage.
struct ReportRecord {
  std::string robot_id;
  std::string run_id;
  std::string parameter_set;  // must name a stored parameter set
  std::int64_t recovery_created = 0;
  std::int64_t recovery_accepted = 0;
  std::int64_t recovery_retracted = 0;  // accepted, then taken back by later evidence
  std::int64_t merge_created = 0;
  std::int64_t merge_conditionally_accepted = 0;
  std::int64_t merge_conditional_then_rejected = 0;
  std::int64_t views_total = 0;
  std::int64_t views_ambiguous = 0;
  bool started_localized = false;
  std::int64_t protrusions_found = 0;
  std::string report;
};

/// One hypothesis decision of a report, in decision order.
struct DecisionRecord {
  std::int64_t sequence = 0;  // unique within the report
  double time_s = 0.0;        // run time of the decision
  std::string kind;           // e.g. "recovery", "merge"
  std::string outcome;        // e.g. "created", "accepted", "conditionally_accepted", "rejected"
  std::int64_t subject_id = 0;
  double score = 0.0;
  std::string detail;
};

/// A view the ambiguity tracker flagged.
struct AmbiguousViewRecord {
  std::int64_t view_id = 0;  // unique within the report
  double time_s = 0.0;
  std::int64_t candidate_count = 0;
  double ambiguity = 0.0;
  std::string detail;
};

struct BoundingBox {
  double min_x = 0.0, min_y = 0.0, max_x = 0.0, max_y = 0.0;
};

/// A protrusion region found in a run with a parameter set, with its features, the classifier's guess and,
/// once an engineer looked at it, a label.
struct ProtrusionRegionRecord {
  std::string robot_id;        // filled on read; taken from the report on write
  std::string run_id;          // filled on read; taken from the report on write
  std::string parameter_set;   // filled on read; taken from the report on write
  std::int64_t region_id = 0;  // unique within the report
  BoundingBox bbox;
  std::string features_json;
  std::string predicted_class;
  double probability = 0.0;
  /// What decided predicted_class (fleet.v1.ProtrusionRegion.decided_by): "views", "classifier" or "none";
  /// empty for regions stored before it was kept.
  std::string decided_by;
  std::optional<std::string> label;
  std::optional<std::string> labelled_by;
};

/// Everything one analysis writes, stored in one transaction.
struct ReportBundle {
  ReportRecord report;
  std::vector<DecisionRecord> decisions;
  std::vector<AmbiguousViewRecord> ambiguous_views;
  std::vector<ProtrusionRegionRecord> protrusion_regions;
};

struct ParameterSetRecord {
  std::string name;
  std::string serialized;
};

struct ModelRecord {
  std::string name;
  std::int64_t version = 0;
  std::string bytes;
  bool active = false;
};

struct NewJob {
  std::string kind;     // e.g. "analyze_run", "reprocess"
  std::string payload;  // opaque to storage
  std::int64_t max_attempts = 3;
  std::optional<std::int64_t> parent_job_id;  // a reprocessing job's per-run tasks point at it
  std::int64_t progress_total = 0;
  std::optional<std::string> robot_id;  // the robot whose data the job works on (erased with the robot)
};

struct JobRecord {
  std::int64_t job_id = 0;
  std::string kind;
  std::string payload;
  JobState state = JobState::kQueued;
  std::int64_t attempts = 0;  // how many times it was leased
  std::int64_t max_attempts = 0;
  std::optional<std::int64_t> parent_job_id;
  std::optional<std::string> lease_owner;  // the worker holding (or that last held) the lease
  std::optional<std::int64_t> lease_expires_at_ms;
  std::string last_error;
  std::int64_t progress_done = 0;
  std::int64_t progress_total = 0;
  std::int64_t created_at_ms = 0;
  std::int64_t updated_at_ms = 0;
  std::optional<std::string> robot_id;
};

/// A held lease: the token proves ownership to Heartbeat/Complete/Fail/UpdateProgress.
struct JobLease {
  JobRecord job;
  std::string lease_token;
};

/// Filters for fleet queries. Empty strings and absent times mean "any".
struct RunFilter {
  std::string robot_id;
  std::string firmware;
  std::string robot_model;
  // Statistics: only reports of this set (empty: all sets, a run counting once per set). ListRuns: only
  // runs that have a report for this set.
  std::string parameter_set;
  std::optional<std::int64_t> started_from_ms;    // inclusive
  std::optional<std::int64_t> started_before_ms;  // exclusive
};

/// Keyset pagination position: the last run of the previous page.
struct RunCursor {
  std::int64_t started_at_ms = 0;
  std::string run_id;
  // The tie-breaker between two robots' runs of one id and start; empty (a cursor from before run ids were
  // per robot): the page continues after every run of that start and id.
  std::string robot_id;
};

struct RunPage {
  std::vector<RunRecord> runs;    // ordered by (started_at_ms, run_id, robot_id); telemetry not loaded
  std::optional<RunCursor> next;  // absent on the last page
};

/// Sums over the reports that match a filter.
struct FleetStatistics {
  std::int64_t reports = 0;  // (run, parameter set) pairs
  std::int64_t robots = 0;   // distinct robots
  std::int64_t recovery_created = 0;
  std::int64_t recovery_accepted = 0;
  std::int64_t merge_created = 0;
  std::int64_t merge_conditionally_accepted = 0;
  std::int64_t merge_conditional_then_rejected = 0;
  std::int64_t views_total = 0;
  std::int64_t views_ambiguous = 0;
  std::int64_t started_localized = 0;  // reports whose run started localized
  std::int64_t protrusions_found = 0;
  std::int64_t recovery_retracted = 0;
};

/// One run's reports under two parameter sets (Repository::ListReportPairs): counters only, no bytes.
struct ReportPair {
  RunRecord run;  // telemetry not loaded
  ReportRecord a, b;
};

/// What a report-pair scan walks; the pairs and their order are the same either way. kRunsInStartOrder:
/// the filter's runs, probing each one's two reports (best when both sets cover most of those runs);
/// kReportsOfSetA / kReportsOfSetB: that set's reports, probing the run and the other report (best when the
/// set covers few runs: a candidate tried on a slice of the fleet), each page sorted by start time.
enum class ReportPairScan { kRunsInStartOrder, kReportsOfSetA, kReportsOfSetB };

struct ReportPairPage {
  std::vector<ReportPair> pairs;
  std::optional<RunCursor> next;  // absent on the last page
};

enum class GroupBy { kRobot, kFirmware, kRobotModel, kParameterSet, kDay };

struct GroupStatistics {
  std::string key;  // the robot id, firmware, ...; for kDay the day number since the epoch (UTC)
  FleetStatistics statistics;
};

/// One version of a robot's map (docs/formats/map-versions.md). Versions are numbered 1, 2, … per robot and
/// never change except for their approval (pending → approved/rejected) and their open_findings count.
struct MapVersionRecord {
  std::string robot_id;
  std::int64_t version = 0;  // assigned by AppendMapVersion
  std::optional<std::int64_t> parent_version;
  std::string snapshot_id;  // must name a stored snapshot
  MapOrigin origin = MapOrigin::kUpload;
  std::string run_id;  // uploads: their run (one version per run); repairs: the run their chain started from
  std::optional<MapAction> action;  // repairs and imports: what was done; none for uploads (stored as "")
  std::string action_detail;
  std::string created_by;
  std::string reason;
  std::int64_t created_at_ms = 0;
  MapApproval approval = MapApproval::kPending;
  std::string approved_by;
  std::int64_t approved_at_ms = 0;
  // Size and health figures, computed when the version is made.
  std::int64_t nodes = 0, edges = 0, observation_edges = 0, views = 0, components = 0;
  double known_area_m2 = 0.0;
  double chi2 = 0.0;
  std::int64_t open_findings = 0;  // kept equal to the version's findings in state kOpen
  // Opaque bytes kept with the version (imported maps: their rooms, zones, …), at most kMaxMapMetadataBytes.
  // AppendMapVersion stores them when not empty; lists and gets leave this empty (they stay light): read them
  // with Repository::GetMapMetadata.
  std::string metadata;
  // Append only, never read back: a pending version that this one carries forward (a repair approved after
  // the robot's next upload overtook it). AppendMapVersion marks it stale in the same transaction, and
  // fails with ABORTED when it is no longer pending.
  std::optional<std::int64_t> supersedes_pending;
};

inline constexpr std::size_t kMaxMapMetadataBytes = 16u << 20;

/// A robot and its map history in brief: one row of the fleet's robots page. Versions are numbered 1, 2, …
/// per robot and never deleted one by one, so the count is also the newest version's number.
struct RobotMapSummary {
  RobotRecord robot;
  std::int64_t versions = 0;
  std::int64_t current_version = 0;            // the newest approved version; 0 when none is approved
  std::int64_t pending_versions = 0;           // versions waiting for an engineer's review
  std::optional<MapApproval> newest_approval;  // the newest version's state; none without versions
  std::int64_t newest_open_findings = 0;
};

inline constexpr int kMaxRobotPage = 1000;

/// A page of robots in robot_id order (keyset: robots after `after_robot_id`).
struct RobotSummaryQuery {
  std::string after_robot_id;
  int limit = 100;            // 1..kMaxRobotPage
  bool only_pending = false;  // only robots with a version waiting for review
};

struct RobotSummaryPage {
  std::vector<RobotMapSummary> robots;
  bool more = false;       // robots after the last one listed match too
  std::int64_t total = 0;  // robots matching the query on all pages
};

/// Something the analysis flags on one map version; `detail_json` is the whole finding as the server
/// describes it (evidence, what a repair would act on), opaque to storage.
struct MapFindingRecord {
  std::int64_t finding_id = 0;  // unique within the version
  FindingKind kind = FindingKind::kProtrusion;
  double severity = 0.0;
  std::string summary;
  FindingState state = FindingState::kOpen;
  std::string detail_json;
};

enum class InsertOutcome { kInserted, kAlreadyPresent };

/// Everything one uploaded run adds, stored by Repository::StoreUpload in one transaction.
struct UploadBundle {
  RobotRecord robot;                   // registered, or its model and firmware updated
  std::vector<std::string> snapshots;  // the maps' bytes (the child and a parent sent with it), deduplicated
  RunRecord run;                       // its snapshot ids name `snapshots` or snapshots stored before
  NewJob analysis_job;                 // enqueued only when the run is new
  MapVersionRecord map_version;        // the child map as the robot's newest version (once per run)
  std::vector<MapFindingRecord> findings;
};

struct StoredUpload {
  InsertOutcome run = InsertOutcome::kInserted;
  std::int64_t analysis_job_id = 0;  // 0 when the run was already present
  MapVersionRecord map_version;      // as stored: its number assigned, or the run's earlier version
};

/// What Repository::DeleteRobot removed, table by table.
struct RobotErasure {
  std::int64_t runs = 0;
  std::int64_t reports = 0;  // of every parameter set
  std::int64_t decisions = 0;
  std::int64_t ambiguous_views = 0;
  std::int64_t protrusion_regions = 0;  // with their labels
  std::int64_t map_versions = 0;
  std::int64_t map_findings = 0;
  std::int64_t snapshots = 0;  // those no other robot's run or map version names
  std::int64_t jobs = 0;
  std::int64_t credentials = 0;   // deleted; the erasure takes a credential epoch so other processes drop it
  std::int64_t map_metadata = 0;  // imported maps' metadata of its versions
};

/// One entry of the audit log: who did what to which subject, when, with counts (JSON, opaque to storage).
struct AuditEntry {
  std::int64_t entry_id = 0;  // assigned on append, increasing
  std::int64_t at_ms = 0;     // assigned on append when 0
  std::string actor;          // the principal, or "fleetd:retention"
  std::string action;         // "delete_robot", "prune_run_events", "prune_jobs", "set_credential",
                              // "rotate_credential", "revoke_credential"
  std::string subject;  // the robot id or principal; for retention the policy, e.g. "uploaded before <ms>"
  std::string detail_json;
};

}  // namespace storage
