// The map's own uncertainty between two places: marginal covariances of relative poses from the pose
// graph's information matrix, not from odometry alone (a loop closed elsewhere makes two places certain
// of each other even when the odometry between them is long).
//
// Method: the Gauss–Newton information matrix H = Σ Jᵀ Ω J of one component at its current poses (the
// error and Jacobians of optimizer.h over plain (x, y, θ) parameters), with the gauge fixed at the
// component's first node, is factorised once by a sparse Cholesky (CHOLMOD's LLᵀ, AMD
// ordering of the nodes). The covariance of
// a relative pose a_T_b needs only the 3×3 blocks Σ_aa, Σ_bb and Σ_ab of H⁻¹: six solves with the factor
// (the recovery of selected marginals of Kaess & Dellaert, "Covariance recovery from a square root
// information matrix for data association", RAS 2009, reduced to the columns needed).
//
// A factorisation describes the graph as it was; the Mapper reaches nodes added later by composing the
// odometry chain from the newest factorised node (exact for a chain without loops, which is what new nodes
// are until the next edge closes a loop), and edges added later by updating the marginal of the few nodes
// they touch (RelativeCovarianceWithEdgesSince) until they touch too many, when it factorises again.
//
// Thread safety: an immutable value after Factorize.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <unordered_map>

#include "incremental_solver.h"
#include "pose_gaussian.h"
#include "slamcore/pose_graph.h"

namespace slamcore::internal {

/// The a-posteriori variance factor σ̂₀² = χ² / redundancy of a component (Förstner & Wrobel, Photogrammetric
/// Computer Vision, 2016, §4.2.3: how far the declared covariances overstate the noise actually met), 1 when
/// it has no redundancy, and the redundancy 3 · (edges − free nodes).
struct VarianceFactor {
  double factor = 1.0;
  long redundancy = 0;
};

class MarginalCovariances {
 public:
  /// Factorises the component of `node`. nullopt when the information matrix is singular (a component
  /// with a node held by nothing, which the Mapper never builds).
  static std::optional<MarginalCovariances> Factorize(const PoseGraph& graph, NodeId node);
  /// The same from the factorisation a whole-component solve of the back-end ended with (the component of
  /// `node`, its first node held): no factorisation of its own. nullopt when it is not that component's, or
  /// another node is held.
  static std::optional<MarginalCovariances> FromSolve(const PoseGraph& graph, NodeId node,
                                                      ComponentFactorisation factorisation);

  ~MarginalCovariances();
  MarginalCovariances(MarginalCovariances&&) noexcept;
  MarginalCovariances& operator=(MarginalCovariances&&) noexcept;

  bool Contains(NodeId node) const { return index_.contains(node); }
  /// The gauge: the factorised node held fixed (zero covariance).
  bool IsHeld(NodeId node) const {
    const auto it = index_.find(node);
    return it != index_.end() && it->second < 0;
  }
  /// The newest (largest id) node of the factorised component.
  NodeId newest_node() const { return newest_node_; }
  std::size_t num_edges() const { return num_edges_; }
  /// The variance factor of the factorised component at the poses it was factorised at.
  const VarianceFactor& variance_factor() const { return variance_factor_; }

  /// a_T_b at the factorised poses, with the covariance of its left perturbation (in a's frame).
  /// Both nodes must be Contained.
  PoseGaussian Relative(NodeId a, NodeId b) const;

  /// The joint covariance (3k × 3k) of the plain (x, y, θ) parameters of k Contained nodes, in their order;
  /// zero rows and columns for the gauge node, which is held.
  Eigen::MatrixXd Joint(const std::vector<NodeId>& nodes) const;

 private:
  struct Factor;
  MarginalCovariances() = default;

  std::unordered_map<NodeId, int> index_;  // node → block column, −1 for the gauge node
  std::unordered_map<NodeId, SE2> poses_;  // at factorisation
  std::unique_ptr<Factor> factor_;
  NodeId newest_node_ = -1;
  std::size_t num_edges_ = 0;
  VarianceFactor variance_factor_;
};

/// The covariance of the left perturbation of a_T_b (in a's frame) from the joint covariance (6 × 6) of
/// the plain (x, y, θ) parameters of a and b at these poses.
Matrix3 RelativeCovariance(const SE2& pose_a, const SE2& pose_b, const Eigen::Matrix<double, 6, 6>& joint);

/// The covariance of a_T_b (left perturbation, in a's frame) once the edges graph.edges() holds beyond the
/// marginals' num_edges() joined the factorised graph, without factorising it again. Those edges must join
/// factorised nodes and the chain the robot drove since (the ids after the newest factorised node, each
/// joined to the one before by one of them: a motion edge); nullopt otherwise, or when more than
/// `max_nodes` nodes carry them. By Bayes' rule on the linearised problem, the new edges act only on the
/// nodes they touch (S), so the old graph enters through the marginal of S alone: the information of S is
/// (Σ_SS)⁻¹ plus the new edges' Jᵀ Ω J, the chain's stretches between nodes of S each one factor with its
/// inner nodes eliminated, and its inverse holds a_T_b's joint — exact but for the linearisation points (the
/// factorisation's poses for Σ_SS, G's current poses for the new edges and a_T_b). The caller keeps to
/// edges only added since (a removal, or G re-posed, calls for a new factorisation). Its cost: the path
/// walks of Σ_SS, a walk along the chain, and a dense factorisation of 3|S| unknowns.
std::optional<Matrix3> RelativeCovarianceWithEdgesSince(const PoseGraph& graph,
                                                        const MarginalCovariances& marginals, NodeId a,
                                                        NodeId b, std::size_t max_nodes);

/// The variance factor of the component of `node` at G's poses: what MarginalCovariances::variance_factor()
/// holds for the graph as it was factorised.
VarianceFactor ComponentVarianceFactor(const PoseGraph& graph, NodeId node);

/// χ² of a set of edges W against a factorised graph, and its degrees of freedom.
struct EdgeSetChi2 {
  double chi2 = 0.0;
  int dof = 0;
};
/// At most `cap` of `edges`, evenly spaced: the test of a subset of W against everything else is still a
/// leave-one-out test, at a bounded cost.
std::vector<const Edge*> EvenlySpaced(std::span<const Edge* const> edges, std::size_t cap);
/// The leave-one-out χ² of edges W of the factorised graph, at the poses `marginals` was factorised at
/// (the studentised residual of regression diagnostics): with W's stacked residuals r, the joint covariance
/// P of the nodes they touch and their Jacobians J, d² = rᵀ (Σ_z − J P Jᵀ)⁺ r is the χ² of W's measurements
/// against what every *other* edge predicts. It sees what an edge's own χ² hides: a flexible map bends to
/// fit every edge, moving the conflict into the odometry between them. Directions in which nothing else
/// constrains W are not testable and are dropped; `dof` counts the kept ones. nullopt when an edge's node is
/// not in the factorised component.
std::optional<EdgeSetChi2> LeaveOneOutChi2(const PoseGraph& graph, const MarginalCovariances& marginals,
                                           std::span<const Edge* const> edges);

}  // namespace slamcore::internal
