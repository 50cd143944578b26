// Contested acceptances (after PCM's pairwise consistency — Mangelson, Dominic, Eustice, Vasudevan,
// "Pairwise Consistent Measurement Set Maximization for Robust Multi-robot Map Merging", ICRA 2018 — used as a
// vote of later passes; the rest of the consistency checks: mapper_consistency.cc).
//
// A recovery accepted on a test that could not tell (the robot lost, σ of tens to hundreds of metres: the
// paper's counts at one pass) places the robot, and the map it bends then fails every later true pass. Each
// is one pass of the min_passes_against_map needed to overrule the map, a hypothesis of its own at its own
// place, and they expire one by one (ais2klinik, a real robot's graph none of these rules were chosen on:
// the last 265 true closures of a run refused so). So the last such acceptance is *contested*:
//  * a later hypothesis that meets the counts but waits against the map is a contradiction of it, kept
//    with its state carried by the odometry like an open hypothesis's;
//  * contradictions agree when one, expressed in the other's reference frame, passes the joint test
//    (map_gate_chi2), and that test tells the two explanations apart: the contested map's own prediction
//    would have failed it (two look-alikes whose references lie kilometres apart in a map unsure of itself
//    agree with anything);
//  * its support is its passes and each later pass that agreed with the map it placed (a direct edge, an
//    acceptance the test confirmed); acceptances made in its own pass ride on it and share its fate;
//  * one hypothesis's own passes against the map are the over-map rule's (min_passes_against_map): the
//    contest counts only when contradictions of more than one hypothesis agree (on a generated city, two
//    traversals of one true pass against a true acceptance the map had placed a little off);
//  * when the agreeing passes outnumber its support, the component is first optimised with it (a test
//    against a G that lags what was accepted can fail a true pass the optimum takes: a generated city
//    without wrong closures), and if the newest contradiction still waits against the map, the acceptance
//    is retracted on trial: its edges leave G, the robot's nodes since the last one a closure holds are put
//    where their odometry says (after hundreds of metres lost the bend is more than the optimiser's few
//    iterations undo, and every later true pass would be refused at a non-optimum), the robot gets back the
//    uncertainty the acceptance took, and the component is optimised. The retraction stands when the
//    newest contradiction then passes the map test and is accepted in its place, verification included
//    (a refusal judged beside the contested acceptance is lifted first); when accepted on a test that could
//    not tell it is contested in turn, with the agreeing passes as its support. Otherwise G and the map
//    tests' marginals are put back as they were (factorised at another time, they decide later tests
//    otherwise) and that contradiction is not counted again.
//
// Cost: per contradiction, its state carried by each odometry step and one joint test per other one kept (at
// most max_open_hypotheses); per trial (at most max_contest_trials per acceptance) a copy of G, two
// optimisations of the component and their factorisations.
#include <algorithm>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "mapper_impl.h"

