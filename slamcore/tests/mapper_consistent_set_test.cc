// The consistent-set check (mapper_consistent_set.cc): the GNC-TLS weight rule with numbers worked by hand,
// and a wrong pass that one pass of the truth could not overrule online, corrected when the run ends.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "graduated_non_convexity.h"
#include "mapper_test_util.h"
#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/loop_closure_outliers.h"
#include "slamcore/manhattan_world.h"
#include "slamcore/optimizer.h"
#include "test_data.h"
#include "test_matchers.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

using testing::EdgeSet;
using ::testing::HasSubstr;
using testing::IsNearlyPose;
using testing::MakeMapper;
using testing::SimulatedRobot;

TEST(TruncatedLeastSquaresWeightTest, InsideOutsideAndTheBlendBetweenAtMuOne) {
  // μ = 1: weight 1 up to s = 1/2, 0 from s = 2, and √(2/s) − 1 between.
  EXPECT_EQ(internal::TruncatedLeastSquaresWeight(0.5, 1.0), 1.0);
  EXPECT_EQ(internal::TruncatedLeastSquaresWeight(2.0, 1.0), 0.0);
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(1.0, 1.0), std::sqrt(2.0) - 1.0, 1e-12);
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(1.5, 1.0), std::sqrt(2.0 / 1.5) - 1.0, 1e-12);
  // The blend is continuous at both ends: √(μ(μ+1)/s) − μ is 1 at s = μ/(μ+1) and 0 at s = (μ+1)/μ.
  for (const double mu : {0.01, 0.3, 4.0}) {
    EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(mu / (mu + 1.0) * (1 + 1e-12), mu), 1.0, 1e-6);
    EXPECT_NEAR(internal::TruncatedLeastSquaresWeight((mu + 1.0) / mu * (1 - 1e-12), mu), 0.0, 1e-6);
  }
}

TEST(TruncatedLeastSquaresWeightTest, TheFirstRoundKeepsEveryMeasurement) {
  // μ₀ = 1/(2·s_max − 1): s_max = 10 gives μ₀ = 1/19, and (μ₀+1)/μ₀ = 20 > 10, so no weight is 0 yet.
  const double mu = internal::InitialControlParameter(10.0);
  EXPECT_NEAR(mu, 1.0 / 19.0, 1e-15);
  EXPECT_GT(internal::TruncatedLeastSquaresWeight(10.0, mu), 0.0);
  // √((1/19)(20/19)/10) − 1/19 = √20/(19·√10) − 1/19 = (√2 − 1)/19.
  EXPECT_NEAR(internal::TruncatedLeastSquaresWeight(10.0, mu), (std::sqrt(2.0) - 1.0) / 19.0, 1e-12);
}

// The corridor of mapper_test_util.h with one pass of the truth after the wrong pass: a single pass cannot
// overrule the map online (three are needed), so it waits and is refused at the end. Only the two judged
// together show which fits the odometry: the truth.
void CorridorWithOnePassOfTruth(Mapper& mapper, bool with_wrong_pass) {
  testing::CorridorOutAndBack(mapper, with_wrong_pass, 1);
}

MapperParams CorridorParams(bool consistent_set_check) {
  MapperParams params = testing::CorridorParams();
  params.consistency.consistent_set_check = consistent_set_check;
  return params;
}

TEST(ConsistentSetCheckTest, WithoutItOnePassOfTruthCannotOverruleAnAcceptedWrongPass) {
  auto mapper = MakeMapper(CorridorParams(false));
  CorridorWithOnePassOfTruth(*mapper, true);
  (void)mapper->Finish();
  EXPECT_EQ(mapper->Statistics().recovery_accepted, 1);
  EXPECT_EQ(mapper->Statistics().recovery_retracted, 0);
}

