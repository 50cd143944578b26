#include "slamcore/loop_closure_outliers.h"

#include <algorithm>
#include <limits>
#include <map>
#include <numbers>
#include <random>

#include "slamcore/optimizer.h"

namespace slamcore {
namespace {

/// For kFirst: for every vertex index v, the robot end (the larger vertex) of the first true loop closure,
/// in replay order, whose other end lies within `radius` vertices of v; INT64_MAX where there is none.
std::vector<long> FirstClosureNear(const std::vector<const Edge*>& true_closures,
                                   const std::map<NodeId, long>& index, std::size_t vertices, long radius) {
  std::vector<long> first(vertices, std::numeric_limits<long>::max());
  for (const Edge* edge : true_closures) {
    const long a = index.at(std::min(edge->from, edge->to)), b = index.at(std::max(edge->from, edge->to));
    for (long v = std::max(0L, a - radius); v <= std::min<long>(static_cast<long>(vertices) - 1, a + radius);
         ++v) {
      first[static_cast<std::size_t>(v)] = std::min(first[static_cast<std::size_t>(v)], b);
    }
  }
  return first;
}

}  // namespace

Result<OutlierOptions::Mode> ParseOutlierMode(const std::string& name) {
  if (name == "random") return OutlierOptions::Mode::kRandom;
  if (name == "local") return OutlierOptions::Mode::kLocal;
  if (name == "first") return OutlierOptions::Mode::kFirst;
  if (name == "shifted") return OutlierOptions::Mode::kShifted;
  return InvalidArgument("outlier mode '" + name + "': expected random, local, first or shifted");
}

int CountLoopClosures(const PoseGraph& graph) {
  return static_cast<int>(std::count_if(graph.edges().begin(), graph.edges().end(),
                                        [](const Edge& edge) { return !(edge.to == edge.from + 1); }));
}

Result<CorruptedGraph> AddLoopClosureOutliers(const PoseGraph& graph, const OutlierOptions& options) {
  if (options.count < 0 || options.total_edges < 0 || options.group_size < 1 || options.local_window < 2 ||
      !(options.single_fraction >= 0.0 && options.single_fraction <= 1.0)) {
    return InvalidArgument(
        "outlier options: count >= 0, total_edges >= 0, group_size >= 1, local_window >= 2 and "
        "single_fraction in [0, 1] are required");
  }
  if (options.max_group_size != 0 && options.max_group_size < options.group_size) {
    return InvalidArgument("outlier options: the largest group (" + std::to_string(options.max_group_size) +
                           ") is smaller than the smallest (" + std::to_string(options.group_size) + ")");
  }
  const int largest_group = std::max(options.group_size, options.max_group_size);
  if (largest_group > 1000) return InvalidArgument("outlier options: groups of at most 1000 pairs");
  const auto first_loop_closure =
      std::find_if(graph.edges().begin(), graph.edges().end(),
                   [](const Edge& edge) { return edge.kind == EdgeKind::kObservation; });
  if (first_loop_closure == graph.edges().end()) {
    return InvalidArgument("the graph has no loop closure to copy the outliers' information from");
  }
  std::vector<NodeId> ids;
  for (const Node& node : graph.nodes()) ids.push_back(node.id);
  std::sort(ids.begin(), ids.end());
  const long last = static_cast<long>(ids.size()) - 1 - largest_group;  // v + group size stays inside
  if (last < 3) return InvalidArgument("the graph has too few vertices for outlier groups of this size");
  // Each wrong edge costs memory and a χ² against the optimum: at most 100 per vertex, as a total or as
  // groups of the largest size.
  const long most_edges = 100 * static_cast<long>(ids.size());
  if (options.total_edges > most_edges ||
      (options.total_edges == 0 && static_cast<long>(options.count) * largest_group > most_edges)) {
    return InvalidArgument("outlier options: more than 100 wrong edges per vertex (" +
                           std::to_string(most_edges) + " for this graph)");
  }

  std::mt19937_64 random(options.seed);
  std::uniform_int_distribution<long> any_vertex(0, last);
  std::normal_distribution<double> translation(0.0, 0.3), rotation(0.0, 10.0 * std::numbers::pi / 180.0);
  std::uniform_int_distribution<int> group_sizes(options.group_size,
                                                 std::max(options.group_size, options.max_group_size));
  std::bernoulli_distribution single(options.single_fraction);
  std::vector<const Edge*> true_closures;  // for kFirst and kShifted
  for (const Edge& edge : graph.edges()) {
    if (edge.kind == EdgeKind::kObservation) true_closures.push_back(&edge);
  }
  std::map<NodeId, long> index_of;
  for (std::size_t k = 0; k < ids.size(); ++k) index_of.emplace(ids[k], static_cast<long>(k));
  const std::vector<long> first_closure =
      options.mode == OutlierOptions::Mode::kFirst
          ? FirstClosureNear(true_closures, index_of, ids.size(), largest_group)
          : std::vector<long>{};
  if (true_closures.empty()) return InvalidArgument("the graph has no loop closure to shift");
  std::uniform_int_distribution<std::size_t> any_closure(0, true_closures.size() - 1);
  std::uniform_int_distribution<long> shift(3, 10);
  std::bernoulli_distribution backwards(0.5);

  CorruptedGraph corrupted{graph, {}, graph.num_edges(), {}};
  const auto enough = [&](int groups) {
    return options.total_edges > 0 ? static_cast<int>(corrupted.outliers.size()) >= options.total_edges
                                   : groups >= options.count;
  };
  for (int group = 0; !enough(group); ++group) {
    int size = single(random) ? 1 : group_sizes(random);
    if (options.total_edges > 0) {
      size = std::min(size, options.total_edges - static_cast<int>(corrupted.outliers.size()));
    }
    long v1 = any_vertex(random), v2 = v1;
    switch (options.mode) {
      case OutlierOptions::Mode::kRandom: do { v2 = any_vertex(random);
        } while (v2 == v1);
        break;
      case OutlierOptions::Mode::kLocal: {
        std::uniform_int_distribution<long> nearby(v1, std::min(last, v1 + options.local_window));
        do {
          v2 = nearby(random);
        } while (v2 == v1 && v1 < last);
        if (v2 == v1) v2 = v1 - 2;  // v1 is the last usable vertex: look back instead
        break;
      }
      case OutlierOptions::Mode::kShifted: break;  // placed below, from a true loop closure
      case OutlierOptions::Mode::kFirst: {
        // The whole group's robot end before the first true closure near v1; retry v1 where there is no room.
        for (int attempt = 0; attempt < 1000; ++attempt) {
          const long deadline = std::min(last, first_closure[static_cast<std::size_t>(v1)] - size);
          if (deadline >= v1 + 2) {
            std::uniform_int_distribution<long> before(v1 + 2, deadline);
            v2 = before(random);
            break;
          }
          v1 = any_vertex(random);
        }
        if (v2 == v1)
          return InvalidArgument("no room to place a wrong group before a region's first loop closure");
        break;
      }
    }
    if (v2 < v1) std::swap(v1, v2);
    if (v2 == v1 + 1) v2 = v1 + 2;  // never an odometry pair
    SE2 measurement(translation(random), translation(random), rotation(random));
    if (options.mode == OutlierOptions::Mode::kShifted) {
      // The true closure's appearance at the wrong place: its measurement, its first end moved by s.
      bool placed = false;
      for (int attempt = 0; attempt < 1000 && !placed; ++attempt) {
        const Edge& closure = *true_closures[any_closure(random)];
        const long s = backwards(random) ? -shift(random) : shift(random);
        v1 = index_of.at(closure.from) + s;
        v2 = index_of.at(closure.to);
        measurement = closure.measurement;
        placed = v1 >= 0 && v1 <= last && v2 >= 0 && v2 <= last && std::abs(v2 - v1) >= 2;
      }
      if (!placed) return InvalidArgument("no true loop closure leaves room for a shifted group");
    }
    for (int k = 0; k < size; ++k) {
      Edge edge;
      edge.from = ids[static_cast<std::size_t>(v1 + k)];
      edge.to = ids[static_cast<std::size_t>(v2 + k)];
      edge.measurement = measurement;
      edge.information = first_loop_closure->information;
      edge.kind = EdgeKind::kObservation;
      RETURN_IF_ERROR(corrupted.graph.AddEdge(edge).status());
      corrupted.outliers.emplace_back(edge.from, edge.to);
    }
  }
  PoseGraph optimum = graph;
  RETURN_IF_ERROR(Optimize(optimum).status());
  for (std::size_t k = corrupted.first_outlier_edge; k < corrupted.graph.num_edges(); ++k) {
    corrupted.agrees_with_optimum.push_back(EdgeChi2(optimum, corrupted.graph.edges()[k]) <=
                                            kAgreesWithOptimumChi2);
  }
  return corrupted;
}

}  // namespace slamcore
