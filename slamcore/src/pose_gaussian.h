// Gaussian poses on SE(2) and the EKF steps of the hypothesis filter, paper III-B equations (2)–(6).
//
// A PoseGaussian is N(mean, covariance) with the covariance over a LEFT perturbation (se2.h):
// T = exp(ε) · mean, ε ~ N(0, covariance). For a hypothesis the state is G ≈ robot_T_ref, so its
// covariance lives in the robot's frame, like that of an observation z = robot_T_view (eq. (1)).
//
// Direction of the motion update. The paper writes G_{i|i-1} = T_{i|i-1} · G_{i-1|i-1}; with
// G = robot_T_ref, T_{i|i-1} must map the old robot frame into the new one, i.e. new_T_old. Our odometry
// reports increment = old_T_new (events.h), so T_{i|i-1} = increment⁻¹, and its covariance is the
// increment's carried through the inverse: exp(ε)·A → A⁻¹·exp(−ε) = exp(−Adj_{A⁻¹} ε)·A⁻¹.
//
// Thread safety: free functions over values.
#pragma once

#include "slamcore/se2.h"

namespace slamcore::internal {

struct PoseGaussian {
  SE2 mean;
  Matrix3 covariance = Matrix3::Zero();
};

/// The odometry increment old_T_new turned into the paper's motion T_{i|i-1} = new_T_old.
PoseGaussian MotionFromIncrement(const SE2& increment, const Matrix3& increment_covariance);

/// Eq. (3): G ← T·G, Σ_G ← Adj_T Σ_G Adj_Tᵀ + Σ_T, with T = MotionFromIncrement(increment).
PoseGaussian PredictMotion(const PoseGaussian& state, const PoseGaussian& motion);

/// Eq. (4): residual R = z · G⁻¹ with Σ_R = Adj_R Σ_G Adj_Rᵀ + Σ_z, and its squared Mahalanobis norm
/// ln(R)ᵀ Σ_R⁻¹ ln(R), compared with a χ² (3 dof) gate.
struct Innovation {
  SE2 residual;
  Vector3 log;  // ln(R)
  Matrix3 covariance;
  double mahalanobis2 = 0.0;
};
Innovation ComputeInnovation(const PoseGaussian& state, const PoseGaussian& observation);

/// Eqs. (5)–(6): Σ_G ← (Σ_G⁻¹ + Σ_z⁻¹)⁻¹, G ← exp(Σ_G' Σ_z⁻¹ ln R) · G. (The gain of eq. (5) is
/// Σ_G (Σ_G + Σ_z)⁻¹ = Σ_G' Σ_z⁻¹; as in the paper the Adjoint of R is left out of the gain.)
PoseGaussian UpdateWithObservation(const PoseGaussian& state, const PoseGaussian& observation);

/// The largest variance of the position part of a pose covariance (the direction it is least sure of).
double LargestPositionVariance(const Matrix3& covariance);

/// a_T_c = a_T_b · b_T_c for independent Gaussians: Σ = Σ_ab + Adj_{a_T_b} Σ_bc Adj_{a_T_b}ᵀ.
PoseGaussian Compose(const PoseGaussian& a_T_b, const PoseGaussian& b_T_c);

}  // namespace slamcore::internal
