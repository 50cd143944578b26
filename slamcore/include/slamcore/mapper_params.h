// MapperParams: every threshold of the Mapper in one place, with documented defaults and validation.
// Section references are to the paper (the README names it).
//
// Thread safety: value type.
#pragma once

#include <cstdint>

#include "slamcore/optimizer.h"
#include "slamcore/status.h"

namespace slamcore {

/// How many observations of how many distinct views a hypothesis needs to be accepted (III-B).
struct AcceptanceCriteria {
  int min_observations = 3;
  int min_views = 2;
};

/// The Mapper optimises often and from a warm start: a few iterations suffice.
inline OptimizerOptions DefaultOptimizerOptions() {
  OptimizerOptions options;
  options.max_iterations = 20;
  return options;
}

/// Correlated wrong observations (one pass past a look-alike yields a run of wrong observations that agree
/// with each other; docs/correlated-outliers.md): evidence is counted per independent pass, a
/// recovery hypothesis is tested against the map's own uncertainty before it is accepted, and an accepted
/// one that later contradicts better-supported evidence is retracted. Design: mapper_consistency.cc.
struct ConsistencyParams {
  bool enabled = true;
  /// Observations of one hypothesis belong to one pass while each follows the previous one within this
  /// time (seconds) and this distance (metres of the robot's odometer).
  double pass_gap_seconds = 20.0;
  double pass_gap_distance = 2.0;
  /// Joint test of a hypothesis against the map: χ² (3 dof) of its state against the map's prediction with
  /// the marginal covariance between the two ends. 16.27 is the 99.9 % quantile.
  double map_gate_chi2 = 16.27;
  /// The map's covariance, and the robot's relative uncertainty Σ_rel of the direct gate, are scaled by the
  /// a-posteriori variance factor χ²/redundancy of its component (never up, never below
  /// min_variance_factor) once the redundancy reaches this: declared odometry noise is often far above the
  /// noise met, which would make every test uninformative and every robot "too uncertain" after metres.
  int min_redundancy_for_scaling = 30;
  double min_variance_factor = 0.01;
  /// The test is informative when an aliasing offset of this size (metres, in the direction the map is least
  /// sure of) would have failed it; an uninformative test confirms nothing.
  double aliasing_offset = 1.0;
  /// Passes a hypothesis needs when the test against the map was uninformative, or when it failed (the map
  /// itself may be wrong: wheel slip, or an earlier wrong acceptance that later evidence retracts).
  int min_passes_uninformative = 1;
  int min_passes_against_map = 3;
  /// After a recovery the map test did not confirm is accepted and the component optimised, the
  /// leave-one-out test of its edges against the rest of G (refused and G restored when it fails) and of the
  /// worst-fitting earlier acceptances (retracted when they fail).
  bool verify_after_optimization = true;
  /// Leave-one-out test: a hypothesis whose edges' leave-one-out χ² (against every other edge of G) exceeds
  /// its quantile at this confidence does not fit: refused when it is the newcomer, else retracted.
  double retraction_confidence = 0.999;
  /// Bounds on the work per observation (validated ranges in mapper_params.cc): open hypotheses kept (the
  /// stalest go first); direct edges that continue an accepted recovery in its pass and share its fate;
  /// earlier acceptances judged per verification (the worst-fitting); retractions per verification; edges
  /// of one hypothesis in its leave-one-out test (evenly spaced over it: the test's cost is cubic in them).
  int max_open_hypotheses = 64;
  int max_continuation_edges = 20;
  int max_judged_per_check = 8;
  int max_retractions_per_check = 4;
  int max_edges_judged = 60;
  /// Contested acceptances (mapper_consistency.cc): a recovery accepted on a map test that could not tell
  /// (uninformative, or none) is retracted on trial when later passes that agree with each other contradict
  /// it, outnumbering the passes that support it, and stays retracted when the contradicting hypothesis then
  /// fits the map without it. At most this many trials (each an optimisation) per such acceptance; 0 turns
  /// the contest off (the what-if baseline).
  int max_contest_trials = 4;
  /// The map test's marginals are updated by the edges added since their factorisation (a dense solve over
  /// the nodes those edges touch) until the edges touch more than this many nodes, then factorised again;
  /// 0 factorises whenever G changed.
  int max_marginal_update_nodes = 48;
  /// The consistent-set check (mapper_consistent_set.cc): the accepted hypotheses of the run and the refused
  /// ones kept (at most max_kept_refused, the oldest forgotten first) are judged together by graduated
  /// non-convexity; those outside the largest consistent set are retracted, refused ones inside it accepted.
  /// It runs when the number of judged hypotheses has grown by consistent_set_growth since the last check,
  /// and at the end of the run. A hypothesis is consistent when its edges' χ² at the solution is within the
  /// quantile at consistent_set_confidence; at most gnc_max_iterations weighted solves per check.
  bool consistent_set_check = true;
  /// A check first solves the status quo (the accepted clusters in, the refused ones out) and the map without
  /// any judged cluster; when every accepted cluster is within its threshold at the first, and every refused
  /// one beyond it at both, the graduated non-convexity is skipped: the check changes nothing, or, with
  /// refused clusters near the set, only the second opinion judges those (mapper_consistent_set.cc). False:
  /// every check runs it in full (the what-if baseline).
  bool status_quo_first = true;
  double consistent_set_confidence = 0.99;
  double consistent_set_growth = 3.0;
  int max_kept_refused = 256;
  int gnc_max_iterations = 40;
};

/// The largest value MapperParams::Validate accepts for each kind of field (the smallest is 1, or > 0).
/// Parameter sets arrive from users: these keep one run's replay bounded in time and memory.
struct MapperParamsLimits {
  static constexpr int kMaxCount = 1000;         // min_observations, min_views, rejections, passes, caps
  static constexpr int kMaxWindowNodes = 10000;  // local_window_nodes
  static constexpr int kMaxOptimizationEvery = 1000000;  // full_optimization_every
  static constexpr double kMaxSeconds = 3600.0;  // hypothesis_expiry_seconds, consistency.pass_gap_seconds
  static constexpr double kMaxMeters = 1000.0;   // distances, sigmas, offsets
  static constexpr double kMaxChi2 = 1000.0;     // gate_chi2, consistency.map_gate_chi2
  static constexpr int kMaxIterations = 1000;    // optimizer.max_iterations
  static constexpr int kMaxThreads = 64;         // optimizer.num_threads
};

/// What moves the map's poses after accepted edges: the incremental back-end (slamcore/src/incremental_solver.h:
/// only the region an edge affects is re-solved), or the batch baseline (a Ceres solve of a local window or of
/// the whole component, optimizer.h), kept for comparison.
enum class MapperBackend : std::uint8_t { kIncremental, kBatch };

struct MapperParams {
  /// Mahalanobis gate, χ² with 3 degrees of freedom: 7.81 is the 95 % quantile. Used both for direct
  /// observation edges against the current estimate and for joining an observation to a hypothesis.
  double gate_chi2 = 7.81;
  /// A direct edge also needs the robot to be sure of its position relative to where it was last anchored:
  /// above this standard deviation (metres, largest axis of Σ_rel; with the consistency checks on, Σ_rel
  /// scaled as the map's a-posteriori variance factor says, see consistency.min_redundancy_for_scaling)
  /// observations go to the recovery filter and need the support of several views, since a wide gate would
  /// pass wrong matches.
  double direct_max_position_sigma = 0.5;

