// Mapper::Impl: the state of one run and the decisions of paper III-B, IV-A and IV-B. Split over
//   mapper.cc               public API, event dispatch, nodes/views/local maps, kidnap, expiry, log;
//   mapper_validation.cc    checks of every event before anything changes (the error contract);
//   mapper_observations.cc  direct gate, hypothesis filter, acceptance, ambiguity marks;
//   mapper_merge.cc         conditional and full merges (G′ as a MergeOverlay);
//   mapper_consistency.cc   correlated wrong observations: passes, the test against the map's marginal
//                           covariance, retraction of accepted hypotheses.
//   mapper_contest.cc       contested acceptances: later passes that agree take back a recovery the map
//                           test could not judge.
//   mapper_consistent_set.cc  the consistent-set check: accepted and refused hypotheses judged together
//                           (graduated non-convexity), retracting or accepting what it decides.
//
// Design choices the paper leaves open, written down here:
//  * Gate covariance for direct observations. The prediction ẑ = robot_T_viewnode comes from G; its
//    uncertainty is the robot's relative uncertainty Σ_rel: odometry covariance accumulated through the
//    Adjoint exactly as eq. (3) since the robot was last anchored. Anchoring = an accepted observation
//    (Σ_rel ← Σ_z of that observation, or Σ_G of an accepted hypothesis; both live in the robot frame like
//    Σ_rel) or the start of a component (Σ_rel ← 0). The map itself is treated as certain here. The test is
//    eq. (4): R = z·ẑ⁻¹, Σ_R = Adj_R Σ_rel Adj_Rᵀ + Σ_z, ln(R)ᵀ Σ_R⁻¹ ln(R) ≤ gate_chi2.
//    With the consistency checks on, Σ_rel is scaled by the a-posteriori variance factor of the component
//    (DeclaredNoiseScale) for both the gate and the "too uncertain for a direct edge" limit: odometry that
//    declares several times the noise the map's residuals meet would otherwise send every observation
//    after a few metres to the recovery filter as "uncertain", and open the gate to wrong matches within
//    the declared noise of the truth.
//    Since Σ_rel is reset on acceptance, G must reflect the accepted edge: with optimize_after_accept a
//    direct edge re-optimises a local window (the robot's last `local_window_nodes` nodes, everything
//    older held), so the recent trajectory agrees with it at O(window) cost; every
//    `full_optimization_every` direct edges, and after every accepted hypothesis, the whole component
//    is optimised. That is the batch back-end; the incremental one (incremental_solver.h, the default)
//    instead re-solves, from the endpoints of the edges added since its last update, the region of G
//    that still moves, whatever its size, so G stays near its optimum without whole-component solves
//    (except for an acceptance the consistency checks will verify, which they judge at the optimum, and
//    one far from the estimate); the edges of direct observations it defers like the batch one.
//  * "Rejected observation" for the ambiguity tracker (IV-A): an observation that failed the direct gate
//    (counted at once, at the odometer where it was made), and every observation of a merge hypothesis
//    that is rejected or expires (counted when it is dropped, stamped with the odometer where it was made,
//    so old ones fall outside the window). Recovery observations are not counted twice, and are taken
//    back out of the rejected tracker when their recovery hypothesis is accepted (they were right after all;
//    otherwise a correct recovery would mark its own newer views ambiguous).
//    "Accepted observation": a direct edge, or an observation of an accepted hypothesis.
//  * Other views of the target component are expressed in the ref frame with v_T_ref from G; G's
//    relative uncertainty is approximated as growing linearly with the distance between the two view nodes
//    (kMapVariancePerMetre), propagated by Compose (pose_gaussian.h).
//  * Competitors: accepting a hypothesis rejects every other open hypothesis of the same kind (they are
//    alternative explanations of where the robot is); hypotheses of the other kind stay, since their
//    state robot_T_ref does not depend on the accepted edges.
//  * Kidnap/reboot: every open hypothesis is rejected and a conditional merge undone, since their states
//    assume continuous odometry; the accepted-observation tracker is cleared (the robot is no longer
//    certain where it is). Events that need a node (views, observations, local maps) between a
//    KidnapEvent and the next OdometryEvent are refused: the robot has no node in its new component yet.
//  * Lifelong mapping: the first node of a run starts a NEW component even on a parent map; the robot
//    becomes localised in the parent's components only through merge hypotheses.
//  * Node ids continue after the parent's largest; the first node of a component sits at the identity
//    (the increment of its OdometryEvent is relative to nothing known); the odometer continues the
//    parent's largest.
//
// Thread safety: as Mapper (not thread-safe).
#pragma once

