// Test helpers shared by slamcore's tests: pose matchers and numerical Jacobians.
#pragma once

#include <gmock/gmock.h>

#include <functional>

#include "slamcore/se2.h"

namespace slamcore::testing {

MATCHER_P2(IsNearlyPose, expected, tolerance, "") {
  if (arg.IsApprox(expected, tolerance)) return true;
  *result_listener << "pose (" << arg.x() << ", " << arg.y() << ", " << arg.theta() << ") vs expected ("
                   << expected.x() << ", " << expected.y() << ", " << expected.theta() << ")";
  return false;
}

/// Central differences of a pose-valued function under a left perturbation of its pose argument,
/// measured as a left perturbation of the output: d Log(f(exp(δ)·T) · f(T)⁻¹) / dδ.
inline Matrix3 NumericPoseJacobian(const std::function<SE2(const SE2&)>& f, const SE2& at,
                                   double step = 1e-6) {
  Matrix3 jacobian;
  const SE2 centre_inverse = f(at).inverse();
  for (int k = 0; k < 3; ++k) {
    Vector3 delta = Vector3::Zero();
    delta[k] = step;
    const Vector3 plus = SE2::Log(f(SE2::Exp(delta) * at) * centre_inverse);
    const Vector3 minus = SE2::Log(f(SE2::Exp(-delta) * at) * centre_inverse);
    jacobian.col(k) = (plus - minus) / (2 * step);
  }
  return jacobian;
}

/// Central differences of a vector-valued function of a vector.
template <int Rows, int Cols>
Eigen::Matrix<double, Rows, Cols> NumericJacobian(
    const std::function<Eigen::Matrix<double, Rows, 1>(const Eigen::Matrix<double, Cols, 1>&)>& f,
    const Eigen::Matrix<double, Cols, 1>& at, double step = 1e-6) {
  Eigen::Matrix<double, Rows, Cols> jacobian;
  for (int k = 0; k < Cols; ++k) {
    Eigen::Matrix<double, Cols, 1> delta = Eigen::Matrix<double, Cols, 1>::Zero();
    delta[k] = step;
    jacobian.col(k) = (f(at + delta) - f(at - delta)) / (2 * step);
  }
  return jacobian;
}

}  // namespace slamcore::testing
