// How healthy a robot's map is against the simulator's ground truth (docs/fleetsim.md, "Map health"): the
// trajectory error of its nodes, the area of false free space (cells the map's home component calls free
// where the home has walls or nothing at all: protrusions, rooms drawn twice by a wrong merge), and its
// components. A map is corrupted past a documented threshold on error or false area.
//
// Thread safety: a MapHealthMeter is immutable after construction; Measure may be called from any thread.
#pragma once

#include <optional>
#include <unordered_map>
#include <vector>

#include "sim/world.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"

namespace sim {

/// The corruption threshold, fixed before any lifelong run was measured: a robot vacuum whose map is off by
/// more than its own width (0.35 m) on average plans through walls and cleans rooms twice; a square metre
/// of false floor is a protrusion of the size the paper shows (its Fig. 11), or a duplicated corner.
struct CorruptionThreshold {
  double trajectory_rmse_m = 0.35;
  double false_free_m2 = 1.0;
};

struct MapHealth {
  double trajectory_rmse_m = 0.0;  // componentwise aligned RMS position error of the map's nodes
  double false_free_m2 = 0.0;  // free in the home component's grid, farther than the margin from true floor
  /// The home's true floor that the home component's grid calls free: what a repair that cut real floor
  /// takes away (health counts false floor only; this is the other side of the ledger).
  double known_floor_m2 = 0.0;
  double home_floor_m2 = 0.0;  // the home's true floor, which known_floor_m2 is a share of
  int components = 0;
  bool corrupted = false;
};

class MapHealthMeter {
 public:
  /// `margin_m`: free cells this close to true floor are rendering noise (a wall's thickness), not false space.
  explicit MapHealthMeter(const World& world, CorruptionThreshold threshold = {}, double margin_m = 0.15);

  /// The map's health; node poses are compared with `truth` (nodes without truth are skipped). The home
  /// component is placed in the world by aligning its nodes with their truth.
  slamcore::Result<MapHealth> Measure(const slamcore::Map& map,
                                      const std::unordered_map<slamcore::NodeId, SE2>& truth) const;

  /// Per cell of `grid` (a rendering of `map`'s home component, in the map's frame), 1 where it is floor
  /// the world does not have within the margin, the component placed as Measure places it; empty when
  /// fewer than two home nodes carry truth.
  slamcore::Result<std::vector<std::uint8_t>> FalseFloor(
      const slamcore::Map& map, const std::unordered_map<slamcore::NodeId, SE2>& truth,
      const slamcore::OccupancyGrid& grid) const;

  const CorruptionThreshold& threshold() const { return threshold_; }
  /// The home's true floor area (its free cells).
  double floor_m2() const { return floor_m2_; }

 private:
  bool NearFloor(const Vector2& point) const;
  /// The transform placing the home component in the world (its nodes aligned with their truth), or
  /// nothing when fewer than two of its nodes carry truth.
  slamcore::Result<std::optional<SE2>> PlaceHome(
      const slamcore::Map& map, const std::unordered_map<slamcore::NodeId, SE2>& truth) const;

  const World& world_;
  CorruptionThreshold threshold_;
  int reach_ = 0;                         // the margin in world cells
  std::vector<std::uint8_t> near_floor_;  // per world cell: true floor within the margin
  double floor_m2_ = 0.0;
};

}  // namespace sim
