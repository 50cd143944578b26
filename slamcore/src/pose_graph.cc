#include "slamcore/pose_graph.h"

#include <Eigen/Cholesky>
#include <numeric>
#include <string>

namespace slamcore {

Status CheckPositiveDefinite(const Matrix3& matrix, const char* what) {
  if (!matrix.allFinite()) return InvalidArgument(std::string(what) + " has a NaN or infinite entry");
  const double scale = matrix.cwiseAbs().maxCoeff();
  if (!(matrix - matrix.transpose()).isZero(1e-9 * scale)) {
    return InvalidArgument(std::string(what) + " is not symmetric");
  }
  const Eigen::LLT<Matrix3> cholesky(matrix);
  if (cholesky.info() != Eigen::Success) {
    return InvalidArgument(std::string(what) + " is not positive definite");
  }
  return Status::Ok();
}

namespace {

Status CheckPose(const SE2& pose, const std::string& what) {
  if (!pose.vector().allFinite()) return InvalidArgument(what + " has a NaN or infinite entry");
  return Status::Ok();
}

}  // namespace

Status PoseGraph::AddNode(const Node& node) {
  if (index_of_.contains(node.id))
    return InvalidArgument("node " + std::to_string(node.id) + " already exists");
  RETURN_IF_ERROR(CheckPose(node.pose, "pose of node " + std::to_string(node.id)));
  if (!std::isfinite(node.time) || !std::isfinite(node.odometer)) {
    return InvalidArgument("time or odometer of node " + std::to_string(node.id) + " is not finite");
  }
  index_of_.emplace(node.id, nodes_.size());
  parent_.push_back(nodes_.size());
  size_.push_back(1);
  nodes_.push_back(node);
  ++num_components_;
  return Status::Ok();
}

Result<std::size_t> PoseGraph::AddEdge(const Edge& edge) {
  const std::string name = "edge " + std::to_string(edge.from) + "->" + std::to_string(edge.to);
  if (!HasNode(edge.from)) return NotFound(name + ": node " + std::to_string(edge.from) + " does not exist");
  if (!HasNode(edge.to)) return NotFound(name + ": node " + std::to_string(edge.to) + " does not exist");
  if (edge.from == edge.to) return InvalidArgument(name + " joins a node to itself");
  RETURN_IF_ERROR(CheckPose(edge.measurement, name + " measurement"));
  RETURN_IF_ERROR(CheckPositiveDefinite(edge.information, (name + " information").c_str()));
  if (edge.view && !HasView(*edge.view)) {
    return NotFound(name + ": view " + std::to_string(*edge.view) + " does not exist");
  }
  edges_.push_back(edge);
  Union(IndexOf(edge.from), IndexOf(edge.to));
  return edges_.size() - 1;
}

Result<PoseGraph> PoseGraph::WithEdges(const std::vector<bool>& keep) const {
  if (keep.size() != edges_.size()) {
    return InvalidArgument("WithEdges: " + std::to_string(keep.size()) + " flags for " +
                           std::to_string(edges_.size()) + " edges");
  }
  // Nodes and views as they are (an observation edge names its view: a copy without the views would refuse
  // every one of them), the kept edges, and the components they make.
  PoseGraph kept = *this;
  kept.edges_.clear();
  for (std::size_t i = 0; i < edges_.size(); ++i) {
    if (keep[i]) kept.edges_.push_back(edges_[i]);
  }
  kept.RebuildComponents();
  return kept;
}

Status PoseGraph::AddView(const View& view) {
  if (view_index_.contains(view.id))
    return InvalidArgument("view " + std::to_string(view.id) + " already exists");
  if (!HasNode(view.node)) {
    return NotFound("view " + std::to_string(view.id) + ": node " + std::to_string(view.node) +
                    " does not exist");
  }
  view_index_.emplace(view.id, views_.size());
  views_.push_back(view);
  return Status::Ok();
}

const Node* PoseGraph::FindNode(NodeId id) const {
  const auto it = index_of_.find(id);
  return it == index_of_.end() ? nullptr : &nodes_[it->second];
}

const View* PoseGraph::FindView(ViewId id) const {
  const auto it = view_index_.find(id);
  return it == view_index_.end() ? nullptr : &views_[it->second];
}

std::vector<ComponentId> PoseGraph::Components() const {
  std::vector<ComponentId> components;
  components.reserve(num_components_);
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (Root(i) == i) components.push_back(nodes_[i].id);
  }
  return components;
}

std::vector<NodeId> PoseGraph::NodesOf(ComponentId component) const {
  const std::size_t root = Root(IndexOf(component));
  std::vector<NodeId> members;
  members.reserve(size_[root]);
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (Root(i) == root) members.push_back(nodes_[i].id);
  }
  return members;
}

std::size_t PoseGraph::Root(std::size_t index) const {
  while (parent_[index] != index) index = parent_[index];
  return index;
}

void PoseGraph::Union(std::size_t a, std::size_t b) {
  // Path compression on the write path keeps const reads short.
  auto compress = [this](std::size_t index) {
    const std::size_t root = Root(index);
    while (parent_[index] != root) index = std::exchange(parent_[index], root);
    return root;
  };
  std::size_t root_a = compress(a), root_b = compress(b);
  if (root_a == root_b) return;
  // Union by size; on ties the older node stays the representative, so component names are stable.
  if (size_[root_a] < size_[root_b] || (size_[root_a] == size_[root_b] && root_b < root_a)) {
    std::swap(root_a, root_b);
  }
  parent_[root_b] = root_a;
  size_[root_a] += size_[root_b];
  --num_components_;
}

void PoseGraph::RebuildComponents() {
  std::iota(parent_.begin(), parent_.end(), std::size_t{0});
  std::fill(size_.begin(), size_.end(), std::size_t{1});
  num_components_ = nodes_.size();
  for (const Edge& edge : edges_) Union(IndexOf(edge.from), IndexOf(edge.to));
}

}  // namespace slamcore
