#include "merge_overlay.h"

namespace slamcore::internal {

SE2 MergeOverlay::PoseOf(NodeId node) const {
  const SE2& pose = base_->node(node).pose;
  return InSource(node) ? target_T_source_ * pose : pose;
}

bool MergeOverlay::SameComponent(NodeId a, NodeId b) const {
  if (base_->SameComponent(a, b)) return true;
  if (edges_.empty()) return false;
  const bool a_joined = InSource(a) || InTarget(a);
  const bool b_joined = InSource(b) || InTarget(b);
  return a_joined && b_joined;
}

}  // namespace slamcore::internal