TEST(ConsistentSetCheckTest, AtTheEndOfTheRunTheTruthIsAcceptedAndTheWrongPassRetracted) {
  auto with_wrong = MakeMapper(CorridorParams(true));
  CorridorWithOnePassOfTruth(*with_wrong, true);
  const PoseGraph corrected = with_wrong->Finish().graph;
  auto without = MakeMapper(CorridorParams(true));
  CorridorWithOnePassOfTruth(*without, false);
  const PoseGraph clean = without->Finish().graph;

  const MapperStatistics statistics = with_wrong->Statistics();
  EXPECT_EQ(statistics.recovery_accepted, 2);  // the wrong pass online, the truth by the check
  // At the end the status quo (the wrong pass in, the truth out) did not hold: that check ran in full.
  const ConsistentSetChecks checks = with_wrong->consistent_set_checks();
  EXPECT_LT(checks.settled_by_status_quo, checks.judged);
  EXPECT_EQ(statistics.recovery_retracted, 1);
  const Decision* retracted = testing::LastDecision(*with_wrong, DecisionKind::kRetracted);
  ASSERT_NE(retracted, nullptr);
  EXPECT_THAT(retracted->reason, HasSubstr("consistent-set check (the run ended"));
  const Decision* accepted = testing::LastDecision(*with_wrong, DecisionKind::kAccepted);
  ASSERT_NE(accepted, nullptr);
  EXPECT_NE(accepted->hypothesis, retracted->hypothesis);
  EXPECT_THAT(accepted->reason, HasSubstr("largest consistent set"));
  for (const AcceptedObservation& edge : with_wrong->accepted_observations()) {
    EXPECT_NE(edge.hypothesis, retracted->hypothesis);
  }

  // G equals the G of a run that never saw the wrong pass: the same edges, the same optimised poses.
  EXPECT_EQ(EdgeSet(corrected), EdgeSet(clean));
  PoseGraph corrected_optimized = corrected, clean_optimized = clean;
  ASSERT_THAT(Optimize(corrected_optimized), IsOk());
  ASSERT_THAT(Optimize(clean_optimized), IsOk());
  for (const Node& node : clean_optimized.nodes()) {
    EXPECT_THAT(corrected_optimized.node(node.id).pose, IsNearlyPose(node.pose, 1e-6)) << "node " << node.id;
  }
  EXPECT_NEAR(corrected_optimized.node(corrected_optimized.num_nodes() - 1).pose.x(), 2.0, 0.05);
}

// A generated city (Olson's Manhattan construction, mapped in one run) has long loops whose drift is real
// and within the declared noise, and no wrong closure at all: every retraction there is a true closure lost.
// Judged with the odometry as stiff as the median edge χ² says (about a fifth of the noise the map meets),
// the check retracted 23 of its true hypotheses and kept 789 of the 1000 closures; confirmed at the noise the
// inliers meet, none is retracted.
TEST(ConsistentSetCheckTest, OnAGeneratedCityWithoutWrongClosuresNoTrueHypothesisIsRetracted) {
  const Result<ManhattanWorld> world = GenerateManhattanWorld({.poses = 2000, .seed = 2});
  ASSERT_THAT(world, IsOk());
  const Result<ReplayResult> replay = ReplayPoseGraph(world->graph, MapperParams{});
  ASSERT_THAT(replay, IsOk());
  EXPECT_EQ(replay->statistics.recovery_retracted, 0);
  const std::size_t closures = replay->accepted.size() + replay->rejected.size();
  ASSERT_EQ(closures, 1000u);
  EXPECT_GE(replay->accepted.size(), 880u);
}

// Observations (robot node, view) that a replay's decisions show joining or starting `hypothesis`.
std::set<VertexPair> ObservationsOf(const ReplayResult& replay, std::int64_t hypothesis) {
  std::set<VertexPair> observed;
  for (const Decision& d : replay.decisions) {
    // Updates that are not joins (a refusal, an adoption) name the hypothesis's first view instead.
    const bool observation =
        d.kind == DecisionKind::kHypothesisCreated ||
        (d.kind == DecisionKind::kHypothesisUpdated && d.reason.find("joined with") != std::string::npos);
    if (d.hypothesis == hypothesis && observation) {
      observed.emplace(std::min(d.node, d.view), std::max(d.node, d.view));
    }
  }
  return observed;
}

