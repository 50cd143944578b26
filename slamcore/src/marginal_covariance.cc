#include "marginal_covariance.h"

#include <cholmod.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <algorithm>
#include <limits>
#include <unordered_map>

#include "slamcore/optimizer.h"
#include "cholmod_cholesky.h"

namespace slamcore::internal {

/// H = P'ᵀ L Lᵀ P' by CHOLMOD (cholmod_cholesky.h: supernodal where the factor is dense enough to repay it),
/// then converted to a simplicial column-by-column LLᵀ for the path walks of Joint. This factorisation is
/// redone whenever G changed.
struct MarginalCovariances::Factor {
  std::unique_ptr<CholmodCholesky> cholesky = std::make_unique<CholmodCholesky>();
  const cholmod_factor* factor = nullptr;  // simplicial, owned by `cholesky`
  std::vector<int> position;               // original column → its column in L
  int size = 0;

  /// Factorises the symmetric matrix whose lower triangle is `lower`; false when it is not positive
  /// definite.
  bool Compute(Eigen::SparseMatrix<double>& lower) {
    size = static_cast<int>(lower.rows());
    return cholesky->Analyze(lower) && cholesky->Factorize(lower) && TakeFactor();
  }
  /// The factor `cholesky` holds, as Joint walks it.
  bool TakeFactor() {
    factor = cholesky->ToSimplicial();
    if (!factor) return false;
    size = static_cast<int>(factor->n);
    position.assign(static_cast<std::size_t>(size), 0);
    const int* permutation = cholesky->permutation();
    for (int k = 0; k < size; ++k) position[static_cast<std::size_t>(permutation[k])] = k;
    return true;
  }
};

namespace {

/// χ² over `edges` edges of a component with `free_nodes` nodes not held.
VarianceFactor VarianceFactorOf(double chi2, long edges, long free_nodes) {
  const long redundancy = 3 * edges - 3 * free_nodes;
  if (redundancy <= 0) return {};
  return {.factor = chi2 / static_cast<double>(redundancy), .redundancy = redundancy};
}

}  // namespace

MarginalCovariances::~MarginalCovariances() = default;
MarginalCovariances::MarginalCovariances(MarginalCovariances&&) noexcept = default;
MarginalCovariances& MarginalCovariances::operator=(MarginalCovariances&&) noexcept = default;

std::optional<MarginalCovariances> MarginalCovariances::Factorize(const PoseGraph& graph, NodeId node) {
  MarginalCovariances result;
  const std::vector<NodeId> nodes = graph.NodesOf(graph.ComponentOf(node));
  const NodeId gauge = *std::min_element(nodes.begin(), nodes.end());
  // Each node's block column, by graph index: −1 for the gauge, −2 outside the component.
  std::vector<int> block_of(graph.num_nodes(), -2);
  int blocks = 0;
  for (const NodeId id : nodes) {
    const int block = id == gauge ? -1 : blocks++;
    block_of[graph.IndexOf(id)] = block;
    result.index_.emplace(id, block < 0 ? -1 : 3 * block);
    result.poses_.emplace(id, graph.node(id).pose);
    result.newest_node_ = std::max(result.newest_node_, id);
  }
  result.num_edges_ = graph.num_edges();
  if (blocks == 0) return std::nullopt;

  // H = Σ Jᵀ Ω J over the component's edges (lower triangle only, as the factorisation reads it), and χ²
  // at the same errors.
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(graph.num_edges() * 27);
  const auto add_block = [&](int row, int column, const Matrix3& block) {
    if (row < 0 || column < 0) return;  // the gauge node is held
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        if (3 * row + r >= 3 * column + c) triplets.emplace_back(3 * row + r, 3 * column + c, block(r, c));
      }
    }
  };
  double chi2 = 0.0;
  std::size_t edges = 0;
  for (const Edge& edge : graph.edges()) {
    const int a = block_of[graph.IndexOf(edge.from)];
    if (a == -2) continue;  // another component
    const int b = block_of[graph.IndexOf(edge.to)];
    Matrix3 d_from, d_to;
    const Vector3 error =
        EdgeError(graph.node(edge.from).pose, graph.node(edge.to).pose, edge.measurement, &d_from, &d_to);
    chi2 += error.dot(edge.information * error);
    ++edges;
    add_block(a, a, d_from.transpose() * edge.information * d_from);
    add_block(b, b, d_to.transpose() * edge.information * d_to);
    if (a >= b) {
      add_block(a, b, d_from.transpose() * edge.information * d_to);
    } else {
      add_block(b, a, d_to.transpose() * edge.information * d_from);
    }
  }
  result.variance_factor_ = VarianceFactorOf(chi2, static_cast<long>(edges), blocks);
  Eigen::SparseMatrix<double> information(3 * blocks, 3 * blocks);
  information.setFromTriplets(triplets.begin(), triplets.end());
  information.makeCompressed();

  result.factor_ = std::make_unique<Factor>();
  if (!result.factor_->Compute(information)) return std::nullopt;
  return result;
}

