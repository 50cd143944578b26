// The O(change) G′ of the conditional merge against the paper's full copy, over sequences of changes.
#include "../src/merge_overlay.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

#include "full_copy_merged_graph.h"
#include "slamcore/optimizer.h"
#include "status_matchers.h"

namespace slamcore::internal {
namespace {

using slamcore::testing::FullCopyMergedGraph;

Edge MakeEdge(NodeId from, NodeId to, const SE2& measurement, EdgeKind kind) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = measurement;
  edge.information = Matrix3::Identity() * 100.0;
  edge.kind = kind;
  return edge;
}

/// Every read of the overlay equals the full copy's, for every node and every pair of nodes.
void ExpectSameReads(const PoseGraph& base, const MergeOverlay& overlay, const std::string& step) {
  const FullCopyMergedGraph reference(base, overlay.source_node(), overlay.alignment(), overlay.edges());
  ASSERT_THAT(reference, IsOk()) << step;
  for (const Node& a : base.nodes()) {
    const SE2 expected = reference.PoseOf(a.id), actual = overlay.PoseOf(a.id);
    // Bit-identical: both compute alignment · pose with the same operands.
    EXPECT_EQ(actual.vector(), expected.vector()) << step << ", node " << a.id;
    for (const Node& b : base.nodes()) {
      EXPECT_EQ(overlay.SameComponent(a.id, b.id), reference.SameComponent(a.id, b.id))
          << step << ", nodes " << a.id << " and " << b.id;
    }
  }
}

/// Three chains: C_t = 0..4 (target, the parent map), C_s = 10..12 (the robot's), C_o = 20..21 (another).
PoseGraph ThreeComponents() {
  PoseGraph graph;
  auto chain = [&](NodeId first, int count, const SE2& start) {
    SE2 pose = start;
    for (int i = 0; i < count; ++i) {
      Node node;
      node.id = first + i;
      node.pose = pose;
      EXPECT_THAT(graph.AddNode(node), IsOk());
      if (i > 0) {
        EXPECT_THAT(graph.AddEdge(MakeEdge(first + i - 1, first + i, SE2(1.0, 0.0, 0.1), EdgeKind::kMotion)),
                    IsOk());
      }
      pose = pose * SE2(1.0, 0.0, 0.1);
    }
  };
  chain(0, 5, SE2::Identity());
  chain(10, 3, SE2(0.0, 0.0, 0.0));
  chain(20, 2, SE2(5.0, 5.0, 1.0));
  return graph;
}

TEST(MergeOverlayTest, WithoutEdgesOnlyTheAlignmentDiffers) {
  PoseGraph graph = ThreeComponents();
  MergeOverlay overlay(graph, 10, 0);
  overlay.SetAlignment(SE2(1.0, 2.0, 3.0));
  ExpectSameReads(graph, overlay, "no edges");
  EXPECT_FALSE(overlay.SameComponent(10, 0));
  EXPECT_THAT(overlay.PoseOf(11).vector(),
              ::testing::Eq((SE2(1.0, 2.0, 3.0) * graph.node(11).pose).vector()));
  EXPECT_EQ(overlay.PoseOf(3).vector(), graph.node(3).pose.vector());
}

TEST(MergeOverlayTest, EqualsTheFullCopyOverASequenceOfModifications) {
  PoseGraph graph = ThreeComponents();
  MergeOverlay overlay(graph, /*source_node=*/12, /*target_node=*/2);
  overlay.SetAlignment(SE2(2.0, -1.0, 0.7));
  overlay.AddEdge(MakeEdge(12, 2, SE2(0.5, 0.0, 0.0), EdgeKind::kObservation));
  ExpectSameReads(graph, overlay, "first edge");
  EXPECT_TRUE(overlay.SameComponent(10, 4));
  EXPECT_FALSE(overlay.SameComponent(10, 20));

  std::mt19937 random(7);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  NodeId robot = 12, next_id = 100;
  for (int step = 0; step < 40; ++step) {
    const std::string name = "step " + std::to_string(step);
    switch (step % 5) {
      case 0: {  // the robot drives on: a new node in C_s, written to G only
        Node node;
        node.id = next_id++;
        node.pose = graph.node(robot).pose * SE2(0.5, 0.0, value(random));
        ASSERT_THAT(graph.AddNode(node), IsOk());
        ASSERT_THAT(graph.AddEdge(MakeEdge(robot, node.id, SE2(0.5, 0.0, 0.0), EdgeKind::kMotion)), IsOk());
        robot = node.id;
        break;
      }
      case 1:  // the hypothesis takes another observation: one more G′ edge
        overlay.AddEdge(MakeEdge(robot, step % 2 == 0 ? 1 : 3,
                                 SE2(value(random), value(random), value(random)), EdgeKind::kObservation));
        break;
      case 2:  // its state moved: a new alignment
        overlay.SetAlignment(SE2(value(random) * 3, value(random) * 3, value(random) * 3));
        break;
      case 3: {  // a direct observation edge inside C_s, then optimisation of C_s in G
        ASSERT_THAT(graph.AddEdge(
                        MakeEdge(robot, 10, SE2(value(random), value(random), 0.2), EdgeKind::kObservation)),
                    IsOk());
        OptimizerOptions options;
        options.component = robot;
        options.max_iterations = 5;
        ASSERT_THAT(Optimize(graph, options), IsOk());
        break;
      }
      case 4: {  // an unrelated component grows
        Node node;
        node.id = next_id++;
        node.pose = SE2(value(random), value(random), value(random));
        ASSERT_THAT(graph.AddNode(node), IsOk());
        ASSERT_THAT(graph.AddEdge(MakeEdge(21, node.id, SE2(1.0, 0.0, 0.0), EdgeKind::kMotion)), IsOk());
        break;
      }
    }
    ExpectSameReads(graph, overlay, name);
  }
  EXPECT_EQ(overlay.edges().size(), 9u);        // the first edge and 8 more
  EXPECT_FALSE(graph.SameComponent(robot, 0));  // G itself was never merged
  EXPECT_TRUE(overlay.SameComponent(robot, 0));
}

}  // namespace
}  // namespace slamcore::internal
