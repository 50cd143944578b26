// Scoring the hypothesis filter on a real pose graph with seeded wrong loop closures: precision and recall
// of accepted loop closures, and trajectory error against the outlier-free solution. Shared by
// bench/filter_accuracy (the README table) and tests/filter_accuracy_test (the asserted thresholds).
#pragma once

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/loop_closure_outliers.h"
#include "slamcore/optimizer.h"
#include "slamcore/trajectory_error.h"

namespace bench {

struct FilterCase {
  std::string graph;                 // relative to the posegraphs directory
  std::string truth;                 // ground-truth poses (id x y θ per line, or x y θ), or empty
  slamcore::OutlierOptions outliers;
};

struct FilterOutcome {
  slamcore::FilterScore score;
  double seconds = 0.0;
  double final_chi2 = 0.0;
  /// With ground truth: trajectory RMSE of the replay, of the replay of the outlier-free graph (what the
  /// filter would give without outliers: the outliers' effect is the difference), and of the outlier-free
  /// batch optimum (all true loop closures, offline).
  std::optional<double> replay_rmse, clean_replay_rmse, clean_rmse;
  /// Without: RMS distance of the replay from the outlier-free batch optimum, after alignment.
  double deviation_from_clean = 0.0;
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

inline slamcore::Result<FilterOutcome> EvaluateFilter(const std::filesystem::path& graphs, const FilterCase& test_case,
                                                      const slamcore::MapperParams& params = {}) {
  auto clean = slamcore::ReadPoseGraph(graphs / test_case.graph);
  if (!clean.ok()) return clean.status();
  const auto corrupted = slamcore::AddLoopClosureOutliers(*clean, test_case.outliers);
  if (!corrupted.ok()) return corrupted.status();
  const auto replay = slamcore::ReplayPoseGraph(corrupted->graph, params);
  if (!replay.ok()) return replay.status();

  FilterOutcome outcome;
  outcome.score = slamcore::ScoreReplay(*replay, corrupted->outliers);
  outcome.seconds = replay->seconds;
  outcome.final_chi2 = replay->final_chi2;
  slamcore::OptimizerOptions batch;
  batch.linear_initialization = true;
  if (const auto solved = slamcore::Optimize(*clean, batch); !solved.ok()) return solved.status();
  // The replay numbers nodes 0, 1, … in vertex order, as the clean graph's nodes are when ids start at 0.
  const auto replay_positions = Positions(replay->graph), clean_positions = Positions(*clean);
  if (replay_positions.size() != clean_positions.size()) {
    return slamcore::Internal("replay and graph differ in node count");
  }
  if (!test_case.truth.empty()) {
    const auto clean_replay = slamcore::ReplayPoseGraph(*clean, params);
    if (!clean_replay.ok()) return clean_replay.status();
    const auto truth = ReadTruth(graphs / test_case.truth);
    const auto replay_rmse = slamcore::AlignedRmse(replay_positions, truth);
    const auto clean_replay_rmse = slamcore::AlignedRmse(Positions(clean_replay->graph), truth);
    const auto clean_rmse = slamcore::AlignedRmse(clean_positions, truth);
    if (!replay_rmse.ok()) return replay_rmse.status();
    if (!clean_replay_rmse.ok()) return clean_replay_rmse.status();
    if (!clean_rmse.ok()) return clean_rmse.status();
    outcome.replay_rmse = *replay_rmse;
    outcome.clean_replay_rmse = *clean_replay_rmse;
    outcome.clean_rmse = *clean_rmse;
  }
  const auto deviation = slamcore::AlignedRmse(replay_positions, clean_positions);
  if (!deviation.ok()) return deviation.status();
  outcome.deviation_from_clean = *deviation;
  return outcome;
}

}  // namespace bench