namespace slamcore {

using internal::Hypothesis;
using internal::PoseGaussian;

void Mapper::Impl::NoteAcceptance(const Hypothesis& accepted, RecoveryVerdict verdict,
                                  std::optional<std::int64_t> anchored_to, const Matrix3& covariance_before) {
  const ConsistencyParams& consistency = params_.consistency;
  if (!consistency.enabled || consistency.max_contest_trials == 0) return;
  const int passes =
      internal::CountPasses(accepted, consistency.pass_gap_seconds, consistency.pass_gap_distance);
  const internal::TraversalPoint now{.time = time_, .odometer = odometer_};
  if (contested_ && anchored_to && std::ranges::count(contested_->hypotheses, *anchored_to) > 0) {
    // Accepted in the contested one's pass, against the map it placed: it stands or falls with it.
    contested_->hypotheses.push_back(accepted.id);
    contested_->last_support = now;
    return;
  }
  if (verdict == RecoveryVerdict::kAcceptAndVerify) {
    contested_ = Contested{.hypotheses = {accepted.id},
                           .support = std::max(1, passes),
                           .last_support = now,
                           .accepted_time = time_,
                           .robot_node = *current_node_,
                           .covariance_before = covariance_before,
                           .contradictions = {},
                           .unexplained = {},
                           .trials = 0};
    return;
  }
  if (contested_ && internal::BeyondPassGap(contested_->last_support, now, consistency.pass_gap_seconds,
                                            consistency.pass_gap_distance)) {
    contested_->support += std::max(1, passes);  // tested against the map it placed, and consistent
  }
  if (contested_) contested_->last_support = now;
}

void Mapper::Impl::NoteDirectEdge(std::optional<std::int64_t> owner) {
  if (!contested_) return;
  const internal::TraversalPoint now{.time = time_, .odometer = odometer_};
  const bool riding = owner && std::ranges::count(contested_->hypotheses, *owner) > 0;
  if (!riding && internal::BeyondPassGap(contested_->last_support, now, params_.consistency.pass_gap_seconds,
                                         params_.consistency.pass_gap_distance)) {
    ++contested_->support;  // a later pass that observed the map where it placed the robot
  }
  contested_->last_support = now;
}

void Mapper::Impl::ContestAcceptance(std::int64_t hypothesis_id, const Vector3& from_the_map) {
  const ConsistencyParams& consistency = params_.consistency;
  if (!contested_) return;
  Contested& contested = *contested_;
  // Retracted or taken back since by the other checks: nothing left to contest.
  std::erase_if(contested.hypotheses,
                [&](std::int64_t id) { return std::ranges::count(retractable_, id) == 0; });
  if (contested.hypotheses.empty()) {
    contested_.reset();
    return;
  }
  Hypothesis* challenger = FindHypothesis(hypothesis_id);
  if (!challenger || challenger->observations.front().time < contested.accepted_time ||
      std::ranges::count(contested.unexplained, hypothesis_id) > 0) {
    return;
  }
  const int passes = std::max(
      1, internal::CountPasses(*challenger, consistency.pass_gap_seconds, consistency.pass_gap_distance));
  auto entry = std::ranges::find(contested.contradictions, hypothesis_id, &Contradiction::hypothesis);
  if (entry == contested.contradictions.end()) {
    if (contested.contradictions.size() >= static_cast<std::size_t>(consistency.max_open_hypotheses))
      contested.contradictions.erase(contested.contradictions.begin());
    contested.contradictions.push_back({.hypothesis = hypothesis_id});
    entry = std::prev(contested.contradictions.end());
  }
  *entry = {.hypothesis = hypothesis_id,
            .ref_node = challenger->ref_node,
            .state = challenger->state,
            .passes = passes};
  // The contradictions that agree with this one count with it: each, expressed in this one's reference frame,
  // passes the joint test (PCM's pairwise consistency) — and that test tells this one's explanation from the
  // contested map's: the map's prediction would have failed it. Two look-alikes far apart in a map unsure
  // of itself agree with anything (kilometres of map between their references: radians of heading).
  std::vector<std::pair<const Contradiction*, Matrix3>> agreeing;  // with the agreement's covariance
  for (const Contradiction& contradiction : contested.contradictions) {
    if (contradiction.hypothesis == hypothesis_id ||
        !map_.graph.SameComponent(contradiction.ref_node, challenger->ref_node)) {
      continue;
    }
    const PoseGaussian in_ref =
        ExpressInRefFrame(contradiction.state, contradiction.ref_node, challenger->ref_node);
    const internal::Innovation agreement = internal::ComputeInnovation(challenger->state, in_ref);
    if (agreement.mahalanobis2 <= consistency.map_gate_chi2)
      agreeing.emplace_back(&contradiction, agreement.covariance);
  }
  const auto passes_against = [&] {
    int against = entry->passes;
    for (const auto& [contradiction, covariance] : agreeing) against += contradiction->passes;
    return against;
  };
  // One hypothesis's own passes against the map are the over-map rule's (min_passes_against_map): the contest
  // needs contradictions from other places too (a generated city without wrong closures: one true pass of
  // two traversals against a true acceptance the map had placed a little off, and both were true).
  if (agreeing.empty() || passes_against() <= contested.support ||
      contested.trials >= consistency.max_contest_trials) {
    return;
  }
  std::erase_if(agreeing, [&](const auto& contradiction_covariance) {
    const Matrix3& covariance = contradiction_covariance.second;
    return from_the_map.dot(covariance.inverse() * from_the_map) <= consistency.map_gate_chi2;
  });
  const int against = passes_against();
  if (agreeing.empty() || against <= contested.support) return;
  ++contested.trials;
  // A contest that retracts nothing leaves the Mapper as it found it: G, and the marginals the map tests use
  // (factorised at another time, they decide later tests otherwise: failed trials on the generated
  // city10000 cost 5 points of recall when only G was restored).
  RestorePoint saved = SaveRestorePoint();
  MarginalState saved_marginals = TakeMarginalState();
  const auto restore = [&] {
    Restore(std::move(saved));
    PutBackMarginalState(std::move(saved_marginals));
  };
  // First at the optimum with it: G may lag behind what was accepted last (a check's solution, deferred
  // direct edges), and a contradiction that the optimum resolves contests nothing (a generated city without
  // wrong closures: a true pass 166 in d² off a map the check had just re-posed, 3.45 after the solve).
  std::string support;
  OptimizeAndFactorize();
  RecoveryVerdict verdict = JudgeRecovery(*challenger, &support);
  if (verdict != RecoveryVerdict::kWaitAgainstMap) {
    if (verdict == RecoveryVerdict::kWait) {
      restore();
    } else {
      AcceptRecovery(hypothesis_id, support, verdict);
    }
    return;
  }
  // The trial: without the contested acceptance (and what rode on it), does the challenger fit the map?
  std::vector<KeptRefused> removed;
  for (const std::int64_t id : contested.hypotheses) {
    removed.push_back({.hypothesis = id, .edges = RemoveHypothesisEdges(id)});
    std::erase(retractable_, id);
  }
  // Nothing but the odometry holds the robot's nodes since the last one a closure holds: they start where
  // the odometry puts them, not where the acceptance bent them (after hundreds of metres lost, a bend that
  // the optimiser's few iterations do not undo, and every later true pass is refused at a non-optimum).
  NodeId last_held = first_run_node_;
  for (const Edge& edge : map_.graph.edges()) {
    if (edge.kind != EdgeKind::kMotion) last_held = std::max({last_held, edge.from, edge.to});
  }
  DeadReckonSince(last_held);
  // The robot is again as unsure as it was before the acceptance, carried to where it is now.
  const SE2 robot_T_accepted_at =
      map_.graph.node(*current_node_).pose.inverse() * map_.graph.node(contested.robot_node).pose;
  robot_relative_covariance_ += internal::Compose({robot_T_accepted_at, Matrix3::Zero()},
                                                  {SE2::Identity(), contested.covariance_before})
                                    .covariance;
  // A verification that refused it beside the contested acceptance judged it against the map this trial
  // changes: it is judged afresh, not kept waiting for another pass.
  const int refused_at_passes = std::exchange(challenger->refused_at_passes, 0);
  OptimizeAndFactorize();
  verdict = JudgeRecovery(*challenger, &support);
  // The retraction stands only with the challenger accepted in its place: a map test passed at the σ of
  // hundreds of metres the retraction gives back tells nothing, and a retraction whose challenger the
  // verification then refused left the robot lost, to take the next wrong group (ais2klinik, first 100 %,
  // seed 3: σ 841 m, then a wrong group at σ 793 m and a dozen more after it).
  const auto unexplained = [&] {
    contested_->unexplained.push_back(hypothesis_id);
    std::erase_if(contested_->contradictions,
                  [&](const Contradiction& c) { return c.hypothesis == hypothesis_id; });
  };
  if (verdict == RecoveryVerdict::kWaitAgainstMap || verdict == RecoveryVerdict::kWait) {
    restore();
    challenger->refused_at_passes = refused_at_passes;
    unexplained();
    return;
  }
  const int support_before = contested.support;
  const std::vector<std::int64_t> retracted = contested.hypotheses;
  std::vector<std::int64_t> agreeing_hypotheses;
  for (const auto& [contradiction, covariance] : agreeing)
    agreeing_hypotheses.push_back(contradiction->hypothesis);
  const std::string last_wait = challenger->last_wait;
  Contested before_trial = std::move(contested);
  contested_.reset();
  const std::size_t decided_before = decisions_.size();
  if (!AcceptRecovery(hypothesis_id, support, verdict)) {
    restore();  // the refusal AcceptRecovery logged and recorded stays: it was judged on trial
    contested_ = std::move(before_trial);
    unexplained();
    return;
  }
  std::ostringstream reason;
  reason << "contested: " << against << " later passes (hypotheses";
  for (const std::int64_t id : agreeing_hypotheses) reason << ' ' << id;
  reason << ' ' << hypothesis_id;
  reason << ") that agree with each other contradict it, against its " << support_before
         << "; with it hypothesis " << hypothesis_id << " waited on " << last_wait
         << ", without it it fits the map (" << support
         << ") and was accepted; it was accepted on a map test that could not tell; edges removed and the "
            "map re-optimised";
  // Logged before the challenger's acceptance, which it made possible.
  const std::size_t decided = decisions_.size();
  for (const std::int64_t id : retracted)
    Log(DecisionKind::kRetracted, -1, id, HypothesisKind::kRecovery, reason.str());
  std::rotate(decisions_.begin() + static_cast<std::ptrdiff_t>(decided_before),
              decisions_.begin() + static_cast<std::ptrdiff_t>(decided), decisions_.end());
  for (KeptRefused& kept : removed) KeepForTheCheck(std::move(kept));
  // Accepted on a test that could not tell, it is contested in turn, with the agreeing passes as its support.
  if (contested_ && contested_->hypotheses.front() == hypothesis_id) contested_->support = against;
}

void Mapper::Impl::DeadReckonSince(NodeId first) {
  std::unordered_map<NodeId, const Edge*> motion_from;
  for (const Edge& edge : map_.graph.edges()) {
    if (edge.kind == EdgeKind::kMotion && edge.from >= first && edge.to == edge.from + 1)
      motion_from.emplace(edge.from, &edge);
  }
  for (NodeId node = first; node < *current_node_; ++node) {
    const auto it = motion_from.find(node);
    if (it == motion_from.end()) return;  // a new component starts: nothing to chain
    map_.graph.mutable_node(node + 1).pose = map_.graph.node(node).pose * it->second->measurement;
  }
  NoteGraphChanged(GraphChange::kReposed);
}

}  // namespace slamcore
