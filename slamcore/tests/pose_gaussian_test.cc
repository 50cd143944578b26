// EKF steps of the hypothesis filter (paper eqs. (2)–(6)) against numbers worked out by hand.
#include "../src/pose_gaussian.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_matchers.h"

namespace slamcore::internal {
namespace {

using testing::IsNearlyPose;
using testing::NumericPoseJacobian;

TEST(PoseGaussianTest, MotionFromIncrementInvertsTheIncrementAndCarriesItsCovariance) {
  // increment old_T_new = (1, 0, 0): T = new_T_old = (−1, 0, 0), Adj_T = [1 0 0; 0 1 1; 0 0 1]
  // (Adj = [R, (y, −x)ᵀ; 0, 1]), so Adj diag(a, b, c) Adjᵀ = [a 0 0; 0 b+c c; 0 c c].
  const PoseGaussian motion = MotionFromIncrement(SE2(1.0, 0.0, 0.0), Vector3(1.0, 2.0, 3.0).asDiagonal());
  EXPECT_THAT(motion.mean, IsNearlyPose(SE2(-1.0, 0.0, 0.0), 1e-12));
  Matrix3 expected;
  expected << 1, 0, 0, 0, 5, 3, 0, 3, 3;
  EXPECT_TRUE(motion.covariance.isApprox(expected, 1e-12)) << motion.covariance;
}

TEST(PoseGaussianTest, MotionUpdateMovesTheViewTowardTheRobot) {
  // View 2 m ahead; the robot drives 1 m forward: the view is now 1 m ahead (eq. (3)).
  const PoseGaussian state{SE2(2.0, 0.0, 0.0), Matrix3::Identity() * 0.01};
  const PoseGaussian motion = MotionFromIncrement(SE2(1.0, 0.0, 0.0), Matrix3::Zero());
  const PoseGaussian predicted = PredictMotion(state, motion);
  EXPECT_THAT(predicted.mean, IsNearlyPose(SE2(1.0, 0.0, 0.0), 1e-12));
  // Pure translation: Adj = [I, (0, 1)ᵀ; 0 1]; Adj (0.01 I) Adjᵀ = 0.01 [1 0 0; 0 2 1; 0 1 1].
  Matrix3 expected;
  expected << 1, 0, 0, 0, 2, 1, 0, 1, 1;
  EXPECT_TRUE(predicted.covariance.isApprox(0.01 * expected, 1e-12)) << predicted.covariance;
}

TEST(PoseGaussianTest, MotionUpdateTurnsTheViewWhenTheRobotTurns) {
  // View 2 m ahead; the robot turns 90° left on the spot: the view is now 2 m to its right, turned −90°.
  const PoseGaussian predicted =
      PredictMotion({SE2(2.0, 0.0, 0.0), Matrix3::Identity() * 0.01},
                    MotionFromIncrement(SE2(0.0, 0.0, std::numbers::pi / 2), Matrix3::Zero()));
  EXPECT_THAT(predicted.mean, IsNearlyPose(SE2(0.0, -2.0, -std::numbers::pi / 2), 1e-12));
}

TEST(PoseGaussianTest, MotionUpdateCovarianceIsTheJacobianOfTheComposition) {
  // The Jacobian of G ↦ T·G under left perturbations, measured numerically, must be the Adjoint used.
  const SE2 motion(0.3, -0.7, 1.1), state(1.5, 0.4, -2.0);
  const Matrix3 numeric = NumericPoseJacobian([&](const SE2& g) { return motion * g; }, state);
  const Matrix3 sigma = Vector3(0.02, 0.03, 0.01).asDiagonal();
  const PoseGaussian predicted = PredictMotion({state, sigma}, {motion, Matrix3::Zero()});
  EXPECT_TRUE(predicted.covariance.isApprox(numeric * sigma * numeric.transpose(), 1e-6));
}

TEST(PoseGaussianTest, InnovationOfAPureTranslationResidual) {
  // G = (1, 0, 0), z = (1.3, 0, 0): R = (0.3, 0, 0), ln R = (0.3, 0, 0).
  // Adj_R = [1 0 0; 0 1 −0.3; 0 0 1]; Σ_R = 0.01 Adj Adjᵀ + 0.01 I, whose x-row is (0.02, 0, 0), so
  // d² = 0.3² / 0.02 = 4.5.
  const Innovation innovation = ComputeInnovation({SE2(1.0, 0.0, 0.0), Matrix3::Identity() * 0.01},
                                                  {SE2(1.3, 0.0, 0.0), Matrix3::Identity() * 0.01});
  EXPECT_THAT(innovation.residual, IsNearlyPose(SE2(0.3, 0.0, 0.0), 1e-12));
  EXPECT_TRUE(innovation.log.isApprox(Vector3(0.3, 0.0, 0.0), 1e-12));
  Matrix3 expected;
  expected << 0.02, 0, 0, 0, 0.01 * 1.09 + 0.01, -0.003, 0, -0.003, 0.02;
  EXPECT_TRUE(innovation.covariance.isApprox(expected, 1e-12)) << innovation.covariance;
  EXPECT_NEAR(innovation.mahalanobis2, 4.5, 1e-9);
}

TEST(PoseGaussianTest, UpdateWithEqualCovariancesMovesHalfway) {
  // Σ_G = Σ_z: K = ½ I, Σ_G' = ½ Σ, G' = exp(½ ln R) · G.
  const PoseGaussian updated = UpdateWithObservation({SE2::Identity(), Matrix3::Identity() * 0.04},
                                                     {SE2(0.2, 0.0, 0.0), Matrix3::Identity() * 0.04});
  EXPECT_THAT(updated.mean, IsNearlyPose(SE2(0.1, 0.0, 0.0), 1e-12));
  EXPECT_TRUE(updated.covariance.isApprox(Matrix3::Identity() * 0.02, 1e-12));
}

TEST(PoseGaussianTest, UpdateWeighsEachAxisByItsVariance) {
  // Σ_G = 0.01 I, Σ_z = diag(0.01, 0.01, 0.03): K = diag(½, ½, ¼), so a 0.2 rad residual moves G by
  // 0.05 rad; Σ_G' = diag(1/200, 1/200, 1/(100 + 100/3)) = diag(0.005, 0.005, 0.0075).
  const PoseGaussian updated =
      UpdateWithObservation({SE2::Identity(), Matrix3::Identity() * 0.01},
                            {SE2(0.0, 0.0, 0.2), Vector3(0.01, 0.01, 0.03).asDiagonal()});
  EXPECT_THAT(updated.mean, IsNearlyPose(SE2(0.0, 0.0, 0.05), 1e-12));
  EXPECT_TRUE(updated.covariance.isApprox(Vector3(0.005, 0.005, 0.0075).asDiagonal().toDenseMatrix(), 1e-12));
}

TEST(PoseGaussianTest, UpdateAppliesTheCorrectionOnTheLeft) {
  constexpr double kHalfPi = std::numbers::pi / 2;
  // G = (1, 0, π/2) and z = Rot(0.2)·G with Σ_G = Σ_z: R = z·G⁻¹ = (0, 0, 0.2), a rotation about the
  // robot's origin. The update exp(½ ln R)·G turns G by 0.1 about that origin, not about G's own origin:
  // (cos 0.1, sin 0.1, π/2 + 0.1).
  const PoseGaussian updated =
      UpdateWithObservation({SE2(1.0, 0.0, kHalfPi), Matrix3::Identity() * 0.01},
                            {SE2(std::cos(0.2), std::sin(0.2), kHalfPi + 0.2), Matrix3::Identity() * 0.01});
  EXPECT_THAT(updated.mean, IsNearlyPose(SE2(std::cos(0.1), std::sin(0.1), kHalfPi + 0.1), 1e-9));
}

TEST(PoseGaussianTest, ComposeCarriesTheSecondCovarianceThroughTheAdjoint) {
  const PoseGaussian a{SE2(1.0, 2.0, 0.5), Matrix3::Identity() * 0.01};
  const PoseGaussian b{SE2(-0.5, 0.3, 0.2), Vector3(0.02, 0.03, 0.004).asDiagonal()};
  const PoseGaussian composed = Compose(a, b);
  EXPECT_THAT(composed.mean, IsNearlyPose(a.mean * b.mean, 1e-12));
  const Matrix3 d_b = NumericPoseJacobian([&](const SE2& x) { return a.mean * x; }, b.mean);
  EXPECT_TRUE(composed.covariance.isApprox(a.covariance + d_b * b.covariance * d_b.transpose(), 1e-6));
}

}  // namespace
}  // namespace slamcore::internal
