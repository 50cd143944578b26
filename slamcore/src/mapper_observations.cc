// The decision for each view observation (paper III-B), acceptance of recovery hypotheses, and the
// ambiguity marks (IV-A). Design choices: mapper_impl.h.
#include <algorithm>
#include <limits>
#include <sstream>

#include "mapper_impl.h"
#include "slamcore/optimizer.h"

namespace slamcore {

using internal::Hypothesis;
using internal::HypothesisObservation;
using internal::PoseGaussian;

namespace {

std::string Chi2Text(double mahalanobis2) {
  std::ostringstream text;
  text.precision(4);
  text << "d²=" << mahalanobis2;
  return text.str();
}

}  // namespace

void Mapper::Impl::DecideObservation(const ViewObservedEvent& event) {
  ContinueAnchorPass(event.time);
  const NodeId view_node = map_.graph.view(event.view).node;
  const NodeId robot = *current_node_;
  if (!map_.graph.SameComponent(view_node, robot)) {
    RouteToFilter(HypothesisKind::kMerge, event, view_node, "view in another component");
    UpdateAmbiguityMarks();
    return;
  }
  // A robot that has driven far since it was last anchored is too uncertain for one observation to be
  // trusted: a wide gate would let any wrong match through. Such observations must gather support as a
  // recovery hypothesis (III-B); they say nothing about the view being ambiguous.
  // Σ_rel as the noise the map meets says (mapper_impl.h, "Gate covariance for direct observations").
  const Matrix3 relative_covariance = robot_relative_covariance_ * DeclaredNoiseScale();
  const double position_sigma = std::sqrt(internal::LargestPositionVariance(relative_covariance));
  if (position_sigma > params_.direct_max_position_sigma) {
    RouteToFilter(
        HypothesisKind::kRecovery, event, view_node,
        "robot too uncertain for a direct edge (position sigma " + std::to_string(position_sigma) + " m)");
    return;
  }
  // Direct gate, eq. (4) with the prediction from G and Σ_rel (mapper_impl.h).
  const PoseGaussian predicted{map_.graph.node(robot).pose.inverse() * map_.graph.node(view_node).pose,
                               relative_covariance};
  const internal::Innovation innovation =
      internal::ComputeInnovation(predicted, {event.robot_T_view, event.covariance});
  if (innovation.mahalanobis2 <= params_.gate_chi2) {
    HypothesisObservation observation{.robot_node = robot,
                                      .view = event.view,
                                      .view_node = view_node,
                                      .robot_T_view = {event.robot_T_view, event.covariance},
                                      .time = event.time,
                                      .odometer = odometer_};
    const std::optional<std::int64_t> owner =
        params_.consistency.enabled ? AnchorForDirectEdge() : std::optional<std::int64_t>();
    AddObservationEdge(observation, owner.value_or(-1), /*direct=*/true);
    NoteDirectEdge(owner);
    robot_relative_covariance_ = event.covariance;
    std::string note;
    if (owner) note = "; continues the pass of accepted hypothesis " + std::to_string(*owner);
    if (params_.optimize_after_accept) OptimizeAfterDirectEdge(robot, innovation.mahalanobis2, &note);
    Log(DecisionKind::kDirectEdge, event.view, nullptr,
        Chi2Text(innovation.mahalanobis2) + " within the gate" + note);
    UpdateAmbiguityMarks();
    return;
  }
  ambiguity_.AddRejected(event.view, odometer_);
  UpdateAmbiguityMarks();  // before the recovery filter, so a freshly ambiguous view does not count
  RouteToFilter(HypothesisKind::kRecovery, event, view_node,
                "failed the direct gate with " + Chi2Text(innovation.mahalanobis2));
}

PoseGaussian Mapper::Impl::ExpressInRefFrame(const PoseGaussian& robot_T_view, NodeId view_node,
                                             NodeId ref_node) const {
  if (view_node == ref_node) return robot_T_view;
  const SE2 view_T_ref = map_.graph.node(view_node).pose.inverse() * map_.graph.node(ref_node).pose;
  const double distance = view_T_ref.translation().norm();
  const PoseGaussian map_relative{view_T_ref, (internal::kMapVariancePerMetre * distance).asDiagonal()};
  return internal::Compose(robot_T_view, map_relative);
}

void Mapper::Impl::RouteToFilter(HypothesisKind kind, const ViewObservedEvent& event, NodeId view_node,
                                 std::string why) {
  const PoseGaussian z{event.robot_T_view, event.covariance};
  HypothesisObservation observation{.robot_node = *current_node_,
                                    .view = event.view,
                                    .view_node = view_node,
                                    .robot_T_view = z,
                                    .time = event.time,
                                    .odometer = odometer_};
  // Join the hypothesis of the same kind and target component with the smallest residual under the gate.
  Hypothesis* best = nullptr;
  internal::Innovation best_innovation{.residual = SE2(),
                                       .log = Vector3::Zero(),
                                       .covariance = Matrix3::Zero(),
                                       .mahalanobis2 = std::numeric_limits<double>::infinity()};
  PoseGaussian best_in_ref;
  std::vector<std::int64_t> passed_by;  // refused hypotheses whose gate would take it without a test
  for (Hypothesis& hypothesis : hypotheses_) {
    if (hypothesis.kind != kind || !map_.graph.SameComponent(hypothesis.ref_node, view_node)) continue;
    const PoseGaussian in_ref = ExpressInRefFrame(z, view_node, hypothesis.ref_node);
    const internal::Innovation innovation = internal::ComputeInnovation(hypothesis.state, in_ref);
    if (innovation.mahalanobis2 > params_.gate_chi2) continue;
    if (kind == HypothesisKind::kRecovery && RefusedAndUntestable(hypothesis, innovation)) {
      passed_by.push_back(hypothesis.id);
      continue;
    }
    if (innovation.mahalanobis2 < best_innovation.mahalanobis2) {
      best = &hypothesis;
      best_innovation = innovation;
      best_in_ref = in_ref;
    }
  }
  std::int64_t id;
  if (best) {
    const double best_mahalanobis2 = best_innovation.mahalanobis2;
    // Would an aliasing offset, in the direction the join is least sure of, have failed this gate?
    observation.confirms = AliasingOffsetWouldFail(
        internal::LargestPositionVariance(best_innovation.covariance), params_.gate_chi2);
    best->state = internal::UpdateWithObservation(best->state, best_in_ref);  // eqs. (5)–(6)
    best->observations.push_back(observation);
    best->last_time = event.time;
    best->last_odometer = odometer_;
    if (best->conditional && overlay_) {
      overlay_->AddEdge(MakeObservationEdge(observation, -1));
    }
    id = best->id;
    Log(DecisionKind::kHypothesisUpdated, event.view, best,
        why + "; joined with " + Chi2Text(best_mahalanobis2) +
            (observation.confirms ? "" : " (an aliasing offset would have joined too: confirms nothing)"));
  } else {
    Hypothesis hypothesis;  // eq. (2): G = z, Σ_G = Σ_z
    hypothesis.id = next_hypothesis_id_++;
    hypothesis.kind = kind;
    hypothesis.ref_view = event.view;
    hypothesis.ref_node = view_node;
    hypothesis.state = z;
    hypothesis.observations.push_back(observation);
    hypothesis.last_time = event.time;
    hypothesis.last_odometer = odometer_;
    hypotheses_.push_back(std::move(hypothesis));
    id = hypotheses_.back().id;
    if (!passed_by.empty()) {
      why += "; a new pass, kept apart from refused hypothesis " + std::to_string(passed_by.front()) +
             (passed_by.size() > 1 ? " and " + std::to_string(passed_by.size() - 1) + " more" : "") +
             " (an aliasing offset would have joined too)";
    }
    Log(DecisionKind::kHypothesisCreated, event.view, &hypotheses_.back(), why);
    EnforceOpenHypothesisCap();
  }
  EvaluateAcceptance(id);
}

internal::EvidenceCount Mapper::Impl::EvidenceOf(const Hypothesis& hypothesis) const {
  const bool discount_ambiguous =
      hypothesis.kind == HypothesisKind::kRecovery || params_.discount_ambiguous_in_merge;
  return internal::CountEvidence(hypothesis, discount_ambiguous,
                                 [this](ViewId view) { return IsAmbiguous(view); });
}

void Mapper::Impl::EvaluateAcceptance(std::int64_t hypothesis_id) {
  const Hypothesis* hypothesis = FindHypothesis(hypothesis_id);
  if (!hypothesis) return;
  const internal::EvidenceCount count = EvidenceOf(*hypothesis);
  if (hypothesis->kind == HypothesisKind::kRecovery) {
    if (!Meets(count, params_.recovery)) return;
    std::string support;
    Vector3 from_the_map = Vector3::Zero();
    const RecoveryVerdict verdict = JudgeRecovery(*hypothesis, &support, &from_the_map);
    if (verdict == RecoveryVerdict::kWait || verdict == RecoveryVerdict::kWaitAgainstMap) {
      FindHypothesis(hypothesis_id)->last_wait = std::move(support);
      if (verdict == RecoveryVerdict::kWaitAgainstMap) ContestAcceptance(hypothesis_id, from_the_map);
      return;
    }
    AcceptRecovery(hypothesis_id, support, verdict);
    return;
  }
  if (Meets(count, params_.merge_full)) {
    AcceptMerge(hypothesis_id);
  } else if (params_.conditional_merge && !hypothesis->conditional && !overlay_ &&
             Meets(count, params_.merge_conditional)) {
    ConditionallyAccept(hypothesis_id);  // at most one conditional merge at a time (IV-B)
  }
}

bool Mapper::Impl::AcceptRecovery(std::int64_t hypothesis_id, const std::string& support,
                                  RecoveryVerdict verdict) {
  Hypothesis* candidate = FindHypothesis(hypothesis_id);
  if (!candidate) return false;
  // What acceptance changes, to restore it exactly when the optimised map refuses the hypothesis.
  const bool verify = verdict != RecoveryVerdict::kAccept && params_.consistency.enabled &&
                      params_.consistency.verify_after_optimization && params_.optimize_after_accept;
  std::optional<RestorePoint> saved;
  if (verify) saved = SaveRestorePoint();
  const std::optional<std::int64_t> anchored_to =
      anchor_ ? std::optional<std::int64_t>(anchor_->hypothesis) : std::nullopt;
  const Matrix3 covariance_before = robot_relative_covariance_;
  for (const HypothesisObservation& observation : candidate->observations) {
    // They failed the direct gate, but the evidence says they were right: no longer rejected (IV-A).
    ambiguity_.RemoveRejected(observation.view, observation.odometer);
    AddObservationEdge(observation, hypothesis_id, /*direct=*/false);
  }
  robot_relative_covariance_ = candidate->state.covariance;
  anchor_ = Anchor{.hypothesis = hypothesis_id, .time = time_, .odometer = odometer_};
  std::string note;
  bool marginals_current = false;
  if (params_.optimize_after_accept) {
    // The verification judges the newcomer at the optimum: the incremental back-end solves the whole
    // component for it, as the batch one does for every acceptance, and its final factorisation gives the
    // marginals the verification needs (the same factorisation, not a second one).
    if (verify && UsesIncrementalBackend()) {
      direct_edges_since_full_optimization_ = 0;
      pending_seeds_.push_back(*current_node_);
      marginals_current = UpdateIncrementally(internal::IncrementalSolver::Start::kWhole);
    } else {
      OptimizeComponentOf(*current_node_, &note);
    }
  }
  if (verify && !VerifyAcceptance(hypothesis_id, verdict == RecoveryVerdict::kAcceptAndVerify,
                                  marginals_current, &note)) {
    Restore(std::move(*saved));
    candidate->refused_at_passes = internal::CountPasses(*candidate, params_.consistency.pass_gap_seconds,
                                                         params_.consistency.pass_gap_distance);
    Log(DecisionKind::kHypothesisUpdated, candidate->ref_view, candidate,
        "not accepted: " + support + note + "; it waits for another pass");
    return false;
  }
  const std::optional<Hypothesis> taken = TakeHypothesis(hypothesis_id);
  const Hypothesis& accepted = *taken;
  retractable_.push_back(accepted.id);
  Log(DecisionKind::kAccepted, accepted.ref_view, &accepted,
      internal::EvidenceText(EvidenceOf(accepted)) + (support.empty() ? "" : "; " + support) + note);
  NoteAcceptance(accepted, verdict, anchored_to, covariance_before);
  AdoptFittingObservationsOfCompetitors(accepted);
  RejectCompetitors(accepted);
  return true;
}

Mapper::Impl::RestorePoint Mapper::Impl::SaveRestorePoint() const {
  return RestorePoint{map_.graph, accepted_,  retractable_,  robot_relative_covariance_,
                      anchor_,    ambiguity_, pending_seeds_};
}

void Mapper::Impl::Restore(RestorePoint saved) {
  map_.graph = std::move(saved.graph);
  accepted_ = std::move(saved.accepted);
  retractable_ = std::move(saved.retractable);
  robot_relative_covariance_ = saved.robot_relative_covariance;
  anchor_ = saved.anchor;
  ambiguity_ = std::move(saved.ambiguity);
  pending_seeds_ = std::move(saved.pending_seeds);
  NoteGraphChanged(GraphChange::kEdgesRemoved);
}

bool Mapper::Impl::RefusedAndUntestable(const Hypothesis& hypothesis,
                                        const internal::Innovation& join) const {
  const ConsistencyParams& consistency = params_.consistency;
  if (!consistency.enabled || hypothesis.refused_at_passes == 0) return false;
  const bool new_pass = internal::BeyondPassGap(
      {.time = hypothesis.last_time, .odometer = hypothesis.last_odometer},
      {.time = time_, .odometer = odometer_}, consistency.pass_gap_seconds, consistency.pass_gap_distance);
  return new_pass &&
         !AliasingOffsetWouldFail(internal::LargestPositionVariance(join.covariance), params_.gate_chi2);
}

void Mapper::Impl::AdoptFittingObservationsOfCompetitors(const Hypothesis& accepted) {
  if (!params_.consistency.enabled) return;
  std::size_t adopted = 0;
  for (Hypothesis& competitor : hypotheses_) {
    if (competitor.kind != accepted.kind) continue;
    std::erase_if(competitor.observations, [&](const HypothesisObservation& observation) {
      const Edge edge = MakeObservationEdge(observation, accepted.id);
      if (EdgeChi2(map_.graph, edge) > params_.gate_chi2) return false;
      ambiguity_.RemoveRejected(observation.view, observation.odometer);  // as for the accepted ones
      AddObservationEdge(observation, accepted.id, /*direct=*/false);
      ++adopted;
      return true;
    });
  }
  if (adopted == 0) return;
  std::string note;
  if (params_.optimize_after_accept) OptimizeComponentOf(*current_node_, &note);
  Log(DecisionKind::kHypothesisUpdated, accepted.ref_view, &accepted,
      std::to_string(adopted) + " observations of its competitors fit the map it made and join it" + note);
}

void Mapper::Impl::AddObservationEdge(const HypothesisObservation& observation, std::int64_t hypothesis_id,
                                      bool direct) {
  const Edge edge = MakeObservationEdge(observation, hypothesis_id);
  // Cannot fail: both nodes and the view exist, and the covariance passed validation.
  if (map_.graph.AddEdge(edge).ok()) {
    NoteGraphChanged(direct ? GraphChange::kDirectEdgeAdded : GraphChange::kEdgesAdded);
    pending_seeds_.push_back(edge.from);
    pending_seeds_.push_back(edge.to);
    accepted_.push_back({.robot_node = edge.from, .view = observation.view, .hypothesis = hypothesis_id});
    ambiguity_.AddAccepted(observation.view, observation.odometer);
  }
}

void Mapper::Impl::NoteGraphChanged(GraphChange change) {
  if (change == GraphChange::kEdgesRemoved || change == GraphChange::kReposed) ++map_test_.structure_revision;
  if (change == GraphChange::kReposed) return;
  ++map_test_.map_revision;
  if (change != GraphChange::kDirectEdgeAdded) ++map_test_.indirect_revision;
}

Edge Mapper::Impl::MakeObservationEdge(const HypothesisObservation& observation,
                                       std::int64_t hypothesis_id) const {
  Edge edge;
  edge.from = observation.robot_node;
  edge.to = observation.view_node;
  edge.measurement = observation.robot_T_view.mean;
  edge.information =
      EdgeInformationFromLeftCovariance(observation.robot_T_view.mean, observation.robot_T_view.covariance);
  edge.kind = EdgeKind::kObservation;
  edge.view = observation.view;
  if (hypothesis_id >= 0) edge.hypothesis = hypothesis_id;
  return edge;
}

void Mapper::Impl::RejectCompetitors(const Hypothesis& accepted) {
  std::vector<std::int64_t> competitors;
  for (const Hypothesis& hypothesis : hypotheses_) {
    if (hypothesis.kind == accepted.kind) competitors.push_back(hypothesis.id);
  }
  for (const std::int64_t id : competitors) {
    DropHypothesis(id, DecisionKind::kRejected,
                   "competitor " + std::to_string(accepted.id) + " was accepted");
  }
}

void Mapper::Impl::DropHypothesis(std::int64_t hypothesis_id, DecisionKind kind, const std::string& reason) {
  const std::optional<Hypothesis> taken = TakeHypothesis(hypothesis_id);
  if (!taken) return;
  const Hypothesis& dropped = *taken;
  // What it had gathered against what acceptance needs: the first question about a dropped hypothesis
  // (a place seen once, as every loop closure of SE-Sync's MIT graph is, never meets the counts).
  const bool recovery = dropped.kind == HypothesisKind::kRecovery;
  const AcceptanceCriteria& needed = recovery ? params_.recovery : params_.merge_full;
  const std::string evidence = "; it held " + internal::EvidenceText(EvidenceOf(dropped)) +
                               (recovery ? ", acceptance needs " : ", a full merge needs ") +
                               std::to_string(needed.min_observations) + " of " +
                               std::to_string(needed.min_views) +
                               (dropped.last_wait.empty() ? "" : "; it last waited on " + dropped.last_wait);
  if (dropped.conditional) {
    overlay_.reset();  // G′ is simply dropped: G never saw the edges (IV-B)
    conditional_hypothesis_ = -1;
    Log(DecisionKind::kRejected, dropped.ref_view, &dropped,
        "conditional merge undone: " + reason + evidence);
  } else {
    Log(kind, dropped.ref_view, &dropped, reason + evidence);
  }
  if (dropped.kind == HypothesisKind::kRecovery) KeepRefused(dropped);
  if (dropped.kind == HypothesisKind::kMerge) {
    for (const HypothesisObservation& observation : dropped.observations) {
      ambiguity_.AddRejected(observation.view, observation.odometer);
    }
    ambiguity_.Forget(odometer_);
    UpdateAmbiguityMarks();
  }
}

void Mapper::Impl::UpdateAmbiguityMarks() {
  const auto creation_order = [this](ViewId view) { return view_creation_order_.at(view); };
  const auto marked = [this](ViewId view) { return IsAmbiguous(view); };
  for (const ViewId view : ambiguity_.FindAmbiguous(creation_order, marked)) {
    map_.graph.mutable_view(view).ambiguous = true;
    Log(DecisionKind::kViewMarkedAmbiguous, view, nullptr,
        std::to_string(ambiguity_.RejectionsInWindow(view)) +
            " rejected observations while an older view was accepted within " +
            std::to_string(params_.ambiguity_window_distance) + " m");
  }
}

void Mapper::Impl::OptimizeComponentOf(NodeId node, std::string* note) {
  direct_edges_since_full_optimization_ = 0;
  if (UsesIncrementalBackend()) {
    UpdateIncrementally(internal::IncrementalSolver::Start::kLocalUnlessFar);
    return;
  }
  OptimizerOptions options = params_.optimizer;
  options.component = node;
  const Result<OptimizerSummary> summary = Optimize(map_.graph, options);
  NoteGraphChanged(GraphChange::kReposed);
  // Optimisation cannot fail on validated data; if Ceres does, G keeps its poses and the log says so.
  if (!summary.ok()) *note += "; optimisation failed: " + summary.status().message();
}

bool Mapper::Impl::UpdateIncrementally(internal::IncrementalSolver::Start start) {
  const internal::IncrementalSummary summary = incremental_.Update(map_.graph, pending_seeds_, start);
  pending_seeds_.clear();
  if (!summary.whole_start) return false;
  // The whole component moved: the marginals factorised before no longer describe it, and the solve's own
  // last factorisation does.
  NoteGraphChanged(GraphChange::kReposed);
  return MarginalsFromTheSolve();
}

// Below this innovation (Mahalanobis², 3 dof: about 0.6 σ per degree of freedom) a direct edge is not worth a
// local re-optimisation; the periodic full optimisation (or incremental update) still takes it in.
constexpr double kLocalOptimizationMinChi2 = 1.0;

void Mapper::Impl::OptimizeAfterDirectEdge(NodeId robot, double innovation_chi2, std::string* note) {
  const bool periodic = ++direct_edges_since_full_optimization_ >= params_.full_optimization_every;
  if (UsesIncrementalBackend()) {
    // A direct edge passed the gate with a robot sure of its position: its correction is local.
    if (periodic) direct_edges_since_full_optimization_ = 0;
    if (periodic || innovation_chi2 >= kLocalOptimizationMinChi2) {
      UpdateIncrementally(internal::IncrementalSolver::Start::kLocal);
    }
    return;
  }
  if (periodic) {
    OptimizeComponentOf(robot, note);
    return;
  }
  // An edge that agrees with the estimate this well would move the window by a fraction of its noise.
  if (innovation_chi2 < kLocalOptimizationMinChi2) return;
  // Nodes are numbered in creation order, so the robot's last nodes in its component are the window.
  OptimizerOptions options = params_.optimizer;
  for (NodeId id = robot; id > robot - params_.local_window_nodes; --id) {
    if (map_.graph.HasNode(id) && map_.graph.SameComponent(id, robot)) options.variable_nodes.push_back(id);
  }
  const Result<OptimizerSummary> summary = Optimize(map_.graph, options);
  if (!summary.ok()) *note += "; optimisation failed: " + summary.status().message();
}

std::optional<Hypothesis> Mapper::Impl::TakeHypothesis(std::int64_t id) {
  const auto it =
      std::find_if(hypotheses_.begin(), hypotheses_.end(), [&](const Hypothesis& h) { return h.id == id; });
  if (it == hypotheses_.end()) return std::nullopt;
  std::optional<Hypothesis> taken(std::move(*it));
  hypotheses_.erase(it);
  return taken;
}

Hypothesis* Mapper::Impl::FindHypothesis(std::int64_t id) {
  for (Hypothesis& hypothesis : hypotheses_) {
    if (hypothesis.id == id) return &hypothesis;
  }
  return nullptr;
}

}  // namespace slamcore