std::set<VertexPair> AcceptedPairs(const ReplayResult& replay) {
  std::set<VertexPair> accepted;
  for (const auto& [from, to] : replay.accepted) accepted.emplace(std::min(from, to), std::max(from, to));
  return accepted;
}

// A corrupted file's wrong closures, each as (smaller vertex, larger vertex) like the two above.
std::set<VertexPair> WrongPairs(const CorruptedGraph& corrupted) {
  std::set<VertexPair> wrong;
  for (const auto& [from, to] : corrupted.outliers) wrong.emplace(std::min(from, to), std::max(from, to));
  return wrong;
}

struct ReplayedWithOutliers {
  CorruptedGraph corrupted;
  ReplayResult replay;
};

// data/'s graph `relative` with as many wrong closures as its true ones, drawn as `options` say, replayed
// with `params` (the defaults unless given).
Result<ReplayedWithOutliers> ReplayWithOutliers(const std::string& relative, OutlierOptions options,
                                                const MapperParams& params = {}) {
  const auto path = test_data::Find(relative);
  if (!path) return NotFound("data/" + relative + " is part of the repository");
  ASSIGN_OR_RETURN(const PoseGraph graph, ReadPoseGraph(*path));
  options.total_edges = CountLoopClosures(graph);
  ASSIGN_OR_RETURN(CorruptedGraph corrupted, AddLoopClosureOutliers(graph, options));
  ASSIGN_OR_RETURN(ReplayResult replay, ReplayPoseGraph(corrupted.graph, params));
  return ReplayedWithOutliers{std::move(corrupted), std::move(replay)};
}

// Most checks change nothing: the accepted hypotheses fit and the refused ones stay far out, and such a check
// is settled by one solve of the status quo. Intel (Vertigo, data/) with as many wrong closures as true ones,
// in groups of ten (seed 1): the run decides exactly as it does with every check run in full.
TEST(ConsistentSetCheckTest, AConsistentStatusQuoSettlesTheCheckAsTheFullCheckWould) {
  const OutlierOptions grouped{.mode = OutlierOptions::Mode::kRandom, .group_size = 10, .seed = 1};
  MapperParams every_check_in_full;
  every_check_in_full.consistency.status_quo_first = false;
  const auto settled = ReplayWithOutliers("posegraphs/vertigo/intel.g2o", grouped);
  const auto in_full = ReplayWithOutliers("posegraphs/vertigo/intel.g2o", grouped, every_check_in_full);
  ASSERT_THAT(settled, IsOk());
  ASSERT_THAT(in_full, IsOk());
  const ConsistentSetChecks checks = settled->replay.consistent_set_checks;
  EXPECT_GT(checks.settled_by_status_quo, 0);
  EXPECT_EQ(checks.judged, in_full->replay.consistent_set_checks.judged);
  EXPECT_EQ(in_full->replay.consistent_set_checks.settled_by_status_quo, 0);
  const std::vector<Decision>& decisions = settled->replay.decisions;
  ASSERT_EQ(decisions.size(), in_full->replay.decisions.size());
  for (std::size_t i = 0; i < decisions.size(); ++i) {
    const Decision& full = in_full->replay.decisions[i];
    EXPECT_EQ(decisions[i].kind, full.kind) << "decision " << i;
    EXPECT_EQ(decisions[i].hypothesis, full.hypothesis) << "decision " << i;
    EXPECT_EQ(decisions[i].reason, full.reason) << "decision " << i;
  }
  EXPECT_EQ(settled->replay.accepted, in_full->replay.accepted);
}

