// The hypothesis filter against seeded wrong loop closures on real pose graphs (precision ≥ 99 %, recall ≥ 95 %
// of accepted loop closures; trajectory error within 5 % of the outlier-free replay), including correlated
// wrong closures: groups of consecutive pairs with one wrong measurement, groups of 1–20, half single and half
// grouped, groups that arrive before the region's first true loop closure, and look-alikes that repeat a true
// closure a few metres away (a generator held out of all tuning). Seed 7 is outside the seeds
// the filter's defaults were chosen on (1–3). The graphs of data/ always run; the others need the larger data
// set and are skipped with the reason without it. The full table is bench/filter_accuracy (README "Measured").
#include <gtest/gtest.h>

#include "filter_evaluation.h"
#include "test_data.h"
#include "status_matchers.h"

namespace {

struct AccuracyCase {
  const char* graph;  // under posegraphs/
  const char* truth;
  const char* mode;  // bench::OutlierCase: random, local, grouped, variable, mixed, first, shifted
  double fraction;   // wrong edges per true loop closure
};

class FilterAccuracyTest : public ::testing::TestWithParam<AccuracyCase> {};

TEST_P(FilterAccuracyTest, RejectsWrongLoopClosuresAndKeepsTrueOnes) {
  const auto graph = test_data::Find(std::string("posegraphs/") + GetParam().graph);
  if (!graph)
    GTEST_SKIP() << "needs posegraphs/" << GetParam().graph << " (the larger data set, ../shared/data)";
  const std::filesystem::path graphs = graph->parent_path().parent_path();
  bench::FilterCase test_case{GetParam().graph, GetParam().truth, bench::OutlierCase(GetParam().mode)};
  test_case.fraction = GetParam().fraction;
  test_case.outliers.seed = 7;
  const auto outcome = bench::EvaluateFilter(graphs, test_case);
  ASSERT_THAT(outcome, IsOk());
  EXPECT_GT(outcome->score.wrong_total, 0);
  EXPECT_GE(outcome->score.Precision(), 0.99) << outcome->score.wrong_accepted << " wrong accepted";
  EXPECT_GE(outcome->score.Recall(), 0.95)
      << outcome->score.true_accepted << " of " << outcome->score.true_total;
  if (outcome->replay_rmse) {
    // The outliers may cost at most 5 % of trajectory accuracy against the same filter without them.
    EXPECT_LE(*outcome->replay_rmse, 1.05 * *outcome->clean_replay_rmse)
        << "trajectory RMSE " << *outcome->replay_rmse << " m vs outlier-free " << *outcome->clean_replay_rmse
        << " m";
  }
}

INSTANTIATE_TEST_SUITE_P(
    RealGraphs, FilterAccuracyTest,
    ::testing::Values(
        // data/: always run.
        AccuracyCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", "random", 1.0},
        AccuracyCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", "grouped", 1.0},
        AccuracyCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", "first", 1.0},
        AccuracyCase{"vertigo/intel.g2o", "", "random", 1.0},
        AccuracyCase{"vertigo/intel.g2o", "", "local", 1.0},
        AccuracyCase{"vertigo/intel.g2o", "", "variable", 1.0},
        AccuracyCase{"vertigo/intel.g2o", "", "first", 0.5},
        AccuracyCase{"sesync/CSAIL.g2o", "", "grouped", 1.0},
        AccuracyCase{"sesync/CSAIL.g2o", "", "mixed", 1.0},
        // Held out of all tuning: look-alikes that repeat a true closure a few metres away.
        AccuracyCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", "shifted", 1.0},
        AccuracyCase{"vertigo/intel.g2o", "", "shifted", 1.0},
        // The larger data set.
        AccuracyCase{"vertigo/manhattanOlson3500_olson.g2o",
                     "vertigo/manhattanOlson3500_nodes_groundTruth.dat", "random", 0.5},
        AccuracyCase{"vertigo/manhattanOlson3500_olson.g2o",
                     "vertigo/manhattanOlson3500_nodes_groundTruth.dat", "grouped", 0.5},
        AccuracyCase{"vertigo/ringCity.g2o", "vertigo/ringCity_groundTruth_poses.txt", "local", 1.0}),
    [](const auto& test_case) {
      std::string name = std::filesystem::path(test_case.param.graph).stem().string() + "_" +
                         test_case.param.mode + "_" +
                         std::to_string(static_cast<int>(100 * test_case.param.fraction));
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

// Wrong groups that the online filter accepts on Intel (Vertigo, data/) and that only the consistent-set
// check's leave-one-out confirmation takes back: judged by their own residual at the noise the inliers meet,
// as before, they bent the lenient map until they fit and stayed (grouped, seed 16: 1 wrong closure
// accepted; variable, seed 24: 3). Seeds outside every table and tuning run.
struct RetractionCase {
  const char* mode;
  unsigned seed;
};

class ConfirmedRetractionTest : public ::testing::TestWithParam<RetractionCase> {};

TEST_P(ConfirmedRetractionTest, TheCheckTakesBackTheWrongGroupItAccepted) {
  const auto graph = test_data::Find("posegraphs/vertigo/intel.g2o");
  ASSERT_TRUE(graph.has_value()) << "data/posegraphs/vertigo/intel.g2o is part of the repository";
  bench::FilterCase test_case{"vertigo/intel.g2o", "", bench::OutlierCase(GetParam().mode)};
  test_case.fraction = 1.0;
  test_case.outliers.seed = GetParam().seed;
  const auto outcome = bench::EvaluateFilter(graph->parent_path().parent_path(), test_case);
  ASSERT_THAT(outcome, IsOk());
  EXPECT_EQ(outcome->score.wrong_accepted, 0);
  EXPECT_GE(outcome->retracted, 1);
  EXPECT_GE(outcome->score.Recall(), 0.95);
}

INSTANTIATE_TEST_SUITE_P(IntelVertigo, ConfirmedRetractionTest,
                         ::testing::Values(RetractionCase{"grouped", 16}, RetractionCase{"variable", 24}),
                         [](const auto& test_case) {
                           return std::string(test_case.param.mode) + "_seed" +
                                  std::to_string(test_case.param.seed);
                         });

}  // namespace
