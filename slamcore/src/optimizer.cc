#include "slamcore/optimizer.h"

#include "slamcore/linear_initialization.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <chrono>
#include <memory>
#include <unordered_set>

#include "calling_thread_only.h"

namespace slamcore {

Vector3 EdgeError(const SE2& from, const SE2& to, const SE2& measurement, Matrix3* d_from, Matrix3* d_to) {
  return EdgeError(from, to, measurement, measurement.rotation().transpose(), d_from, d_to);
}

Vector3 EdgeError(const SE2& from, const SE2& to, const SE2& measurement, const Matrix2& rotation_z_t,
                  Matrix3* d_from, Matrix3* d_to) {
  return EdgeError(from, from.rotation().transpose(), to, measurement, rotation_z_t, d_from, d_to);
}

Vector3 EdgeError(const SE2& from, const Matrix2& rotation_from_t, const SE2& to, const SE2& measurement,
                  const Matrix2& rotation_z_t, Matrix3* d_from, Matrix3* d_to) {
  const Vector2 local = rotation_from_t * (to.translation() - from.translation());  // R_iᵀ (t_j − t_i)
  Vector3 error;
  error.head<2>() = rotation_z_t * (local - measurement.translation());
  error.z() = WrapAngle(to.theta() - from.theta() - measurement.theta());
  if (d_from) {
    d_from->setZero();
    d_from->topLeftCorner<2, 2>() = -rotation_z_t * rotation_from_t;
    d_from->block<2, 1>(0, 2) = -rotation_z_t * Perp(local);
    (*d_from)(2, 2) = -1.0;
  }
  if (d_to) {
    d_to->setZero();
    d_to->topLeftCorner<2, 2>() = rotation_z_t * rotation_from_t;
    (*d_to)(2, 2) = 1.0;
  }
  return error;
}

Matrix3 EdgeInformationFromLeftCovariance(const SE2& measurement, const Matrix3& left_covariance) {
  const Matrix3 adjoint = measurement.Adjoint();
  const Matrix3 information = adjoint.transpose() * left_covariance.inverse() * adjoint;
  return 0.5 * (information + information.transpose());
}

Matrix3 LeftCovarianceFromEdgeInformation(const SE2& measurement, const Matrix3& information) {
  const Matrix3 adjoint = measurement.Adjoint();
  const Matrix3 covariance = adjoint * information.inverse() * adjoint.transpose();
  return 0.5 * (covariance + covariance.transpose());
}

namespace {

/// One edge's whitened residual L·e over two (x, y, θ) parameter blocks, with analytic Jacobians.
class EdgeCost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  EdgeCost(const SE2& measurement, const Matrix3& sqrt_information)
      : measurement_(measurement), sqrt_information_(sqrt_information) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const SE2 from(parameters[0][0], parameters[0][1], parameters[0][2]);
    const SE2 to(parameters[1][0], parameters[1][1], parameters[1][2]);
    Matrix3 d_from, d_to;
    const bool want_jacobians = jacobians != nullptr;
    const Vector3 error = EdgeError(from, to, measurement_, want_jacobians ? &d_from : nullptr,
                                    want_jacobians ? &d_to : nullptr);
    Eigen::Map<Vector3> whitened(residuals);
    whitened = sqrt_information_ * error;
    if (want_jacobians) {
      using RowMajor3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
      if (jacobians[0]) Eigen::Map<RowMajor3>{jacobians[0]} = sqrt_information_ * d_from;
      if (jacobians[1]) Eigen::Map<RowMajor3>{jacobians[1]} = sqrt_information_ * d_to;
    }
    return true;
  }

 private:
  SE2 measurement_;
  Matrix3 sqrt_information_;
};

/// Upper-triangular L with LᵀL = Ω (Ω was checked positive definite when the edge was added).
Matrix3 SqrtInformation(const Matrix3& information) { return Eigen::LLT<Matrix3>(information).matrixU(); }

}  // namespace

double EdgeChi2(const PoseGraph& graph, const Edge& edge) {
  const Vector3 error = EdgeError(graph.node(edge.from).pose, graph.node(edge.to).pose, edge.measurement);
  return error.dot(edge.information * error);
}

Status Validate(const OptimizerOptions& options) {
  if (options.max_iterations < 1) return InvalidArgument("max_iterations must be at least 1");
  if (!(options.relative_cost_decrease > 0.0 && options.relative_cost_decrease < 1.0)) {
    return InvalidArgument("relative_cost_decrease must be in (0, 1)");
  }
  if (!(options.robust_loss_scale > 0.0) || !std::isfinite(options.robust_loss_scale)) {
    return InvalidArgument("robust_loss_scale must be positive and finite");
  }
  if (options.num_threads < 1) return InvalidArgument("num_threads must be at least 1");
  for (const double weight : options.edge_weights) {
    if (!(weight >= 0.0) || !std::isfinite(weight))
      return InvalidArgument("edge_weights must be finite and ≥ 0");
  }
  return Status::Ok();
}

double Chi2(const PoseGraph& graph, std::optional<ComponentId> component) {
  double chi2 = 0.0;
  for (const Edge& edge : graph.edges()) {
    if (component && graph.ComponentOf(edge.from) != *component) continue;
    chi2 += EdgeChi2(graph, edge);
  }
  return chi2;
}