// ringCity (the larger data set) with groups of ten wrong closures before their region's first true one, as many
// as true ones, seed 1. A check on 12 hypotheses took in a wrong group (the second half of a look-alike pass
// whose first half it retracted) against a true pass of 26 views; every later check found that status quo
// consistent, and a pass of 77 views closing the loop back to the start, which fits only together with the
// refused true one, stayed out with it (771 of 901 true closures, 3 wrong kept). A set a check swapped is
// judged in full by the next: it swaps them back (888 of 901, none wrong).
TEST(ConsistentSetCheckTest, ASetTheLastCheckSwappedIsJudgedInFullByTheNext) {
  if (!test_data::Find("posegraphs/vertigo/ringCity.g2o"))
    GTEST_SKIP() << "needs posegraphs/vertigo/ringCity.g2o (the larger data set, ../shared/data)";
  const Result<ReplayedWithOutliers> run = ReplayWithOutliers(
      "posegraphs/vertigo/ringCity.g2o", {.mode = OutlierOptions::Mode::kFirst, .group_size = 10, .seed = 1});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_EQ(score.wrong_accepted, 0);
  EXPECT_GE(score.Recall(), 0.95) << score.true_accepted << " of " << score.true_total;
  // The mechanism: a hypothesis one check took in, a later check took back.
  std::set<std::int64_t> taken_in_by_a_check;
  int taken_back = 0;
  for (const Decision& d : replay.decisions) {
    if (d.reason.find("consistent-set check") == std::string::npos) continue;
    if (d.kind == DecisionKind::kAccepted) taken_in_by_a_check.insert(d.hypothesis);
    if (d.kind == DecisionKind::kRetracted) taken_back += taken_in_by_a_check.count(d.hypothesis) > 0 ? 1 : 0;
  }
  EXPECT_GE(taken_back, 1);
}

// A wrong observation can start a recovery hypothesis that true observations then join, its gate wide after a
// long drive. The check retracts the hypothesis as a whole, but its observations that fit the solution of the
// inliers (which they did not pull on) stay as direct edges. Intel (Vertigo, data/) with single wrong
// closures within 20 vertices, seed 8 (outside every table and tuning run): one retracted hypothesis carried
// two true closures and one wrong; before, the retraction took all three (881 of 893 true closures, now 883).
TEST(ConsistentSetCheckTest, ARetractedHypothesisKeepsTheObservationsThatFitTheMapWithoutIt) {
  const Result<ReplayedWithOutliers> run =
      ReplayWithOutliers("posegraphs/vertigo/intel.g2o", {.mode = OutlierOptions::Mode::kLocal, .seed = 8});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  EXPECT_EQ(ScoreReplay(replay, corrupted.first_outlier_edge).wrong_accepted, 0);

  const auto kept_some =
      std::find_if(replay.decisions.begin(), replay.decisions.end(), [](const Decision& d) {
        return d.kind == DecisionKind::kRetracted &&
               d.reason.find("stay as direct edges") != std::string::npos;
      });
  ASSERT_NE(kept_some, replay.decisions.end()) << "no retraction kept an edge";
  // The retracted hypothesis's observations (robot node, view: the file's vertex ids here): the true closures
  // among them are accepted, the wrong ones are not.
  const std::set<VertexPair> observed = ObservationsOf(replay, kept_some->hypothesis);
  const std::set<VertexPair> wrong = WrongPairs(corrupted);
  const std::set<VertexPair> accepted = AcceptedPairs(replay);
  int true_kept = 0, wrong_seen = 0;
  for (const VertexPair& pair : observed) {
    const bool is_wrong = wrong.count(pair) > 0;
    wrong_seen += is_wrong ? 1 : 0;
    if (is_wrong) {
      EXPECT_EQ(accepted.count(pair), 0u) << pair.first << "-" << pair.second;
    } else {
      EXPECT_EQ(accepted.count(pair), 1u) << pair.first << "-" << pair.second << " is true and fits";
      ++true_kept;
    }
  }
  EXPECT_GE(true_kept, 1);
  EXPECT_GE(wrong_seen, 1) << "the retracted hypothesis held a wrong observation";
}

