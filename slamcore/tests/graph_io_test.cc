#include "slamcore/graph_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include "test_data.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

Result<PoseGraph> Read(const std::string& text) {
  std::istringstream input(text);
  return ReadPoseGraph(input, "test.g2o");
}

void ExpectError(const std::string& text, const std::string& fragment) {
  const auto result = Read(text);
  ASSERT_FALSE(result.ok()) << "accepted:\n" << text;
  EXPECT_NE(result.status().message().find(fragment), std::string::npos)
      << "message '" << result.status().message() << "' lacks '" << fragment << "'";
}

constexpr char kSmallG2o[] =
    "# a comment\n"
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1 0 0.1\n"
    "\n"
    "VERTEX_SE2 2 2 0.5 0.2\n"
    "EDGE_SE2 0 1 1 0 0.1 500 0 0 500 0 5000\n"
    "EDGE_SE2 1 2 1 0.4 0.1 500 1 2 400 3 5000\n"
    "EDGE_SE2 2 0 -2 0 0 100 0 0 100 0 1000\n"
    "FIX 0\n";

TEST(GraphIoTest, ReadsG2o) {
  const auto graph = Read(kSmallG2o);
  ASSERT_THAT(graph, IsOk());
  EXPECT_EQ(graph->num_nodes(), 3u);
  EXPECT_EQ(graph->num_edges(), 3u);
  EXPECT_TRUE(graph->node(0).fixed);
  EXPECT_FALSE(graph->node(1).fixed);
  const Edge& second = graph->edges()[1];
  EXPECT_EQ(second.kind, EdgeKind::kMotion);
  EXPECT_EQ(graph->edges()[2].kind, EdgeKind::kObservation);
  // Upper-triangular order I11 I12 I13 I22 I23 I33, mirrored.
  EXPECT_EQ(second.information(0, 1), 1.0);
  EXPECT_EQ(second.information(1, 0), 1.0);
  EXPECT_EQ(second.information(0, 2), 2.0);
  EXPECT_EQ(second.information(2, 1), 3.0);
  EXPECT_EQ(second.information(1, 1), 400.0);
}

TEST(GraphIoTest, ReadsToroWithItsOwnInformationOrder) {
  // TORO: I11 I12 I22 I33 I13 I23
  const auto graph = Read("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 500 1 400 5000 2 3\n");
  ASSERT_THAT(graph, IsOk());
  const Matrix3& info = graph->edges()[0].information;
  EXPECT_EQ(info(0, 0), 500.0);
  EXPECT_EQ(info(0, 1), 1.0);
  EXPECT_EQ(info(1, 1), 400.0);
  EXPECT_EQ(info(2, 2), 5000.0);
  EXPECT_EQ(info(0, 2), 2.0);
  EXPECT_EQ(info(1, 2), 3.0);
}

