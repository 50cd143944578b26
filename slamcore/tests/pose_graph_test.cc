#include "slamcore/pose_graph.h"

#include <gtest/gtest.h>

#include "status_matchers.h"

namespace slamcore {
namespace {

Node MakeNode(NodeId id, double x = 0.0) {
  Node node;
  node.id = id;
  node.pose = SE2(x, 0.0, 0.0);
  return node;
}

Edge MakeEdge(NodeId from, NodeId to, EdgeKind kind = EdgeKind::kMotion) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = SE2(1.0, 0.0, 0.0);
  edge.kind = kind;
  return edge;
}

TEST(PoseGraphTest, NodesStartAsTheirOwnComponents) {
  PoseGraph graph;
  for (NodeId id = 0; id < 4; ++id) ASSERT_THAT(graph.AddNode(MakeNode(id)), IsOk());
  EXPECT_EQ(graph.NumComponents(), 4u);
  EXPECT_FALSE(graph.SameComponent(0, 1));
}

TEST(PoseGraphTest, EdgesMergeComponents) {
  PoseGraph graph;
  for (NodeId id = 0; id < 6; ++id) ASSERT_THAT(graph.AddNode(MakeNode(id)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(0, 1)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(1, 2)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(3, 4)), IsOk());
  EXPECT_EQ(graph.NumComponents(), 3u);  // {0,1,2} {3,4} {5}
  EXPECT_TRUE(graph.SameComponent(0, 2));
  EXPECT_FALSE(graph.SameComponent(2, 3));
  EXPECT_EQ(graph.ComponentSize(4), 2u);

  // Merging two components by an observation edge.
  ASSERT_THAT(graph.AddEdge(MakeEdge(4, 1, EdgeKind::kObservation)), IsOk());
  EXPECT_EQ(graph.NumComponents(), 2u);
  EXPECT_TRUE(graph.SameComponent(0, 3));
  EXPECT_EQ(graph.ComponentSize(3), 5u);
  // The larger component's name survives the merge.
  EXPECT_EQ(graph.ComponentOf(3), graph.ComponentOf(0));
  EXPECT_EQ(graph.NodesOf(graph.ComponentOf(4)), (std::vector<NodeId>{0, 1, 2, 3, 4}));
  EXPECT_EQ(graph.Components().size(), 2u);
}

TEST(PoseGraphTest, RemovingAnEdgeSplitsComponentsAgain) {
  PoseGraph graph;
  for (NodeId id = 0; id < 4; ++id) ASSERT_THAT(graph.AddNode(MakeNode(id)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(0, 1)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(2, 3)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(1, 2, EdgeKind::kObservation)), IsOk());
  EXPECT_EQ(graph.NumComponents(), 1u);
  EXPECT_EQ(graph.RemoveEdgesIf([](const Edge& edge) { return edge.kind == EdgeKind::kObservation; }), 1u);
  EXPECT_EQ(graph.NumComponents(), 2u);
  EXPECT_FALSE(graph.SameComponent(1, 2));
}

TEST(PoseGraphTest, CopiesAreIndependent) {
  PoseGraph graph;
  ASSERT_THAT(graph.AddNode(MakeNode(0)), IsOk());
  ASSERT_THAT(graph.AddNode(MakeNode(1)), IsOk());
  PoseGraph copy = graph;
  ASSERT_THAT(copy.AddEdge(MakeEdge(0, 1)), IsOk());
  copy.mutable_node(0).pose = SE2(5.0, 0.0, 0.0);
  EXPECT_EQ(graph.NumComponents(), 2u);
  EXPECT_EQ(graph.num_edges(), 0u);
  EXPECT_EQ(graph.node(0).pose.x(), 0.0);
  EXPECT_EQ(copy.NumComponents(), 1u);
}

TEST(PoseGraphTest, ViewsAttachToNodes) {
  PoseGraph graph;
  ASSERT_THAT(graph.AddNode(MakeNode(7)), IsOk());
  ASSERT_THAT(graph.AddView({.id = 70, .node = 7, .ambiguous = false}), IsOk());
  EXPECT_EQ(graph.view(70).node, 7);
  EXPECT_EQ(graph.FindView(71), nullptr);
  EXPECT_EQ(graph.AddView({.id = 71, .node = 8, .ambiguous = false}).code(), StatusCode::kNotFound);
  EXPECT_EQ(graph.AddView({.id = 70, .node = 7, .ambiguous = false}).code(), StatusCode::kInvalidArgument);
}

TEST(PoseGraphTest, AGraphOfSomeEdgesKeepsEveryNodeAndViewAndTheKeptEdgesObservationsIncluded) {
  PoseGraph graph;
  for (NodeId id = 0; id < 4; ++id) ASSERT_THAT(graph.AddNode(MakeNode(id, id)), IsOk());
  ASSERT_THAT(graph.AddView({.id = 50, .node = 0, .ambiguous = false}), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(0, 1)), IsOk());
  ASSERT_THAT(graph.AddEdge(MakeEdge(1, 2)), IsOk());
  Edge observation = MakeEdge(3, 0, EdgeKind::kObservation);
  observation.view = 50;
  ASSERT_THAT(graph.AddEdge(observation), IsOk());
  ASSERT_EQ(graph.NumComponents(), 1u);

