// Wrong loop closures for testing the hypothesis filter, following the protocol most papers mean by
// "Vertigo outliers" (Sünderhauf's generateDataset.py, re-implemented from its description):
//  * random: both vertices uniform over the graph; local: the second within `local_window` after the first;
//    first: the group's later end (where the robot makes the observations) lies before the first true loop
//    closure that observes the region of its earlier end, so the wrong group arrives first;
//    shifted: a look-alike rather than noise — a true loop closure (i, j) seen again with its own
//    measurement but at the wrong place, (i + s + k, j + k) with s uniform in ±[3, 10] vertices (a second
//    identical door a few metres along), so the wrong group is as self-consistent as the true one;
//  * each outlier is repeated for a group of consecutive vertex pairs (v1+k, v2+k) with one measurement:
//    `group_size` pairs, or a size drawn uniformly from [group_size, max_group_size] per group, and with
//    `single_fraction` of the groups single outliers (mixed single and grouped);
//  * measurement dx, dy ~ N(0, 0.3²), dθ ~ N(0, (10°)²), information copied from the first loop closure.
// One seed makes it deterministic. Drawn as wrong is not always wrong: a shifted look-alike on a grid or a
// ring, or a local outlier two vertices long, can be the truth itself, so each outlier is also judged
// against the input's own optimum (`agrees_with_optimum`: χ² ≤ χ²₃(0.999) = 16.27 at its information), and
// scores leave those out (ScoreReplay) — neither a wrong closure accepted nor a true one missed.
//
// Thread safety: free function without shared state.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "slamcore/g2o_replay.h"
#include "slamcore/pose_graph.h"

namespace slamcore {

/// An outlier whose χ² against the input's optimum is at most this (χ²₃ at 0.999) agrees with it.
inline constexpr double kAgreesWithOptimumChi2 = 16.27;

struct OutlierOptions {
  enum class Mode : std::uint8_t { kRandom, kLocal, kFirst, kShifted };
  Mode mode = Mode::kRandom;
  int count = 100;         // outlier groups; ignored when total_edges > 0
  int total_edges = 0;     // when > 0: groups are added until this many wrong edges are written
  int group_size = 1;      // consecutive pairs per group (the smallest, with max_group_size)
  int max_group_size = 0;  // when > group_size: each group's size is uniform in [group_size, max_group_size]
  double single_fraction = 0.0;  // share of groups that are single outliers
  int local_window = 20;         // vertices, for kLocal
  std::uint64_t seed = 1;
};

/// Parses "random", "local", "first" or "shifted".
Result<OutlierOptions::Mode> ParseOutlierMode(const std::string& name);

/// The number of loop closures (edges that are not odometry k → k+1) of a graph.
int CountLoopClosures(const PoseGraph& graph);

struct CorruptedGraph {
  PoseGraph graph;                     // the input with the outliers appended as observation edges
  std::vector<VertexPair> outliers;    // the appended edges, (from, to) as in the graph
  std::size_t first_outlier_edge = 0;  // their index in graph.edges(): every edge from it on
  /// Per outlier: its measurement agrees with the input's optimum (see the top of this file).
  std::vector<bool> agrees_with_optimum;
};

/// Fails when the graph has no loop closure to copy the information from, too few vertices, or no optimum
/// (the input is optimised once to judge the outliers).
Result<CorruptedGraph> AddLoopClosureOutliers(const PoseGraph& graph, const OutlierOptions& options);

}  // namespace slamcore
