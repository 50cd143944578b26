// Nonlinear least-squares optimisation of a PoseGraph with Ceres Solver.
//
// Error of an edge i→j with measurement z = i_T_j (the g2o EDGE_SE2 convention, so χ² values compare
// with published g2o results):
//     e = ( R_zᵀ · (R_iᵀ · (t_j − t_i) − t_z),  wrap(θ_j − θ_i − θ_z) ),     χ² = Σ eᵀ Ω e.
// Residuals are L·e with Ω = LᵀL and analytic Jacobians; the trust region is Powell's dogleg over Ceres'
// sparse normal Cholesky. The gauge is fixed per component: nodes marked `fixed`, or else the component's first node.
// Optimisation starts from the graph's current poses (warm start), or optionally from a linear estimate,
// and stops when the relative cost
// decrease of an iteration falls below `relative_cost_decrease`.
//
// Thread safety: Optimize writes the graph's poses; the caller serialises access to the graph.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore {

enum class RobustLoss { kNone, kHuber, kCauchy };

struct OptimizerOptions {
  int max_iterations = 100;
  /// Stop when |Δcost| / cost of an iteration is below this (Ceres' function_tolerance).
  double relative_cost_decrease = 1e-6;
  RobustLoss robust_loss = RobustLoss::kNone;
  /// Scale of the robust loss in units of the whitened residual norm.
  double robust_loss_scale = 1.0;
  /// When set, only this component is optimised; otherwise every component is.
  std::optional<ComponentId> component;
  /// When non-empty, only these nodes move (a local window): the edges touching them are optimised and
  /// their other ends are held where they are. `component` is then ignored.
  std::vector<NodeId> variable_nodes;
  /// Threads for residual evaluation and the linear solver.
  int num_threads = 1;
  /// Start from the linear estimate of linear_initialization.h instead of the current poses (which is
  /// the warm start). For batch optimisation of graphs whose initial guess is composed odometry.
  bool linear_initialization = false;
  /// When non-empty, one weight ≥ 0 per edge of the graph, in edges() order: the edge's information is
  /// scaled by it and edges weighted 0 are left out (graduated non-convexity, mapper_consistent_set.cc).
  std::vector<double> edge_weights;
};

/// Checks that options are usable; names the bad field.
Status Validate(const OptimizerOptions& options);

struct OptimizerSummary {
  double initial_chi2 = 0.0;
  double final_chi2 = 0.0;
  int iterations = 0;
  double seconds = 0.0;
  bool converged = false;  // stopped by a tolerance rather than by the iteration limit or a failure
  std::string message;     // Ceres' reason for stopping
};

/// Optimises the poses of `graph` in place. χ² figures in the summary cover the optimised edges.
Result<OptimizerSummary> Optimize(PoseGraph& graph, const OptimizerOptions& options = {});

/// The error e of one edge (see the top of this file), with optional Jacobians with respect to the plain
/// (x, y, θ) parameters of the two poses.
Vector3 EdgeError(const SE2& from, const SE2& to, const SE2& measurement, Matrix3* d_from = nullptr,
                  Matrix3* d_to = nullptr);
/// The same with Rᵀ of the measurement given (`measurement.rotation().transpose()`), for solvers that
/// linearise one edge many times: the measurement does not change, its sine and cosine need not be redone.
Vector3 EdgeError(const SE2& from, const SE2& to, const SE2& measurement,
                  const Matrix2& measurement_rotation_t, Matrix3* d_from = nullptr, Matrix3* d_to = nullptr);
/// The same with Rᵀ of `from` given too (`from.rotation().transpose()`): a solver that evaluates many edges
/// at poses that mostly stay put keeps each node's, and redoes it only when the node turned.
Vector3 EdgeError(const SE2& from, const Matrix2& from_rotation_t, const SE2& to, const SE2& measurement,
                  const Matrix2& measurement_rotation_t, Matrix3* d_from = nullptr, Matrix3* d_to = nullptr);

/// The information matrix of an edge z = from_T_to over the error above, from a covariance of left
/// perturbations of z (the convention of events.h): z·exp(e) = exp(Adj_z e)·z, so Σ_e = Adj_z⁻¹ Σ Adj_z⁻ᵀ.
Matrix3 EdgeInformationFromLeftCovariance(const SE2& measurement, const Matrix3& left_covariance);
/// The inverse translation: the left-perturbation covariance of z from an edge's information.
Matrix3 LeftCovarianceFromEdgeInformation(const SE2& measurement, const Matrix3& information);

/// eᵀ Ω e of one edge at the graph's current poses (its residual).
double EdgeChi2(const PoseGraph& graph, const Edge& edge);

/// χ² = Σ eᵀ Ω e over all edges, or over the edges of one component.
double Chi2(const PoseGraph& graph, std::optional<ComponentId> component = std::nullopt);

}  // namespace slamcore