  // The second motion edge left out: the observation edge (naming view 50) stays, and so do all nodes.
  const auto kept = graph.WithEdges({true, false, true});
  ASSERT_THAT(kept, IsOk());
  EXPECT_EQ(kept->num_nodes(), 4u);
  ASSERT_EQ(kept->views().size(), 1u);
  ASSERT_EQ(kept->num_edges(), 2u);
  EXPECT_EQ(kept->edges()[1].kind, EdgeKind::kObservation);
  EXPECT_EQ(kept->edges()[1].view, std::optional<ViewId>(50));
  EXPECT_EQ(kept->NumComponents(), 2u);  // {0, 1, 3} {2}
  EXPECT_TRUE(kept->SameComponent(3, 1));
  EXPECT_FALSE(kept->SameComponent(1, 2));
  EXPECT_EQ(graph.num_edges(), 3u) << "the graph itself is unchanged";
  EXPECT_EQ(graph.WithEdges({true, false}).status().code(), StatusCode::kInvalidArgument);
}

TEST(PoseGraphTest, RejectsBadInputAndStaysUnchanged) {
  PoseGraph graph;
  ASSERT_THAT(graph.AddNode(MakeNode(0)), IsOk());
  ASSERT_THAT(graph.AddNode(MakeNode(1)), IsOk());
  EXPECT_EQ(graph.AddNode(MakeNode(0)).code(), StatusCode::kInvalidArgument);

  Node nan_node = MakeNode(2);
  nan_node.pose = SE2(std::nan(""), 0.0, 0.0);
  EXPECT_EQ(graph.AddNode(nan_node).code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(graph.AddEdge(MakeEdge(0, 9)).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(graph.AddEdge(MakeEdge(0, 0)).status().code(), StatusCode::kInvalidArgument);
  Edge indefinite = MakeEdge(0, 1);
  indefinite.information(2, 2) = -1.0;
  const auto status = graph.AddEdge(indefinite).status();
  EXPECT_THAT(status, StatusIs(StatusCode::kInvalidArgument));
  EXPECT_NE(status.message().find("positive definite"), std::string::npos) << status.message();
  Edge asymmetric = MakeEdge(0, 1);
  asymmetric.information(0, 1) = 0.5;
  EXPECT_EQ(graph.AddEdge(asymmetric).status().code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(graph.num_nodes(), 2u);
  EXPECT_EQ(graph.num_edges(), 0u);
  EXPECT_EQ(graph.NumComponents(), 2u);
}

}  // namespace
}  // namespace slamcore
