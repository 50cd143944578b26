// Wrong loop closures for testing the hypothesis filter, following the protocol most papers mean by
// "Vertigo outliers" (Sünderhauf's generateDataset.py, re-implemented from its description):
//  * random: both vertices uniform over the graph; local: the second within `local_window` after the first;
//  * each outlier is repeated for `group_size` consecutive vertex pairs (v1+k, v2+k) with one measurement;
//  * measurement dx, dy ~ N(0, 0.3²), dθ ~ N(0, (10°)²), information copied from the first loop closure.
// One seed makes it deterministic.
//
// Thread safety: free function without shared state.
#pragma once

#include <cstdint>
#include <vector>

#include "slamcore/g2o_replay.h"
#include "slamcore/pose_graph.h"

namespace slamcore {

struct OutlierOptions {
  enum class Mode : std::uint8_t { kRandom, kLocal };
  Mode mode = Mode::kRandom;
  int count = 100;         // outlier groups
  int group_size = 1;      // consecutive pairs per group
  int local_window = 20;   // vertices, for kLocal
  std::uint64_t seed = 1;
};

struct CorruptedGraph {
  PoseGraph graph;                  // the input with the outliers appended as observation edges
  std::vector<VertexPair> outliers; // the appended edges, (from, to) as in the graph
};

/// Fails when the graph has no loop closure to copy the information from, or too few vertices.
Result<CorruptedGraph> AddLoopClosureOutliers(const PoseGraph& graph, const OutlierOptions& options);

}  // namespace slamcore