  /// Recovery hypotheses (observations in the current component that failed the gate).
  AcceptanceCriteria recovery{.min_observations = 3, .min_views = 2};
  /// Merge hypotheses (observations of another component): permissive → conditional merge (IV-B) ...
  AcceptanceCriteria merge_conditional{.min_observations = 2, .min_views = 1};
  /// ... strict → full merge.
  AcceptanceCriteria merge_full{.min_observations = 4, .min_views = 2};
  /// When false, merge hypotheses go straight from nothing to a full merge under `merge_full`.
  bool conditional_merge = true;

  /// Expiry: a hypothesis with no new observation for this long (seconds) or this far (metres) is deleted.
  double hypothesis_expiry_seconds = 120.0;
  double hypothesis_expiry_distance = 8.0;

  /// Ambiguity tracker (IV-A): observations are forgotten after the robot travelled this far (metres).
  double ambiguity_window_distance = 4.0;
  /// A view with at least this many rejected observations in the window is a candidate ...
  int ambiguity_min_rejections = 2;
  /// ... and is marked ambiguous when an accepted observation of a trusted view is also in the window.
  /// Ambiguous views never count toward recovery acceptance; by this option not toward merges either.
  bool discount_ambiguous_in_merge = true;

  /// Optimisation after accepted edges. A direct edge re-optimises the robot's last `local_window_nodes`
  /// nodes (older ones held), and every `full_optimization_every`-th direct edge the whole component; an
  /// accepted hypothesis always re-optimises the whole component.
  /// With the incremental back-end the window is the region an update starts from (it grows while the map
  /// around it would still move), and `full_optimization_every` folds in the direct edges too small to
  /// re-solve at once.
  bool optimize_after_accept = true;
  MapperBackend backend = MapperBackend::kIncremental;
  int local_window_nodes = 30;
  int full_optimization_every = 100;
  OptimizerOptions optimizer = DefaultOptimizerOptions();
  /// Wheel slip corrected as it happens (slip_detection.h): when a node's local map, placed along the motion
  /// odometry claims since the last local map on its chain, agrees with that one short of where odometry
  /// put it and disagrees beyond (the view that stood still), and no view observation anchors the node, its
  /// motion edge is replaced by the motion the views show, so neither it nor the nodes after it march on with
  /// the wheels, and their local maps draw no protrusion. Not in the paper (whose robots leave protrusions
  /// to the service to find, IV-C): docs/parameter-sets/paper-filter.json turns it off.
  bool correct_slip_from_views = true;

  ConsistencyParams consistency;

  /// Checks every field; the message names the first bad one and its value.
  Status Validate() const;
};

}  // namespace slamcore
