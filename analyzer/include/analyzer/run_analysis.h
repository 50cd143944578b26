// Analysis of one stored run (docs/architecture.md "Data flow of one run", step 2): the run's telemetry is replayed
// by slamcore's Mapper from its parent snapshot with a parameter set, and the report says what the
// back-end decided (hypotheses, relocalization times, ambiguous views), what protrusions appeared in the
// occupancy map, how the rerun differs from the map the robot uploaded, and, when the run carries ground
// truth, how right it was.
//
// Thread safety: AnalyzeRun is a pure function of its inputs; call it from any number of threads.
#pragma once

#include <memory>
#include <optional>
#include <set>
#include <unordered_map>
#include <functional>
#include <string>

#include "fleet/v1/report.pb.h"
#include "fleet/v1/telemetry.pb.h"
#include "slamcore/mapper.h"
#include "slamcore/mapper_params.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_detector.h"

namespace analyzer {

/// A run on an existing map "started localized" (paper Fig. 7) when it joined that map, conditionally or
/// fully, within this many seconds of its first event: before it had driven far from where it started.
inline constexpr double kStartedLocalizedSeconds = 15.0;

struct AnalysisOptions {
  std::string parameter_set_name = "default";
  slamcore::MapperParams mapper;
  /// Classifies protrusion regions; unset: slamcore's built-in default model (and "unclassified",
  /// probability −1, only if that cannot load).
  const slamcore::ProtrusionClassifier* classifier = nullptr;
  /// Keep the rerun's child map in the report (for map pages and reprocessing comparisons).
  bool keep_rerun_child = true;
  /// The analysis budget: asked every 256 events of the replay and before the maps are rendered; a non-OK
  /// status (deadline passed, job cancelled) ends the analysis with it, naming the event reached. Unset: no
  /// budget.
  std::function<slamcore::Status()> keep_going;
};

/// The occupancy grids the protrusion detector compares (paper IV-C): the parent's largest component (the
/// robot's home map) and the same component in the child, each rendered from its nodes' local patches.
/// New space outside the home component has no parent to compare with. `parent` is empty (width 0) when the
/// parent map has no local maps; then `child` is the whole child map, all of it new.
struct ComparedGrids {
  slamcore::OccupancyGrid parent, child;
  std::vector<slamcore::NodeId> child_nodes;  // the child nodes rendered
};
slamcore::Result<ComparedGrids> RenderComparedGrids(const slamcore::Map& parent, const slamcore::Map& child);

/// Which of the detector's regions some nodes drew (RegionsDrawnAway), per region and per cell of the child.
struct RegionCover {
  std::vector<std::uint8_t> covered;    // per cell of `grids.child`
  std::vector<bool> region_is_covered;  // in the order of `regions`
};

/// The detector's regions drawn where the robot was not (paper IV-C): a region cell is drawn away when a patch
/// of a node of `really_at` gives it a state (free or wall) at the node's estimate in `child`, and the same
/// patches drawn at `really_at` (where the robot really was, in the map's frame) give no cell within
/// `tolerance_m` that state — the band a stuck robot draws, not the surroundings its sensor saw in their
/// place. A region is covered when more than half of its cells are drawn away; `covered` is 1 on those
/// cells. With the nodes a simulator made while the robot was stuck (WhereStuckNodesWere with its truth)
/// this is the ground truth of a simulated run; with the nodes whose slip the run's own views show
/// (slamcore::FindSlipNodes, each where the robot was at its contradicting view) it is the analysis'
/// evidence (ClassifyRegions).
slamcore::Result<RegionCover> RegionsDrawnAway(
    const slamcore::Map& child, const std::unordered_map<slamcore::NodeId, slamcore::SE2>& really_at,
    const ComparedGrids& grids, const std::vector<slamcore::ProtrusionRegion>& regions,
    double tolerance_m = 0.15);

/// Where the robot really was at each of `stuck_nodes` of `child`, in the map's frame: the estimate of the
/// last earlier node of its component that was not stuck, moved by the true motion since (`truth`, a
/// simulator's poses: a stuck robot rocks and creeps). Nodes without truth are left out.
std::unordered_map<slamcore::NodeId, slamcore::SE2> WhereStuckNodesWere(
    const slamcore::Map& child, const std::set<slamcore::NodeId>& stuck_nodes,
    const std::unordered_map<slamcore::NodeId, slamcore::SE2>& truth);

/// How the analysis classes a region. When the run's own views show that nodes of this run (those of
/// `child` that `parent` does not hold) had slipped (slamcore::FindSlipNodes: a path through a seen wall, a
/// view that stood still) and their patches drew most of the region away from where their contradicting
/// views put the robot (RegionsDrawnAway), it is a protrusion whatever its shape; otherwise the map-only
/// classifier decides (paper IV-C), or nothing when there is none.
struct RegionClass {
  enum class DecidedBy : std::uint8_t { kViews, kClassifier, kNone };
  bool protrusion = false;
  double probability = -1.0;  // the classifier's, −1 without one
  DecidedBy decided_by = DecidedBy::kNone;
};
const char* DecidedByName(RegionClass::DecidedBy decided_by);
slamcore::Result<std::vector<RegionClass>> ClassifyRegions(
    const slamcore::Map& parent, const slamcore::Map& child, const ComparedGrids& grids,
    const std::vector<slamcore::ProtrusionRegion>& regions, const slamcore::ProtrusionClassifier* classifier);

/// RMS position error of `graph` against `truth`, each component aligned on its own (components have
/// independent frames); nullopt when fewer than two nodes carry truth. `count`: the nodes compared.
std::optional<double> ComponentwiseRmse(const slamcore::PoseGraph& graph,
                                        const std::unordered_map<slamcore::NodeId, slamcore::SE2>& truth,
                                        int* count);

/// A robot's home map in a graph of several components: the largest (ties: the one of the first node). The
/// graph must have nodes.
slamcore::ComponentId HomeComponent(const slamcore::PoseGraph& graph);

/// The nodes of `map` in `nodes` with their local maps (no edges), for rendering part of a map.
slamcore::Map ComponentMap(const slamcore::Map& map, const std::set<slamcore::NodeId>& nodes);

/// The maps of a run's two snapshots, decoded: the map the run started from (empty for a robot's first run)
/// and the map the robot uploaded.
struct RunMaps {
  slamcore::Map parent;
  slamcore::Map uploaded_child;
};
/// Checks the run's header, then decodes its snapshots (INVALID_ARGUMENT naming the snapshot).
slamcore::Result<RunMaps> DecodeRunMaps(const fleet::v1::RunFile& run);

/// Fails (INVALID_ARGUMENT naming the field) when the run's telemetry is malformed, e.g. an event the
/// Mapper refuses: "events[12]: ViewObservedEvent at t=3.5: view 7 does not exist".
slamcore::Result<fleet::v1::RunReport> AnalyzeRun(const fleet::v1::RunFile& run,
                                                  const AnalysisOptions& options);
/// The same with the run's snapshots already decoded (DecodeRunMaps), for callers that use the maps after
/// the analysis too; `run`'s snapshot fields are not read.
slamcore::Result<fleet::v1::RunReport> AnalyzeRun(const fleet::v1::RunFile& run, const RunMaps& maps,
                                                  const AnalysisOptions& options);

}  // namespace analyzer
