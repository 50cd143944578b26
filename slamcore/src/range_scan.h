// A range sensor drawn into an occupancy grid: what the protrusion data generator uses to make child
// maps the way a robot makes them (paper IV-C). A scan is cast in the TRUE home from where the sensor
// really is and drawn at the pose the robot BELIEVES it has; for a stuck robot the two differ, and the
// scan's copy of the real surroundings lands in the wrong place (the protrusion).
//
// Votes follow GlobalGridRenderer's cell rule (occupancy_grid.h): a cell with an occupied vote and occupied
// votes at least half its free votes is occupied, otherwise free. The renderer's withdrawal of a patch's
// votes past an agreed wall is not modelled (docs/protrusion-data.md). Votes from erroneous poses and from
// true poses are kept apart, so every changed cell can be labelled by what made it.
//
// Thread safety: value types; one ScanVotes per thread.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "slamcore/occupancy_grid.h"
#include "slamcore/se2.h"

namespace slamcore::internal {

struct RangeSensor {
  double range_m = 1.5;
  double field_of_view = 2.0;   // radians centred ahead; ≥ 2π is a rotating lidar
  double range_noise_m = 0.01;  // σ of each hit's range
  double dropout = 0.03;        // share of beams that return nothing
};

/// Free/occupied votes per cell of a grid the scans are drawn into (same geometry as `frame`).
class ScanVotes {
 public:
  explicit ScanVotes(const OccupancyGrid& frame);

  /// Casts `sensor` in `world` from `sensor_pose` (beams stop at the first occupied cell, and end without
  /// a hit on unknown cells or at the range) and votes along each beam as seen from `drawn_pose`.
  /// `erroneous` marks the votes as coming from a wrong pose. Returns the number of cells voted.
  int AddScan(const OccupancyGrid& world, const SE2& sensor_pose, const SE2& drawn_pose,
              const RangeSensor& sensor, bool erroneous, std::mt19937_64& random);

  bool Voted(std::size_t cell) const { return Free(cell) + Occupied(cell) > 0; }
  int Free(std::size_t cell) const { return free_[0][cell] + free_[1][cell]; }
  int Occupied(std::size_t cell) const { return occupied_[0][cell] + occupied_[1][cell]; }
  /// True when most of the cell's votes came from erroneous poses.
  bool MostlyErroneous(std::size_t cell) const {
    return free_[1][cell] + occupied_[1][cell] > free_[0][cell] + occupied_[0][cell];
  }
  /// The cell's state from its votes alone (the renderer's rule); unknown without votes.
  std::int8_t Resolve(std::size_t cell) const;

 private:
  const OccupancyGrid& frame_;
  std::vector<std::uint16_t> free_[2], occupied_[2];
  std::vector<std::uint32_t> free_stamp_, hit_stamp_;  // the last scan that voted a cell free / occupied
  std::uint32_t scan_ = 0;
};

}  // namespace slamcore::internal
