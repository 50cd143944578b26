// Map health and repair (docs/formats/map-versions.md): the figures and findings of one version of a
// robot's map, the repairs that make a new version from it, and its export as ROS map_server files and g2o.
//
// A version's map is a slamcore::Map. The run that a version's chain started from matters for two things:
// its parent map tells which nodes (and so which edges, hypotheses and occupancy patches) the run added, and
// the server's rerun of that run (its RunReport, made with the fleet's default parameters) is the second
// opinion that findings compare the robot's own decisions with.
//
// Thread safety: pure functions of their inputs.
#pragma once

#include <array>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fleet/v1/report.pb.h"
#include "fleet/v1/maps.pb.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"

namespace analyzer {

/// Size and health figures of a map (MapVersion fields), all cheap: linear in nodes and edges.
struct MapFigures {
  std::int64_t nodes = 0, edges = 0, observation_edges = 0, views = 0, components = 0;
  double chi2 = 0.0;
};
MapFigures ComputeFigures(const slamcore::Map& map);

/// Free or occupied area (m²) of the home component's grid (RenderHomeGrid): renders the map.
slamcore::Result<double> KnownArea(const slamcore::Map& map);

/// The home component (the largest; ties: the one of the first node) rendered as an occupancy grid, as the
/// dashboard shows a version and map_server export writes it. An empty grid (width 0) for an empty map.
slamcore::Result<slamcore::OccupancyGrid> RenderHomeGrid(const slamcore::Map& map);

/// The nodes `map` has and `run_parent` has not: those the run added.
std::set<slamcore::NodeId> NodesAddedByRun(const slamcore::Map& map, const slamcore::Map& run_parent);

struct FindingOptions {
  /// An observation edge is a residual outlier when its χ² exceeds this (χ²(3) at 99.9 %) ...
  double residual_chi2 = 16.27;
  /// ... and this many times the median χ² of the map's observation edges.
  double residual_peer_factor = 5.0;
  /// Regions the classifier calls protrusion with at least this probability.
  double protrusion_probability = 0.5;
};

/// What FindMapFindings looks at. `report` and `run_parent` may be null (not analysed yet, or a version
/// without a run); then only the findings on the map itself are made.
struct FindingInputs {
  const slamcore::Map* map = nullptr;
  const slamcore::Map* run_parent = nullptr;
  const fleet::v1::RunReport* report = nullptr;
};

/// The findings, ordered by severity (highest first) and numbered from 1 in that order:
///   high_residual_edge      observation edges far above their peers after optimisation (grouped by hypothesis)
///   unconfirmed_hypothesis  edges the robot added by accepting a hypothesis that the server's rerun did not add
///   protrusion              regions the classifier called protrusion; resolved once the run's cells are cut
///   undone_merge            conditional merges the rerun undid (state "info": evidence, nothing to repair)
///   ambiguous_view          views marked ambiguous in the map, one finding for all (state "info")
std::vector<fleet::v1::MapFinding> FindMapFindings(const FindingInputs& inputs,
                                                   const FindingOptions& options = {});

/// Re-optimises every component from a linear initialisation (repairs can move a component far).
slamcore::Status Reoptimize(slamcore::Map& map);

/// Repairs: each returns the repaired copy and describes what it did in `detail`. INVALID_ARGUMENT (naming
/// what is missing) when there is nothing to repair, so a repair never makes a version equal to its base.
///
/// Removes one observation edge (`view` disambiguates parallel edges) and re-optimises.
slamcore::Result<slamcore::Map> RejectEdge(const slamcore::Map& map, slamcore::NodeId from,
                                           slamcore::NodeId to, std::optional<slamcore::ViewId> view,
                                           std::string* detail);
/// Removes every edge that hypothesis `hypothesis` of the run added (edges from `run_nodes` carrying that
/// hypothesis id) and re-optimises. When it was a merge, the run's observation edges placed since that join
/// the same two parts go with it (they were gated in the merged frame), so the components split again.
slamcore::Result<slamcore::Map> RejectHypothesis(const slamcore::Map& map,
                                                 const std::set<slamcore::NodeId>& run_nodes,
                                                 std::int64_t hypothesis, std::string* detail);
/// Marks unknown every cell the run's nodes' patches put inside `world_bbox` (min_x, min_y, max_x, max_y in
/// the home frame), so the map there is what it was before the run.
slamcore::Result<slamcore::Map> CutRegion(const slamcore::Map& map,
                                          const std::set<slamcore::NodeId>& run_nodes,
                                          const std::array<double, 4>& world_bbox, std::string* detail);

/// A repair made on `base` (its result: `repaired`) applied again to `target`, a later version built on
/// `base` (the robot uploaded again before the repair was approved): the observation edges the repair removed
/// are removed from `target` where it still has them, and the patch cells it changed are changed in `target`'s
/// patches of the same nodes; then `target` is re-optimised when edges went. Like a cherry-pick, it carries
/// the change, not the repair's parameters, so it works for every edit (reject edge or hypothesis, cut). Cells
/// that `target`'s own run changed since `base` keep `target`'s value (the later observation wins).
/// INVALID_ARGUMENT when nothing of the repair still applies to `target`.
slamcore::Result<slamcore::Map> CarryRepairForward(const slamcore::Map& base, const slamcore::Map& repaired,
                                                   const slamcore::Map& target, std::string* detail);

/// Export: ROS map_server files of the home grid ("<stem>.pgm", "<stem>.yaml"), the pose graph as g2o
/// ("<stem>.g2o"), or the home grid as ValetudoMap JSON ("<stem>.json", WriteValetudoMap) with the rooms,
/// entities and poses of `metadata` when given. INVALID_ARGUMENT for another format or an empty map.
slamcore::Result<std::vector<fleet::v1::ExportedFile>> ExportMap(
    const slamcore::Map& map, const std::string& format, const std::string& stem,
    const fleet::v1::MapMetadata* metadata = nullptr);

}  // namespace analyzer
