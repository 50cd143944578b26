// Wheel slip from the map's own views: the path through a seen wall, and the view that stood still (see
// the header).
#include "slamcore/slip_detection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "slamcore/occupancy_grid.h"

namespace slamcore {
namespace {

constexpr std::int8_t kOccupiedFrom = 50;  // a patch cell at or above this is a wall (as the renderer votes)
constexpr double kShadowDepthM = 0.15;     // how far past a wall the view must have seen nothing

std::int8_t PatchCell(const LocalMapEvent& patch, int col, int row) {
  if (col < 0 || row < 0 || col >= patch.width || row >= patch.height) return -1;
  return patch.cells[static_cast<std::size_t>(row) * patch.width + col];
}

/// The cell of `patch` under `in_node` (a point in the patch's node frame).
std::pair<int, int> CellOf(const LocalMapEvent& patch, const Vector2& in_node) {
  const Vector2 local = patch.node_T_origin.inverse() * in_node;
  return {static_cast<int>(std::floor(local.x() / patch.resolution)),
          static_cast<int>(std::floor(local.y() / patch.resolution))};
}

/// Whether the segment from `from` to `to` (in `patch`'s node frame) passes through one of its walls into
/// the space behind it that the view did not see (a path grazing a door frame through a pose error comes
/// out on seen floor). Sampled at half a cell, so a one-cell wall cannot be stepped over.
bool CrossesWall(const LocalMapEvent& patch, const Vector2& from, const Vector2& to) {
  const double length = (to - from).norm();
  if (length <= 0.0) return false;
  const Vector2 direction = (to - from) / length;
  const double step = 0.5 * patch.resolution;
  for (double along = 0.0; along <= length + 1e-9; along += step) {
    const auto [col, row] = CellOf(patch, from + direction * along);
    if (PatchCell(patch, col, row) < kOccupiedFrom) continue;
    // Behind the wall: the first cell past it along the path that is not wall.
    double behind = along + step;
    for (;; behind += step) {
      const auto [next_col, next_row] = CellOf(patch, from + direction * behind);
      if (PatchCell(patch, next_col, next_row) < kOccupiedFrom) break;
    }
    const auto [shadow_col, shadow_row] = CellOf(patch, from + direction * (behind + kShadowDepthM));
    const auto [past_col, past_row] = CellOf(patch, from + direction * behind);
    if (PatchCell(patch, past_col, past_row) < 0 && PatchCell(patch, shadow_col, shadow_row) < 0) return true;
    along = behind;
  }
  return false;
}

Status Check(const SlipDetectionParams& params) {
  auto positive = [](double value, const char* name) -> Status {
    if (!(value > 0.0) || !std::isfinite(value)) {
      return InvalidArgument(std::string("slip detection: ") + name + " must be positive and finite");
    }
    return Status::Ok();
  };
  RETURN_IF_ERROR(positive(params.max_path_m, "max_path_m"));
  RETURN_IF_ERROR(positive(params.min_still_motion_m, "min_still_motion_m"));
  if (!(params.min_still_agreement > 0.0 && params.min_still_agreement <= 1.0)) {
    return InvalidArgument("slip detection: min_still_agreement must be in (0, 1]");
  }
  if (!(params.min_agreement_margin > 0.0 && params.min_agreement_margin <= 1.0)) {
    return InvalidArgument("slip detection: min_agreement_margin must be in (0, 1]");
  }
  if (params.min_wall_cells < 1) return InvalidArgument("slip detection: min_wall_cells must be at least 1");
  return Status::Ok();
}

}  // namespace

double WallAgreement(const LocalMapEvent& earlier, const LocalMapEvent& later, const SE2& earlier_T_later,
                     int* landed) {
  int count = 0, agreeing = 0;
  for (int row = 0; row < later.height; ++row) {
    for (int col = 0; col < later.width; ++col) {
      if (PatchCell(later, col, row) < kOccupiedFrom) continue;
      const Vector2 centre((col + 0.5) * later.resolution, (row + 0.5) * later.resolution);
      const auto [earlier_col, earlier_row] =
          CellOf(earlier, earlier_T_later * (later.node_T_origin * centre));
      if (PatchCell(earlier, earlier_col, earlier_row) < 0) continue;  // unseen there: no judgement
      ++count;
      bool wall_near = false;
      for (int dr = -1; dr <= 1 && !wall_near; ++dr) {
        for (int dc = -1; dc <= 1 && !wall_near; ++dc)
          wall_near = PatchCell(earlier, earlier_col + dc, earlier_row + dr) >= kOccupiedFrom;
      }
      agreeing += wall_near;
    }
  }
  if (landed != nullptr) *landed = count;
  return count > 0 ? static_cast<double>(agreeing) / count : 0.0;
}

Result<std::vector<SlipFinding>> FindSlipNodes(const Map& map, const SlipDetectionParams& params) {
  RETURN_IF_ERROR(Check(params));
  const PoseGraph& graph = map.graph;
  std::map<NodeId, NodeId> next;  // along motion edges; ordered, so chains are walked in id order
  std::set<NodeId> has_predecessor;
  for (const Edge& edge : graph.edges()) {
    if (edge.kind != EdgeKind::kMotion || edge.from == edge.to) continue;
    if (!graph.HasNode(edge.from) || !graph.HasNode(edge.to)) continue;
    if (const auto it = next.find(edge.from); it == next.end() || edge.to < it->second)
      next[edge.from] = edge.to;
    has_predecessor.insert(edge.to);
  }
  std::vector<SlipFinding> findings;
  std::set<NodeId> walked;
  for (const auto& [start, unused] : next) {
    if (has_predecessor.contains(start)) continue;
    // The last node with a view, where it stood, and the path walked since (in the world frame).
    const LocalMapEvent* reference = nullptr;
    NodeId reference_node = 0;
    SE2 world_T_reference;
    double path_m = 0.0;
    bool through_wall = false;
    NodeId previous = start;
    for (NodeId node = start;;) {
      if (!walked.insert(node).second) break;  // a cycle of motion edges (a malformed map): stop there
      const SE2& pose = graph.node(node).pose;
      const LocalMapEvent* view = nullptr;
      if (const auto it = map.local_maps.find(node);
          it != map.local_maps.end() && ValidateLocalMap(node, it->second).ok())
        view = &it->second;
      if (reference != nullptr && node != start) {
        const SE2 reference_T_world = world_T_reference.inverse();
        const Vector2 from = reference_T_world * graph.node(previous).pose.translation();
        const Vector2 to = reference_T_world * pose.translation();
        path_m += (to - from).norm();
        through_wall = through_wall || CrossesWall(*reference, from, to);
        if (through_wall) {
          findings.push_back({node, SlipEvidence::kPathThroughWall, reference_node});
        } else if (view != nullptr) {
          const SE2 reference_T_node = reference_T_world * pose;
          int landed_still = 0, landed_moved = 0;
          const double still = WallAgreement(*reference, *view, SE2(), &landed_still);
          const double moved = WallAgreement(*reference, *view, reference_T_node, &landed_moved);
          if (reference_T_node.translation().norm() >= params.min_still_motion_m &&
              landed_still >= params.min_wall_cells && landed_moved >= params.min_wall_cells &&
              still >= params.min_still_agreement && still - moved >= params.min_agreement_margin) {
            findings.push_back({node, SlipEvidence::kViewStoodStill, reference_node});
          }
        }
        if (path_m > params.max_path_m) reference = nullptr;
      }
      if (view != nullptr) {
        reference = view;
        reference_node = node;
        world_T_reference = pose;
        path_m = 0.0;
        through_wall = false;
      }
      const auto it = next.find(node);
      if (it == next.end()) break;
      previous = node;
      node = it->second;
    }
  }
  return findings;
}

}  // namespace slamcore
