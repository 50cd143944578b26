// Scoring a replay against known wrong loop closures: each closure is scored as the edge of the file it is,
// also when a wrong one is written between the same two vertices as a true one.
#include <Eigen/LU>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <numbers>

#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/optimizer.h"
#include "status_matchers.h"
#include "test_data.h"

namespace slamcore {
namespace {

/// A 10 m square driven one and a half times: 60 poses 1 m apart, turning left at every corner, so pose
/// k + 40 is pose k; odometry between consecutive poses, true loop closures k → k + 40 for k = 10..14
/// (edge indices 59..63), and one wrong closure 12 → 52 (index 64) that says the robot was 5 m further on.
PoseGraph SquareWithAWrongTwin(bool twin_first = false) {
  PoseGraph graph;
  for (int k = 0; k < 60; ++k) EXPECT_THAT(graph.AddNode(Node{.id = k}), IsOk());
  const Matrix3 information = Vector3(1e4, 1e4, 1e6).asDiagonal();  // 1 cm, 1 mrad: direct edges
  for (int k = 0; k + 1 < 60; ++k) {
    const double turn = k % 10 == 9 ? std::numbers::pi / 2 : 0.0;
    EXPECT_THAT(graph.AddEdge(
                    Edge{.from = k, .to = k + 1, .measurement = SE2(1, 0, turn), .information = information}),
                IsOk());
  }
  const auto add_twin = [&] {
    EXPECT_THAT(graph.AddEdge(Edge{.from = 12,
                                   .to = 52,
                                   .measurement = SE2(5, 0, 0),
                                   .information = information,
                                   .kind = EdgeKind::kObservation}),
                IsOk());
  };
  if (twin_first) add_twin();
  for (int k = 10; k < 15; ++k) {
    EXPECT_THAT(graph.AddEdge(Edge{.from = k,
                                   .to = k + 40,
                                   .measurement = SE2(0, 0, 0),
                                   .information = information,
                                   .kind = EdgeKind::kObservation}),
                IsOk());
  }
  if (!twin_first) add_twin();
  return graph;
}

TEST(ReplayScoreTest, AWrongClosureBetweenTheVerticesOfATrueOneIsScoredAsItself) {
  const PoseGraph graph = SquareWithAWrongTwin();
  ASSERT_EQ(graph.num_edges(), 65u);
  const auto replay = ReplayPoseGraph(graph, MapperParams{});
  ASSERT_THAT(replay, IsOk());
  // Every loop closure of the file is either accepted or rejected, once.
  std::vector<std::size_t> all = replay->accepted_edges;
  all.insert(all.end(), replay->rejected_edges.begin(), replay->rejected_edges.end());
  std::sort(all.begin(), all.end());
  EXPECT_THAT(all, ::testing::ElementsAre(59, 60, 61, 62, 63, 64));
  // The true 12 → 52 (index 61) is taken, its wrong twin (64) is not, though both join the same vertices.
  EXPECT_THAT(replay->accepted_edges, ::testing::Contains(61));
  EXPECT_THAT(replay->rejected_edges, ::testing::ElementsAre(64));

  const FilterScore score = ScoreReplay(*replay, /*first_wrong_edge=*/64);
  EXPECT_EQ(score.wrong_total, 1);
  EXPECT_EQ(score.wrong_accepted, 0);
  EXPECT_EQ(score.true_total, 5);
  EXPECT_EQ(score.true_accepted, 5);
  EXPECT_DOUBLE_EQ(score.Precision(), 1.0);
}

TEST(ReplayScoreTest, TheAcceptedOneOfTwoClosuresBetweenTheSameVerticesIsTheOneWhoseMeasurementGHolds) {
  // The wrong twin written first (index 59), the true 12 → 52 at 62: the Mapper's edge carries the true
  // measurement, so the true closure is the accepted one, whatever the file order.
  const auto replay = ReplayPoseGraph(SquareWithAWrongTwin(/*twin_first=*/true), MapperParams{});
  ASSERT_THAT(replay, IsOk());
  EXPECT_THAT(replay->accepted_edges, ::testing::Contains(62));
  EXPECT_THAT(replay->rejected_edges, ::testing::ElementsAre(59));
}

// A file may write its odometry backwards (k → k−1). Each such edge is read inverted — z⁻¹, whose left
// perturbation covariance is the edge's own Ω⁻¹ — so the replay is the replay of the same graph written
// forwards: the same closures accepted, the same χ². (Before, every one started a new component.)
TEST(ReplayTest, OdometryWrittenBackwardsReplaysAsWrittenForwards) {
  const auto ring = test_data::Find("posegraphs/vertigo/ring.g2o");
  ASSERT_TRUE(ring) << "data/ holds the ring graph";
  const Result<PoseGraph> forwards = ReadPoseGraph(*ring);
  ASSERT_THAT(forwards, IsOk());
  PoseGraph backwards;
  for (const Node& node : forwards->nodes()) ASSERT_THAT(backwards.AddNode(node), IsOk());
  int reversed = 0;
  for (const Edge& edge : forwards->edges()) {
    Edge written = edge;
    if (edge.to == edge.from + 1) {
      written.from = edge.to;
      written.to = edge.from;
      written.measurement = edge.measurement.inverse();
      written.information =
          EdgeInformationFromLeftCovariance(written.measurement, edge.information.inverse());
      written.kind = EdgeKind::kObservation;  // as the reader labels an edge k → k−1
      ++reversed;
    }
    ASSERT_THAT(backwards.AddEdge(written), IsOk());
  }
  ASSERT_GT(reversed, 400);
  // Each reversed edge's χ² at the file's poses is the forward one's: the information was carried over.
  EXPECT_NEAR(Chi2(backwards), Chi2(*forwards), 1e-6 * Chi2(*forwards));
  const auto a = ReplayPoseGraph(*forwards, MapperParams{});
  const auto b = ReplayPoseGraph(backwards, MapperParams{});
  ASSERT_THAT(a, IsOk());
  ASSERT_THAT(b, IsOk());
  ASSERT_FALSE(a->accepted.empty());
  EXPECT_EQ(b->accepted, a->accepted);
  EXPECT_EQ(b->rejected, a->rejected);  // no odometry edge taken for a loop closure
  EXPECT_NEAR(b->final_chi2, a->final_chi2, 1e-6 * a->final_chi2);
}

}  // namespace
}  // namespace slamcore
