#include "sim/sensor.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace sim {

RangeSensor DrawSensor(const SimParams& params, std::mt19937_64& random) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  RangeSensor sensor;
  if (unit(random) < params.lidar_share) {
    sensor.model = kLidarModel;
    sensor.range = params.lidar_min_range + (params.lidar_max_range - params.lidar_min_range) * unit(random);
    sensor.field_of_view = 2 * std::numbers::pi;
    sensor.rays = 360;
    sensor.resolution = 0.10;
    sensor.free_range = params.lidar_free_range;
  } else {
    sensor.model = kTofModel;
    sensor.range = params.tof_min_range + (params.tof_max_range - params.tof_min_range) * unit(random);
    sensor.field_of_view = params.tof_field_of_view;
    // About 2.5° apart: at 1.5 m the rays are 6.5 cm apart, about a cell.
    sensor.rays =
        std::max(8, static_cast<int>(std::ceil(sensor.field_of_view / (2.5 * std::numbers::pi / 180))));
  }
  return sensor;
}

slamcore::LocalMapEvent ScanAt(const Grid& grid, const SE2& world_T_robot, const RangeSensor& sensor,
                               double robot_radius, double time) {
  const double resolution = sensor.resolution;
  const double reach = std::max(sensor.range, robot_radius) + resolution;
  const int size = static_cast<int>(std::ceil(2.0 * reach / resolution));
  std::vector<std::int8_t> square(static_cast<std::size_t>(size) * size, -1);
  auto mark = [&](const Vector2& in_robot, std::int8_t value) {
    const int col = static_cast<int>(std::floor((in_robot.x() + reach) / resolution));
    const int row = static_cast<int>(std::floor((in_robot.y() + reach) / resolution));
    if (col < 0 || row < 0 || col >= size || row >= size) return;
    std::int8_t& cell = square[static_cast<std::size_t>(row) * size + col];
    if (cell != 100) cell = value;
  };
  const bool all_around = sensor.field_of_view >= 2 * std::numbers::pi - 1e-9;
  const double step = 0.5 * std::min(resolution, grid.resolution());
  for (int k = 0; k < sensor.rays; ++k) {
    const double angle =
        all_around ? 2 * std::numbers::pi * k / sensor.rays
                   : -0.5 * sensor.field_of_view + sensor.field_of_view * k / std::max(1, sensor.rays - 1);
    const double range =
        grid.CastRay(world_T_robot.translation(), world_T_robot.theta() + angle, sensor.range);
    const Vector2 direction(std::cos(angle), std::sin(angle));
    const double free_to = sensor.free_range > 0.0 ? std::min(range, sensor.free_range) : range;
    for (double d = 0.0; d < free_to; d += step) mark(d * direction, 0);
    if (range < sensor.range) mark((range + step) * direction, 100);
  }
  for (double dx = -robot_radius; dx <= robot_radius; dx += step) {
    for (double dy = -robot_radius; dy <= robot_radius; dy += step) {
      if (std::hypot(dx, dy) <= robot_radius) mark(Vector2(dx, dy), 0);
    }
  }
  // Crop to the known cells: a lidar in a small room sees the room, not its whole range.
  int min_col = size, min_row = size, max_col = -1, max_row = -1;
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) {
      if (square[static_cast<std::size_t>(row) * size + col] == -1) continue;
      min_col = std::min(min_col, col), max_col = std::max(max_col, col);
      min_row = std::min(min_row, row), max_row = std::max(max_row, row);
    }
  }
  slamcore::LocalMapEvent patch;
  patch.time = time;
  patch.resolution = resolution;
  patch.width = max_col - min_col + 1;
  patch.height = max_row - min_row + 1;
  patch.node_T_origin = SE2(-reach + min_col * resolution, -reach + min_row * resolution, 0.0);
  patch.cells.reserve(static_cast<std::size_t>(patch.width) * patch.height);
  for (int row = min_row; row <= max_row; ++row) {
    for (int col = min_col; col <= max_col; ++col)
      patch.cells.push_back(square[static_cast<std::size_t>(row) * size + col]);
  }
  return patch;
}

}  // namespace sim