// Intel (SE-Sync) with groups of ten wrong closures placed before their region's first true one, as many wrong
// closures as true ones, seed 1 (the traced case of the README's table): wrong groups accepted before the
// truth arrived bent G, and graduated non-convexity started from G's poses ended with the true passes refused
// on the way at s ≈ 4·10³ — a local minimum; started again from the linear initialisation of the inliers'
// graph it finds a lower objective with them in (recall 51 % before, 100 % now).
TEST(ConsistentSetCheckTest, ALinearStartLeadsTheCheckOutOfTheBasinTheWrongGroupsBentGInto) {
  const Result<ReplayedWithOutliers> run = ReplayWithOutliers(
      "posegraphs/sesync/intel.g2o", {.mode = OutlierOptions::Mode::kFirst, .group_size = 10, .seed = 1});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_GE(score.Recall(), 0.95);
  EXPECT_GE(score.Precision(), 0.99);
  const long taken_in =
      std::count_if(replay.decisions.begin(), replay.decisions.end(), [](const Decision& d) {
        return d.kind == DecisionKind::kAccepted &&
               d.reason.find("consistent-set check") != std::string::npos;
      });
  EXPECT_GE(taken_in, 1) << "no refused hypothesis was taken in by a check";
}

// Intel (SE-Sync) with wrong groups first, seed 2 (the table's worst case before: recall 64.8 %, 18 wrong
// closures accepted). One traversal past a region whose wrong closures agree came out as a hypothesis
// accepted, observations that failed the gate of the map it bent and gathered in new hypotheses, then more
// that passed it: direct edges made more than a pass gap after the acceptance's last one, owned by no
// hypothesis, so every later consistent-set check held them as trusted and refused the truth against them.
// The pass goes on through every observation, and those edges share the acceptance's fate.
TEST(PassesTest, DirectEdgesBelongToTheAcceptanceWhoseTraversalTheyContinue) {
  const Result<ReplayedWithOutliers> run = ReplayWithOutliers(
      "posegraphs/sesync/intel.g2o", {.mode = OutlierOptions::Mode::kFirst, .group_size = 10, .seed = 2});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_GE(score.Recall(), 0.95);
  EXPECT_GE(score.Precision(), 0.99);
  // Direct edges owned by an acceptance that was later retracted left G with it.
  std::set<std::int64_t> retracted;
  for (const Decision& d : replay.decisions) {
    if (d.kind == DecisionKind::kRetracted) retracted.insert(d.hypothesis);
  }
  int owned_by_retracted = 0;
  for (const Decision& d : replay.decisions) {
    const std::size_t at = d.reason.find("continues the pass of accepted hypothesis ");
    if (d.kind != DecisionKind::kDirectEdge || at == std::string::npos) continue;
    owned_by_retracted += retracted.count(std::stoll(d.reason.substr(at + 42))) > 0 ? 1 : 0;
  }
  // 30 such edges when this case was traced; since contested acceptances (mapper_consistency.cc) the wrong
  // acceptance is retracted by the next true passes, before its traversal has made more than a few.
  EXPECT_GE(owned_by_retracted, 1);
  // Each contest's retraction is followed by the acceptance of the challenger it names (mapper_contest.cc:
  // a retraction whose challenger is then refused is put back).
  int contested = 0;
  const std::vector<Decision>& decisions = replay.decisions;
  for (std::size_t i = 0; i + 1 < decisions.size(); ++i) {
    const std::size_t at = decisions[i].reason.find(" waited on ");
    if (decisions[i].kind != DecisionKind::kRetracted || !decisions[i].reason.starts_with("contested:") ||
        at == std::string::npos)
      continue;
    ++contested;
    const std::size_t named = decisions[i].reason.rfind("hypothesis ", at);
    ASSERT_NE(named, std::string::npos) << decisions[i].reason;
    const std::int64_t challenger = std::stoll(decisions[i].reason.substr(named + 11));
    std::size_t next = i + 1;
    while (next < decisions.size() && decisions[next].kind == DecisionKind::kRetracted) ++next;
    ASSERT_LT(next, decisions.size());
    EXPECT_EQ(decisions[next].kind, DecisionKind::kAccepted) << decisions[i].reason;
    EXPECT_EQ(decisions[next].hypothesis, challenger) << decisions[i].reason;
  }
  EXPECT_GE(contested, 1);
}

