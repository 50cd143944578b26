// The hypothesis filter on real pose graphs with seeded wrong loop closures (Vertigo protocol: random,
// local, and grouped): precision and recall of accepted loop closures, and trajectory error against the
// outlier-free optimum. Prints the table for the README.
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "filter_evaluation.h"

int main() {
  const std::filesystem::path graphs = std::filesystem::path(SHARED_DATA_DIR) / "posegraphs";
  struct Graph {
    const char* file;
    const char* truth;
  };
  const Graph graph_list[] = {
      {"vertigo/manhattanOlson3500_olson.g2o", "vertigo/manhattanOlson3500_nodes_groundTruth.dat"},
      {"vertigo/ring.g2o", "vertigo/ring_groundTruth_poses.txt"},
      {"vertigo/ringCity.g2o", "vertigo/ringCity_groundTruth_poses.txt"},
      {"vertigo/intel.g2o", ""},
      {"sesync/intel.g2o", ""},
      {"sesync/CSAIL.g2o", ""},
  };
  struct Mode {
    const char* name;
    slamcore::OutlierOptions::Mode mode;
    int count, group;
  };
  const Mode modes[] = {{"random 100", slamcore::OutlierOptions::Mode::kRandom, 100, 1},
                        {"local 100", slamcore::OutlierOptions::Mode::kLocal, 100, 1},
                        {"grouped 10x10", slamcore::OutlierOptions::Mode::kRandom, 10, 10}};
  std::printf("| graph | outliers | seeds | precision | recall | wrong accepted | trajectory RMSE (m): ours / "
              "outlier-free replay / batch optimum | deviation from batch optimum (m) | replay s |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  for (const Graph& graph : graph_list) {
    for (const Mode& mode : modes) {
      slamcore::FilterScore total;
      double replay_rmse = 0, clean_replay_rmse = 0, clean_rmse = 0, deviation = 0, seconds = 0;
      bool has_truth = false;
      const int seeds = 3;
      for (int seed = 1; seed <= seeds; ++seed) {
        bench::FilterCase test_case{graph.file, graph.truth, {}};
        test_case.outliers.mode = mode.mode;
        test_case.outliers.count = mode.count;
        test_case.outliers.group_size = mode.group;
        test_case.outliers.seed = static_cast<std::uint64_t>(seed);
        const auto outcome = bench::EvaluateFilter(graphs, test_case);
        if (!outcome.ok()) {
          std::fprintf(stderr, "%s: %s\n", graph.file, outcome.status().ToString().c_str());
          return 1;
        }
        total.true_accepted += outcome->score.true_accepted;
        total.true_total += outcome->score.true_total;
        total.wrong_accepted += outcome->score.wrong_accepted;
        total.wrong_total += outcome->score.wrong_total;
        if (outcome->replay_rmse) {
          has_truth = true;
          replay_rmse += *outcome->replay_rmse / seeds;
          clean_replay_rmse += *outcome->clean_replay_rmse / seeds;
          clean_rmse += *outcome->clean_rmse / seeds;
        }
        deviation += outcome->deviation_from_clean / seeds;
        seconds += outcome->seconds / seeds;
      }
      char rmse[64] = "no ground truth";
      if (has_truth) std::snprintf(rmse, sizeof rmse, "%.3f / %.3f / %.3f", replay_rmse, clean_replay_rmse, clean_rmse);
      std::printf("| %s | %s | %d | %.2f %% | %.2f %% | %d of %d | %s | %.3f | %.1f |\n", graph.file, mode.name, seeds,
                  100 * total.Precision(), 100 * total.Recall(), total.wrong_accepted, total.wrong_total, rmse,
                  deviation, seconds);
      std::fflush(stdout);
    }
  }
  return 0;
}
