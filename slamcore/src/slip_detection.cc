// Wheel slip from the map's own views: the path through a seen wall, and the view that stood still (see
// the header).
#include "slamcore/slip_detection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <span>
#include <string>

#include "slamcore/occupancy_grid.h"

namespace slamcore {
namespace {

constexpr std::int8_t kOccupiedFrom = 50;  // a patch cell at or above this is a wall (as the renderer votes)
constexpr double kShadowDepthM = 0.15;     // how far past a wall the view must have seen nothing
constexpr double kShortestJudgedStepM = 0.15;  // three cells: beyond WallAgreement's one-cell tolerance
constexpr double kPathStepM = 0.1;             // placements along the claimed motion, this far apart
constexpr int kMaxPathSteps = 40;              // and at most this many: the work per view is bounded
constexpr std::size_t kMaxWallPoints = 4096;   // walls of a view judged (WallPoints)

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

/// The centres of `patch`'s wall cells in its node frame: a view's walls, taken once for the many
/// placements a judgement tries. At most kMaxWallPoints of them, evenly spaced in row order: agreement is a
/// share, and an uploaded patch may hold millions of wall cells (2048² at most), which every placement
/// would otherwise visit.
std::vector<Vector2> WallPoints(const LocalMapEvent& patch) {
  const auto is_wall = [&](std::size_t cell) { return patch.cells[cell] >= kOccupiedFrom; };
  std::size_t count = 0;
  for (std::size_t cell = 0; cell < patch.cells.size(); ++cell) count += is_wall(cell);
  const std::size_t kept = std::min(count, kMaxWallPoints);
  std::vector<Vector2> points;
  points.reserve(kept);
  for (std::size_t cell = 0, seen = 0; cell < patch.cells.size(); ++cell) {
    if (!is_wall(cell)) continue;
    // The seen-th wall is kept when it starts a new 1/kept share of them (all of them when kept == count).
    if ((seen * kept) / count != ((seen + 1) * kept) / count) {
      const auto col = static_cast<double>(cell % static_cast<std::size_t>(patch.width));
      const auto row = static_cast<double>(cell / static_cast<std::size_t>(patch.width));
      points.push_back(patch.node_T_origin *
                       Vector2((col + 0.5) * patch.resolution, (row + 0.5) * patch.resolution));
    }
    ++seen;
  }
  return points;
}

/// How many of a view's walls land on another view's known cells, and how many of those on (within one cell
/// of) its walls.
struct WallCounts {
  int landed = 0, agreeing = 0;
  double share() const { return landed > 0 ? static_cast<double>(agreeing) / landed : 0.0; }
};

/// WallAgreement's counts, for the later view's walls given as points in its node frame.
WallCounts CountAgreement(const LocalMapEvent& earlier, std::span<const Vector2> later_walls,
                          const SE2& earlier_T_later) {
  // One transform from the later node's frame to the earlier patch's cell frame, applied to every point.
  const SE2 origin_T_later = earlier.node_T_origin.inverse() * earlier_T_later;
  const Matrix2 rotation = origin_T_later.rotation();
  const Vector2 translation = origin_T_later.translation();
  WallCounts counts;
  for (const Vector2& wall : later_walls) {
    const Vector2 local = rotation * wall + translation;
    const int earlier_col = static_cast<int>(std::floor(local.x() / earlier.resolution));
    const int earlier_row = static_cast<int>(std::floor(local.y() / earlier.resolution));
    if (PatchCell(earlier, earlier_col, earlier_row) < 0) continue;  // unseen there: no judgement
    ++counts.landed;
    bool wall_near = false;
    for (int dr = -1; dr <= 1 && !wall_near; ++dr) {
      for (int dc = -1; dc <= 1 && !wall_near; ++dc)
        wall_near = PatchCell(earlier, earlier_col + dc, earlier_row + dr) >= kOccupiedFrom;
    }
    counts.agreeing += wall_near;
  }
  return counts;
}

/// Each view's walls against the other's, pooled: a view placed past a wall the other saw head-on puts its
/// own wall in the other's shadow (no judgement), but the other's wall on its own floor.
WallCounts CountBothWays(const LocalMapEvent& earlier, std::span<const Vector2> earlier_walls,
                         const LocalMapEvent& later, std::span<const Vector2> later_walls,
                         const SE2& earlier_T_later) {
  const WallCounts forward = CountAgreement(earlier, later_walls, earlier_T_later);
  const WallCounts backward = CountAgreement(later, earlier_walls, earlier_T_later.inverse());
  return {.landed = forward.landed + backward.landed, .agreeing = forward.agreeing + backward.agreeing};
}

/// Where `later`'s view says its node stood, in `earlier`'s node frame, when that is short of where odometry
/// moved it (`earlier_T_later`) — the header's "view that stood still", for a robot that may have moved part
/// of the way before its wheels lost grip. The view is placed at steps along the claimed motion (turned as
/// odometry says at that point of it, or by the whole claimed turn: a wedged robot may still turn in place);
/// a placement is judged when at least `min_wall_cells` walls land (both ways, CountBothWays). A slip is
/// claimed when the best-agreeing placement agrees well, lies at least `min_still_motion_m` short of the
/// odometry's end, and the farthest judged placement beyond it disagrees by the margin: that placement asks
/// whether the view's structure along the motion could have told a move at all, so a featureless wall or
/// corridor along the motion claims nothing.
std::optional<SE2> StoodShort(const LocalMapEvent& earlier, std::span<const Vector2> earlier_walls,
                              const LocalMapEvent& later, std::span<const Vector2> later_walls,
                              const SE2& earlier_T_later, const SlipDetectionParams& params) {
  const double motion = earlier_T_later.translation().norm();
  if (motion < params.min_still_motion_m) return std::nullopt;
  const int steps = std::min(kMaxPathSteps, static_cast<int>(std::ceil(motion / kPathStepM)));
  struct Placement {
    SE2 pose;
    double agreement = -1.0;  // −1: not judged (too few walls landed)
  };
  std::vector<Placement> along(static_cast<std::size_t>(steps) + 1);
  for (int k = 0; k <= steps; ++k) {
    const double fraction = static_cast<double>(k) / steps;
    const Vector2 position = fraction * earlier_T_later.translation();
    Placement& best = along[static_cast<std::size_t>(k)];
    best.pose = SE2(position, fraction * earlier_T_later.theta());  // where it lies, judged or not
    for (const double turn : {fraction * earlier_T_later.theta(), earlier_T_later.theta()}) {
      const SE2 pose(position, turn);
      const WallCounts counts = CountBothWays(earlier, earlier_walls, later, later_walls, pose);
      if (counts.landed >= params.min_wall_cells && counts.share() > best.agreement)
        best = {pose, counts.share()};
    }
  }
  std::size_t stood = 0;  // the first of a tie: the one nearest the earlier view
  for (std::size_t k = 1; k < along.size(); ++k) {
    if (along[k].agreement > along[stood].agreement) stood = k;
  }
  const Placement& at = along[stood];
  if (at.agreement < params.min_still_agreement ||
      (earlier_T_later.translation() - at.pose.translation()).norm() < params.min_still_motion_m) {
    return std::nullopt;
  }
  for (std::size_t k = along.size() - 1; k > stood; --k) {
    if ((along[k].pose.translation() - at.pose.translation()).norm() < kShortestJudgedStepM) break;
    if (along[k].agreement < 0.0) continue;
    if (at.agreement - along[k].agreement >= params.min_agreement_margin) return at.pose;
    break;
  }
  return std::nullopt;
}

}  // namespace

ViewSlipJudge::ViewSlipJudge(const LocalMapEvent& view) : view_(&view), walls_(WallPoints(view)) {}

bool ViewSlipJudge::CrossesWall(const Vector2& from, const Vector2& to) const {
  return slamcore::CrossesWall(*view_, from, to);
}

std::optional<SE2> ViewSlipJudge::StoodShort(const ViewSlipJudge& later, const SE2& judge_T_later,
                                             const SlipDetectionParams& params) const {
  return slamcore::StoodShort(*view_, walls_, *later.view_, later.walls_, judge_T_later, params);
}

double WallAgreement(const LocalMapEvent& earlier, const LocalMapEvent& later, const SE2& earlier_T_later,
                     int* landed) {
  const WallCounts counts = CountAgreement(earlier, WallPoints(later), earlier_T_later);
  if (landed != nullptr) *landed = counts.landed;
  return counts.share();
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
    std::optional<ViewSlipJudge> reference;
    NodeId reference_node = 0;
    SE2 world_T_reference;
    double path_m = 0.0;
    bool through_wall = false;
    NodeId previous = start;
    for (NodeId node = start;;) {
      if (!walked.insert(node).second) break;  // a cycle of motion edges (a malformed map): stop there
      const SE2& pose = graph.node(node).pose;
      std::optional<ViewSlipJudge> view;
      if (const auto it = map.local_maps.find(node);
          it != map.local_maps.end() && ValidateLocalMap(node, it->second).ok())
        view.emplace(it->second);
      if (reference && node != start) {
        const SE2 reference_T_world = world_T_reference.inverse();
        const Vector2 from = reference_T_world * graph.node(previous).pose.translation();
        const Vector2 to = reference_T_world * pose.translation();
        path_m += (to - from).norm();
        through_wall = through_wall || reference->CrossesWall(from, to);
        if (through_wall) {
          findings.push_back({node, SlipEvidence::kPathThroughWall, reference_node, SE2()});
        } else if (view) {
          if (const auto stood = reference->StoodShort(*view, reference_T_world * pose, params))
            findings.push_back({node, SlipEvidence::kViewStoodStill, reference_node, *stood});
        }
        if (path_m > params.max_path_m) reference.reset();
      }
      if (view) {
        reference = std::move(view);
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