Result<OptimizerSummary> Optimize(PoseGraph& graph, const OptimizerOptions& options) {
  RETURN_IF_ERROR(Validate(options));
  if (options.component && !graph.HasNode(*options.component)) {
    return NotFound("component " + std::to_string(*options.component) + " does not exist");
  }
  for (const NodeId id : options.variable_nodes) {
    if (!graph.HasNode(id)) return NotFound("variable node " + std::to_string(id) + " does not exist");
  }
  if (!options.edge_weights.empty() && options.edge_weights.size() != graph.num_edges()) {
    return InvalidArgument("edge_weights has " + std::to_string(options.edge_weights.size()) +
                           " weights for " + std::to_string(graph.num_edges()) + " edges");
  }
  const auto start = std::chrono::steady_clock::now();
  const std::optional<ComponentId> component =
      options.component ? std::optional(graph.ComponentOf(*options.component)) : std::nullopt;
  // Which nodes move: the listed window, or every node of the selected component(s).
  std::vector<bool> variable(graph.num_nodes(), options.variable_nodes.empty());
  if (!options.variable_nodes.empty()) {
    for (const NodeId id : options.variable_nodes) variable[graph.IndexOf(id)] = true;
  } else if (component) {
    for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
      variable[i] = graph.ComponentOf(graph.nodes()[i].id) == *component;
    }
  }
  std::vector<const Edge*> included;
  std::vector<double> included_weights;
  for (std::size_t k = 0; k < graph.num_edges(); ++k) {
    const Edge& edge = graph.edges()[k];
    const double weight = options.edge_weights.empty() ? 1.0 : options.edge_weights[k];
    if (weight == 0.0 || !(variable[graph.IndexOf(edge.from)] || variable[graph.IndexOf(edge.to)])) continue;
    included.push_back(&edge);
    included_weights.push_back(weight);
  }
  auto included_chi2 = [&] {
    double chi2 = 0.0;
    for (const Edge* edge : included) chi2 += EdgeChi2(graph, *edge);
    return chi2;
  };

  OptimizerSummary summary;
  summary.initial_chi2 = included_chi2();
  if (options.linear_initialization) RETURN_IF_ERROR(InitializeLinear(graph, component));

  // Parameter blocks: plain (x, y, θ) per node, θ kept wrapped by the residual, not by a manifold.
  std::vector<std::array<double, 3>> parameters(graph.num_nodes());
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    const SE2& pose = graph.nodes()[i].pose;
    parameters[i] = {pose.x(), pose.y(), pose.theta()};
  }

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // Every block was validated when the graph was built; Ceres' per-insert checks only cost time.
  problem_options.disable_all_safety_checks = true;
  ceres::Problem problem(problem_options);
  std::unique_ptr<ceres::LossFunction> loss;
  if (options.robust_loss == RobustLoss::kHuber)
    loss = std::make_unique<ceres::HuberLoss>(options.robust_loss_scale);
  if (options.robust_loss == RobustLoss::kCauchy) {
    loss = std::make_unique<ceres::CauchyLoss>(options.robust_loss_scale);
  }
  for (std::size_t k = 0; k < included.size(); ++k) {
    const Edge* edge = included[k];
    problem.AddResidualBlock(
        new EdgeCost(edge->measurement, std::sqrt(included_weights[k]) * SqrtInformation(edge->information)),
        loss.get(), parameters[graph.IndexOf(edge->from)].data(), parameters[graph.IndexOf(edge->to)].data());
  }
  if (problem.NumResidualBlocks() == 0) {
    summary.final_chi2 = summary.initial_chi2;
    summary.converged = true;
    summary.message = "no edges to optimise";
    return summary;
  }

  // Gauge: nodes outside a window are held where they are, and so are fixed nodes; a component with
  // neither gets its first node held.
  std::unordered_set<ComponentId> anchored;
  for (const Node& node : graph.nodes()) {
    const std::size_t index = graph.IndexOf(node.id);
    if (!problem.HasParameterBlock(parameters[index].data())) continue;
    if (node.fixed || !variable[index]) anchored.insert(graph.ComponentOf(node.id));
  }
  for (const Node& node : graph.nodes()) {
    const std::size_t index = graph.IndexOf(node.id);
    double* block = parameters[index].data();
    if (!problem.HasParameterBlock(block)) continue;
    if (node.fixed || !variable[index] || anchored.insert(graph.ComponentOf(node.id)).second) {
      problem.SetParameterBlockConstant(block);
    }
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  // Powell's dogleg: from a good start (warm, or the linear estimate) it needs far fewer factorisations
  // than Levenberg-Marquardt's default radius schedule (3 vs 10 iterations on Manhattan 3500).
  solver_options.trust_region_strategy_type = ceres::DOGLEG;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.relative_cost_decrease;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary ceres_summary;
  {
    const internal::CallingThreadOnly calling_thread_only;  // Ceres factorises with CHOLMOD too
    ceres::Solve(solver_options, &problem, &ceres_summary);
  }
  if (ceres_summary.termination_type == ceres::FAILURE) {
    return Internal("optimisation failed: " + ceres_summary.message);
  }

  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    Node& node = graph.mutable_nodes()[i];
    if (variable[i] && !node.fixed) node.pose = SE2(parameters[i][0], parameters[i][1], parameters[i][2]);
  }
  summary.final_chi2 = included_chi2();
  summary.iterations = ceres_summary.num_successful_steps + ceres_summary.num_unsuccessful_steps;
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.message = ceres_summary.message;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace slamcore
