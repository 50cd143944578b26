// Merge hypotheses: conditional merge through G′ and full merge into G (paper IV-B).
#include <algorithm>

#include "mapper_impl.h"

namespace slamcore {

using internal::Hypothesis;
using internal::HypothesisObservation;

/// The rigid motion carrying the robot's component C_s into the target component's frame, from the
/// hypothesis's G ≈ robot_T_ref: target_T_robot = target_T_ref · G⁻¹, so
/// target_T_source = target_T_ref · G⁻¹ · (source_T_robot)⁻¹. The EKF motion update moves G and the
/// robot's pose in C_s together, so this only changes when G is corrected by an observation or C_s is
/// re-optimised.
SE2 Mapper::Impl::TargetFromSource(const Hypothesis& hypothesis) const {
  const SE2& target_T_ref = map_.graph.node(hypothesis.ref_node).pose;
  const SE2& source_T_robot = map_.graph.node(*current_node_).pose;
  return target_T_ref * hypothesis.state.mean.inverse() * source_T_robot.inverse();
}

void Mapper::Impl::ConditionallyAccept(std::int64_t hypothesis_id) {
  Hypothesis* hypothesis = FindHypothesis(hypothesis_id);
  if (!hypothesis) return;
  hypothesis->conditional = true;
  conditional_hypothesis_ = hypothesis_id;
  overlay_.emplace(map_.graph, *current_node_, hypothesis->ref_node);
  for (const HypothesisObservation& observation : hypothesis->observations) {
    overlay_->AddEdge(MakeObservationEdge(observation, -1));
  }
  overlay_->SetAlignment(TargetFromSource(*hypothesis));
  Log(DecisionKind::kConditionallyAccepted, hypothesis->ref_view, hypothesis,
      internal::EvidenceText(EvidenceOf(*hypothesis)));
}

void Mapper::Impl::AcceptMerge(std::int64_t hypothesis_id) {
  const std::optional<Hypothesis> taken = TakeHypothesis(hypothesis_id);
  if (!taken) return;
  const Hypothesis& accepted = *taken;
  const NodeId robot = *current_node_;
  const ComponentId source = map_.graph.ComponentOf(robot);
  const ComponentId target = map_.graph.ComponentOf(accepted.ref_node);
  // Carry C_s into C_t's frame before joining them, so the optimiser starts next to the answer (the two
  // frames are unrelated, e.g. 180° apart, which a local solver would not undo).
  const SE2 target_T_source = TargetFromSource(accepted);
  for (Node& node : map_.graph.mutable_nodes()) {
    if (map_.graph.ComponentOf(node.id) == source) node.pose = target_T_source * node.pose;
  }
  NoteGraphChanged(GraphChange::kReposed);
  if (accepted.conditional) {
    overlay_.reset();  // G now holds the edges itself
    conditional_hypothesis_ = -1;
  }
  for (const HypothesisObservation& observation : accepted.observations)
    AddObservationEdge(observation, accepted.id, /*direct=*/false);
  robot_relative_covariance_ = accepted.state.covariance;
  std::string note;
  if (params_.optimize_after_accept) OptimizeComponentOf(robot, &note);
  Log(DecisionKind::kAccepted, accepted.ref_view, &accepted,
      internal::EvidenceText(EvidenceOf(accepted)) + note);
  Log(DecisionKind::kComponentsMerged, accepted.ref_view, &accepted,
      "component of node " + std::to_string(source) + " joined component of node " + std::to_string(target));
  RejectCompetitors(accepted);  // a competing conditional merge is undone here
}

void Mapper::Impl::RefreshOverlay() {
  if (!overlay_) return;
  if (const Hypothesis* hypothesis = FindHypothesis(conditional_hypothesis_)) {
    overlay_->SetAlignment(TargetFromSource(*hypothesis));
  }
}

}  // namespace slamcore
