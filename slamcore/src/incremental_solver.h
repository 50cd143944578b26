// The Mapper's incremental back-end: new edges update the solution without re-solving the component.
//
// Method: incremental Gauss–Newton with fluid relinearisation of only the affected variables, the idea of
// iSAM2 (Kaess et al., "iSAM2: Incremental smoothing and mapping using the Bayes tree", IJRR 2012, §5:
// variables are relinearised only where their change exceeds a threshold, and the update stops spreading
// — "wildfire" — where the change falls below it). Instead of a Bayes tree we re-eliminate the affected
// region as a sub-problem:
//  1. The region starts as the nodes nearest (in edges) to the endpoints of the edges added or changed
//     since the last update (`seeds`), `initial_region_nodes` of them — or, for an accepted hypothesis,
//     as the whole component when one of the seeds' edges is far from the estimate (χ² above `whole_component_edge_chi2`: a long loop
//     closed, whose correction a small region held at its boundary would absorb by bending).
//  2. Gauss–Newton (Levenberg–Marquardt damping on a rejected step) over the region, every node outside it
//     held: the edges touching the region are linearised at the current poses and the normal equations
//     solved by a sparse Cholesky (LDLᵀ, AMD ordering), the symbolic analysis done once per region. It
//     stops when an iteration decreases χ² by less than `relative_cost_decrease` (relative) or moves no node
//     by more than a hundredth of the tolerances below, or, for a region held at its boundary, when an
//     undamped step decreased χ² by what its linearisation predicted, to within `relative_cost_decrease`:
//     the problem is linear at that scale, and a further factorisation would only confirm it. An undamped
//     step rejected after predicting less than that tolerance is rounding at the minimum: it stops too.
//  3. The wildfire test: for each held node next to the region, how much the update changed the step it
//     would take alone (its own Gauss–Newton block, −H_uu⁻¹ g_u over its edges, with the region's poses
//     after against before). When every change is below `position_tolerance` / `angle_tolerance`, the
//     update has not reached beyond the region and ends; otherwise the region grows from the nodes it
//     reached (doubling), and step 2 repeats.
//     A region that reaches the whole component is a full solve (gauge: fixed nodes, else the first node).
// Only what the update changes spreads: residual disequilibrium elsewhere (edges deferred by the Mapper,
// earlier updates' tolerance) is left to the updates that touch it and to a final whole solve.
// Cost: O(region + its edges) per update; the region stays small unless an edge moves much of the map
// (a long loop closed with a large correction), which a batch solver pays for always.
//
// The solver keeps only the graph's adjacency, extended as edges are appended; when edges were removed
// or G replaced (retractions, a refused acceptance restored) it notices (fewer edges, or a different last
// edge) and rebuilds it, O(edges), rare.
//
// Thread safety: not thread-safe; one per Mapper.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "slamcore/optimizer.h"
#include "slamcore/pose_graph.h"
#include "cholmod_cholesky.h"

namespace slamcore::internal {

struct IncrementalSolverOptions {
  int initial_region_nodes = 30;
  /// An update whose seeds touch an edge with a larger χ² (whitened, at the current poses) starts from the
  /// whole component: the correction is too large for a small region to carry.
  double whole_component_edge_chi2 = 100.0;
  /// The wildfire threshold: a held node whose lone step is below both stays held.
  double position_tolerance = 1e-2;  // metres
  double angle_tolerance = 1e-3;     // radians
  /// Gauss–Newton iterations per region, and the relative χ² decrease that ends them.
  int max_iterations = 20;
  double relative_cost_decrease = 1e-6;
};

struct IncrementalSummary {
  int region_nodes = 0;      // variables of the last region solved
  int rounds = 0;            // regions solved (1 + growths)
  int iterations = 0;        // Gauss–Newton iterations over all rounds
  bool full = false;         // the region reached the whole component
  bool whole_start = false;  // it started from the whole component (a far edge, or asked to)
};

/// The normal equations of a whole component as a solve left them: H = Σ Jᵀ Ω J over all its edges at the
/// poses before the solve's last step, factorised, its first node held. That step was undamped, accepted and
/// within the solver's tolerances, so H is the component's information at its solution to within them.
struct ComponentFactorisation {
  std::unique_ptr<CholmodCholesky> cholesky;
  std::vector<std::pair<NodeId, int>> first_column;  // every node: its first column, −1 for the held one
};

class IncrementalSolver {
 public:
  explicit IncrementalSolver(IncrementalSolverOptions options = {}) : options_(options) {}

  /// Whether an update may start from the whole component when a seed's edge is far from the estimate:
  /// kLocal for edges whose correction is bounded (a direct edge passed the gate with a robot sure of its
  /// position), kLocalUnlessFar for accepted hypotheses (a recovery after a long drift).
  /// kWhole: the whole component at once (an acceptance the Mapper will verify against the optimum).
  enum class Start : std::uint8_t { kLocal, kLocalUnlessFar, kWhole };