#include <Eigen/LU>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ambiguity_tracker.h"
#include "hypothesis.h"
#include "incremental_solver.h"
#include "marginal_covariance.h"
#include "merge_overlay.h"
#include "slamcore/mapper.h"
#include "slamcore/slip_detection.h"

namespace slamcore {

class Mapper::Impl {
 public:
  Impl(const MapperParams& params, Map parent);

  Status Process(const Event& event);

  std::optional<NodeId> CurrentNode() const { return current_node_; }
  std::optional<SE2> CurrentPose() const;
  SE2 PoseOf(NodeId node) const;
  bool SameComponentInView(NodeId a, NodeId b) const;
  bool HasConditionalMerge() const { return overlay_.has_value(); }

  const Map& map() const { return map_; }
  const std::vector<Decision>& decisions() const { return decisions_; }
  const std::vector<AcceptedObservation>& accepted_observations() const { return accepted_; }
  ConsistentSetChecks consistent_set_checks() const { return consistent_set_checks_; }
  const std::unordered_map<NodeId, SE2>& ground_truth() const { return ground_truth_; }
  Map Finish();

 private:
  /// kAccept: the map's informative test agreed. kAcceptAndVerify: the test could not tell, so the optimised
  /// map gets the last word (VerifyAcceptance). kAcceptOverMap: independent passes overrule the map; what
  /// they contradict is retracted, they are not refused.
  /// kWaitAgainstMap: the map test failed and the passes are too few to overrule the map.
  enum class RecoveryVerdict { kAccept, kAcceptAndVerify, kAcceptOverMap, kWait, kWaitAgainstMap };
  // mapper_validation.cc: return an error naming the event, or Ok; never change anything.
  Status Validate(const OdometryEvent& event) const;
  Status Validate(const ViewCreatedEvent& event) const;
  Status Validate(const ViewObservedEvent& event) const;
  Status Validate(const LocalMapEvent& event) const;
  Status Validate(const KidnapEvent& event) const;
  Status Validate(const GroundTruthEvent& event) const;
  Status CheckTime(const char* name, double time) const;
  Status CheckHasNode(const char* name, double time) const;

  // mapper.cc
  void Apply(const OdometryEvent& event);
  void Apply(const ViewCreatedEvent& event);
  void Apply(const ViewObservedEvent& event);
  void Apply(const LocalMapEvent& event);
  void Apply(const KidnapEvent& event);
  void Apply(const GroundTruthEvent& event);
  void ExpireHypotheses();
  /// The robot moved by `increment` (its covariance `covariance`): every hypothesis's state, the contested
  /// acceptance's, the map test's odometry chain and the robot's relative uncertainty follow (eq. (3)).
  void MoveRobot(const SE2& increment, const Matrix3& covariance);
  /// MapperParams::correct_slip_from_views: judges `node`'s local map (`view`) against the last one on its
  /// chain and, when it stood still, moves the node to where its view says it stood (mapper.cc).
  void CorrectSlip(NodeId node, const ViewSlipJudge& view);
  void Log(DecisionKind kind, ViewId view, const internal::Hypothesis* hypothesis, std::string reason);
  /// For a hypothesis no longer open (a retraction names one already accepted).
  void Log(DecisionKind kind, ViewId view, std::int64_t hypothesis,
           std::optional<HypothesisKind> hypothesis_kind, std::string reason);

