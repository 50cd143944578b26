// Replaying a g2o pose graph through the Mapper "online, as a robot would see it", to check the
// hypothesis filter against public benchmarks (with or without injected wrong loop closures).
//
// Translation of a file into a run: vertices in increasing id order are the robot's nodes, one every
// `seconds_per_node`; vertex k creates view k at node k. Edge k−1 → k is the odometry that creates node k, or,
// in a file that writes it backwards, edge k → k−1 inverted (neither: a kidnap, node k starts a new
// component). Any other edge between i and j is an
// observation made at node max(i, j) of the view of the other vertex, issued right after that node is
// created, in file order: z = robot_T_view is the edge's measurement or its inverse. Covariances are the
// inverse of the file's information, moved into the left-perturbation convention of events.h.
//
// Thread safety: free functions without shared state.
#pragma once

#include <utility>
#include <vector>

#include "slamcore/events.h"
#include "slamcore/mapper.h"
#include "slamcore/pose_graph.h"

namespace slamcore {

/// A loop closure as written in the file: (from, to) vertex ids.
using VertexPair = std::pair<NodeId, NodeId>;

struct G2oRun {
  std::vector<Event> events;
  /// For every ViewObservedEvent, in event order, the index in the graph's edges of the file's edge it
  /// came from (which tells apart two loop closures written between the same vertices).
  std::vector<std::size_t> observation_edges;
};

/// Builds the run. Fails when vertex ids are not contiguous from the smallest (the replay needs node k
/// to follow node k−1).
Result<G2oRun> RunFromPoseGraph(const PoseGraph& graph, double seconds_per_node = 1.0);

struct ReplayResult {
  std::vector<VertexPair> accepted;  // loop closures that became observation edges
  std::vector<VertexPair> rejected;  // the others
  /// The same loop closures as indices into the replayed graph's edges.
  std::vector<std::size_t> accepted_edges, rejected_edges;
  double final_chi2 = 0.0;   // after a final optimisation of the Mapper's graph
  double mapper_chi2 = 0.0;  // of the Mapper's graph as the run finished, before that optimisation
  double seconds = 0.0;      // Mapper plus final optimisation
  MapperStatistics statistics;
  ConsistentSetChecks consistent_set_checks;
  /// The Mapper's decision log (nodes are the Mapper's, numbered from 0 in vertex order; views are the
  /// file's vertex ids): why each closure was taken or refused.
  std::vector<Decision> decisions;
  PoseGraph graph;  // the Mapper's graph, optimised
};

/// Replays `graph` through a Mapper with `params`, then optimises the resulting graph once more.
Result<ReplayResult> ReplayPoseGraph(const PoseGraph& graph, const MapperParams& params);

/// How well the filter separated true loop closures from known wrong ones.
struct FilterScore {
  int true_accepted = 0, true_total = 0;
  int wrong_accepted = 0, wrong_total = 0;
  /// Drawn as wrong but agreeing with the input's optimum (CorruptedGraph::agrees_with_optimum): counted
  /// neither way.
  int agreeing_accepted = 0, agreeing_total = 0;
  double Precision() const;  // true accepted / all accepted (1 when nothing was accepted)
  double Recall() const;     // true accepted / all true (1 when there were none)
};
/// `first_wrong_edge`: the replayed graph's edges from this index on are the wrong ones (as
/// AddLoopClosureOutliers appends them), so a wrong closure written between the same vertices as a true
/// one is scored as what it is. `agrees_with_optimum` (one per wrong edge, or empty) marks those that are
/// not wrong after all.
FilterScore ScoreReplay(const ReplayResult& result, std::size_t first_wrong_edge,
                        const std::vector<bool>& agrees_with_optimum = {});

}  // namespace slamcore