  /// Moves the poses of `graph` to the optimum after the edges at `seeds` changed (see the top of this
  /// file). Seeds that are not in the graph are ignored.
  IncrementalSummary Update(PoseGraph& graph, const std::vector<NodeId>& seeds,
                            Start start = Start::kLocalUnlessFar);
  /// Solves the whole components of `seeds` to convergence (relative χ² decrease below 1e-10): the end of
  /// a run, so the child map is at its optimum and not only within the wildfire tolerance.
  IncrementalSummary SolveComponents(PoseGraph& graph, const std::vector<NodeId>& seeds);
  /// Solves the whole component of `seed` with each edge's information scaled by its weight (one weight ≥ 0
  /// per edge of the graph, in edges() order; 0 leaves the edge out), until an iteration decreases the
  /// weighted χ² by less than `relative_cost_decrease` or after `max_iterations`: the weighted solves of the
  /// consistent-set check (graduated non-convexity), the same Gauss–Newton as the updates. Keeps no
  /// factorisation.
  IncrementalSummary SolveWeightedComponent(PoseGraph& graph, NodeId seed,
                                            const std::vector<double>& edge_weights, int max_iterations,
                                            double relative_cost_decrease);
  /// The factorisation the last update ended with, when it solved a whole component large enough for
  /// CHOLMOD's Cholesky and converged (see ComponentFactorisation); taken once, dropped by the next update.
  std::optional<ComponentFactorisation> TakeComponentFactorisation();

 private:
  /// When a region is solved to convergence (a whole component), and over which edges' weights.
  struct Convergence {
    int max_iterations = 0;
    double relative_cost_decrease = 0.0;
    const std::vector<double>* edge_weights = nullptr;  // none: every edge at its own information
  };
  IncrementalSummary Run(PoseGraph& graph, const std::vector<NodeId>& seeds, Start start,
                         std::optional<Convergence> whole);
  void SyncAdjacency(const PoseGraph& graph);
  /// Admits up to `count` nodes to the region, breadth-first from `from`.
  void Grow(const PoseGraph& graph, std::vector<std::size_t>& region, const std::vector<std::size_t>& from,
            std::size_t count);
  /// Gauss–Newton over `region` (graph indices), the rest held; returns the iterations taken.
  /// With `converged`: the final factorisation, when the region is large and the solve converged.
  int SolveRegion(PoseGraph& graph, const std::vector<std::size_t>& region, bool hold_gauge,
                  const std::optional<Convergence>& to_convergence,
                  std::optional<ComponentFactorisation>* converged = nullptr);
  /// Held neighbours of the region whose lone step exceeds the tolerance.
  std::vector<std::size_t> MovingNeighbours(const PoseGraph& graph, const std::vector<std::size_t>& region);
  /// How much the update changed a held node's Gauss–Newton step over its own edges: the step with the
  /// region's poses as they are, less the step with them as they were.
  Vector3 LoneStepChange(const PoseGraph& graph, std::size_t held);

  IncrementalSolverOptions options_;
  std::vector<std::vector<std::uint32_t>> incident_;  // node index → incident edge indices
  /// Edge index → its ends' node indices, looked up once: the hot loops read this instead of hashing ids.
  struct EdgeEnds {
    std::uint32_t from, to;
  };
  std::vector<EdgeEnds> ends_;
  std::vector<Matrix2> measurement_rotation_t_;  // edge index → Rᵀ of its measurement, which never changes
  /// A node's Rᵀ for the angle it was last asked at: most edges are evaluated at poses that stay put (held
  /// nodes, a region between iterations), so their sine and cosine are not redone.
  struct NodeRotation {
    std::uint64_t theta_bits = 0;
    bool valid = false;
    Matrix2 transposed;
  };
  std::vector<NodeRotation> node_rotation_t_;
  const Matrix2& RotationT(std::size_t index, const SE2& pose);
  std::size_t known_edges_ = 0;
  Edge last_edge_;               // graph.edges()[known_edges_ − 1] when known_edges_ > 0
  std::vector<char> in_region_;  // by node index; all 0 between updates
  std::vector<int> column_;      // by node index: the region's columns during a solve, −1 otherwise
  std::vector<SE2> original_;    // by node index: a region node's pose when the update admitted it
  // A held node's term (JᵀΩJ and JᵀΩe) of one edge at the poses the update started from, by 2 × edge index
  // + (the held node is the edge's `to`); valid while `update` is the current update's number.
  struct StartTerm {
    Matrix3 block;
    Vector3 gradient;
    std::uint64_t update = 0;
  };
  std::vector<StartTerm> start_terms_;
  std::uint64_t updates_ = 0;
  std::optional<ComponentFactorisation> component_factorisation_;
};

}  // namespace slamcore::internal
