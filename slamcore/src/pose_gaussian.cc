#include "pose_gaussian.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace slamcore::internal {
namespace {

Matrix3 Symmetrized(const Matrix3& matrix) { return 0.5 * (matrix + matrix.transpose()); }

}  // namespace

PoseGaussian MotionFromIncrement(const SE2& increment, const Matrix3& increment_covariance) {
  const SE2 inverse = increment.inverse();
  const Matrix3 adjoint = inverse.Adjoint();
  return {inverse, Symmetrized(adjoint * increment_covariance * adjoint.transpose())};
}

PoseGaussian PredictMotion(const PoseGaussian& state, const PoseGaussian& motion) {
  const Matrix3 adjoint = motion.mean.Adjoint();
  return {motion.mean * state.mean,
          Symmetrized(adjoint * state.covariance * adjoint.transpose() + motion.covariance)};
}

Innovation ComputeInnovation(const PoseGaussian& state, const PoseGaussian& observation) {
  Innovation innovation;
  innovation.residual = observation.mean * state.mean.inverse();
  innovation.log = SE2::Log(innovation.residual);
  const Matrix3 adjoint = innovation.residual.Adjoint();
  innovation.covariance =
      Symmetrized(adjoint * state.covariance * adjoint.transpose() + observation.covariance);
  innovation.mahalanobis2 = innovation.log.dot(innovation.covariance.ldlt().solve(innovation.log));
  return innovation;
}

PoseGaussian UpdateWithObservation(const PoseGaussian& state, const PoseGaussian& observation) {
  const Vector3 log_residual = SE2::Log(observation.mean * state.mean.inverse());
  // Information form of eq. (6); both covariances were checked positive definite on the way in.
  const Matrix3 observation_information = observation.covariance.inverse();
  const Matrix3 covariance = Symmetrized((state.covariance.inverse() + observation_information).inverse());
  const Vector3 step = covariance * observation_information * log_residual;
  return {SE2::Exp(step) * state.mean, covariance};
}

PoseGaussian Compose(const PoseGaussian& a_T_b, const PoseGaussian& b_T_c) {
  const Matrix3 adjoint = a_T_b.mean.Adjoint();
  return {a_T_b.mean * b_T_c.mean,
          Symmetrized(a_T_b.covariance + adjoint * b_T_c.covariance * adjoint.transpose())};
}

double LargestPositionVariance(const Matrix3& covariance) {
  return covariance.topLeftCorner<2, 2>().selfadjointView<Eigen::Lower>().eigenvalues().maxCoeff();
}

}  // namespace slamcore::internal
