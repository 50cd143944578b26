// MapperParams: every threshold of the Mapper in one place, with documented defaults and validation.
// Section references are to the paper (docs: ../shared/docs/PAPER.md restates it).
//
// Thread safety: value type.
#pragma once

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

struct MapperParams {
  /// Mahalanobis gate, χ² with 3 degrees of freedom: 7.81 is the 95 % quantile. Used both for direct
  /// observation edges against the current estimate and for joining an observation to a hypothesis.
  double gate_chi2 = 7.81;
  /// A direct edge also needs the robot to be sure of its position relative to where it was last anchored:
  /// above this standard deviation (metres, largest axis of Σ_rel) observations go to the recovery filter
  /// and need the support of several views, since a wide gate would pass wrong matches.
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
  bool optimize_after_accept = true;
  int local_window_nodes = 30;
  int full_optimization_every = 100;
  OptimizerOptions optimizer = DefaultOptimizerOptions();

  /// Checks every field; the message names the first bad one and its value.
  Status Validate() const;
};

}  // namespace slamcore
