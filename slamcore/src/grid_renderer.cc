// GlobalGridRenderer: the global occupancy grid from local patches at node poses (see occupancy_grid.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"

namespace slamcore {
namespace {

constexpr std::int8_t kFree = static_cast<std::int8_t>(CellState::kFree);
constexpr std::int8_t kOccupied = static_cast<std::int8_t>(CellState::kOccupied);
constexpr std::int8_t kUnknown = static_cast<std::int8_t>(CellState::kUnknown);

/// The world-frame corners of a patch placed at `node_pose`.
std::array<Vector2, 4> PatchCorners(const SE2& node_pose, const LocalMapEvent& patch) {
  const SE2 world_T_patch = node_pose * patch.node_T_origin;
  const double w = patch.width * patch.resolution, h = patch.height * patch.resolution;
  return {world_T_patch * Vector2(0, 0), world_T_patch * Vector2(w, 0), world_T_patch * Vector2(0, h),
          world_T_patch * Vector2(w, h)};
}

bool SamePose(const SE2& a, const SE2& b) {
  return a.x() == b.x() && a.y() == b.y() && a.theta() == b.theta();
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

Status GlobalGridRenderer::RenderAll(const Map& map) {
  ASSIGN_OR_RETURN(auto grid, Bounds(map));
  grid_ = std::move(grid);
  free_votes_.assign(grid_.cells.size(), 0);
  occupied_votes_.assign(grid_.cells.size(), 0);
  contributions_.clear();
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;
    Contribution contribution;
    Vote(map.graph.node(node).pose, patch, &contribution);  // always in bounds: bounds built from these poses
    Apply(contribution, +1);
    contributions_.emplace(node, std::move(contribution));
  }
  for (std::size_t cell = 0; cell < grid_.cells.size(); ++cell) Resolve(static_cast<std::int32_t>(cell));
  return Status::Ok();
}

Status GlobalGridRenderer::Update(const Map& map, int* nodes_rerendered) {
  if (nodes_rerendered) *nodes_rerendered = 0;
  if (grid_.cells.empty()) return RenderAll(map);
  std::vector<std::int32_t> touched;
  auto retire = [&](Contribution& old) {
    Apply(old, -1);
    touched.insert(touched.end(), old.cells.begin(), old.cells.end());
  };
  for (auto it = contributions_.begin(); it != contributions_.end();) {
    if (!map.local_maps.contains(it->first) || !map.graph.HasNode(it->first)) {
      retire(it->second);
      it = contributions_.erase(it);
      if (nodes_rerendered) ++*nodes_rerendered;
    } else {
      ++it;
    }
  }
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;
    const SE2& pose = map.graph.node(node).pose;
    auto existing = contributions_.find(node);
    if (existing != contributions_.end() && SamePose(existing->second.pose, pose) &&
        SamePose(existing->second.node_T_origin, patch.node_T_origin) &&
        existing->second.patch_width == patch.width && existing->second.patch_height == patch.height) {
      continue;
    }
    RETURN_IF_ERROR(ValidateLocalMap(node, patch));
    Contribution contribution;
    if (!Vote(pose, patch, &contribution)) return RenderAll(map);  // left the bounds: grow them
    if (existing != contributions_.end()) retire(existing->second);
    Apply(contribution, +1);
    touched.insert(touched.end(), contribution.cells.begin(), contribution.cells.end());
    contributions_[node] = std::move(contribution);
    if (nodes_rerendered) ++*nodes_rerendered;
  }
  for (const std::int32_t cell : touched) Resolve(cell);
  return Status::Ok();
}

namespace {

/// Calls visit(global cell, occupied) for every known patch cell's vote into `grid` (inverse mapping: each
/// global cell centre in the patch's bounding box is looked up in the patch, so rotations leave no holes);
/// false, visiting nothing, when the patch's bounding box leaves the grid.
template <typename Visit>
bool ForEachVote(const OccupancyGrid& grid, double resolution, const SE2& node_pose,
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
  if (!grid.InBounds(col0, row0) || !grid.InBounds(col1 - 1, row1 - 1)) return false;
  const SE2 patch_T_world = (node_pose * patch.node_T_origin).inverse();
  const double inverse_patch_resolution = 1.0 / patch.resolution;
  for (int row = row0; row < row1; ++row) {
    for (int col = col0; col < col1; ++col) {
      const Vector2 centre(grid.origin_x + (col + 0.5) * resolution,
                           grid.origin_y + (row + 0.5) * resolution);
      const Vector2 local = patch_T_world * centre;
      const int patch_col = static_cast<int>(std::floor(local.x() * inverse_patch_resolution));
      const int patch_row = static_cast<int>(std::floor(local.y() * inverse_patch_resolution));
      if (patch_col < 0 || patch_row < 0 || patch_col >= patch.width || patch_row >= patch.height) continue;
      const std::int8_t value = patch.cells[static_cast<std::size_t>(patch_row) * patch.width + patch_col];
      if (value < 0) continue;  // unknown cells do not vote
      visit(static_cast<std::int32_t>(static_cast<std::size_t>(row) * grid.width + col), value >= 50);
    }
  }
  return true;
}

}  // namespace

bool GlobalGridRenderer::Vote(const SE2& node_pose, const LocalMapEvent& patch,
                              Contribution* contribution) const {
  contribution->pose = node_pose;
  contribution->node_T_origin = patch.node_T_origin;
  contribution->patch_width = patch.width;
  contribution->patch_height = patch.height;
  return ForEachVote(grid_, resolution_, node_pose, patch, [&](std::int32_t cell, bool occupied) {
    contribution->cells.push_back(cell);
    contribution->occupied.push_back(occupied);
  });
}

Result<std::int64_t> GlobalGridRenderer::CountKnownCells(const Map& map) const {
  ASSIGN_OR_RETURN(const OccupancyGrid bounds, Bounds(map));
  // A cell RenderAll resolves is unknown exactly when no patch voted into it, free or occupied.
  std::vector<std::uint8_t> voted(bounds.cells.size(), 0);
  std::int64_t known = 0;
  for (const auto& [node, patch] : map.local_maps) {
    if (!map.graph.HasNode(node)) continue;
    ForEachVote(bounds, resolution_, map.graph.node(node).pose, patch, [&](std::int32_t cell, bool) {
      std::uint8_t& seen = voted[static_cast<std::size_t>(cell)];
      known += seen == 0 ? 1 : 0;
      seen = 1;
    });
  }
  return known;
}

void GlobalGridRenderer::Apply(const Contribution& contribution, int sign) {
  for (std::size_t i = 0; i < contribution.cells.size(); ++i) {
    auto& votes = contribution.occupied[i] ? occupied_votes_ : free_votes_;
    votes[static_cast<std::size_t>(contribution.cells[i])] += sign;
  }
}

void GlobalGridRenderer::Resolve(std::int32_t cell) {
  const auto index = static_cast<std::size_t>(cell);
  const std::int32_t occupied = occupied_votes_[index], free = free_votes_[index];
  std::int8_t value = kUnknown;
  if (occupied > 0 && 2 * occupied >= free) {
    value = kOccupied;
  } else if (free > 0) {
    value = kFree;
  }
  grid_.cells[index] = value;
}

}  // namespace slamcore
