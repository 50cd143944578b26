// GlobalGridRenderer: the global occupancy grid from local patches at node poses (see occupancy_grid.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"

namespace slamcore {
namespace {

/// The world-frame corners of a patch placed at `node_pose`.
std::array<Vector2, 4> PatchCorners(const SE2& node_pose, const LocalMapEvent& patch) {
  const SE2 world_T_patch = node_pose * patch.node_T_origin;
  const double w = patch.width * patch.resolution, h = patch.height * patch.resolution;
  return {world_T_patch * Vector2(0, 0), world_T_patch * Vector2(w, 0), world_T_patch * Vector2(0, h),
          world_T_patch * Vector2(w, h)};
}

}  // namespace

Status ValidateLocalMap(NodeId node, const LocalMapEvent& patch) {
  // Called for every patch a rendering or the slip detector reads: the message is built only on failure.
  const auto refuse = [&](const std::string& what) {
    return InvalidArgument("local map of node " + std::to_string(node) + ": " + what);
  };
  if (patch.width <= 0 || patch.height <= 0 || patch.width > kMaxGridSide || patch.height > kMaxGridSide) {
    return refuse("bad size " + std::to_string(patch.width) + " x " + std::to_string(patch.height));
  }
  if (patch.cells.size() != static_cast<std::size_t>(patch.width) * patch.height) {
    return refuse("cells do not match width x height");
  }
  if (!(patch.resolution > 0.0) || !std::isfinite(patch.resolution)) {
    return refuse("resolution must be positive");
  }
  return Status::Ok();
}

Result<OccupancyGrid> GlobalGridRenderer::Bounds(const Map& map) const {
  if (!(resolution_ > 0.0) || !std::isfinite(resolution_)) return InvalidArgument("renderer: bad resolution");
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x;
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;  // a patch of a removed node is not part of the map
    RETURN_IF_ERROR(ValidateLocalMap(node, patch));
    for (const Vector2& corner : PatchCorners(map.graph.node(node).pose, patch)) {
      if (!corner.allFinite())
        return InvalidArgument("node " + std::to_string(node) + ": pose is not finite");
      min_x = std::min(min_x, corner.x());
      min_y = std::min(min_y, corner.y());
      max_x = std::max(max_x, corner.x());
      max_y = std::max(max_y, corner.y());
    }
  }
  if (!std::isfinite(min_x)) return InvalidArgument("renderer: the map has no local maps at existing nodes");
  // Origin snapped to the resolution so that re-renders with grown bounds keep cells where they were.
  const double origin_x = std::floor((min_x - margin_m_) / resolution_) * resolution_;
  const double origin_y = std::floor((min_y - margin_m_) / resolution_) * resolution_;
  const double width = std::ceil((max_x + margin_m_ - origin_x) / resolution_);
  const double height = std::ceil((max_y + margin_m_ - origin_y) / resolution_);
  if (width > kMaxGridSide || height > kMaxGridSide || width * height > static_cast<double>(kMaxGridCells)) {
    return InvalidArgument("renderer: the map spans an absurd area (" + std::to_string(width) + " x " +
                           std::to_string(height) + " cells)");
  }
  return OccupancyGrid::Create(static_cast<int>(width), static_cast<int>(height), resolution_, origin_x,
                               origin_y);
}