std::optional<MarginalCovariances> MarginalCovariances::FromSolve(const PoseGraph& graph, NodeId node,
                                                                  ComponentFactorisation factorisation) {
  const ComponentId component = graph.ComponentOf(node);
  if (!factorisation.cholesky || factorisation.first_column.size() != graph.ComponentSize(component)) {
    return std::nullopt;
  }
  MarginalCovariances result;
  NodeId held = -1, gauge = std::numeric_limits<NodeId>::max();
  for (const auto& [id, column] : factorisation.first_column) {
    if (!graph.HasNode(id) || graph.ComponentOf(id) != component) return std::nullopt;
    if (column < 0) held = id;
    gauge = std::min(gauge, id);
    result.index_.emplace(id, column);
    result.poses_.emplace(id, graph.node(id).pose);
    result.newest_node_ = std::max(result.newest_node_, id);
  }
  if (held != gauge) return std::nullopt;  // Factorize holds the smallest id: the same gauge, or nothing
  result.num_edges_ = graph.num_edges();
  result.variance_factor_ = ComponentVarianceFactor(graph, node);  // at the poses the solve ended with
  result.factor_ = std::make_unique<Factor>();
  result.factor_->cholesky = std::move(factorisation.cholesky);
  if (!result.factor_->TakeFactor()) return std::nullopt;
  return result;
}

