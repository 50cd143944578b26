// A hypothesis of the hypothesis filter (paper III-B): an EKF over G ≈ robot_T_ref (pose_gaussian.h) and
// the observations that built it, kept so that accepting it can add one observation edge per observation
// at the robot node where it was made.
//
// Thread safety: value types.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "pose_gaussian.h"
#include "slamcore/mapper.h"

namespace slamcore::internal {

struct HypothesisObservation {
  NodeId robot_node = -1;
  ViewId view = -1;
  NodeId view_node = -1;
  PoseGaussian robot_T_view;  // z as observed, Σ_z
  double time = 0.0;
  double odometer = 0.0;
  /// Whether it confirms the hypothesis: it started it, or it joined through a test that an aliasing
  /// offset would have failed. An observation that joins a hypothesis grown uncertain by the odometry
  /// since (an offset of consistency.aliasing_offset would have joined too) agrees with anything.
  bool confirms = true;
};

struct Hypothesis {
  std::int64_t id = -1;
  HypothesisKind kind = HypothesisKind::kRecovery;
  ViewId ref_view = -1;  // the first observed view; G is robot_T_ref
  NodeId ref_node = -1;  // the node of ref_view, which also names the target component
  PoseGaussian state;
  std::vector<HypothesisObservation> observations;
  double last_time = 0.0;      // of the last observation, for expiry
  double last_odometer = 0.0;  // likewise
  bool conditional = false;    // a merge hypothesis that is conditionally accepted (IV-B)
  int refused_at_passes = 0;   // passes when the optimised map last refused it (mapper_consistency.cc)
  /// Why it last waited although it met the counts (the map test and its passes), for the log of its end.
  std::string last_wait;
};

/// Observations and distinct views that count toward acceptance. With `discount_ambiguous`, observations of
/// views for which `is_ambiguous` holds do not count (IV-A).
struct EvidenceCount {
  int observations = 0;
  int views = 0;
};
EvidenceCount CountEvidence(const Hypothesis& hypothesis, bool discount_ambiguous,
                            const std::function<bool(ViewId)>& is_ambiguous);
/// "3 observations of 2 views", for the decision log.
std::string EvidenceText(const EvidenceCount& count);

/// When and where (robot odometer) an observation was made.
struct TraversalPoint {
  double time = 0.0;
  double odometer = 0.0;
  bool confirms = true;  // see HypothesisObservation::confirms
};

/// Whether `later` starts a new pass after `earlier`: made more than `gap_seconds` or more than `gap_distance`
/// (robot odometer) after it. The one rule of where a pass ends (CountPasses, the anchor of an acceptance,
/// a refused hypothesis's next pass).
bool BeyondPassGap(const TraversalPoint& earlier, const TraversalPoint& later, double gap_seconds,
                   double gap_distance);
/// Independent passes among observations in the order they were made: a pass is a run of observations, each
/// made within `gap_seconds` and `gap_distance` (robot odometer) of the previous one. One traversal past a
/// look-alike is one pass however many views it matched (mapper_consistency.cc). A pass whose first
/// observation does not confirm is not counted: it would have agreed with a wrong hypothesis as well (the
/// pass's later observations are tested against a state that already took in the first).
int CountPasses(std::span<const TraversalPoint> points, double gap_seconds, double gap_distance);
/// The passes among a hypothesis's observations.
int CountPasses(const Hypothesis& hypothesis, double gap_seconds, double gap_distance);

inline bool Meets(const EvidenceCount& count, const AcceptanceCriteria& criteria) {
  return count.observations >= criteria.min_observations && count.views >= criteria.min_views;
}

}  // namespace slamcore::internal