// Intel (Vertigo, data/) with groups of ten wrong closures, as many as true ones, seed 7 (outside every
// table). A wrong group whose observations lay more than a pass gap apart overruled the map and, verified
// after its acceptance, retracted two true hypotheses it contradicted (53 true closures); a later true
// acceptance retracted it in turn, but the two were gone for good: only the consistent-set check's own
// retractions were kept for it to judge again (recall 74.8 % before). A verification's retractions are kept
// too, and the check takes them back.
TEST(ConsistentSetCheckTest, WhatAVerificationRetractedTheCheckCanBringBack) {
  const Result<ReplayedWithOutliers> run = ReplayWithOutliers(
      "posegraphs/vertigo/intel.g2o", {.mode = OutlierOptions::Mode::kRandom, .group_size = 10, .seed = 7});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  std::set<std::int64_t> retracted_by_verification;
  int brought_back = 0;
  for (const Decision& d : replay.decisions) {
    if (d.kind == DecisionKind::kRetracted &&
        d.reason.find("contradicted by hypothesis") != std::string::npos)
      retracted_by_verification.insert(d.hypothesis);
    if (d.kind == DecisionKind::kAccepted && d.reason.find("consistent-set check") != std::string::npos)
      brought_back += retracted_by_verification.count(d.hypothesis) > 0 ? 1 : 0;
  }
  EXPECT_GE(brought_back, 1);
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_GE(score.Recall(), 0.8);
  EXPECT_GE(score.Precision(), 0.99);
}

// The same replay: a true pass of 110 observations, refused when a competitor was accepted, stayed outside
// the set at 2.8–3.1× its threshold, the odometry weighted 40–55× by its variance factor in the judged solves
// (recall 82.4 %). Judged again at the noise the inliers meet, by its leave-one-out χ², it is taken in.
TEST(ConsistentSetCheckTest, ARefusedPassJustOutsideTheSetIsJudgedAgainAtTheNoiseTheInliersMeet) {
  const Result<ReplayedWithOutliers> run = ReplayWithOutliers(
      "posegraphs/vertigo/intel.g2o", {.mode = OutlierOptions::Mode::kRandom, .group_size = 10, .seed = 7});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  const std::set<VertexPair> wrong = WrongPairs(corrupted);
  int admitted_true_observations = 0;
  for (const Decision& d : replay.decisions) {
    if (d.kind != DecisionKind::kAccepted ||
        d.reason.find("taken in at the noise the inliers meet") == std::string::npos) {
      continue;
    }
    for (const VertexPair& pair : ObservationsOf(replay, d.hypothesis)) {
      const bool is_wrong = wrong.count(pair) > 0;
      EXPECT_FALSE(is_wrong) << pair.first << "-" << pair.second << " of hypothesis " << d.hypothesis;
      admitted_true_observations += is_wrong ? 0 : 1;
    }
  }
  EXPECT_GE(admitted_true_observations, 100);
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_GE(score.Recall(), 0.95);
  EXPECT_GE(score.Precision(), 0.99);
}

