#include "slamcore/loop_closure_outliers.h"

#include <algorithm>
#include <numbers>
#include <random>

namespace slamcore {

Result<CorruptedGraph> AddLoopClosureOutliers(const PoseGraph& graph, const OutlierOptions& options) {
  if (options.count < 0 || options.group_size < 1 || options.local_window < 2) {
    return InvalidArgument("outlier options: count >= 0, group_size >= 1 and local_window >= 2 are required");
  }
  const auto first_loop_closure = std::find_if(graph.edges().begin(), graph.edges().end(),
                                               [](const Edge& edge) { return edge.kind == EdgeKind::kObservation; });
  if (first_loop_closure == graph.edges().end()) {
    return InvalidArgument("the graph has no loop closure to copy the outliers' information from");
  }
  std::vector<NodeId> ids;
  for (const Node& node : graph.nodes()) ids.push_back(node.id);
  std::sort(ids.begin(), ids.end());
  const long last = static_cast<long>(ids.size()) - 1 - options.group_size;  // v + group_size stays inside
  if (last < 3) return InvalidArgument("the graph has too few vertices for outlier groups of this size");

  std::mt19937_64 random(options.seed);
  std::uniform_int_distribution<long> any_vertex(0, last);
  std::normal_distribution<double> translation(0.0, 0.3), rotation(0.0, 10.0 * std::numbers::pi / 180.0);

  CorruptedGraph corrupted{graph, {}};
  for (int group = 0; group < options.count; ++group) {
    long v1 = any_vertex(random), v2;
    if (options.mode == OutlierOptions::Mode::kRandom) {
      do { v2 = any_vertex(random); } while (v2 == v1);
    } else {
      std::uniform_int_distribution<long> nearby(v1, std::min(last, v1 + options.local_window));
      do { v2 = nearby(random); } while (v2 == v1 && v1 < last);
      if (v2 == v1) v2 = v1 - 2;  // v1 is the last usable vertex: look back instead
    }
    if (v2 < v1) std::swap(v1, v2);
    if (v2 == v1 + 1) v2 = v1 + 2;  // never an odometry pair
    const SE2 measurement(translation(random), translation(random), rotation(random));
    for (int k = 0; k < options.group_size; ++k) {
      Edge edge;
      edge.from = ids[static_cast<std::size_t>(v1 + k)];
      edge.to = ids[static_cast<std::size_t>(v2 + k)];
      edge.measurement = measurement;
      edge.information = first_loop_closure->information;
      edge.kind = EdgeKind::kObservation;
      const auto added = corrupted.graph.AddEdge(edge);
      if (!added.ok()) return added.status();
      corrupted.outliers.emplace_back(edge.from, edge.to);
    }
  }
  return corrupted;
}

}  // namespace slamcore
