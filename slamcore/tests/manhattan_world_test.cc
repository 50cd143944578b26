#include "slamcore/manhattan_world.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "slamcore/optimizer.h"
#include "slamcore/trajectory_error.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

ManhattanWorld Generate(int poses, std::uint64_t seed) {
  ManhattanOptions options;
  options.poses = poses;
  options.seed = seed;
  auto world = GenerateManhattanWorld(options);
  EXPECT_THAT(world, IsOk());
  return std::move(*world);
}

std::vector<Vector2> Positions(const std::vector<SE2>& poses) {
  std::vector<Vector2> positions;
  for (const SE2& pose : poses) positions.push_back(pose.translation());
  return positions;
}

std::vector<Vector2> Positions(const PoseGraph& graph) {
  std::vector<Vector2> positions;
  for (const Node& node : graph.nodes()) positions.push_back(node.pose.translation());
  return positions;
}

TEST(ManhattanWorldTest, SameSeedSameGraphOtherSeedOtherGraph) {
  const ManhattanWorld a = Generate(500, 7), b = Generate(500, 7), c = Generate(500, 8);
  ASSERT_EQ(a.graph.num_edges(), b.graph.num_edges());
  for (std::size_t k = 0; k < a.graph.num_edges(); ++k) {
    const Edge &ea = a.graph.edges()[k], &eb = b.graph.edges()[k];
    EXPECT_EQ(ea.from, eb.from);
    EXPECT_EQ(ea.to, eb.to);
    EXPECT_EQ(ea.measurement.x(), eb.measurement.x());
    EXPECT_EQ(ea.measurement.theta(), eb.measurement.theta());
  }
  for (std::size_t k = 0; k < a.graph.num_nodes(); ++k)
    EXPECT_EQ(a.graph.nodes()[k].pose.y(), b.graph.nodes()[k].pose.y());
  bool differs = a.graph.num_edges() != c.graph.num_edges();
  for (std::size_t k = 0; !differs && k < a.graph.num_nodes(); ++k) {
    differs = a.graph.nodes()[k].pose.x() != c.graph.nodes()[k].pose.x();
  }
  EXPECT_TRUE(differs);
}

TEST(ManhattanWorldTest, CountsAndStructure) {
  const ManhattanOptions defaults;
  for (const int poses : {100, 3500}) {
    const ManhattanWorld world = Generate(poses, 1);
    ASSERT_EQ(world.graph.num_nodes(), static_cast<std::size_t>(poses));
    ASSERT_EQ(world.truth.size(), static_cast<std::size_t>(poses));
    EXPECT_EQ(world.graph.NumComponents(), 1u);
    int motion = 0, closures = 0;
    for (const Edge& edge : world.graph.edges()) {
      if (edge.kind == EdgeKind::kMotion) {
        EXPECT_EQ(edge.to, edge.from + 1);
        ++motion;
      } else {
        ++closures;
      }
    }
    EXPECT_EQ(motion, poses - 1);
    EXPECT_LE(closures, defaults.max_closures_per_pose * poses);
    if (poses == 3500) {
      // The density of Olson's set (2099 closures on 3500 poses), within a factor of two.
      EXPECT_GT(closures, 1000);
      EXPECT_LT(closures, 4200);
    }
  }
}

TEST(ManhattanWorldTest, ClosuresOnlyBetweenTrulyRevisitedPlaces) {
  const ManhattanOptions defaults;
  const ManhattanWorld world = Generate(3500, 3);
  int closures = 0;
  for (const Edge& edge : world.graph.edges()) {
    const SE2& from = world.truth[static_cast<std::size_t>(edge.from)];
    const SE2& to = world.truth[static_cast<std::size_t>(edge.to)];
    // Every edge's measurement is the true relative pose up to its noise (5 σ).
    const SE2 truth = from.inverse() * to;
    EXPECT_LT(std::abs(edge.measurement.x() - truth.x()), 5 * defaults.sigma_xy);
    EXPECT_LT(std::abs(WrapAngle(edge.measurement.theta() - truth.theta())), 5 * defaults.sigma_theta);
    if (edge.kind != EdgeKind::kObservation) continue;
    ++closures;
    EXPECT_LE((from.translation() - to.translation()).norm(), defaults.closure_radius);
    EXPECT_GE(edge.to - edge.from, defaults.min_closure_gap);
  }
  EXPECT_GT(closures, 0);
}

TEST(ManhattanWorldTest, TruthWalksTheGridInsideTheWorld) {
  const ManhattanWorld world = Generate(2000, 5);
  const ManhattanOptions defaults;
  const double side = std::ceil(std::sqrt(2000.0) / 3.0) * defaults.block_length;
  for (std::size_t k = 0; k < world.truth.size(); ++k) {
    const SE2& pose = world.truth[k];
    EXPECT_EQ(pose.x(), std::round(pose.x()));
    EXPECT_GE(pose.x(), 0.0);
    EXPECT_LE(pose.y(), side);
    if (k > 0) {
      EXPECT_NEAR((pose.translation() - world.truth[k - 1].translation()).norm(), 1.0, 1e-12);
    }
  }
}

TEST(ManhattanWorldTest, GroundTruthFileLetsTrajectoryErrorBeComputed) {
  ManhattanWorld world = Generate(800, 2);
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "manhattan_truth.txt";
  ASSERT_THAT(WriteGroundTruth(world.truth, path), IsOk());
  std::ifstream input(path);
  std::vector<Vector2> read;
  for (double id, x, y, theta; input >> id >> x >> y >> theta;) {
    EXPECT_EQ(id, static_cast<double>(read.size()));
    read.emplace_back(x, y);
  }
  ASSERT_EQ(read.size(), world.truth.size());
  EXPECT_EQ(read.back(), world.truth.back().translation());  // full precision
  // Dead reckoning drifts; the optimised graph is far closer to the truth.
  const double drift = *AlignedRmse(Positions(world.graph), read);
  OptimizerOptions options;
  options.linear_initialization = true;
  ASSERT_THAT(Optimize(world.graph, options), IsOk());
  const double optimised = *AlignedRmse(Positions(world.graph), read);
  EXPECT_LT(optimised, 0.5 * drift);
  EXPECT_LT(optimised, 0.3);
  EXPECT_EQ(*AlignedRmse(Positions(world.truth), read), 0.0);
}

TEST(ManhattanWorldTest, RefusesBadOptionsNamingThem) {
  ManhattanOptions options;
  options.poses = 1;
  EXPECT_NE(GenerateManhattanWorld(options).status().message().find("poses"), std::string::npos);
  options.poses = kMaxManhattanPoses + 1;
  EXPECT_NE(GenerateManhattanWorld(options).status().message().find("poses"), std::string::npos);
  options = {};
  options.sigma_xy = 0.0;
  EXPECT_NE(GenerateManhattanWorld(options).status().message().find("sigma_xy"), std::string::npos);
  options = {};
  options.closure_probability = 1.5;
  EXPECT_NE(GenerateManhattanWorld(options).status().message().find("closure_probability"),
            std::string::npos);
  EXPECT_FALSE(WriteGroundTruth({SE2::Identity()}, "/nonexistent-directory/truth.txt").ok());
}

}  // namespace
}  // namespace slamcore
