// Mapper: the robot's back-end. Consumes one run's events in order (events.h) on top of a parent map and
// produces the child map, deciding for every view observation between a direct observation edge, a
// recovery hypothesis and a merge hypothesis (paper III-B), tracking ambiguous views (IV-A) and merging
// components conditionally (IV-B). Every decision is written to the decision log; reports are built
// from it.
//
// Error contract: Process() validates the event fully before changing anything. On error (unknown view,
// NaN/inf, covariance not positive definite, time going backwards, an event before the first node or
// between a KidnapEvent and the next OdometryEvent …) it
// returns a Status naming the event and leaves the Mapper exactly as it was.
//
// Thread safety: not thread-safe; one Mapper per run, used from one thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "slamcore/events.h"
#include "slamcore/mapper_params.h"
#include "slamcore/pose_graph.h"

namespace slamcore {

/// A robot's map: the pose graph (with views and their ambiguity marks) and the local occupancy patches
/// attached to its nodes. The child map of run k is the parent map of run k+1.
struct Map {
  PoseGraph graph;
  std::unordered_map<NodeId, LocalMapEvent> local_maps;
};

enum class HypothesisKind : std::uint8_t { kRecovery, kMerge };

enum class DecisionKind : std::uint8_t {
  kDirectEdge,  // observation passed the gate: edge added at once
  kHypothesisCreated,
  kHypothesisUpdated,      // observation joined an existing hypothesis
  kConditionallyAccepted,  // merge hypothesis met the permissive criteria (IV-B)
  kAccepted,               // edges added to G
  kRejected,               // deleted because a competitor was accepted, or a conditional merge undone
  kExpired,                // no new observation for too long or too far
  kViewMarkedAmbiguous,
  kComponentCreated,  // first node, kidnap or reboot
  kComponentsMerged,
  kRetracted,      // an accepted hypothesis's edges left G: later evidence contradicted them
  kSlipCorrected,  // a node's local map showed the wheels slipped: the node moved where it stood
};

const char* DecisionKindName(DecisionKind kind);
/// "recovery" or "merge".
const char* HypothesisKindName(HypothesisKind kind);

struct Decision {
  double time = 0.0;
  DecisionKind kind = DecisionKind::kDirectEdge;
  NodeId node = -1;              // the robot's node when the decision was made
  ViewId view = -1;              // the observed view, where one is involved
  std::int64_t hypothesis = -1;  // hypothesis id, where one is involved
  std::optional<HypothesisKind> hypothesis_kind;
  std::string reason;  // human-readable, e.g. "3 observations of 2 views"
};

/// Counts over the decision log, the raw material of the fleet statistics (paper Fig. 6–8).
struct MapperStatistics {
  int direct_edges = 0;
  int recovery_created = 0, recovery_accepted = 0, recovery_expired = 0, recovery_rejected = 0;
  int merge_created = 0, merge_conditionally_accepted = 0, merge_accepted = 0, merge_expired = 0,
      merge_rejected = 0;
  int merge_conditional_then_rejected = 0;
  int recovery_retracted = 0;  // accepted, later retracted (counted in recovery_accepted too)
  int views_marked_ambiguous = 0;
  int components_created = 0;
  int slip_corrections = 0;  // MapperParams::correct_slip_from_views
};

/// The counts of a decision log (what Mapper::Statistics returns), also for logs read back from storage.
/// merge_conditional_then_rejected counts hypotheses with a kConditionallyAccepted and a later kRejected.
MapperStatistics ComputeStatistics(const std::vector<Decision>& decisions);

/// The run's consistent-set checks (mapper_consistent_set.cc): those that judged anything; of them those
/// the status quo settled without the graduated non-convexity (the second opinion may still take in refused
/// hypotheses near the set); and those whose graduated non-convexity ended above the status quo's
/// objective, so that the status quo stayed the set. A check that changes G logs its decisions.
struct ConsistentSetChecks {
  int judged = 0;
  int settled_by_status_quo = 0;
  int status_quo_below_gnc = 0;
};

/// An accepted observation edge as added to G, with the hypothesis that brought it (or -1 for direct).
struct AcceptedObservation {
  NodeId robot_node = -1;
  ViewId view = -1;
  std::int64_t hypothesis = -1;
};

class Mapper {
 public:
  /// Starts from `parent` (lifelong mapping) or from an empty map. Fails when params are invalid.
  static Result<std::unique_ptr<Mapper>> Create(const MapperParams& params, Map parent = {});
  ~Mapper();
  Mapper(const Mapper&) = delete;
  Mapper& operator=(const Mapper&) = delete;

  /// Consumes one event; on error the Mapper is unchanged (see the top of this file).
  Status Process(const Event& event);

  /// Reads through G′ (IV-B): under a conditional merge they include the hypothesis's edges.
  /// The robot's current node, or nullopt before the first odometry event.
  std::optional<NodeId> CurrentNode() const;
  /// The robot's pose in the frame of its component as seen through G′.
  std::optional<SE2> CurrentPose() const;
  /// The pose of any node as seen through G′ (the identity for a node that does not exist).
  SE2 PoseOf(NodeId node) const;
  /// Whether two nodes are connected in G′ (false when either does not exist).
  bool SameComponentInView(NodeId a, NodeId b) const;
  bool HasConditionalMerge() const;

  /// G: the committed map, without any conditional merge.
  const Map& map() const;
  const std::vector<Decision>& decisions() const;
  MapperStatistics Statistics() const;
  ConsistentSetChecks consistent_set_checks() const;
  /// Every observation edge in G, in the order added.
  const std::vector<AcceptedObservation>& accepted_observations() const;
  /// Ground truth kept aside, by node (the last GroundTruthEvent at or before each node's creation).
  const std::unordered_map<NodeId, SE2>& ground_truth() const;

  /// Ends the run: open hypotheses expire (logged), a pending conditional merge is undone, with the
  /// incremental back-end the robot's component is solved once to convergence, and the child map (G) is
  /// returned. The Mapper must not be used afterwards.
  Map Finish();

 private:
  class Impl;
  explicit Mapper(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace slamcore