  // mapper_observations.cc
  void DecideObservation(const ViewObservedEvent& event);
  void RouteToFilter(HypothesisKind kind, const ViewObservedEvent& event, NodeId view_node, std::string why);
  internal::PoseGaussian ExpressInRefFrame(const internal::PoseGaussian& robot_T_view, NodeId view_node,
                                           NodeId ref_node) const;
  void EvaluateAcceptance(std::int64_t hypothesis_id);
  /// False when the verification refused it (G restored, the refusal logged).
  bool AcceptRecovery(std::int64_t hypothesis_id, const std::string& support, RecoveryVerdict verdict);
  Edge MakeObservationEdge(const internal::HypothesisObservation& observation,
                           std::int64_t hypothesis_id) const;
  /// `direct`: a direct edge (it passed the gate with a robot sure of its position), the one change to G
  /// after which the marginals factorised before still bound the map's covariance (MapPredictionBound).
  void AddObservationEdge(const internal::HypothesisObservation& observation, std::int64_t hypothesis_id,
                          bool direct);
  /// How G changed, for what the marginals factorised before it can still tell: while only direct edges
  /// were added they bound the map's covariance (MapPredictionBound); while only edges were added they are
  /// the prior the new edges update (MapPrediction); after edges were removed (or G restored to before
  /// some were added) or the whole component re-posed, only a new factorisation describes G's new edges.
  /// A re-pose alone leaves current marginals current (to within the linearisation point).
  enum class GraphChange : std::uint8_t { kDirectEdgeAdded, kEdgesAdded, kEdgesRemoved, kReposed };
  void NoteGraphChanged(GraphChange change);
  void RejectCompetitors(const internal::Hypothesis& accepted);
  /// Observations of the competitors of a recovery just accepted that fit the map it made (each edge's χ²
  /// within gate_chi2) join it as its edges, and the component is re-optimised (mapper_consistency.cc).
  void AdoptFittingObservationsOfCompetitors(const internal::Hypothesis& accepted);
  /// Whether an observation must not join `hypothesis`: the optimised map refused it, the observation
  /// would start a new pass of it, and the join's gate is one an aliasing offset would pass too
  /// (mapper_consistency.cc).
  bool RefusedAndUntestable(const internal::Hypothesis& hypothesis, const internal::Innovation& join) const;
  /// Removes a hypothesis, logging `kind` (kRejected or kExpired) — or kRejected when it was a conditional
  /// merge, which is then undone — and feeding a merge hypothesis's observations to the rejected tracker.
  void DropHypothesis(std::int64_t hypothesis_id, DecisionKind kind, const std::string& reason);
  void UpdateAmbiguityMarks();
  bool IsAmbiguous(ViewId view) const { return map_.graph.view(view).ambiguous; }
  /// What a hypothesis holds as its kind counts it: ambiguous views never count toward a recovery (IV-A), and
  /// toward a merge only without discount_ambiguous_in_merge.
  internal::EvidenceCount EvidenceOf(const internal::Hypothesis& hypothesis) const;
  void OptimizeComponentOf(NodeId node, std::string* note);
  /// The incremental back-end's update from the pending seeds (which it clears). When it started from the
  /// whole component, its last factorisation becomes the marginals (true when it could).
  bool UpdateIncrementally(internal::IncrementalSolver::Start start);
  /// The incremental back-end minimises plain χ²: with a robust loss the batch one is used.
  bool UsesIncrementalBackend() const {
    return params_.backend == MapperBackend::kIncremental &&
           params_.optimizer.robust_loss == RobustLoss::kNone;
  }
  /// After a direct edge: a local window, or the component every full_optimization_every edges.
  void OptimizeAfterDirectEdge(NodeId robot, double innovation_chi2, std::string* note);
  internal::Hypothesis* FindHypothesis(std::int64_t id);
  /// Removes an open hypothesis and returns it; nullopt when there is none with that id.
  std::optional<internal::Hypothesis> TakeHypothesis(std::int64_t id);