namespace {

/// Calls visit(global cell, occupied, cell centre) for every known patch cell's vote into `grid` (inverse
/// mapping: each global cell centre the patch covers is looked up in the patch, so rotations leave no holes).
/// Visits nothing when the patch's bounding box leaves the grid (never within RenderAll's own bounds).
template <typename Visit>
void ForEachVote(const OccupancyGrid& grid, double resolution, const SE2& node_pose,
                 const LocalMapEvent& patch, Visit&& visit) {
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x;
  for (const Vector2& corner : PatchCorners(node_pose, patch)) {
    min_x = std::min(min_x, corner.x());
    min_y = std::min(min_y, corner.y());
    max_x = std::max(max_x, corner.x());
    max_y = std::max(max_y, corner.y());
  }
  const int col0 = static_cast<int>(std::floor((min_x - grid.origin_x) / resolution));
  const int row0 = static_cast<int>(std::floor((min_y - grid.origin_y) / resolution));
  const int col1 = static_cast<int>(std::ceil((max_x - grid.origin_x) / resolution));
  const int row1 = static_cast<int>(std::ceil((max_y - grid.origin_y) / resolution));
  if (!grid.InBounds(col0, row0) || !grid.InBounds(col1 - 1, row1 - 1)) return;
  // Patch coordinates (in patch cells) of a global cell centre are affine in its column and row: each
  // row's run of centres inside the patch is found by clipping, then walked by adding one column's step.
  const SE2 patch_T_world = (node_pose * patch.node_T_origin).inverse();
  const double inverse_patch_resolution = 1.0 / patch.resolution;
  const Vector2 origin_in_patch =
      inverse_patch_resolution *
      (patch_T_world * Vector2(grid.origin_x + 0.5 * resolution, grid.origin_y + 0.5 * resolution));
  const Vector2 column_step =
      inverse_patch_resolution * (patch_T_world.rotation() * Vector2(resolution, 0.0));
  const Vector2 row_step = inverse_patch_resolution * (patch_T_world.rotation() * Vector2(0.0, resolution));
  const double extent[2] = {static_cast<double>(patch.width), static_cast<double>(patch.height)};
  for (int row = row0; row < row1; ++row) {
    const Vector2 row_start = origin_in_patch + row * row_step;
    // Columns whose centre lies within [0, extent) on both patch axes, widened by one to stay safe
    // against rounding; the exact test is made per cell below.
    double from = col0, to = col1 - 1;
    for (int axis = 0; axis < 2; ++axis) {
      const double start = row_start[axis], step = column_step[axis];
      if (std::abs(step) < 1e-12) {
        if (start < -1e-9 || start > extent[axis] + 1e-9) from = to + 1;  // the whole row misses
        continue;
      }
      const double a = (0.0 - start) / step, b = (extent[axis] - start) / step;
      from = std::max(from, std::floor(std::min(a, b)) - 1.0);
      to = std::min(to, std::ceil(std::max(a, b)) + 1.0);
    }
    if (from > to) continue;
    Vector2 local = row_start + from * column_step;
    for (int col = static_cast<int>(from); col <= static_cast<int>(to); ++col, local += column_step) {
      if (local.x() < 0.0 || local.y() < 0.0) continue;
      const int patch_col = static_cast<int>(local.x()), patch_row = static_cast<int>(local.y());
      if (patch_col >= patch.width || patch_row >= patch.height) continue;
      const std::int8_t value = patch.cells[static_cast<std::size_t>(patch_row) * patch.width + patch_col];
      if (value < 0) continue;  // unknown cells do not vote
      const Vector2 centre(grid.origin_x + (col + 0.5) * resolution,
                           grid.origin_y + (row + 0.5) * resolution);
      visit(static_cast<std::int32_t>(static_cast<std::size_t>(row) * grid.width + col), value >= 50, centre);
    }
  }
}

/// A direction's position around the circle, in [0, 4): monotonic in its angle from +x (a quarter turn per
/// unit), without trigonometry. Its sectors are not of equal angle, which does not matter: crossings and
/// votes are sorted into them by the same function.
double PseudoAngle(const Vector2& direction) {
  const double length = std::abs(direction.x()) + std::abs(direction.y());
  if (length == 0.0) return 0.0;  // a cell centred on the node: any sector will do
  const double along = direction.x() / length;
  return direction.y() < 0 ? 3.0 + along : 1.0 - along;
}

/// Where one patch's rays crossed an agreed wall, by direction from the patch's node: in each of kSectors
/// sectors of the circle, the squared distance past which the patch's votes do not count.
class WallCrossings {
 public:
  static constexpr int kSectors = 2048;  // 0.11–0.22°: at 8 m a sector is at most 3 cm wide, under a cell

  explicit WallCrossings(double tolerance) : tolerance_(tolerance) {}

  void Reset() {
    limit_squared_.assign(kSectors, std::numeric_limits<double>::infinity());
    any_ = false;
  }
  bool any() const { return any_; }

  static int SectorOf(const Vector2& ray) {
    return std::min(kSectors - 1, static_cast<int>(PseudoAngle(ray) * (kSectors / 4.0)));
  }

