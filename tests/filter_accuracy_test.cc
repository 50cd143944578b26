// The hypothesis filter against seeded wrong loop closures on real pose graphs (issue: precision ≥ 99 %,
// recall ≥ 95 % of accepted loop closures; trajectory error close to the outlier-free solution). The full
// table over more graphs, modes and seeds is bench/filter_accuracy (README "Measured").
#include <gtest/gtest.h>

#include "filter_evaluation.h"

namespace {

const std::filesystem::path kGraphs = std::filesystem::path(SHARED_DATA_DIR) / "posegraphs";

struct AccuracyCase {
  const char* graph;
  const char* truth;
  slamcore::OutlierOptions::Mode mode;
};

class FilterAccuracyTest : public ::testing::TestWithParam<AccuracyCase> {};

TEST_P(FilterAccuracyTest, RejectsWrongLoopClosuresAndKeepsTrueOnes) {
  bench::FilterCase test_case{GetParam().graph, GetParam().truth, {}};
  test_case.outliers.mode = GetParam().mode;
  test_case.outliers.count = 100;
  test_case.outliers.seed = 7;
  const auto outcome = bench::EvaluateFilter(kGraphs, test_case);
  ASSERT_TRUE(outcome.ok()) << outcome.status().ToString();
  EXPECT_EQ(outcome->score.wrong_total, 100);
  EXPECT_GE(outcome->score.Precision(), 0.99) << outcome->score.wrong_accepted << " wrong accepted";
  EXPECT_GE(outcome->score.Recall(), 0.95) << outcome->score.true_accepted << " of " << outcome->score.true_total;
  if (outcome->replay_rmse) {
    // The outliers may cost at most 5 % of trajectory accuracy against the same filter without them.
    EXPECT_LE(*outcome->replay_rmse, 1.05 * *outcome->clean_replay_rmse)
        << "trajectory RMSE " << *outcome->replay_rmse << " m vs outlier-free " << *outcome->clean_replay_rmse << " m";
  }
}

INSTANTIATE_TEST_SUITE_P(
    RealGraphs, FilterAccuracyTest,
    ::testing::Values(
        AccuracyCase{"vertigo/manhattanOlson3500_olson.g2o", "vertigo/manhattanOlson3500_nodes_groundTruth.dat",
                     slamcore::OutlierOptions::Mode::kRandom},
        AccuracyCase{"vertigo/ringCity.g2o", "vertigo/ringCity_groundTruth_poses.txt",
                     slamcore::OutlierOptions::Mode::kLocal},
        AccuracyCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", slamcore::OutlierOptions::Mode::kRandom},
        AccuracyCase{"vertigo/intel.g2o", "", slamcore::OutlierOptions::Mode::kRandom},
        AccuracyCase{"vertigo/intel.g2o", "", slamcore::OutlierOptions::Mode::kLocal}),
    [](const auto& test_case) {
      std::string name = std::filesystem::path(test_case.param.graph).stem().string() +
                         (test_case.param.mode == slamcore::OutlierOptions::Mode::kLocal ? "_local" : "_random");
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

}  // namespace
