// Wheel slip seen in a map's own views (paper I and IV-C). A robot pressed against a wall, caught under
// furniture or lifted by a rug keeps turning its wheels: odometry carries its nodes on while its sensors
// keep seeing the one place it is stuck at. Two physical contradictions give such nodes away, whatever the
// sensor and however long the episode:
//  * the path through the wall: the nodes' estimated path runs through a cell that the view of an earlier
//    node of the same chain held as a wall (the robot cannot have gone there);
//  * the view that stood still: placed along the motion odometry claims since the view before it, a view
//    agrees best short of where odometry put it (at the earlier node's place, or where the robot was when
//    its wheels lost grip), and disagrees beyond: it did not move on. Agreement is counted both ways (each
//    view's walls on the other's), so a short-range view of a wall ahead is judged too.
// Where neither can be seen (open floor with a short-range sensor, a featureless corridor along the
// motion) nothing is claimed: the judgement is "slip seen", never "no slip".
//
// Thread safety: free functions over const data.
#pragma once

#include <optional>
#include <set>
#include <vector>

#include "slamcore/mapper.h"
#include "slamcore/status.h"

namespace slamcore {

struct SlipDetectionParams {
  /// A node is judged against the last view before it along this much path at most (metres): farther on,
  /// drift makes an earlier view a poor judge of where the robot can be.
  double max_path_m = 3.0;
  /// Views stood still: the place where the views agree best must lie at least this far (metres) short of
  /// where odometry put the later view; there at least `min_still_agreement` of the walls that land on the
  /// other view's known cells must lie on (within a cell of) its walls, and at least `min_agreement_margin`
  /// more than at the farthest placement beyond it that can be judged. A placement is judged when at least
  /// `min_wall_cells` walls land.
  double min_still_motion_m = 0.25;
  double min_still_agreement = 0.8;
  double min_agreement_margin = 0.35;
  int min_wall_cells = 8;
};

/// How a node was judged (for reports and tests).
enum class SlipEvidence : std::uint8_t { kPathThroughWall, kViewStoodStill };

struct SlipFinding {
  NodeId node = 0;
  SlipEvidence evidence = SlipEvidence::kPathThroughWall;
  NodeId judged_against = 0;  // the earlier node whose view contradicts this node's pose
  /// Where the views say the node stood, in `judged_against`'s frame: where its view agrees best along the
  /// claimed motion (kViewStoodStill), or `judged_against`'s own pose (kPathThroughWall: somewhere short of
  /// the wall, which the path does not say).
  SE2 judge_T_stood;
};

/// The nodes of `map` whose poses the map's own views contradict, in chain order; each node with a view is
/// judged against the last view before it on its chain. Chains follow motion edges (a run's start or a
/// kidnap starts a new chain; a node with several motion successors continues along the one with the
/// smallest id). Fails on an invalid parameter.
Result<std::vector<SlipFinding>> FindSlipNodes(const Map& map, const SlipDetectionParams& params = {});

/// A view as the judge of the nodes after it on its chain: what FindSlipNodes asks node by node, and the
/// Mapper online when it corrects slip (MapperParams::correct_slip_from_views). Refers to the view, which
/// must outlive it.
class ViewSlipJudge {
 public:
  explicit ViewSlipJudge(const LocalMapEvent& view);

  /// Whether the path segment from `from` to `to` (in this view's node frame) passes through one of its
  /// walls into the space behind it that it did not see: the robot cannot have gone there.
  bool CrossesWall(const Vector2& from, const Vector2& to) const;
  /// Where `later`'s view says its node stood, in this view's node frame, when that is short of where
  /// odometry put it (`judge_T_later`) and the two views disagree beyond: the view that stood still.
  std::optional<SE2> StoodShort(const ViewSlipJudge& later, const SE2& judge_T_later,
                                const SlipDetectionParams& params) const;

 private:
  const LocalMapEvent* view_;
  std::vector<Vector2> walls_;  // its wall cells' centres in its node frame (at most 4096, evenly spaced)
};

/// Share of `later`'s wall cells that land on (within one cell of) a wall of `earlier` when `later`'s node is
/// placed at `earlier_T_later` in `earlier`'s node frame, among those that land on `earlier`'s known cells;
/// `landed` receives that count. Of a view with more than 4096 wall cells, 4096 evenly spaced ones are
/// tried: the work per placement is bounded whatever an upload holds. Both patches must hold width × height
/// cells.
double WallAgreement(const LocalMapEvent& earlier, const LocalMapEvent& later, const SE2& earlier_T_later,
                     int* landed);

}  // namespace slamcore
