// Correlated wrong observations (docs/correlated-outliers.md). One pass past a look-alike — the
// bed frame from the wrong side, a second identical door — yields a run of wrong observations that agree
// with each other, so a filter that counts consistent observations (paper III-B) counts one mistake many
// times. Three mechanisms, after RRR (Latif, Cadena, Neira, "Robust loop closing over time for pose graph
// SLAM", IJRR 2013) and PCM (Mangelson et al., ICRA 2018), sized for a robot:
//
//  * Evidence by passes. Observations made in one traversal (each within pass_gap_seconds and
//    pass_gap_distance of the previous) are one piece of evidence, whatever the number of views. A pass
//    is evidence only when its first observation confirms the hypothesis: it started it, or joined it
//    through a gate that an aliasing offset would have failed (the map test's informativeness check,
//    applied to the passes themselves: after a long drive on noisy odometry the hypothesis could be
//    anywhere within metres, and an observation that joins it then agrees with anything). Such a pass
//    does not join a hypothesis that the optimised map has already refused: it starts its own. Joined, it
//    would add nothing to the evidence of a hypothesis suspected wrong but its observations to its fate:
//    one started by a wrong observation, its gate ever wider, collected every later pass there (true
//    passes of 200 observations refused with it, Intel with local wrong closures; RRR's intra-cluster
//    consistency). A hypothesis never refused still takes such a pass, as the paper's filter does (on
//    sparse views a traversal's observations are metres apart, each pass by our gaps). The observations of the
//    competitors of an accepted recovery that fit the map it made (each edge within gate_chi2 at the
//    re-optimised map) join it, so that an earlier pass of the same place kept apart is not lost when its
//    competitor wins. Direct edges that follow an accepted recovery in the same pass belong to it (they
//    were only possible because the robot believed it), so they share its fate. The pass goes on while the
//    robot keeps observing views within the pass gaps, whatever became of each observation: a wrong group
//    seen from one traversal is often split — a hypothesis accepted, observations that fail the gate of
//    the map it bent and gather in a new hypothesis, then more that pass it — and the later direct edges
//    are as much that acceptance's as the first (Intel (SE-Sync) with the wrong group first, seed 2: 30
//    wrong closures entered G as direct edges owned by nothing, every later consistent-set check held
//    them as trusted, and 276 true closures stayed refused).
//  * The joint test against the map. When a recovery hypothesis meets the counts, its state G ≈ robot_T_ref
//    is tested against the map's own prediction with the marginal covariance of the relative pose between
//    the robot and the reference node (marginal_covariance.h), scaled by the component's a-posteriori
//    variance factor once it has redundancy (declared odometry noise is often far above the noise met):
//    χ² ≤ map_gate_chi2. The test is *informative* when an aliasing offset of `aliasing_offset` metres, in
//    the direction the combined uncertainty is largest, would have failed it. Consistent and informative:
//    accepted. Consistent but uninformative: accepted after min_passes_uninformative passes, and verified.
//    Inconsistent: it waits for min_passes_against_map independent passes, which then overrule the map (a
//    robot whose wheels slipped does come back to the same place).
//  * Verification and retraction. After an acceptance that the map test did not confirm, the component is
//    optimised with the newcomer's edges and the leave-one-out test below judges the newcomer and the
//    earlier acceptances whose edges now fit worst (RRR's rule: while one fails, the one with the largest
//    normalised error goes). When that is the newcomer, G is restored exactly (poses included) and the
//    hypothesis stays open until another pass; when it is an earlier acceptance, that one is *retracted* —
//    its edges leave G, the decision log records kRetracted with the reason, and the component is
//    re-optimised. A newcomer accepted on passes against the map is never refused, only what it
//    contradicts is retracted.
//  * Contested acceptances: mapper_contest.cc.
//
// The leave-one-out test of a hypothesis W: with its stacked edge residuals r at the optimum, the joint
// covariance P of the nodes they touch and the edges' Jacobians J, d² = rᵀ (Σ_z − J P Jᵀ)⁺ r is the χ² of
// W's measurements against what every *other* edge of G predicts (the studentised residual of
// regression diagnostics; directions in which nothing else constrains W are not testable and are
// dropped). It sees what an edge's own χ² hides: a flexible map bends to fit every edge, moving the
// conflict into the odometry between them. W fails when d² exceeds the χ² quantile at
// retraction_confidence for the kept degrees of freedom.
//
// Costs: per map test, the joint marginal of the nodes the edges added since the last factorisation touch
// (path walks in its factor) and a dense solve over them (marginal_covariance.h:
// RelativeCovarianceWithEdgesSince), or, past max_marginal_update_nodes of them or after edges were removed
// or G re-posed, a new factorisation of the component's information matrix; per verification a copy of G,
// one factorisation and 3 solves per node of the judged hypotheses (at most max_judged_per_check of them,
// each judged by at most max_edges_judged of its edges, evenly spaced), plus one optimisation per retraction
// (at most max_retractions_per_check).
// Open hypotheses are capped at max_open_hypotheses.
#include <algorithm>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include <boost/math/distributions/chi_squared.hpp>

