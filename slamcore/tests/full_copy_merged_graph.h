// The paper's G′ taken literally (IV-B): a full copy of G, the source component's poses carried by the
// alignment, the hypothesis's edges added. O(graph) per rebuild; tests only, as the reference the
// MergeOverlay must equal.
#pragma once

#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore::testing {

class FullCopyMergedGraph {
 public:
  FullCopyMergedGraph(const PoseGraph& base, NodeId source_node, const SE2& target_T_source,
                      const std::vector<Edge>& edges)
      : copy_(base) {
    for (Node& node : copy_.mutable_nodes()) {
      if (base.SameComponent(node.id, source_node)) node.pose = target_T_source * node.pose;
    }
    for (const Edge& edge : edges) ok_ = ok_ && copy_.AddEdge(edge).ok();
  }

  bool ok() const { return ok_; }
  SE2 PoseOf(NodeId node) const { return copy_.node(node).pose; }
  bool SameComponent(NodeId a, NodeId b) const { return copy_.SameComponent(a, b); }
  const PoseGraph& graph() const { return copy_; }

 private:
  PoseGraph copy_;
  bool ok_ = true;
};

}  // namespace slamcore::testing
