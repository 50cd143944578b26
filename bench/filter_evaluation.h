// Scoring the hypothesis filter on a real pose graph with seeded wrong loop closures: precision and recall
// of accepted loop closures, and trajectory error against the outlier-free solution. Shared by
// bench/filter_accuracy (the README table) and tests/filter_accuracy_test (the asserted thresholds).
#pragma once

#include <filesystem>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/loop_closure_outliers.h"
#include "slamcore/trajectory_error.h"

namespace bench {

/// The cases of the README's table by name: random, local, grouped (10), variable (1–20), mixed (half single,
/// half groups of 10), first (groups of 10 arriving before the region's first true loop closure), shifted
/// (groups of 10 repeating a true loop closure 3–10 vertices away; held out of tuning).
inline slamcore::OutlierOptions OutlierCase(const std::string& mode) {
  slamcore::OutlierOptions options;
  if (mode == "local") options.mode = slamcore::OutlierOptions::Mode::kLocal;
  if (mode == "first") options.mode = slamcore::OutlierOptions::Mode::kFirst;
  if (mode == "shifted") options.mode = slamcore::OutlierOptions::Mode::kShifted;
  if (mode == "grouped" || mode == "first" || mode == "shifted") options.group_size = 10;
  if (mode == "variable") options.group_size = 1, options.max_group_size = 20;
  if (mode == "mixed") options.group_size = 10, options.single_fraction = 0.5;
  return options;
}

struct FilterCase {
  std::string graph;  // relative to the posegraphs directory
  std::string truth;  // ground-truth poses (id x y θ per line, or x y θ), or empty
  slamcore::OutlierOptions outliers;
  /// When > 0: this many wrong edges per true loop closure of the graph (overrides outliers.count).
  double fraction = 0.0;
};

struct FilterOutcome {
  slamcore::FilterScore score;
  int retracted = 0;  // accepted recovery hypotheses taken back during the replay
  double seconds = 0.0;
  double clean_seconds = 0.0;  // the outlier-free replay of the same graph
  double final_chi2 = 0.0;
  /// With ground truth: trajectory RMSE of the replay, and of the replay of the outlier-free graph (what the
  /// filter would give without outliers: the outliers' effect is the difference).
  std::optional<double> replay_rmse, clean_replay_rmse;
};

inline std::vector<slamcore::Vector2> ReadTruth(const std::filesystem::path& path) {
  std::ifstream input(path);
  std::vector<slamcore::Vector2> positions;
  std::string line;
  while (std::getline(input, line)) {
    std::istringstream fields(line);
    std::vector<double> values;
    for (double value; fields >> value;) values.push_back(value);
    if (values.size() == 4) positions.emplace_back(values[1], values[2]);
    if (values.size() == 3) positions.emplace_back(values[0], values[1]);
  }
  return positions;
}

inline std::vector<slamcore::Vector2> Positions(const slamcore::PoseGraph& graph) {
  std::vector<slamcore::Vector2> positions;
  for (const slamcore::Node& node : graph.nodes()) positions.push_back(node.pose.translation());
  return positions;
}

/// Outlier-free replays already run: graph and parameter choice → (seconds, trajectory RMSE or −1).
/// Not thread-safe (a bench and a test call it from one thread).
inline std::map<std::string, std::pair<double, double>>& CleanReplays() {
  static std::map<std::string, std::pair<double, double>> cache;
  return cache;
}

/// The outlier-free replay of a graph, once per graph and parameter set (CleanReplays().clear() measures
/// its time again, e.g. beside each row of a table when the machine's load may have changed).
inline slamcore::Result<std::pair<double, double>> CleanReplay(const std::filesystem::path& graphs,
                                                               const FilterCase& test_case,
                                                               const slamcore::PoseGraph& clean,
                                                               const slamcore::MapperParams& params) {
  auto& cache = CleanReplays();
  std::ostringstream key;
  key << test_case.graph << "|" << params.consistency.enabled << params.consistency.verify_after_optimization;
  if (const auto it = cache.find(key.str()); it != cache.end()) return it->second;
  ASSIGN_OR_RETURN(const auto replay, slamcore::ReplayPoseGraph(clean, params));
  double rmse = -1;
  if (!test_case.truth.empty()) {
    ASSIGN_OR_RETURN(const auto aligned,
                     slamcore::AlignedRmse(Positions(replay.graph), ReadTruth(graphs / test_case.truth)));
    rmse = aligned;
  }
  return cache[key.str()] = {replay.seconds, rmse};
}

inline slamcore::Result<FilterOutcome> EvaluateFilter(const std::filesystem::path& graphs,
                                                      const FilterCase& test_case,
                                                      const slamcore::MapperParams& params = {}) {
  ASSIGN_OR_RETURN(auto clean, slamcore::ReadPoseGraph(graphs / test_case.graph));
  slamcore::OutlierOptions outliers = test_case.outliers;
  if (test_case.fraction > 0) {
    outliers.total_edges =
        std::max(1, static_cast<int>(std::lround(test_case.fraction * slamcore::CountLoopClosures(clean))));
  }
  ASSIGN_OR_RETURN(const auto corrupted, slamcore::AddLoopClosureOutliers(clean, outliers));
  ASSIGN_OR_RETURN(const auto replay, slamcore::ReplayPoseGraph(corrupted.graph, params));
  ASSIGN_OR_RETURN(const auto clean_replay, CleanReplay(graphs, test_case, clean, params));

  FilterOutcome outcome;
  outcome.score = slamcore::ScoreReplay(replay, corrupted.first_outlier_edge, corrupted.agrees_with_optimum);
  outcome.retracted = replay.statistics.recovery_retracted;
  outcome.seconds = replay.seconds;
  outcome.clean_seconds = clean_replay.first;
  outcome.final_chi2 = replay.final_chi2;
  if (!test_case.truth.empty()) {
    // The replay numbers nodes 0, 1, … in vertex order, as the file's vertices are when ids start at 0.
    ASSIGN_OR_RETURN(const auto replay_rmse,
                     slamcore::AlignedRmse(Positions(replay.graph), ReadTruth(graphs / test_case.truth)));
    outcome.replay_rmse = replay_rmse;
    outcome.clean_replay_rmse = clean_replay.second;
  }
  return outcome;
}

}  // namespace bench