#include "mapper_impl.h"
#include "slamcore/optimizer.h"

namespace slamcore {

using internal::Hypothesis;
using internal::HypothesisObservation;
using internal::PoseGaussian;

double Mapper::Impl::DeclaredNoiseScale() const {
  const ConsistencyParams& consistency = params_.consistency;
  if (!consistency.enabled || !map_test_.marginals ||
      map_test_.variance_factor.redundancy < consistency.min_redundancy_for_scaling) {
    return 1.0;
  }
  return std::clamp(map_test_.variance_factor.factor, consistency.min_variance_factor, 1.0);
}

std::optional<PoseGaussian> Mapper::Impl::MapPrediction(NodeId node) {
  const NodeId robot = *current_node_;
  if (!map_.graph.SameComponent(node, robot)) return std::nullopt;
  const SE2 robot_T_node = map_.graph.node(robot).pose.inverse() * map_.graph.node(node).pose;
  if (map_test_.marginals && map_test_.marginals_revision != map_test_.map_revision &&
      map_test_.marginals_structure_revision == map_test_.structure_revision) {
    // Edges were only added since the factorisation: they update its marginals (a small dense solve)
    // until they touch more nodes than that is worth.
    if (const std::optional<Matrix3> covariance = internal::RelativeCovarianceWithEdgesSince(
            map_.graph, *map_test_.marginals, robot, node,
            static_cast<std::size_t>(params_.consistency.max_marginal_update_nodes))) {
      map_test_.variance_factor = internal::ComponentVarianceFactor(map_.graph, robot);
      return PoseGaussian{robot_T_node, DeclaredNoiseScale() * *covariance};
    }
  }
  if (!map_test_.marginals || map_test_.marginals_revision != map_test_.map_revision ||
      !map_test_.marginals->Contains(node)) {
    RefactorizeMarginals();
    if (!map_test_.marginals) return std::nullopt;
  }
  // robot_T_node = robot_T_newest · newest_T_node: the chain since the factorisation, then the map.
  PoseGaussian newest_T_node = map_test_.marginals->Relative(map_test_.marginals->newest_node(), node);
  // The map's covariance as the noise met so far says, never above what was declared.
  newest_T_node.covariance *= DeclaredNoiseScale();
  const Matrix3 covariance = internal::Compose(map_test_.robot_T_factorized, newest_T_node).covariance;
  return PoseGaussian{robot_T_node, covariance};
}

std::optional<PoseGaussian> Mapper::Impl::MapPredictionBound(NodeId node) const {
  const NodeId robot = *current_node_;
  if (!map_test_.marginals || map_test_.marginals_revision == map_test_.map_revision ||
      map_test_.marginals_indirect_revision != map_test_.indirect_revision ||
      !map_test_.marginals->Contains(node) || !map_.graph.SameComponent(node, robot)) {
    return std::nullopt;
  }
  // Direct edges only added information: the covariance of the marginals before them is no smaller
  // (at the linearisation point then; direct edges move the map little). The variance factor is taken at
  // its largest, 1, since the new edges change it.
  const Matrix3 covariance =
      internal::Compose(map_test_.robot_T_factorized,
                        map_test_.marginals->Relative(map_test_.marginals->newest_node(), node))
          .covariance;
  return PoseGaussian{map_.graph.node(robot).pose.inverse() * map_.graph.node(node).pose, covariance};
}

void Mapper::Impl::RefactorizeMarginals() {
  SetMarginals(internal::MarginalCovariances::Factorize(map_.graph, *current_node_));
}

void Mapper::Impl::SetMarginals(std::optional<internal::MarginalCovariances> marginals) {
  map_test_.marginals = std::move(marginals);
  map_test_.marginals_revision = map_test_.map_revision;
  map_test_.marginals_indirect_revision = map_test_.indirect_revision;
  map_test_.marginals_structure_revision = map_test_.structure_revision;
  if (map_test_.marginals) map_test_.variance_factor = map_test_.marginals->variance_factor();
  map_test_.robot_T_factorized = PoseGaussian{SE2::Identity(), Matrix3::Zero()};
}

bool Mapper::Impl::MarginalsFromTheSolve() {
  std::optional<internal::ComponentFactorisation> factorisation = incremental_.TakeComponentFactorisation();
  if (!factorisation) return false;
  std::optional<internal::MarginalCovariances> marginals =
      internal::MarginalCovariances::FromSolve(map_.graph, *current_node_, std::move(*factorisation));
  if (!marginals) return false;
  SetMarginals(std::move(marginals));
  return true;
}

Mapper::Impl::RecoveryVerdict Mapper::Impl::JudgeRecovery(const Hypothesis& hypothesis, std::string* why,
                                                          Vector3* from_the_map) {
  const ConsistencyParams& consistency = params_.consistency;
  if (!consistency.enabled) return RecoveryVerdict::kAccept;
  const int passes =
      internal::CountPasses(hypothesis, consistency.pass_gap_seconds, consistency.pass_gap_distance);
  std::ostringstream text;
  text.precision(3);
  // A hypothesis inconsistent with a covariance no smaller than the map's is inconsistent with the map's
  // (d² only grows as the covariance shrinks): no refactorisation. The margin covers the linearisation
  // point, which the direct edges since have moved a little.
  constexpr double kBoundMargin = 2.0;
  if (const std::optional<PoseGaussian> bound = MapPredictionBound(hypothesis.ref_node)) {
    const internal::Innovation against_bound = internal::ComputeInnovation(*bound, hypothesis.state);
    const double lower_d2 = against_bound.mahalanobis2;
    if (from_the_map) *from_the_map = against_bound.log;
    if (lower_d2 > kBoundMargin * consistency.map_gate_chi2) {
      text << "map test d²≥" << lower_d2 << " (inconsistent), " << passes << " of "
           << consistency.min_passes_against_map << " passes";
      *why = text.str();
      if (passes < consistency.min_passes_against_map || passes <= hypothesis.refused_at_passes) {
        return RecoveryVerdict::kWaitAgainstMap;
      }
      return RecoveryVerdict::kAcceptOverMap;
    }
  }
  const std::optional<PoseGaussian> prediction = MapPrediction(hypothesis.ref_node);
  if (!prediction) {
    text << "no map test, " << passes << " of " << consistency.min_passes_uninformative << " passes";
    *why = text.str();
    return passes >= consistency.min_passes_uninformative && passes > hypothesis.refused_at_passes
               ? RecoveryVerdict::kAcceptAndVerify
               : RecoveryVerdict::kWait;
  }
  const internal::Innovation innovation = internal::ComputeInnovation(*prediction, hypothesis.state);
  if (from_the_map) *from_the_map = innovation.log;
  const double largest_variance = internal::LargestPositionVariance(innovation.covariance);
  const bool consistent = innovation.mahalanobis2 <= consistency.map_gate_chi2;
  const bool informative = AliasingOffsetWouldFail(largest_variance, consistency.map_gate_chi2);
  const int needed = consistent ? (informative ? 1 : consistency.min_passes_uninformative)
                                : consistency.min_passes_against_map;
  text << "map test d²=" << innovation.mahalanobis2 << " (σ " << std::sqrt(largest_variance) << " m, "
       << (consistent ? "consistent" : "inconsistent") << ", "
       << (informative ? "informative" : "uninformative") << "), " << passes << " of " << needed << " passes";
  *why = text.str();
  // A hypothesis the optimised map refused waits for a new pass before it is tried again.
  if (passes < needed || passes <= hypothesis.refused_at_passes)
    return consistent ? RecoveryVerdict::kWait : RecoveryVerdict::kWaitAgainstMap;
  if (!consistent) return RecoveryVerdict::kAcceptOverMap;
  return informative ? RecoveryVerdict::kAccept : RecoveryVerdict::kAcceptAndVerify;
}

bool Mapper::Impl::AliasingOffsetWouldFail(double largest_variance, double gate_chi2) const {
  const double offset = params_.consistency.aliasing_offset;
  return offset * offset / largest_variance > gate_chi2;
}

bool Mapper::Impl::IsRetractableEdge(const Edge& edge, std::int64_t hypothesis_id) const {
  return edge.kind == EdgeKind::kObservation && edge.hypothesis == hypothesis_id &&
         edge.from >= first_run_node_;
}

std::optional<double> Mapper::Impl::LeaveOneOutRatio(std::int64_t hypothesis_id) const {
  std::vector<const Edge*> all_edges;
  for (const Edge& edge : map_.graph.edges()) {
    if (IsRetractableEdge(edge, hypothesis_id)) all_edges.push_back(&edge);
  }
  if (all_edges.empty() || !map_test_.marginals) return std::nullopt;
  // A long hypothesis is judged by evenly spaced edges.
  const std::vector<const Edge*> edges =
      internal::EvenlySpaced(all_edges, static_cast<std::size_t>(params_.consistency.max_edges_judged));
  const std::optional<internal::EdgeSetChi2> test =
      internal::LeaveOneOutChi2(map_.graph, *map_test_.marginals, edges);
  if (!test) return std::nullopt;
  if (test->dof == 0) return 0.0;
  const boost::math::chi_squared_distribution<double> distribution(test->dof);
  return test->chi2 / boost::math::quantile(distribution, params_.consistency.retraction_confidence);
}

std::vector<Edge> Mapper::Impl::RemoveHypothesisEdges(std::int64_t hypothesis_id) {
  std::vector<Edge> removed;
  map_.graph.RemoveEdgesIf([&](const Edge& edge) {
    if (!IsRetractableEdge(edge, hypothesis_id)) return false;
    removed.push_back(edge);
    return true;
  });
  std::erase_if(accepted_, [&](const AcceptedObservation& edge) {
    return edge.hypothesis == hypothesis_id && edge.robot_node >= first_run_node_;
  });
  NoteGraphChanged(GraphChange::kEdgesRemoved);
  if (anchor_ && anchor_->hypothesis == hypothesis_id) anchor_.reset();
  return removed;
}

void Mapper::Impl::OptimizeAndFactorize() {
  OptimizerOptions options = params_.optimizer;
  options.component = *current_node_;
  (void)Optimize(map_.graph, options);  // cannot fail on validated data; the test reads whatever G holds
  RefactorizeMarginals();
}

bool Mapper::Impl::VerifyAcceptance(std::int64_t hypothesis_id, bool may_refuse, bool marginals_current,
                                    std::string* note) {
  // RRR's rule at the optimum that took the newcomer in: while the newcomer or one of the accepted
  // hypotheses that fit worst fails the leave-one-out test, the one with the largest ratio goes — the
  // newcomer (refused; the caller restores G) or an earlier acceptance (retracted).
  if (!marginals_current) RefactorizeMarginals();
  std::vector<std::pair<std::int64_t, double>> retracted;
  std::vector<KeptRefused> retracted_edges;
  bool refused = false;
  for (int round = 0; round <= params_.consistency.max_retractions_per_check; ++round) {
    std::int64_t worst = -1;
    double worst_ratio = 1.0;
    std::vector<std::int64_t> judged = WorstFittingAccepted(params_.consistency.max_judged_per_check);
    if (may_refuse) judged.push_back(hypothesis_id);
    for (const std::int64_t id : judged) {
      const std::optional<double> ratio = LeaveOneOutRatio(id);
      if (ratio && *ratio > worst_ratio) worst = id, worst_ratio = *ratio;
    }
    if (worst < 0) break;
    if (worst == hypothesis_id || round == params_.consistency.max_retractions_per_check) {
      std::ostringstream text;
      text.precision(3);
      text << "; after optimisation " << (worst == hypothesis_id ? "its" : "the map's")
           << " edges' leave-one-out χ² is " << worst_ratio << "× the "
           << 100 * params_.consistency.retraction_confidence << " % quantile";
      *note += text.str();
      refused = true;
      break;
    }
    retracted_edges.push_back({.hypothesis = worst, .edges = RemoveHypothesisEdges(worst)});
    std::erase(retractable_, worst);
    retracted.emplace_back(worst, worst_ratio);
    OptimizeAndFactorize();
  }
  if (refused)
    return false;  // the retractions go with the restored G: they were judged beside a newcomer that lost
  LogRetractions(retracted, hypothesis_id);
  // Judged beside one newcomer: the consistent-set check may bring them back when the newcomer is itself
  // retracted later, as it does with the ones it retracts.
  for (KeptRefused& kept : retracted_edges) KeepForTheCheck(std::move(kept));
  if (!retracted.empty())
    *note += "; retracted " + std::to_string(retracted.size()) + " earlier acceptance(s)";
  return true;
}

std::vector<std::int64_t> Mapper::Impl::WorstFittingAccepted(int count) const {
  std::unordered_map<std::int64_t, std::pair<double, int>> fit;  // hypothesis → (Σ χ², edges)
  const std::unordered_set<std::int64_t> retractable(retractable_.begin(), retractable_.end());
  for (const Edge& edge : map_.graph.edges()) {
    if (!edge.hypothesis || !retractable.contains(*edge.hypothesis) ||
        !IsRetractableEdge(edge, *edge.hypothesis)) {
      continue;
    }
    auto& [sum, edges] = fit[*edge.hypothesis];
    sum += EdgeChi2(map_.graph, edge);
    ++edges;
  }
  std::vector<std::pair<double, std::int64_t>> by_fit;
  for (const auto& [id, sum_edges] : fit) by_fit.emplace_back(sum_edges.first / sum_edges.second, id);
  std::sort(by_fit.rbegin(), by_fit.rend());
  std::vector<std::int64_t> worst;
  for (std::size_t k = 0; k < by_fit.size() && worst.size() < static_cast<std::size_t>(count); ++k) {
    worst.push_back(by_fit[k].second);
  }
  return worst;
}

void Mapper::Impl::LogRetractions(const std::vector<std::pair<std::int64_t, double>>& retracted,
                                  std::int64_t challenger) {
  for (const auto& [id, ratio] : retracted) {
    std::ostringstream reason;
    reason.precision(3);
    reason << "contradicted by hypothesis " << challenger << ": leave-one-out χ² " << ratio << "× its "
           << 100 * params_.consistency.retraction_confidence
           << " % quantile; edges removed and the map re-optimised";
    Log(DecisionKind::kRetracted, -1, id, HypothesisKind::kRecovery, reason.str());
  }
}

void Mapper::Impl::ContinueAnchorPass(double time) {
  if (!anchor_) return;
  const ConsistencyParams& consistency = params_.consistency;
  if (internal::BeyondPassGap({.time = anchor_->time, .odometer = anchor_->odometer},
                              {.time = time, .odometer = odometer_}, consistency.pass_gap_seconds,
                              consistency.pass_gap_distance)) {
    anchor_.reset();
    return;
  }
  anchor_->time = time;
  anchor_->odometer = odometer_;
}

std::optional<std::int64_t> Mapper::Impl::AnchorForDirectEdge() {
  if (!anchor_) return std::nullopt;
  if (anchor_->continuation_edges >= params_.consistency.max_continuation_edges) {
    anchor_.reset();
    return std::nullopt;
  }
  ++anchor_->continuation_edges;
  return anchor_->hypothesis;
}

void Mapper::Impl::EnforceOpenHypothesisCap() {
  const auto cap = static_cast<std::size_t>(params_.consistency.max_open_hypotheses);
  while (hypotheses_.size() > cap) {
    const auto stalest =
        std::min_element(hypotheses_.begin(), hypotheses_.end(),
                         [](const Hypothesis& a, const Hypothesis& b) { return a.last_time < b.last_time; });
    DropHypothesis(stalest->id, DecisionKind::kExpired,
                   "more than " + std::to_string(cap) + " open hypotheses: the stalest goes first");
  }
}

}  // namespace slamcore
