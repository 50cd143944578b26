#include "slamcore/linear_initialization.h"

#include <Eigen/LU>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <cmath>
#include <deque>
#include <numbers>
#include <unordered_map>

namespace slamcore {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

/// Solves H x = g for the free variables (anchor rows/columns already left out).
Result<Eigen::VectorXd> SolveNormalEquations(const std::vector<Eigen::Triplet<double>>& triplets,
                                             const Eigen::VectorXd& rhs) {
  Eigen::SparseMatrix<double> hessian(rhs.size(), rhs.size());
  hessian.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(hessian);
  if (solver.info() != Eigen::Success) return Internal("linear initialisation: factorisation failed");
  Eigen::VectorXd solution = solver.solve(rhs);
  if (solver.info() != Eigen::Success || !solution.allFinite()) {
    return Internal("linear initialisation: solve failed");
  }
  return solution;
}

/// Heading variance of an edge: (Ω⁻¹)₃₃, the marginal that the orientation-only problem sees.
double HeadingWeight(const Matrix3& information) { return 1.0 / information.inverse()(2, 2); }

}  // namespace

Status InitializeLinear(PoseGraph& graph, std::optional<ComponentId> component) {
  if (component && !graph.HasNode(*component)) {
    return NotFound("component " + std::to_string(*component) + " does not exist");
  }
  const std::optional<ComponentId> selected_component =
      component ? std::optional(graph.ComponentOf(*component)) : std::nullopt;
  auto selected = [&](NodeId id) {
    return !selected_component || graph.ComponentOf(id) == *selected_component;
  };

  // Anchors (one per component) keep their pose; every other selected node is a variable.
  std::unordered_map<ComponentId, std::size_t> anchor_of;
  for (const Node& node : graph.nodes()) {
    if (node.fixed && selected(node.id))
      anchor_of.try_emplace(graph.ComponentOf(node.id), graph.IndexOf(node.id));
  }
  for (const Node& node : graph.nodes()) {
    if (selected(node.id)) anchor_of.try_emplace(graph.ComponentOf(node.id), graph.IndexOf(node.id));
  }
  const std::size_t n = graph.num_nodes();
  std::vector<long> variable(n, -1);  // index of each node's unknown, -1 for anchors and unselected nodes
  long num_variables = 0;
  std::vector<bool> is_anchor(n, false);
  for (const auto& [unused, index] : anchor_of) is_anchor[index] = true;
  for (std::size_t i = 0; i < n; ++i) {
    if (selected(graph.nodes()[i].id) && !is_anchor[i]) variable[i] = num_variables++;
  }
  if (num_variables == 0) return Status::Ok();

  // 1. Unwrapped headings along a spanning tree from each anchor, odometry preferred (0-1 BFS).
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> adjacency(n);  // node → (edge, neighbour)
  for (std::size_t e = 0; e < graph.num_edges(); ++e) {
    const Edge& edge = graph.edges()[e];
    if (!selected(edge.from)) continue;
    const std::size_t a = graph.IndexOf(edge.from), b = graph.IndexOf(edge.to);
    adjacency[a].emplace_back(e, b);
    adjacency[b].emplace_back(e, a);
  }
  std::vector<double> tree_heading(n, 0.0);
  std::vector<bool> reached(n, false);
  for (const auto& [unused, anchor] : anchor_of) {
    std::deque<std::pair<std::size_t, double>> queue{{anchor, graph.nodes()[anchor].pose.theta()}};
    while (!queue.empty()) {
      const auto [index, heading] = queue.front();
      queue.pop_front();
      if (reached[index]) continue;
      reached[index] = true;
      tree_heading[index] = heading;
      for (const auto& [e, neighbour] : adjacency[index]) {
        if (reached[neighbour]) continue;
        const Edge& edge = graph.edges()[e];
        const bool forward = graph.IndexOf(edge.from) == index;
        const double next = heading + (forward ? edge.measurement.theta() : -edge.measurement.theta());
        if (edge.kind == EdgeKind::kMotion) {
          queue.emplace_front(neighbour, next);
        } else {
          queue.emplace_back(neighbour, next);
        }
      }
    }
  }

  // 2. Headings: minimise Σ w (θ_j − θ_i − δ_ij − 2πk_ij)², with k_ij from the tree headings.
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(num_variables);
  for (const Edge& edge : graph.edges()) {
    if (!selected(edge.from)) continue;
    const std::size_t i = graph.IndexOf(edge.from), j = graph.IndexOf(edge.to);
    const double raw = tree_heading[j] - tree_heading[i] - edge.measurement.theta();
    const double target = edge.measurement.theta() + kTwoPi * std::round(raw / kTwoPi);
    const double weight = HeadingWeight(edge.information);
    const long vi = variable[i], vj = variable[j];
    // θ_j − θ_i = target, with an anchor's heading moved to the right-hand side.
    const double known = (vj < 0 ? tree_heading[j] : 0.0) - (vi < 0 ? tree_heading[i] : 0.0);
    if (vi >= 0) {
      triplets.emplace_back(vi, vi, weight);
      rhs[vi] -= weight * (target - known);
    }
    if (vj >= 0) {
      triplets.emplace_back(vj, vj, weight);
      rhs[vj] += weight * (target - known);
    }
    if (vi >= 0 && vj >= 0) {
      triplets.emplace_back(vi, vj, -weight);
      triplets.emplace_back(vj, vi, -weight);
    }
  }
  ASSIGN_OR_RETURN(const auto headings, SolveNormalEquations(triplets, rhs));
  std::vector<double> heading(n);
  for (std::size_t i = 0; i < n; ++i)
    heading[i] = variable[i] >= 0 ? (headings)[variable[i]] : tree_heading[i];

  // 3. Positions with headings fixed: e = M (t_j − t_i) − c, M = (R_i R_z)ᵀ, c = R_zᵀ t_z, weight Ω_tt.
  triplets.clear();
  Eigen::VectorXd position_rhs = Eigen::VectorXd::Zero(2 * num_variables);
  for (const Edge& edge : graph.edges()) {
    if (!selected(edge.from)) continue;
    const std::size_t i = graph.IndexOf(edge.from), j = graph.IndexOf(edge.to);
    const Matrix2 m = (SE2(0, 0, heading[i]).rotation() * edge.measurement.rotation()).transpose();
    const Matrix2 w = m.transpose() * edge.information.topLeftCorner<2, 2>() * m;  // weight on Δt
    // Δt should equal M⁻¹ c = R_i t_z.
    const Vector2 target = SE2(0, 0, heading[i]).rotation() * edge.measurement.translation();
    const long vi = variable[i], vj = variable[j];
    const Vector2 known = (vj < 0 ? graph.nodes()[j].pose.translation() : Vector2::Zero()) -
                          (vi < 0 ? graph.nodes()[i].pose.translation() : Vector2::Zero());
    const Vector2 g = w * (target - known);
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 2; ++c) {
        if (vi >= 0) triplets.emplace_back(2 * vi + r, 2 * vi + c, w(r, c));
        if (vj >= 0) triplets.emplace_back(2 * vj + r, 2 * vj + c, w(r, c));
        if (vi >= 0 && vj >= 0) {
          triplets.emplace_back(2 * vi + r, 2 * vj + c, -w(r, c));
          triplets.emplace_back(2 * vj + r, 2 * vi + c, -w(r, c));
        }
      }
      if (vj >= 0) position_rhs[2 * vj + r] += g[r];
      if (vi >= 0) position_rhs[2 * vi + r] -= g[r];
    }
  }
  ASSIGN_OR_RETURN(const auto positions, SolveNormalEquations(triplets, position_rhs));
  for (std::size_t i = 0; i < n; ++i) {
    if (variable[i] < 0) continue;
    const long v = variable[i];
    graph.mutable_nodes()[i].pose = SE2((positions)[2 * v], (positions)[2 * v + 1], heading[i]);
  }
  return Status::Ok();
}

}  // namespace slamcore