// Intel (SE-Sync) with one local wrong closure per true one, seed 11 (no table uses it). Wrong observations
// made while the robot was unsure of itself start recovery hypotheses that the optimised map refuses; a
// refused hypothesis's gate widens with every metre the robot drives, and before the rule every later pass
// it could not test joined it, true passes of a hundred observations and more among them, refused with it
// (recall 73.0 %, against 97.2 % with the rule).
TEST(PassesTest, APassThatARefusedHypothesisCouldNotTestStartsItsOwn) {
  const Result<ReplayedWithOutliers> run =
      ReplayWithOutliers("posegraphs/sesync/intel.g2o", {.mode = OutlierOptions::Mode::kLocal, .seed = 11});
  ASSERT_THAT(run, IsOk());
  const auto& [corrupted, replay] = *run;
  const std::set<VertexPair> accepted = AcceptedPairs(replay);
  const std::set<VertexPair> wrong = WrongPairs(corrupted);
  int kept_apart = 0, long_true_passes = 0;
  for (const Decision& d : replay.decisions) {
    if (d.kind != DecisionKind::kHypothesisCreated ||
        d.reason.find("kept apart from refused hypothesis") == std::string::npos) {
      continue;
    }
    ++kept_apart;
    // A long true pass kept apart (a wrong observation may have started the hypothesis it then built):
    // its true observations are in G.
    std::vector<VertexPair> true_observations;
    for (const VertexPair& pair : ObservationsOf(replay, d.hypothesis)) {
      if (wrong.count(pair) == 0) true_observations.push_back(pair);
    }
    if (true_observations.size() < 100) continue;
    ++long_true_passes;
    for (const VertexPair& pair : true_observations) {
      EXPECT_EQ(accepted.count(pair), 1u) << pair.first << "-" << pair.second;
    }
  }
  EXPECT_GE(kept_apart, 1);
  EXPECT_GE(long_true_passes, 1);
  const FilterScore score = ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  EXPECT_GE(score.Recall(), 0.95);
  EXPECT_GE(score.Precision(), 0.98);
}

// data/'s Intel (Vertigo), no outliers: two passes of one place that the filter kept apart (the second did
// not fit the first's estimate carried over metres of odometry) compete; when one is accepted, the other's
// observations that fit the map it made join it instead of being dropped with it (881 of 893 true closures
// accepted before, 883 now).
TEST(PassesTest, ObservationsOfACompetitorThatFitTheAcceptedMapJoinIt) {
  const auto path = test_data::Find("posegraphs/vertigo/intel.g2o");
  ASSERT_TRUE(path.has_value()) << "data/posegraphs/vertigo/intel.g2o is part of the repository";
  const Result<PoseGraph> graph = ReadPoseGraph(*path);
  ASSERT_THAT(graph, IsOk());
  const Result<ReplayResult> replay = ReplayPoseGraph(*graph, MapperParams{});
  ASSERT_THAT(replay, IsOk());
  const std::set<VertexPair> accepted = AcceptedPairs(*replay);
  int adoptions = 0;
  for (const Decision& d : replay->decisions) {
    if (d.kind != DecisionKind::kRejected || d.reason.find("competitor ") == std::string::npos) continue;
    const std::int64_t winner = std::stoll(d.reason.substr(d.reason.find("competitor ") + 11));
    const auto adopted =
        std::find_if(replay->decisions.begin(), replay->decisions.end(), [&](const Decision& e) {
          return e.hypothesis == winner &&
                 e.reason.find("fit the map it made and join it") != std::string::npos;
        });
    if (adopted == replay->decisions.end()) continue;
    ++adoptions;
    // Every observation of the dropped competitor is a true closure here, and each that fits is in G.
    int in_g = 0;
    for (const VertexPair& pair : ObservationsOf(*replay, d.hypothesis))
      in_g += accepted.count(pair) > 0 ? 1 : 0;
    EXPECT_GE(in_g, 1) << "competitor " << d.hypothesis << " of " << winner;
  }
  EXPECT_GE(adoptions, 1);
  EXPECT_GE(replay->accepted.size(), 883u);
}

TEST(ConsistentSetCheckTest, ItsFieldsAreValidated) {
  const auto refused = [](auto change) {
    MapperParams params;
    change(params);
    return params.Validate();
  };
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.consistent_set_confidence = 1.0; }).message(),
              HasSubstr("consistency.consistent_set_confidence"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.consistent_set_growth = 1.0; }).message(),
              HasSubstr("consistency.consistent_set_growth"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.max_kept_refused = -1; }).message(),
              HasSubstr("consistency.max_kept_refused"));
  EXPECT_THAT(refused([](MapperParams& p) { p.consistency.gnc_max_iterations = 0; }).message(),
              HasSubstr("consistency.gnc_max_iterations"));
}

}  // namespace
}  // namespace slamcore
