#include "slamcore/trajectory_error.h"

#include <gtest/gtest.h>

#include <random>

#include "status_matchers.h"

namespace slamcore {
namespace {

TEST(TrajectoryErrorTest, RecoversAKnownRigidMotion) {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> coordinate(-10.0, 10.0);
  const SE2 motion(3.0, -2.0, 2.5);
  std::vector<Vector2> estimate, reference;
  for (int k = 0; k < 50; ++k) {
    estimate.emplace_back(coordinate(random), coordinate(random));
    reference.push_back(motion * estimate.back());
  }
  const auto aligned = AlignRigidly(estimate, reference);
  ASSERT_THAT(aligned, IsOk());
  EXPECT_TRUE(aligned->IsApprox(motion, 1e-9));
  EXPECT_NEAR(*AlignedRmse(estimate, reference), 0.0, 1e-9);
}

TEST(TrajectoryErrorTest, RmseOfAKnownOffsetPattern) {
  // Points of a square, the estimate with alternating ±0.1 m radial errors: the best rigid motion is the
  // identity by symmetry and the RMS error is 0.1 m exactly.
  const std::vector<Vector2> reference = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  const std::vector<Vector2> estimate = {{1.1, 0}, {0, 0.9}, {-1.1, 0}, {0, -0.9}};
  EXPECT_NEAR(*AlignedRmse(estimate, reference), 0.1, 1e-12);
}

TEST(TrajectoryErrorTest, RefusesMismatchedInput) {
  EXPECT_FALSE(AlignRigidly({{0, 0}}, {{0, 0}}).ok());
  EXPECT_FALSE(AlignRigidly({{0, 0}, {1, 1}}, {{0, 0}}).ok());
}

}  // namespace
}  // namespace slamcore