Eigen::MatrixXd MarginalCovariances::Joint(const std::vector<NodeId>& nodes) const {
  // With P H Pᵀ = L Lᵀ, the blocks asked for are Eᵀ H⁻¹ E = Yᵀ Y with Y = L⁻¹ P E. A column of Y, L⁻¹ e_p,
  // is nonzero only on the elimination tree's path from p to the root (the parent of column j is its first
  // row below the diagonal), so forward substitution walks that path alone (Davis, "Direct Methods for
  // Sparse Linear Systems", SIAM 2006, §4.1). Two paths of a tree, once they meet, run together to the
  // root: the dot product of two columns is over the common tail alone, found from where they meet.
  const cholmod_factor& lower = *factor_->factor;
  const int* column_start = static_cast<const int*>(lower.p);
  const int* row_of = static_cast<const int*>(lower.i);
  const double* value_of = static_cast<const double*>(lower.x);
  struct PathColumn {
    std::vector<int> rows;  // the path, ascending
    std::vector<double> values;
  };
  const auto size = static_cast<std::size_t>(factor_->size);
  std::vector<double> scratch(size, 0.0);
  const auto solve_unit = [&](int start) {
    PathColumn column;
    scratch[static_cast<std::size_t>(start)] = 1.0;
    for (int j = start; j >= 0;) {
      // The diagonal comes first in each column of a simplicial CHOLMOD factor.
      const double value = scratch[static_cast<std::size_t>(j)] / value_of[column_start[j]];
      scratch[static_cast<std::size_t>(j)] = 0.0;
      column.rows.push_back(j);
      column.values.push_back(value);
      int parent = -1;
      for (int entry = column_start[j] + 1; entry < column_start[j + 1]; ++entry) {
        const int row = row_of[entry];
        if (parent < 0 || row < parent) parent = row;
        scratch[static_cast<std::size_t>(row)] -= value_of[entry] * value;
      }
      j = parent;
    }
    return column;
  };

  const int k = static_cast<int>(nodes.size());
  std::vector<PathColumn> columns(static_cast<std::size_t>(3 * k));
  for (int n = 0; n < k; ++n) {
    const int index = index_.at(nodes[static_cast<std::size_t>(n)]);
    if (index < 0) continue;  // the gauge node: held, zero covariance
    for (int axis = 0; axis < 3; ++axis) {
      columns[static_cast<std::size_t>(3 * n + axis)] =
          solve_unit(factor_->position[static_cast<std::size_t>(index + axis)]);
    }
  }
  Eigen::MatrixXd joint = Eigen::MatrixXd::Zero(3 * k, 3 * k);
  std::vector<int> place_on_path(size, -1);  // row → its place on the first column's path
  for (int a = 0; a < 3 * k; ++a) {
    const PathColumn& first = columns[static_cast<std::size_t>(a)];
    for (std::size_t i = 0; i < first.rows.size(); ++i) {
      place_on_path[static_cast<std::size_t>(first.rows[i])] = static_cast<int>(i);
    }
    for (int b = a; b < 3 * k; ++b) {
      const PathColumn& second = columns[static_cast<std::size_t>(b)];
      std::size_t j = 0;
      while (j < second.rows.size() && place_on_path[static_cast<std::size_t>(second.rows[j])] < 0) ++j;
      double sum = 0.0;
      if (j < second.rows.size()) {
        // From here both paths are the same rows, in the same (ascending) order.
        const std::size_t i =
            static_cast<std::size_t>(place_on_path[static_cast<std::size_t>(second.rows[j])]);
        const std::size_t common = second.rows.size() - j;
        for (std::size_t t = 0; t < common; ++t) sum += first.values[i + t] * second.values[j + t];
      }
      joint(a, b) = joint(b, a) = sum;
    }
    for (const int row : first.rows) place_on_path[static_cast<std::size_t>(row)] = -1;
  }
  return joint;
}

PoseGaussian MarginalCovariances::Relative(NodeId a, NodeId b) const {
  const SE2 pose_a = poses_.at(a), pose_b = poses_.at(b);
  return {pose_a.inverse() * pose_b, RelativeCovariance(pose_a, pose_b, Joint({a, b}))};
}

Matrix3 RelativeCovariance(const SE2& pose_a, const SE2& pose_b, const Eigen::Matrix<double, 6, 6>& joint) {
  // Left perturbation ε of a_T_b against the plain parameters of a and b, by central differences (the
  // relative pose is smooth; six evaluations cost nothing next to the solves).
  const SE2 relative = pose_a.inverse() * pose_b;
  Eigen::Matrix<double, 3, 6> jacobian;
  constexpr double kStep = 1e-6;
  for (int k = 0; k < 6; ++k) {
    Vector3 delta = Vector3::Zero();
    delta(k % 3) = kStep;
    const auto perturbed = [&](double sign) {
      const Vector3 d = sign * delta;
      const auto moved = [&](const SE2& pose) {
        return SE2(pose.x() + d.x(), pose.y() + d.y(), pose.theta() + d.z());
      };
      const SE2 a_moved = k < 3 ? moved(pose_a) : pose_a;
      const SE2 b_moved = k < 3 ? pose_b : moved(pose_b);
      return SE2::Log((a_moved.inverse() * b_moved) * relative.inverse());
    };
    jacobian.col(k) = (perturbed(1.0) - perturbed(-1.0)) / (2 * kStep);
  }
  const Matrix3 covariance = jacobian * joint * jacobian.transpose();
  return 0.5 * (covariance + covariance.transpose());
}

