#include "slamcore/se2.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "test_matchers.h"

namespace slamcore {
namespace {

using testing::IsNearlyPose;
using testing::NumericJacobian;
using testing::NumericPoseJacobian;
constexpr double kPi = std::numbers::pi;

/// Poses at identity, at θ ≈ 0, at θ ≈ ±π and at random places.
std::vector<SE2> SamplePoses() {
  std::vector<SE2> poses = {SE2::Identity(),           SE2(1.0, -2.0, 1e-9),        SE2(0.3, 0.4, -1e-7),
                            SE2(2.0, 1.0, kPi - 1e-9), SE2(-1.0, 0.5, -kPi + 1e-9), SE2(0.0, 3.0, kPi / 2)};
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coordinate(-5.0, 5.0), angle(-kPi, kPi);
  for (int i = 0; i < 20; ++i) poses.emplace_back(coordinate(random), coordinate(random), angle(random));
  return poses;
}

std::vector<Vector3> SampleTangents() {
  std::vector<Vector3> tangents = {Vector3::Zero(), Vector3(1.0, 2.0, 1e-9), Vector3(-0.5, 0.2, 3e-5),
                                   Vector3(1.0, -1.0, kPi - 1e-6), Vector3(0.3, 0.1, -kPi + 1e-6)};
  std::mt19937 random(11);
  std::uniform_real_distribution<double> coordinate(-3.0, 3.0), angle(-kPi + 1e-3, kPi - 1e-3);
  for (int i = 0; i < 20; ++i) tangents.emplace_back(coordinate(random), coordinate(random), angle(random));
  return tangents;
}

TEST(WrapAngleTest, WrapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(WrapAngle(kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(-kPi), kPi);
  EXPECT_NEAR(WrapAngle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(WrapAngle(2 * kPi + 0.5), 0.5, 1e-12);
  EXPECT_NEAR(WrapAngle(-2 * kPi - 0.5), -0.5, 1e-12);
  EXPECT_NEAR(WrapAngle(kPi + 0.1), -kPi + 0.1, 1e-12);
}

TEST(SE2Test, ConstructorWrapsTheta) {
  EXPECT_NEAR(SE2(0, 0, 3 * kPi / 2).theta(), -kPi / 2, 1e-12);
  EXPECT_NEAR((SE2(0, 0, kPi * 0.75) * SE2(0, 0, kPi * 0.75)).theta(), -kPi / 2, 1e-12);
}

TEST(SE2Test, ComposeAndActFollowTheFrameConvention) {
  const SE2 world_T_robot(1.0, 2.0, kPi / 2);
  const SE2 robot_T_view(1.0, 0.0, 0.0);
  // One metre ahead of a robot facing +y is one metre further along y.
  EXPECT_THAT(world_T_robot * robot_T_view, IsNearlyPose(SE2(1.0, 3.0, kPi / 2), 1e-12));
  const Vector2 point = world_T_robot * Vector2(0.0, 1.0);
  EXPECT_NEAR(point.x(), 0.0, 1e-12);
  EXPECT_NEAR(point.y(), 2.0, 1e-12);
}

TEST(SE2Test, InverseComposesToIdentity) {
  for (const SE2& pose : SamplePoses()) {
    EXPECT_THAT(pose * pose.inverse(), IsNearlyPose(SE2::Identity(), 1e-12));
    EXPECT_THAT(pose.inverse() * pose, IsNearlyPose(SE2::Identity(), 1e-12));
  }
}

TEST(SE2Test, ExpOfLogIsIdentity) {
  for (const SE2& pose : SamplePoses()) EXPECT_THAT(SE2::Exp(SE2::Log(pose)), IsNearlyPose(pose, 1e-9));
}

TEST(SE2Test, LogOfExpIsIdentity) {
  for (const Vector3& xi : SampleTangents()) {
    EXPECT_TRUE(SE2::Log(SE2::Exp(xi)).isApprox(xi, 1e-9)) << xi.transpose();
  }
}

TEST(SE2Test, ExpOfPureTranslationAndRotation) {
  EXPECT_THAT(SE2::Exp(Vector3(1.0, 2.0, 0.0)), IsNearlyPose(SE2(1.0, 2.0, 0.0), 1e-15));
  // Moving along a quarter circle of arc length π/2 ends at (1, 1) facing +y.
  EXPECT_THAT(SE2::Exp(Vector3(kPi / 2, 0.0, kPi / 2)), IsNearlyPose(SE2(1.0, 1.0, kPi / 2), 1e-12));
}

TEST(SE2Test, AdjointIdentity) {
  for (const SE2& pose : SamplePoses()) {
    for (const Vector3& xi : SampleTangents()) {
      const SE2 conjugated = pose * SE2::Exp(xi) * pose.inverse();
      EXPECT_THAT(conjugated, IsNearlyPose(SE2::Exp(pose.Adjoint() * xi), 1e-9));
    }
  }
}

TEST(SE2Test, ComposeJacobiansMatchNumeric) {
  const auto poses = SamplePoses();
  for (std::size_t k = 0; k + 1 < poses.size(); ++k) {
    const SE2 &a = poses[k], &b = poses[k + 1];
    Matrix3 d_a, d_b;
    SE2::Compose(a, b, &d_a, &d_b);
    EXPECT_TRUE(d_a.isApprox(NumericPoseJacobian([&](const SE2& x) { return x * b; }, a), 1e-6));
    EXPECT_TRUE(d_b.isApprox(NumericPoseJacobian([&](const SE2& x) { return a * x; }, b), 1e-6));
  }
}

TEST(SE2Test, InverseJacobianMatchesNumeric) {
  for (const SE2& pose : SamplePoses()) {
    Matrix3 d_pose;
    SE2::Inverse(pose, &d_pose);
    EXPECT_TRUE(d_pose.isApprox(NumericPoseJacobian([](const SE2& x) { return x.inverse(); }, pose), 1e-6));
  }
}

TEST(SE2Test, ActJacobiansMatchNumeric) {
  const Vector2 point(0.7, -1.3);
  for (const SE2& pose : SamplePoses()) {
    Eigen::Matrix<double, 2, 3> d_pose;
    Matrix2 d_point;
    pose.Act(point, &d_pose, &d_point);
    const auto numeric_pose = NumericJacobian<2, 3>(
        [&](const Vector3& delta) -> Vector2 { return SE2::Exp(delta) * pose * point; }, Vector3::Zero());
    const auto numeric_point =
        NumericJacobian<2, 2>([&](const Vector2& p) -> Vector2 { return pose * p; }, point);
    EXPECT_TRUE(d_pose.isApprox(numeric_pose, 1e-6));
    EXPECT_TRUE(d_point.isApprox(numeric_point, 1e-6));
  }
}

TEST(SE2Test, LeftJacobianMatchesNumeric) {
  for (const Vector3& xi : SampleTangents()) {
    Matrix3 left;
    const SE2 centre = SE2::Exp(xi, &left);
    const auto numeric = NumericJacobian<3, 3>(
        [&](const Vector3& delta) -> Vector3 { return SE2::Log(SE2::Exp(xi + delta) * centre.inverse()); },
        Vector3::Zero());
    EXPECT_TRUE(left.isApprox(numeric, 1e-6)) << "at " << xi.transpose() << "\n" << left << "\n" << numeric;
  }
}

}  // namespace
}  // namespace slamcore
