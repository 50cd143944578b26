#include "sim/map_health.h"

#include <algorithm>
#include <cmath>

#include "analyzer/map_repair.h"
#include "analyzer/run_analysis.h"
#include "slamcore/trajectory_error.h"

namespace sim {
namespace {

// Calls visit(col, row, centre in the world) for each free cell of `grid`, the map placed by world_T_map.
template <typename Visit>
void ForEachFreeCell(const slamcore::OccupancyGrid& grid, const SE2& world_T_map, const Visit& visit) {
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      if (grid.at(col, row) != static_cast<std::int8_t>(slamcore::CellState::kFree)) continue;
      const Vector2 in_map(grid.origin_x + (col + 0.5) * grid.resolution,
                           grid.origin_y + (row + 0.5) * grid.resolution);
      visit(col, row, world_T_map * in_map);
    }
  }
}

}  // namespace

MapHealthMeter::MapHealthMeter(const World& world, CorruptionThreshold threshold, double margin_m)
    : world_(world), threshold_(threshold) {
  const Grid& grid = world.grid;
  reach_ = std::max(0, static_cast<int>(std::ceil(margin_m / grid.resolution())));
  const int reach = reach_;
  long floor_cells = 0;
  for (int j = 0; j < grid.height(); ++j) {
    for (int i = 0; i < grid.width(); ++i) floor_cells += grid.at(i, j) == Cell::kFree ? 1 : 0;
  }
  floor_m2_ = static_cast<double>(floor_cells) * grid.resolution() * grid.resolution();
  near_floor_.assign(static_cast<std::size_t>(grid.width()) * static_cast<std::size_t>(grid.height()), 0);
  // Dilate the true floor by the margin: rows first, then columns (a square neighbourhood).
  std::vector<std::uint8_t> rows(near_floor_.size(), 0);
  for (int j = 0; j < grid.height(); ++j) {
    for (int i = 0; i < grid.width(); ++i) {
      if (grid.at(i, j) != Cell::kFree) continue;
      for (int d = -reach; d <= reach; ++d) {
        if (grid.Contains(i + d, j)) rows[static_cast<std::size_t>(j) * grid.width() + (i + d)] = 1;
      }
    }
  }
  for (int j = 0; j < grid.height(); ++j) {
    for (int i = 0; i < grid.width(); ++i) {
      if (!rows[static_cast<std::size_t>(j) * grid.width() + i]) continue;
      for (int d = -reach; d <= reach; ++d) {
        if (grid.Contains(i, j + d)) near_floor_[static_cast<std::size_t>(j + d) * grid.width() + i] = 1;
      }
    }
  }
}

bool MapHealthMeter::NearFloor(const Vector2& point) const {
  const Grid& grid = world_.grid;
  const auto [i, j] = grid.CellOf(point);
  // Beyond the home's grid: near floor only within the margin of its edge (where the nearest cell decides).
  const int ci = std::clamp(i, 0, grid.width() - 1), cj = std::clamp(j, 0, grid.height() - 1);
  if (std::max(std::abs(i - ci), std::abs(j - cj)) > reach_) return false;
  return near_floor_[static_cast<std::size_t>(cj) * grid.width() + ci] != 0;
}

slamcore::Result<MapHealth> MapHealthMeter::Measure(
    const slamcore::Map& map, const std::unordered_map<slamcore::NodeId, SE2>& truth) const {
  MapHealth health;
  health.home_floor_m2 = floor_m2_;
  if (map.graph.num_nodes() == 0) return health;
  health.components = static_cast<int>(analyzer::ComputeFigures(map).components);
  int compared = 0;
  health.trajectory_rmse_m = analyzer::ComponentwiseRmse(map.graph, truth, &compared).value_or(0.0);

  ASSIGN_OR_RETURN(const auto grid, analyzer::RenderHomeGrid(map));
  ASSIGN_OR_RETURN(const std::optional<SE2> world_T_map, PlaceHome(map, truth));
  if (world_T_map) {
    // One pass over the map's free cells: those away from true floor (false floor), and the true floor under
    // them, each world cell once.
    const Grid& world = world_.grid;
    std::vector<std::uint8_t> known(static_cast<std::size_t>(world.width()) * world.height(), 0);
    long false_cells = 0, known_cells = 0;
    ForEachFreeCell(grid, *world_T_map, [&](int, int, const Vector2& in_world) {
      if (!NearFloor(in_world)) ++false_cells;
      const auto [i, j] = world.CellOf(in_world);
      if (world.at(i, j) != Cell::kFree) return;
      std::uint8_t& seen = known[static_cast<std::size_t>(j) * world.width() + i];
      known_cells += seen ? 0 : 1;
      seen = 1;
    });
    health.false_free_m2 = static_cast<double>(false_cells) * grid.resolution * grid.resolution;
    health.known_floor_m2 = static_cast<double>(known_cells) * world.resolution() * world.resolution();
  }
  health.corrupted = health.trajectory_rmse_m > threshold_.trajectory_rmse_m ||
                     health.false_free_m2 > threshold_.false_free_m2;
  return health;
}

slamcore::Result<std::vector<std::uint8_t>> MapHealthMeter::FalseFloor(
    const slamcore::Map& map, const std::unordered_map<slamcore::NodeId, SE2>& truth,
    const slamcore::OccupancyGrid& grid) const {
  std::vector<std::uint8_t> false_floor;
  ASSIGN_OR_RETURN(const std::optional<SE2> world_T_map, PlaceHome(map, truth));
  if (!world_T_map) return false_floor;
  false_floor.assign(grid.cells.size(), 0);
  ForEachFreeCell(grid, *world_T_map, [&](int col, int row, const Vector2& in_world) {
    if (!NearFloor(in_world)) false_floor[static_cast<std::size_t>(row) * grid.width + col] = 1;
  });
  return false_floor;
}

slamcore::Result<std::optional<SE2>> MapHealthMeter::PlaceHome(
    const slamcore::Map& map, const std::unordered_map<slamcore::NodeId, SE2>& truth) const {
  if (map.graph.num_nodes() == 0) return std::optional<SE2>();
  const slamcore::ComponentId home = analyzer::HomeComponent(map.graph);
  std::vector<Vector2> estimate, reference;
  for (const auto& [node, pose] : truth) {
    if (!map.graph.HasNode(node) || map.graph.ComponentOf(node) != home) continue;
    estimate.push_back(map.graph.node(node).pose.translation());
    reference.push_back(pose.translation());
  }
  if (estimate.size() < 2) return std::optional<SE2>();
  ASSIGN_OR_RETURN(const SE2 world_T_map, slamcore::AlignRigidly(estimate, reference));
  return std::optional<SE2>(world_T_map);
}

}  // namespace sim