TEST(GraphIoTest, FileWithoutVerticesIsInitialisedFromOdometry) {
  const auto graph = Read(
      "EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\n"
      "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 2 0 0 0 0 1 0 0 1 0 1\n");
  ASSERT_THAT(graph, IsOk());
  EXPECT_NEAR(graph->node(2).pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(graph->node(2).pose.y(), 1.0, 1e-12);
}

TEST(GraphIoTest, RoundTripIsIdentical) {
  for (const GraphFormat format : {GraphFormat::kG2o, GraphFormat::kToro}) {
    const auto original = Read(kSmallG2o);
    ASSERT_THAT(original, IsOk());
    std::ostringstream first;
    WritePoseGraph(*original, first, format);
    std::istringstream input(first.str());
    const auto reread = ReadPoseGraph(input, "written");
    ASSERT_THAT(reread, IsOk());
    std::ostringstream second;
    WritePoseGraph(*reread, second, format);
    EXPECT_EQ(first.str(), second.str());
    ASSERT_EQ(reread->num_nodes(), original->num_nodes());
    for (const Node& node : original->nodes()) {
      EXPECT_EQ(reread->node(node.id).pose.vector(), node.pose.vector());
      // TORO has no FIX tag, so only g2o keeps it.
      if (format == GraphFormat::kG2o) {
        EXPECT_EQ(reread->node(node.id).fixed, node.fixed);
      }
    }
    for (std::size_t k = 0; k < original->num_edges(); ++k) {
      EXPECT_EQ(reread->edges()[k].measurement.vector(), original->edges()[k].measurement.vector());
      EXPECT_EQ(reread->edges()[k].information, original->edges()[k].information);
    }
  }
}

TEST(GraphIoTest, RealGraphsRoundTripIdentically) {
  // Graphs carried in data/: one with ground-truth poses, one real with vertices, one with edges only.
  const std::filesystem::path data = test_data::Sample() / "posegraphs";
  for (const char* name : {"vertigo/ring.g2o", "vertigo/intel.g2o", "sesync/CSAIL.g2o"}) {
    const auto original = ReadPoseGraph(data / name);
    ASSERT_THAT(original, IsOk());
    const std::filesystem::path written = std::filesystem::path(::testing::TempDir()) / "roundtrip.g2o";
    ASSERT_THAT(WritePoseGraph(*original, written, GraphFormat::kG2o), IsOk());
    const auto reread = ReadPoseGraph(written);
    ASSERT_THAT(reread, IsOk());
    ASSERT_EQ(reread->num_nodes(), original->num_nodes()) << name;
    ASSERT_EQ(reread->num_edges(), original->num_edges()) << name;
    for (std::size_t k = 0; k < original->num_nodes(); ++k) {
      EXPECT_EQ(reread->nodes()[k].id, original->nodes()[k].id);
      EXPECT_EQ(reread->nodes()[k].pose.vector(), original->nodes()[k].pose.vector());
    }
    for (std::size_t k = 0; k < original->num_edges(); ++k) {
      const Edge &a = original->edges()[k], &b = reread->edges()[k];
      EXPECT_EQ(a.from, b.from);
      EXPECT_EQ(a.to, b.to);
      EXPECT_EQ(a.measurement.vector(), b.measurement.vector());
      EXPECT_EQ(a.information, b.information);
    }
  }
}

TEST(GraphIoTest, MalformedInputIsRefusedWithFileLineAndReason) {
  ExpectError(
      "VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\n",
      "test.g2o:2: unknown tag 'VERTEX_XY': landmarks are not read, only poses and the edges between them");
  ExpectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", "test.g2o:1: unknown tag 'VERTEX_SE3:QUAT': a 3D graph");
  ExpectError("VERTEX_SE2 0 0 0 0\nEDGE_SE2_XY 0 1 1 1 1 0 1\n",
              "test.g2o:2: unknown tag 'EDGE_SE2_XY': landmarks");
  ExpectError("VERTEX_SE2 0 0 0 0\nEDGE_SE2_PRIOR 0 0 0 0 1 0 0 1 0 1\n",
              "unknown tag 'EDGE_SE2_PRIOR' (read: VERTEX_SE2, EDGE_SE2, FIX; TORO's VERTEX2, EDGE2)");
  ExpectError("VERTX_SE2 0 0 0 0\n", "test.g2o:1: unknown tag 'VERTX_SE2' (read: VERTEX_SE2, EDGE_SE2, FIX");
  ExpectError("VERTEX_SE2 0 0 0\n", "test.g2o:1: VERTEX_SE2 needs 4 fields, found 3");
  ExpectError("VERTEX_SE2 0 0 0 0 7\n", "needs 4 fields, found 5");
  ExpectError("VERTEX_SE2 0 abc 0 0\n", "test.g2o:1: field 2 'abc' is not a number");
  ExpectError("VERTEX_SE2 x 0 0 0\n", "field 1 'x' is not an integer id");
  ExpectError("VERTEX_SE2 0 nan 0 0\n", "field 2 'nan' is not finite");
  ExpectError("VERTEX_SE2 0 0 inf 0\n", "field 3 'inf' is not finite");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 -1 0 0 1 0 1\n",
              "test.g2o:3: information is not positive definite");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n",
              "information is not positive definite");
  ExpectError("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 5 1 0 0 1 0 0 1 0 1\n",
              "test.g2o:2: edge refers to vertex 5, which is not declared");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n",
              "test.g2o:2: vertex 0 already declared at test.g2o:1");
  ExpectError("VERTEX_SE2 0 0 0 0\nFIX 3\n", "test.g2o:2: FIX of vertex 3, which is not declared");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX2 1 0 0 0\n", "mixes g2o and TORO");
  ExpectError("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 0 1 0 0 1 0 0 1 0 1\n", "joins vertex 0 to itself");
  // Finite but absurd: the optimiser met infinities ("linear initialisation: solve failed").
  ExpectError("VERTEX_SE2 0 1e308 0 0\n", "test.g2o:1: vertex 0 lies 1e+308 m out, beyond the 1e+07 m");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 0 -2e7 0 1 0 0 1 0 1\n",
              "test.g2o:3: the edge's measurement reaches 2e+07 m");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1e-308 0 0 1 0 1\n",
              "test.g2o:3: information 1 at most, covariance");
  ExpectError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1e13 0 0 1 0 1\n",
              "each must stay within 1e+12");
}

TEST(GraphIoTest, MissingFileIsNotFound) {
  const auto result = ReadPoseGraph(std::filesystem::path("/nonexistent/graph.g2o"));
  EXPECT_THAT(result, StatusIs(StatusCode::kNotFound));
  EXPECT_NE(result.status().message().find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace slamcore