  // mapper_consistency.cc
  /// What a recovery hypothesis that meets the counts gets: its passes against the outcome of the test
  /// against the map. `why` says what decided.
  /// `from_the_map`, when given: ln of the hypothesis's state against the map's prediction (when tested).
  RecoveryVerdict JudgeRecovery(const internal::Hypothesis& hypothesis, std::string* why,
                                Vector3* from_the_map = nullptr);
  /// Whether a test with this largest position variance (of its innovation) against `gate_chi2` is
  /// informative: an aliasing offset of consistency.aliasing_offset metres would have failed it.
  bool AliasingOffsetWouldFail(double largest_variance, double gate_chi2) const;
  /// The factor by which the declared covariances overstate the noise the robot's component meets: the
  /// a-posteriori variance factor the last map test measured (map_test_.variance_factor), clamped to
  /// [consistency.min_variance_factor, 1], once its redundancy reaches consistency.min_redundancy_for_scaling;
  /// else (and with the consistency checks off) 1.
  double DeclaredNoiseScale() const;
  /// robot_T_node from G with the map's marginal covariance between the two; nullopt when unavailable.
  std::optional<internal::PoseGaussian> MapPrediction(NodeId node);
  /// robot_T_node with a covariance no smaller than MapPrediction's, from marginals factorised before
  /// the last direct edges, without refactorising; nullopt when they are current or cannot bound it.
  std::optional<internal::PoseGaussian> MapPredictionBound(NodeId node) const;
  void RefactorizeMarginals();
  /// Takes `marginals` as those of G as it is now.
  void SetMarginals(std::optional<internal::MarginalCovariances> marginals);
  /// The marginals from the factorisation the back-end's last whole-component solve ended with, when it
  /// left one for the robot's component; false (map_test_.marginals untouched) otherwise.
  bool MarginalsFromTheSolve();
  void OptimizeAndFactorize();
  /// After a recovery's edges joined G and the component was optimised: false when its own edges fail the
  /// leave-one-out test (the caller restores G); else retracts the earlier acceptances that now fail it,
  /// the worst first. Appends what it found to `note`.
  /// `marginals_current`: map_test_.marginals were just made at this optimum (MarginalsFromTheSolve).
  bool VerifyAcceptance(std::int64_t hypothesis_id, bool may_refuse, bool marginals_current,
                        std::string* note);
  /// d² of a hypothesis's edges against the rest of G over its χ² quantile (> 1 fails); nullopt when
  /// it has no edges in the factorised component.
  std::optional<double> LeaveOneOutRatio(std::int64_t hypothesis_id) const;
  bool IsRetractableEdge(const Edge& edge, std::int64_t hypothesis_id) const;
  /// Accepted recovery hypotheses of this run, the worst-fitting first (mean χ² per edge), at most `count`.
  std::vector<std::int64_t> WorstFittingAccepted(int count) const;
  /// Removes the hypothesis's retractable edges from G and returns them, in G's order.
  std::vector<Edge> RemoveHypothesisEdges(std::int64_t hypothesis_id);
  void LogRetractions(const std::vector<std::pair<std::int64_t, double>>& retracted, std::int64_t challenger);
  /// An observation at `time` continues the pass of the anchor's acceptance, or ends it after a gap.
  void ContinueAnchorPass(double time);
  /// The accepted hypothesis a direct edge continues (same pass), which then owns the edge.
  std::optional<std::int64_t> AnchorForDirectEdge();
  /// Drops the stalest open hypotheses beyond the cap.
  void EnforceOpenHypothesisCap();

