// Optimisation of the real public pose graphs reaches the known optimum. Ring, Intel (Vertigo), CSAIL and MIT
// are in data/posegraphs; Manhattan, ringCity and SE-Sync's Intel and Manhattan only in the larger data set
// (their cases skip without it).
//
// Reference χ² (g2o convention, Ω as written in the file):
//  * graphs with ground truth (Manhattan-Olson 3500, ring, ringCity): the optimum reached from the
//    ground-truth poses, which start in the global optimum's basin (recomputed here, not hard-coded);
//  * real graphs without ground truth (Intel ×2, CSAIL, MIT, SE-Sync's Manhattan): the constants below,
//    the minimum reached both from the file's poses (up to 500 iterations) and from the linear start,
//    which agree to 1e-6 relative; Ceres with automatic differentiation (bench/optimizer_bench) reaches
//    the same values where it converges.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "slamcore/graph_io.h"
#include "slamcore/optimizer.h"
#include "test_data.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

PoseGraph Load(const std::filesystem::path& path) {
  auto graph = ReadPoseGraph(path);
  EXPECT_THAT(graph, IsOk());
  return graph.ok() ? std::move(graph).value() : PoseGraph();
}

double OptimisedChi2(PoseGraph graph, bool linear_initialization, int max_iterations = 100) {
  OptimizerOptions options;
  options.linear_initialization = linear_initialization;
  options.max_iterations = max_iterations;
  const auto summary = Optimize(graph, options);
  EXPECT_THAT(summary, IsOk());
  if (!summary.ok()) return -1.0;
  EXPECT_TRUE(summary->converged) << summary->message;
  return summary->final_chi2;
}

/// The graph's edges with the ground-truth poses as the starting point.
PoseGraph WithGroundTruthStart(const PoseGraph& graph, const std::vector<SE2>& truth) {
  PoseGraph started = graph;
  for (Node& node : started.mutable_nodes()) node.pose = truth.at(static_cast<std::size_t>(node.id));
  return started;
}

std::vector<SE2> ReadTruthLines(const std::filesystem::path& path, bool with_id) {
  std::ifstream input(path);
  std::vector<SE2> poses;
  double id, x, y, theta;
  while (with_id ? static_cast<bool>(input >> id >> x >> y >> theta)
                 : static_cast<bool>(input >> x >> y >> theta)) {
    poses.emplace_back(x, y, theta);
  }
  return poses;
}

/// "vertigo/manhattanOlson3500_olson.g2o" → "vertigo_manhattanOlson3500_olson".
std::string TestName(std::string graph) {
  graph = graph.substr(0, graph.rfind('.'));
  for (char& c : graph) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return graph;
}

struct GroundTruthCase {
  const char* graph;
  const char* truth;
  bool truth_has_ids;
};

class GroundTruthGraphTest : public ::testing::TestWithParam<GroundTruthCase> {};

TEST_P(GroundTruthGraphTest, ReachesTheOptimumOfTheGroundTruthBasin) {
  TEST_DATA_FILE_OR_SKIP(graph_path, std::string("posegraphs/") + GetParam().graph);
  TEST_DATA_FILE_OR_SKIP(truth_path, std::string("posegraphs/") + GetParam().truth);
  const PoseGraph graph = Load(graph_path);
  const std::vector<SE2> truth = ReadTruthLines(truth_path, GetParam().truth_has_ids);
  ASSERT_EQ(truth.size(), graph.num_nodes());
  const double reference = OptimisedChi2(WithGroundTruthStart(graph, truth), false, 500);
  ASSERT_GT(reference, 0.0);
  EXPECT_NEAR(OptimisedChi2(graph, true), reference, 1e-4 * reference) << "from the linear start";
  EXPECT_NEAR(OptimisedChi2(graph, false), reference, 1e-4 * reference) << "from the file's poses";
}

INSTANTIATE_TEST_SUITE_P(
    RealGraphs, GroundTruthGraphTest,
    ::testing::Values(GroundTruthCase{"vertigo/manhattanOlson3500_olson.g2o",
                                      "vertigo/manhattanOlson3500_nodes_groundTruth.dat", false},
                      GroundTruthCase{"vertigo/manhattanOlson3500_g2o.g2o",
                                      "vertigo/manhattanOlson3500_nodes_groundTruth.dat", false},
                      GroundTruthCase{"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt", true},
                      GroundTruthCase{"vertigo/ringCity.g2o", "vertigo/ringCity_groundTruth_poses.txt",
                                      true}),
    [](const auto& test_case) { return TestName(test_case.param.graph); });

struct ReferenceCase {
  const char* graph;
  double reference_chi2;
};

class ReferenceGraphTest : public ::testing::TestWithParam<ReferenceCase> {};

TEST_P(ReferenceGraphTest, ReachesTheReferenceOptimumFromTheLinearStart) {
  TEST_DATA_FILE_OR_SKIP(graph_path, std::string("posegraphs/") + GetParam().graph);
  const PoseGraph graph = Load(graph_path);
  const double reference = GetParam().reference_chi2;
  EXPECT_NEAR(OptimisedChi2(graph, true), reference, 1e-4 * reference);
}

INSTANTIATE_TEST_SUITE_P(RealGraphs, ReferenceGraphTest,
                         ::testing::Values(ReferenceCase{"vertigo/intel.g2o", 546.4611},
                                           ReferenceCase{"sesync/intel.g2o", 45.00471},
                                           ReferenceCase{"sesync/CSAIL.g2o", 40.55513},
                                           ReferenceCase{"sesync/MIT.g2o", 770.6640},
                                           ReferenceCase{"sesync/manhattan.g2o", 3549.037}),
                         [](const auto& test_case) { return TestName(test_case.param.graph); });

TEST(RealGraphTest, MitFromOdometryNeedsTheLinearStartWithinTheDefaultIterationLimit) {
  // Composed odometry leaves MIT far from the optimum: within 100 iterations the warm start does not
  // get there, the linear start does. This is why slamtool defaults to the linear start.
  TEST_DATA_FILE_OR_SKIP(mit, "posegraphs/sesync/MIT.g2o");
  const PoseGraph graph = Load(mit);
  PoseGraph warm = graph;
  const auto summary = Optimize(warm, {});
  ASSERT_THAT(summary, IsOk());
  EXPECT_GT(summary->final_chi2, 1.1 * 770.664);
  EXPECT_NEAR(OptimisedChi2(graph, true), 770.664, 0.1);
}

}  // namespace
}  // namespace slamcore
