// PoseGraph: robot poses (nodes), views attached to nodes, motion and observation edges, and the
// connected components they form.
//
// An edge from node a to node b carries the measurement a_T_b (the pose of b in a's frame) and a 3×3
// information matrix over the g2o-style error (see optimizer.h). Components are kept by a union-find
// over node indices (union by size, path compression on writes); every query is const and cheap.
// Removing edges rebuilds the components, O(nodes + edges).
//
// Thread safety: a PoseGraph is a value; concurrent const reads are safe, writes need exclusive access.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "slamcore/se2.h"
#include "slamcore/status.h"

namespace slamcore {

using NodeId = std::int64_t;
using ViewId = std::int64_t;
/// A component is named by one of its nodes (its union-find representative); the name of a component
/// can change when it merges with another.
using ComponentId = NodeId;

enum class EdgeKind : std::uint8_t { kMotion, kObservation };

struct Node {
  NodeId id = 0;
  SE2 pose;               // estimate in the frame of its component
  double time = 0.0;      // seconds
  double odometer = 0.0;  // metres travelled since the start of the map
  bool fixed = false;     // held constant by the optimiser (g2o FIX)
};

struct View {
  ViewId id = 0;
  NodeId node = 0;  // the node the view was created at
  bool ambiguous = false;
};

struct Edge {
  NodeId from = 0;
  NodeId to = 0;
  SE2 measurement;  // from_T_to
  Matrix3 information = Matrix3::Identity();
  EdgeKind kind = EdgeKind::kMotion;
  std::optional<ViewId> view;  // the observed view, for observation edges
  /// Observation edges: the Mapper hypothesis whose acceptance added the edge (ids restart every run);
  /// absent for direct edges and edges read from files. Lets a repair reject a whole hypothesis.
  std::optional<std::int64_t> hypothesis;
};

/// Checks that a 3×3 information or covariance matrix is finite, symmetric and positive definite.
Status CheckPositiveDefinite(const Matrix3& matrix, const char* what);

class PoseGraph {
 public:
  /// Adds a node; it starts a component of its own until an edge joins it to another.
  Status AddNode(const Node& node);
  /// Adds an edge between existing nodes, merging their components when they differ. Returns its index.
  Result<std::size_t> AddEdge(const Edge& edge);
  Status AddView(const View& view);

  /// Removes every edge for which `remove(edge)` is true and rebuilds the components; returns the count.
  template <typename Predicate>
  std::size_t RemoveEdgesIf(Predicate remove);

  /// A copy with every node and view and the edges whose flag in `keep` (one per edge index) is set, in
  /// their order: a graph of some of this one's edges (a judged solve's inliers). INVALID_ARGUMENT unless
  /// `keep` has one flag per edge.
  Result<PoseGraph> WithEdges(const std::vector<bool>& keep) const;

  bool HasNode(NodeId id) const { return index_of_.contains(id); }
  bool HasView(ViewId id) const { return view_index_.contains(id); }
  const Node& node(NodeId id) const { return nodes_[IndexOf(id)]; }
  Node& mutable_node(NodeId id) { return nodes_[IndexOf(id)]; }
  const View& view(ViewId id) const { return views_[view_index_.at(id)]; }
  View& mutable_view(ViewId id) { return views_[view_index_.at(id)]; }
  const Node* FindNode(NodeId id) const;
  const View* FindView(ViewId id) const;

  std::span<const Node> nodes() const { return nodes_; }
  std::span<Node> mutable_nodes() { return nodes_; }
  std::span<const Edge> edges() const { return edges_; }
  std::span<const View> views() const { return views_; }
  std::size_t num_nodes() const { return nodes_.size(); }
  std::size_t num_edges() const { return edges_.size(); }

  ComponentId ComponentOf(NodeId id) const { return nodes_[Root(IndexOf(id))].id; }
  bool SameComponent(NodeId a, NodeId b) const { return Root(IndexOf(a)) == Root(IndexOf(b)); }
  std::size_t ComponentSize(NodeId id) const { return size_[Root(IndexOf(id))]; }
  std::size_t NumComponents() const { return num_components_; }
  /// The distinct components, each named as ComponentOf names it, in order of their first node.
  std::vector<ComponentId> Components() const;
  /// Nodes of one component in insertion order, O(nodes).
  std::vector<NodeId> NodesOf(ComponentId component) const;

  /// Index of a node in nodes(); stable until nodes are removed (they never are).
  std::size_t IndexOf(NodeId id) const { return index_of_.at(id); }

 private:
  std::size_t Root(std::size_t index) const;
  void Union(std::size_t a, std::size_t b);
  void RebuildComponents();

  std::vector<Node> nodes_;
  std::vector<Edge> edges_;
  std::vector<View> views_;
  std::unordered_map<NodeId, std::size_t> index_of_;
  std::unordered_map<ViewId, std::size_t> view_index_;
  std::vector<std::size_t> parent_;  // union-find over node indices
  std::vector<std::size_t> size_;    // component size, valid at roots
  std::size_t num_components_ = 0;
};

template <typename Predicate>
std::size_t PoseGraph::RemoveEdgesIf(Predicate remove) {
  const std::size_t before = edges_.size();
  std::erase_if(edges_, remove);
  const std::size_t removed = before - edges_.size();
  if (removed > 0) RebuildComponents();
  return removed;
}

}  // namespace slamcore