  // mapper_contest.cc
  /// After a recovery is accepted: it starts a new contest when its map test could not tell, rides on the
  /// contested acceptance when made in its pass (`anchored_to`: the anchor's hypothesis before this
  /// acceptance), and otherwise supports it. `covariance_before`: Σ_rel before the acceptance reset it.
  void NoteAcceptance(const internal::Hypothesis& accepted, RecoveryVerdict verdict,
                      std::optional<std::int64_t> anchored_to, const Matrix3& covariance_before);
  /// A direct edge, owned by `owner` (or nothing): beyond the contested acceptance's pass, a pass for it.
  void NoteDirectEdge(std::optional<std::int64_t> owner);
  /// A hypothesis that meets the counts but waits against the map: a contradiction of the contested
  /// acceptance, which is retracted on trial when the contradictions that agree with this one outnumber
  /// its support; the trial stands when the hypothesis then fits the map without it and is accepted.
  /// `from_the_map`: its innovation against the map's prediction, as its map test computed it.
  void ContestAcceptance(std::int64_t hypothesis_id, const Vector3& from_the_map);
  /// Re-poses the robot's nodes after `first` (this run's, up to the current one) by chaining their odometry.
  void DeadReckonSince(NodeId first);

  // mapper_consistent_set.cc
  /// A refused recovery hypothesis kept for the consistent-set check: the edges its acceptance would add
  /// (or, for a retracted one, the edges it had).
  struct KeptRefused {
    std::int64_t hypothesis = -1;
    std::vector<Edge> edges;
  };
  /// Keeps a dropped recovery hypothesis that met the counts (its observations as edges).
  void KeepRefused(const internal::Hypothesis& hypothesis);
  /// Keeps refused or retracted edges for the consistent-set check (the oldest go beyond the cap).
  void KeepForTheCheck(KeptRefused kept);
  /// Runs the check when the judged hypotheses have grown enough since the last one.
  void MaybeCheckConsistentSet();
  void CheckConsistentSet(const char* trigger);

  // mapper_merge.cc
  SE2 TargetFromSource(const internal::Hypothesis& hypothesis) const;
  void ConditionallyAccept(std::int64_t hypothesis_id);
  void AcceptMerge(std::int64_t hypothesis_id);
  void RefreshOverlay();

  MapperParams params_;
  Map map_;
  std::optional<NodeId> current_node_;
  NodeId next_node_id_ = 0;
  double odometer_ = 0.0;
  double time_ = -std::numeric_limits<double>::infinity();  // of the last event processed
  /// Set at the start and by a KidnapEvent: the next OdometryEvent starts a new component.
  bool start_new_component_ = true;
  std::string new_component_reason_ = "first node of the run";
  Matrix3 robot_relative_covariance_ = Matrix3::Zero();  // Σ_rel, see the top of this file
  int direct_edges_since_full_optimization_ = 0;
  internal::IncrementalSolver incremental_;
  /// Endpoints of the edges added since the incremental back-end's last update.
  std::vector<NodeId> pending_seeds_;

  /// The last local map kept on the robot's chain, as the judge of the next (CorrectSlip), and the nodes
  /// driven since; reset with the chain (a new component).
  struct SlipReference {
    SlipReference(NodeId at, const LocalMapEvent& event)
        : node(at), view(std::make_unique<const LocalMapEvent>(event)), judge(*view) {}
    NodeId node;
    std::unique_ptr<const LocalMapEvent> view;  // on the heap: the judge refers to it
    ViewSlipJudge judge;
    std::vector<NodeId> since;
  };
  std::optional<SlipReference> slip_reference_;
  /// A view was observed at the current node: its pose is anchored by (or tested against) the views, and
  /// its slip, if any, is the filter's to judge.
  bool observed_at_current_node_ = false;

  std::vector<internal::Hypothesis> hypotheses_;  // open ones, in creation order
  std::int64_t next_hypothesis_id_ = 0;
  std::optional<internal::MergeOverlay> overlay_;  // G′ while a merge is conditionally accepted
  std::int64_t conditional_hypothesis_ = -1;

  internal::AmbiguityTracker ambiguity_;
  std::unordered_map<ViewId, std::size_t> view_creation_order_;

