// Map health against a hand-made home: the known true floor and the false floor of a two-node map whose
// patches are counted cell by cell.
#include "sim/map_health.h"

#include <gtest/gtest.h>

#include "status_matchers.h"

namespace sim {
namespace {

using slamcore::CellState;
using slamcore::LocalMapEvent;

// A free square patch, `side` cells of 5 cm, its corner at the node.
LocalMapEvent FreePatch(int side) {
  LocalMapEvent patch;
  patch.resolution = 0.05;
  patch.width = side;
  patch.height = side;
  patch.cells.assign(static_cast<std::size_t>(side) * side, static_cast<std::int8_t>(CellState::kFree));
  return patch;
}

TEST(MapHealthTest, CountsTheTrueFloorTheMapKnowsAndTheFloorItInvents) {
  // A 5 m × 3 m home whose right half (x ≥ 2.5 m) is solid: 7.5 m² of floor.
  World world;
  world.grid = Grid(100, 60, 0.05, Vector2::Zero(), Cell::kFree);
  for (int j = 0; j < 60; ++j) {
    for (int i = 50; i < 100; ++i) world.grid.set(i, j, Cell::kOccupied);
  }
  const MapHealthMeter meter(world);
  EXPECT_NEAR(meter.floor_m2(), 7.5, 1e-9);

  // Two nodes where the truth has them, each drawing 1 m × 1 m of floor from its corner: the first at
  // x ∈ [1, 2) (all true floor), the second at x ∈ [2, 3) (half true floor, half inside the solid part).
  slamcore::Map map;
  ASSERT_THAT(map.graph.AddNode({.id = 0, .pose = SE2(1.0, 1.0, 0.0)}), IsOk());
  ASSERT_THAT(map.graph.AddNode({.id = 1, .pose = SE2(2.0, 1.0, 0.0)}), IsOk());
  ASSERT_THAT(map.graph.AddEdge({.from = 0, .to = 1, .measurement = SE2(1.0, 0.0, 0.0)}), IsOk());
  map.local_maps[0] = FreePatch(20);
  map.local_maps[1] = FreePatch(20);
  const std::unordered_map<slamcore::NodeId, SE2> truth = {{0, SE2(1.0, 1.0, 0.0)}, {1, SE2(2.0, 1.0, 0.0)}};

  const auto health = meter.Measure(map, truth);
  ASSERT_THAT(health, IsOk());
  // 400 + 200 true floor cells of 25 cm² under the map's free cells.
  EXPECT_NEAR(health->known_floor_m2, 1.5, 1e-6);
  EXPECT_NEAR(health->home_floor_m2, 7.5, 1e-9);
  // Beyond the 0.15 m margin of the true floor: x ∈ [2.65, 3), 7 columns of 20 cells.
  EXPECT_NEAR(health->false_free_m2, 0.35, 1e-6);
  EXPECT_NEAR(health->trajectory_rmse_m, 0.0, 1e-9);
  EXPECT_FALSE(health->corrupted);
}

}  // namespace
}  // namespace sim
