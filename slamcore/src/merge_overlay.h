// MergeOverlay: G′ of the conditional merge (paper IV-B) without copying G.
//
// The paper keeps G′ as a full copy of G plus the conditionally accepted hypothesis's edges, re-copied after
// every modification of G: O(graph) per step. G′ differs from G in two things only, so we store just those:
//  * the hypothesis's observation edges, each joining the source component C_s (the robot's) to the
//    target component C_t (the one the hypothesis localises it in);
//  * one rigid alignment target_T_source that carries C_s's node poses into C_t's frame, the frame G′
//    shows C_s in (the Mapper derives it from the hypothesis's state: see mapper_merge.cc).
// Reads go through the base graph G by reference: a node of C_s is shown at alignment · pose, every other
// node as in G; two nodes are connected in G′ when they are in G, or when one is in C_s and the other in
// C_t. Each modification costs O(1) (AddEdge, SetAlignment); changes to G (new nodes, edges, optimised
// poses) are seen at once because nothing is copied. Reads cost what G's reads cost.
//
// The contract is that every read equals that of the full-copy reference (copy G, move C_s's poses by
// the alignment, add the edges): tests/merge_overlay_test.cc checks it over sequences of modifications.
// Precondition: C_s and C_t are distinct components of G (a full merge in G ends the overlay).
//
// Thread safety: reads the base graph; the caller serialises writes to the graph and the overlay.
#pragma once

#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore::internal {

class MergeOverlay {
 public:
  /// `source_node` names C_s and `target_node` names C_t by any of their nodes (component names in G can
  /// change; membership of a node cannot, since the Mapper never removes edges).
  MergeOverlay(const PoseGraph& base, NodeId source_node, NodeId target_node)
      : base_(&base), source_node_(source_node), target_node_(target_node) {}

  void SetAlignment(const SE2& target_T_source) { target_T_source_ = target_T_source; }
  /// Adds an edge of the hypothesis; it must join C_s and C_t.
  void AddEdge(const Edge& edge) { edges_.push_back(edge); }

  /// Node pose as seen in G′. The node must exist in G.
  SE2 PoseOf(NodeId node) const;
  bool SameComponent(NodeId a, NodeId b) const;
  bool InSource(NodeId node) const { return base_->SameComponent(node, source_node_); }
  bool InTarget(NodeId node) const { return base_->SameComponent(node, target_node_); }

  const std::vector<Edge>& edges() const { return edges_; }
  const SE2& alignment() const { return target_T_source_; }
  NodeId source_node() const { return source_node_; }
  NodeId target_node() const { return target_node_; }

 private:
  const PoseGraph* base_;
  NodeId source_node_;
  NodeId target_node_;
  SE2 target_T_source_;
  std::vector<Edge> edges_;
};

}  // namespace slamcore::internal