  /// The map's marginal covariances, refactorised when observation edges changed since (map_test_.map_revision),
  /// and the odometry chain from their newest node to the robot (map_test_.robot_T_factorized). While only direct
  /// edges were added since (map_test_.indirect_revision unchanged), G has only gained information, so stale
  /// marginals still bound the map's covariance from above.
  struct MarginalState {
    std::optional<internal::MarginalCovariances> marginals;
    std::uint64_t marginals_revision = 0, map_revision = 0;
    std::uint64_t marginals_indirect_revision = 0, indirect_revision = 0;
    std::uint64_t marginals_structure_revision = 0, structure_revision = 0;
    /// The variance factor of the robot's component as the last map test measured it (from the marginals
    /// when they were factorised for it, else from G): DeclaredNoiseScale's.
    internal::VarianceFactor variance_factor;
    internal::PoseGaussian robot_T_factorized;
  };
  MarginalState map_test_;
  /// This run's first node: edges at or after it were added in this run (parent edges are never retracted).
  NodeId first_run_node_ = 0;
  /// Accepted recovery hypotheses of this run whose edges are in G, for retraction.
  std::vector<std::int64_t> retractable_;
  /// The last accepted recovery hypothesis while the robot is still in the pass that accepted it.
  struct Anchor {
    std::int64_t hypothesis = -1;
    double time = 0.0, odometer = 0.0;  // of the pass's last observation
    int continuation_edges = 0;
  };
  std::optional<Anchor> anchor_;
  /// The last recovery accepted on a map test that could not tell, while no later pass has settled it
  /// (mapper_contest.cc).
  struct Contradiction {
    std::int64_t hypothesis = -1;
    NodeId ref_node = -1;
    internal::PoseGaussian state;  // robot_T_ref, carried by the odometry like an open hypothesis's
    int passes = 1;
  };
  struct Contested {
    std::vector<std::int64_t> hypotheses;   // the acceptance, and those accepted in its pass after it
    int support = 1;                        // its passes, and the later passes that agreed with it
    internal::TraversalPoint last_support;  // the end of the last of those passes
    double accepted_time = 0.0;
    NodeId robot_node = -1;                       // where it was accepted
    Matrix3 covariance_before = Matrix3::Zero();  // Σ_rel there before the acceptance reset it
    std::vector<Contradiction> contradictions;    // at most consistency.max_open_hypotheses
    std::vector<std::int64_t> unexplained;        // contradictions a trial found it does not explain
    int trials = 0;
  };
  std::optional<Contested> contested_;
  /// What an acceptance, or a retraction on trial, changes: restored exactly when it does not stand.
  struct RestorePoint {
    PoseGraph graph;
    std::vector<AcceptedObservation> accepted;
    std::vector<std::int64_t> retractable;
    Matrix3 robot_relative_covariance;
    std::optional<Anchor> anchor;
    internal::AmbiguityTracker ambiguity;
    std::vector<NodeId> pending_seeds;
  };
  RestorePoint SaveRestorePoint() const;
  void Restore(RestorePoint saved);
  /// The map test's state, taken out whole and put back (a contest that retracts nothing).
  MarginalState TakeMarginalState() { return std::exchange(map_test_, {}); }
  void PutBackMarginalState(MarginalState state) { map_test_ = std::move(state); }
  std::vector<KeptRefused> kept_refused_;  // oldest first, at most consistency.max_kept_refused
  std::size_t judged_at_last_check_ = 0;
  bool judge_next_check_in_full_ = false;  // the next check then runs in full (CheckConsistentSet)
  ConsistentSetChecks consistent_set_checks_;

  std::vector<Decision> decisions_;
  std::vector<AcceptedObservation> accepted_;
  std::unordered_map<NodeId, SE2> ground_truth_;
  std::optional<GroundTruthEvent> latest_ground_truth_;
};

namespace internal {
/// Variance per metre of distance between two view nodes of the map's relative pose (x, y, θ), for
/// expressing an observation of one view in another view's frame (see the top of this file). 1 cm² and
/// 0.0003 rad² (≈ 1°²) per metre: the drift of good wheel odometry, an upper bound for an optimised map.
inline const Vector3 kMapVariancePerMetre{1e-4, 1e-4, 3e-4};
}  // namespace internal

}  // namespace slamcore
