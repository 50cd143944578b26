// Range scans cast in a true home and drawn at a believed pose (see range_scan.h).
#include "range_scan.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace slamcore::internal {
namespace {

constexpr std::int8_t kOccupied = static_cast<std::int8_t>(CellState::kOccupied);
constexpr std::int8_t kUnknown = static_cast<std::int8_t>(CellState::kUnknown);

/// The cell of a world point, or −1 outside the grid.
std::int64_t CellOf(const OccupancyGrid& grid, double x, double y) {
  const double u = (x - grid.origin_x) / grid.resolution, v = (y - grid.origin_y) / grid.resolution;
  if (!(u >= 0.0) || !(v >= 0.0) || u >= grid.width || v >= grid.height) return -1;
  return static_cast<std::int64_t>(v) * grid.width + static_cast<std::int64_t>(u);
}

}  // namespace

ScanVotes::ScanVotes(const OccupancyGrid& frame)
    : frame_(frame), free_stamp_(frame.cells.size(), 0), hit_stamp_(frame.cells.size(), 0) {
  for (int k = 0; k < 2; ++k) {
    free_[k].assign(frame.cells.size(), 0);
    occupied_[k].assign(frame.cells.size(), 0);
  }
}

int ScanVotes::AddScan(const OccupancyGrid& world, const SE2& sensor_pose, const SE2& drawn_pose,
                       const RangeSensor& sensor, bool erroneous, std::mt19937_64& random) {
  ++scan_;
  const int source = erroneous ? 1 : 0;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> range_noise(0.0, sensor.range_noise_m);
  const double step = 0.5 * std::min(world.resolution, frame_.resolution);
  const bool all_round = sensor.field_of_view >= 2.0 * std::numbers::pi;
  const double fov = all_round ? 2.0 * std::numbers::pi : sensor.field_of_view;
  // Beams close enough that neighbouring beams' ends are less than a cell apart at full range.
  const int beams =
      std::max(8, static_cast<int>(std::ceil(fov * sensor.range_m / (0.7 * frame_.resolution))));
  int voted = 0;
  auto vote = [&](double local_x, double local_y, bool hit) {
    const Vector2 drawn = drawn_pose * Vector2(local_x, local_y);
    const std::int64_t cell = CellOf(frame_, drawn.x(), drawn.y());
    if (cell < 0) return;
    const auto index = static_cast<std::size_t>(cell);
    // One vote of each kind per scan and cell: a beam's hit may land on a cell another beam passed.
    auto& stamp = hit ? hit_stamp_[index] : free_stamp_[index];
    if (stamp == scan_) return;
    if (free_stamp_[index] != scan_ && hit_stamp_[index] != scan_) ++voted;
    stamp = scan_;
    auto& votes = hit ? occupied_[source][index] : free_[source][index];
    if (votes < 0xFFFF) ++votes;
  };
  for (int beam = 0; beam < beams; ++beam) {
    if (unit(random) < sensor.dropout) continue;
    const double bearing = all_round ? fov * beam / beams : -0.5 * fov + fov * (beam + 0.5) / beams;
    const double c = std::cos(bearing), s = std::sin(bearing);
    const Vector2 direction = sensor_pose.rotation() * Vector2(c, s);
    for (double r = 0.0; r <= sensor.range_m; r += step) {
      const Vector2 point = sensor_pose.translation() + r * direction;
      const std::int64_t cell = CellOf(world, point.x(), point.y());
      const std::int8_t state = cell < 0 ? kUnknown : world.cells[static_cast<std::size_t>(cell)];
      if (state == kUnknown) break;  // outside the home: no return
      if (state == kOccupied) {
        const double measured = std::max(0.0, r + range_noise(random));
        vote(measured * c, measured * s, true);
        break;
      }
      vote(r * c, r * s, false);
    }
  }
  return voted;
}

std::int8_t ScanVotes::Resolve(std::size_t cell) const {
  return static_cast<std::int8_t>(CellFromVotes(Occupied(cell), Free(cell)));
}

}  // namespace slamcore::internal