  /// A free vote of the patch for the cell centred at `ray` from the node (a cell `cell_size` wide) lies on
  /// an agreed wall: every sector the cell spans is blocked from the cell's centre on.
  void Cross(const Vector2& ray, double cell_size) {
    const double distance = ray.norm();
    const double limit = distance + tolerance_;
    any_ = true;
    if (distance < cell_size) {  // the node stands on the wall: every ray crosses it
      for (double& sector : limit_squared_) sector = std::min(sector, limit * limit);
      return;
    }
    // The sectors of the cell's four corners; the span between them may wrap past +x.
    const double half = 0.5 * cell_size;
    int first = kSectors, last = -1;
    int corners[4];
    for (int k = 0; k < 4; ++k) {
      corners[k] = SectorOf(ray + Vector2(k & 1 ? half : -half, k & 2 ? half : -half));
      first = std::min(first, corners[k]);
      last = std::max(last, corners[k]);
    }
    // Across +x the corners lie at both ends of [0, kSectors): the span runs from those near its end round
    // through +x to those near its start.
    if (last - first > kSectors / 2) {
      int low_end = -1, high_start = kSectors;
      for (const int corner : corners) {
        if (corner < kSectors / 2)
          low_end = std::max(low_end, corner);
        else
          high_start = std::min(high_start, corner);
      }
      first = high_start;
      last = low_end;
    }
    for (int sector = first;; sector = (sector + 1) % kSectors) {
      limit_squared_[sector] = std::min(limit_squared_[sector], limit * limit);
      if (sector == last) break;
    }
  }

  /// Whether a vote for the cell centred at `ray` from the node lies past its sector's crossing.
  bool Beyond(const Vector2& ray) const { return ray.squaredNorm() > limit_squared_[SectorOf(ray)]; }

 private:
  double tolerance_;
  std::vector<double> limit_squared_;
  bool any_ = false;
};

}  // namespace

Status GlobalGridRenderer::RenderAll(const Map& map) {
  ASSIGN_OR_RETURN(auto grid, Bounds(map));
  grid_ = std::move(grid);
  std::vector<std::int32_t> free_votes(grid_.cells.size(), 0), occupied_votes(grid_.cells.size(), 0);
  // Bounds are built from these very poses, so no patch leaves the grid.
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;  // a patch of a removed node is not part of the map
    ForEachVote(grid_, resolution_, map.graph.node(node).pose, patch,
                [&](std::int32_t cell, bool occupied, const Vector2&) {
                  ++(occupied ? occupied_votes : free_votes)[static_cast<std::size_t>(cell)];
                });
  }
  std::vector<std::uint8_t> agreed_wall(grid_.cells.size(), 0);
  for (std::size_t cell = 0; cell < grid_.cells.size(); ++cell) {
    agreed_wall[cell] = occupied_votes[cell] >= kWallVotes &&
                        CellFromVotes(occupied_votes[cell], free_votes[cell]) == CellState::kOccupied;
  }
  // Each patch's votes past the agreed walls its rays crossed are withdrawn.
  struct PatchVote {
    std::int32_t cell;
    bool occupied;
    Vector2 ray;  // from the node to the cell's centre
  };
  std::vector<PatchVote> votes;
  WallCrossings crossings(kWallTolerance * resolution_);
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;
    const Vector2 sensor = map.graph.node(node).pose.translation();
    votes.clear();
    crossings.Reset();
    ForEachVote(grid_, resolution_, map.graph.node(node).pose, patch,
                [&](std::int32_t cell, bool occupied, const Vector2& centre) {
                  votes.push_back({cell, occupied, centre - sensor});
                  if (!occupied && agreed_wall[static_cast<std::size_t>(cell)]) {
                    crossings.Cross(votes.back().ray, resolution_);
                  }
                });
    if (!crossings.any()) continue;
    for (const PatchVote& vote : votes) {
      if (crossings.Beyond(vote.ray))
        --(vote.occupied ? occupied_votes : free_votes)[static_cast<std::size_t>(vote.cell)];
    }
  }
  for (std::size_t cell = 0; cell < grid_.cells.size(); ++cell) {
    grid_.cells[cell] = static_cast<std::int8_t>(CellFromVotes(occupied_votes[cell], free_votes[cell]));
  }
  return Status::Ok();
}

}  // namespace slamcore