std::optional<Matrix3> RelativeCovarianceWithEdgesSince(const PoseGraph& graph,
                                                        const MarginalCovariances& marginals, NodeId a,
                                                        NodeId b, std::size_t max_nodes) {
  const std::span<const Edge> edges = graph.edges();
  if (edges.size() < marginals.num_edges()) return std::nullopt;
  const NodeId newest = marginals.newest_node();
  // The chain: node id → the motion edge from id − 1; every other new edge is a factor of its own.
  std::unordered_map<NodeId, const Edge*> chain_step;
  std::vector<const Edge*> factors;
  for (std::size_t k = marginals.num_edges(); k < edges.size(); ++k) {
    const Edge& edge = edges[k];
    if (edge.kind == EdgeKind::kMotion && edge.to == edge.from + 1 && edge.to > newest) {
      if (!chain_step.emplace(edge.to, &edge).second) return std::nullopt;
    } else {
      factors.push_back(&edge);
    }
  }
  NodeId chain_end = newest;
  while (chain_step.contains(chain_end + 1)) ++chain_end;

  // The nodes of S: factorised ones (the gauge is held, so it has no column) and the chain's that new
  // edges touch; the chain's first node anchors it when any of its nodes is in S.
  std::vector<NodeId> old_nodes, chain_nodes;
  std::unordered_map<NodeId, int> column;  // node → its block in the joint information
  const auto take = [&](NodeId node) {
    if (marginals.Contains(node)) {
      if (!marginals.IsHeld(node) && column.emplace(node, -1).second) old_nodes.push_back(node);
      return true;
    }
    if (node <= newest || node > chain_end) return false;
    if (column.emplace(node, -1).second) chain_nodes.push_back(node);
    return true;
  };
  for (const Edge* edge : factors) {
    if (!take(edge->from) || !take(edge->to)) return std::nullopt;
  }
  if (!take(a) || !take(b)) return std::nullopt;
  if (!chain_nodes.empty() && !take(newest)) return std::nullopt;
  if (old_nodes.size() + chain_nodes.size() > max_nodes) return std::nullopt;
  std::sort(chain_nodes.begin(), chain_nodes.end());
  int blocks = 0;
  for (const NodeId node : old_nodes) column[node] = blocks++;
  for (const NodeId node : chain_nodes) column[node] = blocks++;

  // Each new edge as a linear factor on S, e = J_from δx_from + J_to δx_to with information Ω, at G's poses.
  struct LinearFactor {
    NodeId from, to;
    Matrix3 d_from, d_to, information;
  };
  std::vector<LinearFactor> linear;
  for (const Edge* edge : factors) {
    LinearFactor factor{
        .from = edge->from, .to = edge->to, .d_from = {}, .d_to = {}, .information = edge->information};
    (void)EdgeError(graph.node(edge->from).pose, graph.node(edge->to).pose, edge->measurement, &factor.d_from,
                    &factor.d_to);
    linear.push_back(factor);
  }
  // The chain's stretch from one node of S to the next, its inner nodes eliminated: each motion edge gives
  // δx_to = F δx_from + w (F = −J_to⁻¹ J_from, cov w = J_to⁻¹ Ω⁻¹ J_to⁻ᵀ), and the products along the
  // stretch give δx_to = F δx_from + w, a factor with J_from = −F, J_to = I, Ω = (cov w)⁻¹.
  NodeId from = newest;
  for (const NodeId to : chain_nodes) {
    Matrix3 transition = Matrix3::Identity(), noise = Matrix3::Zero();
    for (NodeId id = from + 1; id <= to; ++id) {
      const Edge& step = *chain_step.at(id);
      Matrix3 d_from, d_to;
      (void)EdgeError(graph.node(step.from).pose, graph.node(step.to).pose, step.measurement, &d_from, &d_to);
      const Matrix3 to_inverse = d_to.inverse();
      const Matrix3 step_transition = -to_inverse * d_from;
      transition = step_transition * transition;
      noise = step_transition * noise * step_transition.transpose() +
              to_inverse * step.information.inverse() * to_inverse.transpose();
    }
    linear.push_back({.from = from,
                      .to = to,
                      .d_from = -transition,
                      .d_to = Matrix3::Identity(),
                      .information = noise.inverse()});
    from = to;
  }

  const int size = 3 * blocks;
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(size, size);
  if (!old_nodes.empty()) {
    const Eigen::LDLT<Eigen::MatrixXd> prior(marginals.Joint(old_nodes));
    if (prior.info() != Eigen::Success || !prior.isPositive()) return std::nullopt;
    const int old_size = 3 * static_cast<int>(old_nodes.size());
    information.topLeftCorner(old_size, old_size) =
        prior.solve(Eigen::MatrixXd::Identity(old_size, old_size));
  }
  const auto block = [&](NodeId node) {
    const auto it = column.find(node);
    return it == column.end() ? -1 : 3 * it->second;  // −1: the gauge, held
  };
  for (const LinearFactor& factor : linear) {
    const int i = block(factor.from), j = block(factor.to);
    if (i >= 0)
      information.block<3, 3>(i, i) += factor.d_from.transpose() * factor.information * factor.d_from;
    if (j >= 0) information.block<3, 3>(j, j) += factor.d_to.transpose() * factor.information * factor.d_to;
    if (i >= 0 && j >= 0) {
      const Matrix3 cross = factor.d_from.transpose() * factor.information * factor.d_to;
      information.block<3, 3>(i, j) += cross;
      information.block<3, 3>(j, i) += cross.transpose();
    }
  }
  const Eigen::LDLT<Eigen::MatrixXd> posterior(information);
  if (posterior.info() != Eigen::Success || !posterior.isPositive()) return std::nullopt;
  // Σ's columns of a and b only.
  Eigen::MatrixXd selector = Eigen::MatrixXd::Zero(size, 6);
  for (int end = 0; end < 2; ++end) {
    const auto it = column.find(end == 0 ? a : b);
    if (it != column.end()) selector.block<3, 3>(3 * it->second, 3 * end).setIdentity();
  }
  const Eigen::MatrixXd columns = posterior.solve(selector);
  const Eigen::Matrix<double, 6, 6> joint = selector.transpose() * columns;
  return RelativeCovariance(graph.node(a).pose, graph.node(b).pose, 0.5 * (joint + joint.transpose()));
}

VarianceFactor ComponentVarianceFactor(const PoseGraph& graph, NodeId node) {
  const ComponentId component = graph.ComponentOf(node);
  double chi2 = 0.0;
  long edges = 0;
  for (const Edge& edge : graph.edges()) {
    if (graph.ComponentOf(edge.from) != component) continue;
    chi2 += EdgeChi2(graph, edge);
    ++edges;
  }
  return VarianceFactorOf(chi2, edges, static_cast<long>(graph.ComponentSize(component)) - 1);
}

std::vector<const Edge*> EvenlySpaced(std::span<const Edge* const> edges, std::size_t cap) {
  const std::size_t count = std::min(cap, edges.size());
  std::vector<const Edge*> spaced;
  for (std::size_t k = 0; k < count; ++k) spaced.push_back(edges[k * edges.size() / count]);
  return spaced;
}

std::optional<EdgeSetChi2> LeaveOneOutChi2(const PoseGraph& graph, const MarginalCovariances& marginals,
                                           std::span<const Edge* const> edges) {
  std::vector<NodeId> nodes;
  std::unordered_map<NodeId, int> column;
  for (const Edge* edge : edges) {
    for (const NodeId node : {edge->from, edge->to}) {
      if (column.emplace(node, static_cast<int>(nodes.size())).second) nodes.push_back(node);
    }
  }
  for (const NodeId node : nodes) {
    if (!marginals.Contains(node)) return std::nullopt;
  }
  const Eigen::MatrixXd joint = marginals.Joint(nodes);
  const int count = static_cast<int>(edges.size());
  const int rows = 3 * count;
  Eigen::VectorXd residual(rows);
  // J has two 3×3 blocks per edge (its Jacobians at its two ends), so J P Jᵀ is formed block by block:
  // (J P Jᵀ)_kl = Σ over the ends a of k and b of l of D_ka P_ab D_lbᵀ, a few hundred flops per pair where
  // the dense product costs O(rows · nodes²).
  struct EdgeEnds {
    Matrix3 d[2];
    int column[2];
  };
  std::vector<EdgeEnds> ends(edges.size());
  Eigen::VectorXd measurement_variance_diagonal(rows);
  Eigen::MatrixXd residual_covariance = Eigen::MatrixXd::Zero(rows, rows);
  for (int k = 0; k < count; ++k) {
    const Edge& edge = *edges[static_cast<std::size_t>(k)];
    EdgeEnds& end = ends[static_cast<std::size_t>(k)];
    residual.segment<3>(3 * k) = EdgeError(graph.node(edge.from).pose, graph.node(edge.to).pose,
                                           edge.measurement, &end.d[0], &end.d[1]);
    end.column[0] = 3 * column.at(edge.from);
    end.column[1] = 3 * column.at(edge.to);
    const Matrix3 measurement_covariance = edge.information.inverse();
    residual_covariance.block<3, 3>(3 * k, 3 * k) = measurement_covariance;
    measurement_variance_diagonal.segment<3>(3 * k) = measurement_covariance.diagonal();
  }
  for (int k = 0; k < count; ++k) {
    const EdgeEnds& first = ends[static_cast<std::size_t>(k)];
    for (int l = k; l < count; ++l) {
      const EdgeEnds& second = ends[static_cast<std::size_t>(l)];
      Matrix3 predicted = Matrix3::Zero();
      for (int a = 0; a < 2; ++a) {
        for (int b = 0; b < 2; ++b) {
          predicted +=
              first.d[a] * joint.block<3, 3>(first.column[a], second.column[b]) * second.d[b].transpose();
        }
      }
      residual_covariance.block<3, 3>(3 * k, 3 * l) -= predicted;
      if (l != k) residual_covariance.block<3, 3>(3 * l, 3 * k) -= predicted.transpose();
    }
  }
  const Eigen::MatrixXd symmetric = 0.5 * (residual_covariance + residual_covariance.transpose());
  // Directions nothing but W constrains have (numerically) no residual variance: not testable.
  const double floor = 1e-4 * measurement_variance_diagonal.minCoeff();
  // When every eigenvalue lies above the floor (S − floor·I has a Cholesky factor), every direction is
  // testable and the sum over the eigenvectors below is rᵀ S⁻¹ r, which a Cholesky factor of S gives for a
  // fraction of the eigen decomposition's cost — the common case, W's nodes held by other edges too.
  if (Eigen::LLT<Eigen::MatrixXd>(symmetric - floor * Eigen::MatrixXd::Identity(rows, rows)).info() ==
      Eigen::Success) {
    const Eigen::LLT<Eigen::MatrixXd> factor(symmetric);
    if (factor.info() == Eigen::Success)
      return EdgeSetChi2{.chi2 = residual.dot(factor.solve(residual)), .dof = rows};
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(symmetric);
  EdgeSetChi2 result;
  for (int i = 0; i < rows; ++i) {
    if (eigen.eigenvalues()(i) <= floor) continue;
    const double projection = eigen.eigenvectors().col(i).dot(residual);
    result.chi2 += projection * projection / eigen.eigenvalues()(i);
    ++result.dof;
  }
  return result;
}

}  // namespace slamcore::internal
