#include "analyzer/map_repair.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "analyzer/telemetry_codec.h"
#include "slamcore/graph_io.h"
#include "status_matchers.h"

namespace analyzer {
namespace {

using slamcore::Edge;
using slamcore::EdgeKind;
using slamcore::Map;
using slamcore::NodeId;
using slamcore::SE2;

constexpr int kChain = 12;  // nodes per component

/// A 1 m × 1 m free patch with an occupied border, 0.05 m cells, centred on its node.
slamcore::LocalMapEvent Patch() {
  slamcore::LocalMapEvent patch;
  patch.resolution = 0.05;
  patch.width = patch.height = 20;
  patch.node_T_origin = SE2(-0.5, -0.5, 0.0);
  patch.cells.assign(400, 0);
  for (int i = 0; i < 20; ++i) patch.cells[static_cast<std::size_t>(i)] = 100;
  return patch;
}

void AddMotion(Map& map, NodeId from, NodeId to) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = map.graph.node(from).pose.inverse() * map.graph.node(to).pose;
  edge.information = slamcore::Matrix3::Identity() * 100.0;
  ASSERT_THAT(map.graph.AddEdge(edge), IsOk());
}

/// Home: nodes 0..11 along y = 0 with patches and views 100..111, the robot's earlier map. The run added
/// nodes 20..31 along y = 3 in a component of its own (with patches), joined to home by `merge_edges`
/// observation edges of hypothesis 4 that are consistent with where the nodes are.
struct Scenario {
  Map parent, child;
};

Scenario MakeScenario(int merge_edges = 2) {
  Scenario s;
  for (int i = 0; i < kChain; ++i) {
    EXPECT_THAT(s.parent.graph.AddNode({.id = i, .pose = SE2(0.5 * i, 0.0, 0.0)}), IsOk());
    EXPECT_THAT(s.parent.graph.AddView({.id = 100 + i, .node = i}), IsOk());
    s.parent.local_maps[i] = Patch();
    if (i > 0) AddMotion(s.parent, i - 1, i);
  }
  s.child = s.parent;
  for (int i = 0; i < kChain; ++i) {
    const NodeId id = 20 + i;
    (void)s.child.graph.AddNode({.id = id, .pose = SE2(0.5 * i, 3.0, 0.0)});
    s.child.local_maps[id] = Patch();
    if (i > 0) AddMotion(s.child, id - 1, id);
  }
  for (int k = 0; k < merge_edges; ++k) {
    Edge edge;
    edge.from = 22 + 3 * k;
    edge.to = 2 + 3 * k;
    edge.measurement = s.child.graph.node(edge.from).pose.inverse() * s.child.graph.node(edge.to).pose;
    edge.kind = EdgeKind::kObservation;
    edge.view = 102 + 3 * k;
    edge.hypothesis = 4;
    edge.information = slamcore::Matrix3::Identity() * 50.0;
    EXPECT_THAT(s.child.graph.AddEdge(edge), IsOk());
  }
  return s;
}

fleet::v1::RunReport ReportWithRerun(const Map& rerun_child) {
  fleet::v1::RunReport report;
  report.set_parameter_set("default");
  *report.mutable_rerun_child() = ToProto(rerun_child);
  return report;
}

const fleet::v1::MapFinding* FindKind(const std::vector<fleet::v1::MapFinding>& findings,
                                      fleet::v1::FindingKind kind) {
  for (const auto& finding : findings) {
    if (finding.finding_kind() == kind) return &finding;
  }
  return nullptr;
}

TEST(MapRepairTest, FiguresCountTheMapAndItsKnownArea) {
  const Scenario s = MakeScenario();
  const MapFigures figures = ComputeFigures(s.child);
  const auto known_area = KnownArea(s.child);
  ASSERT_THAT(known_area, IsOk());
  EXPECT_EQ(figures.nodes, 2 * kChain);
  EXPECT_EQ(figures.edges, 2 * (kChain - 1) + 2);
  EXPECT_EQ(figures.observation_edges, 2);
  EXPECT_EQ(figures.views, kChain);
  EXPECT_EQ(figures.components, 1);
  EXPECT_NEAR(figures.chi2, 0.0, 1e-9);
  // Two strips of patches 1 m tall, 6.5 m long, 2 m apart (the grid's cells are 0.05 m like the patches).
  EXPECT_NEAR(*known_area, 2 * 6.5, 0.6);
  // Counted without rendering, it is the rendered home grid's known area exactly.
  const auto grid = RenderHomeGrid(s.child);
  ASSERT_THAT(grid, IsOk());
  const auto known = static_cast<double>(static_cast<std::int64_t>(grid->cells.size()) -
                                         grid->CountCells(slamcore::CellState::kUnknown));
  EXPECT_EQ(*known_area, known * grid->resolution * grid->resolution);
}

TEST(MapRepairTest, RejectingAMergeHypothesisSplitsTheComponentsAgain) {
  const Scenario s = MakeScenario();
  const auto run_nodes = NodesAddedByRun(s.child, s.parent);
  EXPECT_EQ(run_nodes.size(), static_cast<std::size_t>(kChain));
  std::string detail;
  const auto repaired = RejectHypothesis(s.child, run_nodes, 4, &detail);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->graph.NumComponents(), 2u);
  EXPECT_EQ(repaired->graph.num_edges(), s.child.graph.num_edges() - 2);
  EXPECT_NE(detail.find("2 edge(s) removed; components 1 → 2"), std::string::npos) << detail;
  // The home component stays where it was (its anchor is its first node) and keeps its shape.
  for (int i = 0; i < kChain; ++i) {
    EXPECT_NEAR(repaired->graph.node(i).pose.translation().x(), 0.5 * i, 1e-6);
    EXPECT_NEAR(repaired->graph.node(i).pose.translation().y(), 0.0, 1e-6);
  }
  // A hypothesis that added nothing (already rejected, or of another run) is an error, not an empty repair.
  const auto again = RejectHypothesis(*repaired, run_nodes, 4, &detail);
  EXPECT_THAT(again, StatusIs(slamcore::StatusCode::kInvalidArgument));
  EXPECT_EQ(RejectHypothesis(s.child, {}, 4, &detail).status().code(),
            slamcore::StatusCode::kInvalidArgument);
}

/// An observation edge from run node `from` to node `to` (of view 100 + to) that fits where the nodes are.
void AddObservation(Map& map, NodeId from, NodeId to, std::optional<std::int64_t> hypothesis) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = map.graph.node(from).pose.inverse() * map.graph.node(to).pose;
  edge.kind = EdgeKind::kObservation;
  edge.view = 100 + to;
  edge.hypothesis = hypothesis;
  edge.information = slamcore::Matrix3::Identity() * 50.0;
  ASSERT_THAT(map.graph.AddEdge(edge), IsOk());
}

TEST(MapRepairTest, RejectingAMergeAlsoTakesTheLaterEdgesThatRestOnIt) {
  // Merge hypothesis 4 observed at nodes 22 and 25 (accepted at 25); afterwards the robot, localised in the
  // merged map, made direct edges to home at nodes 28 and 31, and one within its own run (30 → 21).
  Scenario s = MakeScenario();
  AddObservation(s.child, 28, 8, std::nullopt);
  AddObservation(s.child, 31, 11, std::nullopt);
  ASSERT_THAT(s.child.graph.AddView({.id = 121, .node = 21}), IsOk());
  AddObservation(s.child, 30, 21, std::nullopt);
  const auto run_nodes = NodesAddedByRun(s.child, s.parent);
  std::string detail;
  const auto repaired = RejectHypothesis(s.child, run_nodes, 4, &detail);
  ASSERT_THAT(repaired, IsOk());
  // Without the two direct edges to home the run's part would stay joined at the merge's alignment.
  EXPECT_EQ(repaired->graph.NumComponents(), 2u) << detail;
  EXPECT_EQ(repaired->graph.num_edges(), s.child.graph.num_edges() - 4);
  EXPECT_FALSE(repaired->graph.SameComponent(20, 0));
  EXPECT_EQ(detail,
            "rejected hypothesis 4 (a merge): 2 edge(s) removed, and 2 later observation edge(s) of the run "
            "that joined the parts it merged; components 1 → 2");
  bool run_internal_kept = false;
  for (const Edge& edge : repaired->graph.edges()) run_internal_kept |= edge.from == 30 && edge.to == 21;
  EXPECT_TRUE(run_internal_kept);
  // The server's rerun that did not merge names it a merge, not a loop closure.
  Map rerun = s.parent;
  for (int i = 0; i < kChain; ++i) (void)rerun.graph.AddNode({.id = 20 + i, .pose = SE2(0.5 * i, 3.0, 0.0)});
  const fleet::v1::RunReport report = ReportWithRerun(rerun);
  const auto findings = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &report});
  const fleet::v1::MapFinding* unconfirmed = nullptr;
  for (const fleet::v1::MapFinding& finding : findings) {
    if (finding.finding_kind() == fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS && finding.hypothesis() == 4)
      unconfirmed = &finding;
  }
  ASSERT_NE(unconfirmed, nullptr);
  EXPECT_EQ(unconfirmed->summary().rfind("merge by hypothesis 4", 0), 0u) << unconfirmed->summary();
  EXPECT_DOUBLE_EQ(unconfirmed->severity(), 0.8);
}

TEST(MapRepairTest, RejectingALoopClosureAfterATrueMergeLeavesTheMergeAndItsEdges) {
  // Merge 4 (accepted at node 25), then loop-closure hypothesis 9 observed at nodes 28 and 30 (accepted at
  // 30), then a direct edge at node 31: hypothesis 9 joined nothing, so only its own edges go.
  Scenario s = MakeScenario();
  AddObservation(s.child, 28, 8, 9);
  AddObservation(s.child, 30, 10, 9);
  AddObservation(s.child, 31, 11, std::nullopt);
  const auto run_nodes = NodesAddedByRun(s.child, s.parent);
  std::string detail;
  const auto repaired = RejectHypothesis(s.child, run_nodes, 9, &detail);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->graph.NumComponents(), 1u);
  EXPECT_EQ(repaired->graph.num_edges(), s.child.graph.num_edges() - 2);
  EXPECT_EQ(detail, "rejected hypothesis 9: 2 edge(s) removed; components 1 → 1");
}

TEST(MapRepairTest, RejectEdgeRemovesOneObservationEdgeAndRefusesMotionEdges) {
  const Scenario s = MakeScenario();
  std::string detail;
  const auto repaired = RejectEdge(s.child, 22, 2, 102, &detail);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->graph.num_edges(), s.child.graph.num_edges() - 1);
  EXPECT_EQ(repaired->graph.NumComponents(), 1u);  // the other merge edge still joins them
  const auto motion = RejectEdge(s.child, 0, 1, std::nullopt, &detail);
  ASSERT_FALSE(motion.ok());
  EXPECT_NE(motion.status().message().find("motion"), std::string::npos) << motion.status().message();
  EXPECT_EQ(RejectEdge(s.child, 3, 7, std::nullopt, &detail).status().code(),
            slamcore::StatusCode::kInvalidArgument);
}

TEST(MapRepairTest, AnEdgeThatContradictsItsPeersIsAResidualFinding) {
  Scenario s = MakeScenario(3);
  // A loop closure inside home that claims node 10 sits 1.5 m from where odometry and the views put it.
  Edge wrong;
  wrong.from = 10;
  wrong.to = 1;
  wrong.measurement = SE2(-7.5, 1.5, 0.0);
  wrong.kind = EdgeKind::kObservation;
  wrong.view = 101;
  wrong.information = slamcore::Matrix3::Identity() * 50.0;
  ASSERT_THAT(s.child.graph.AddEdge(wrong), IsOk());
  ASSERT_THAT(Reoptimize(s.child), IsOk());
  const auto findings = FindMapFindings({.map = &s.child, .run_parent = &s.parent});
  const auto* residual = FindKind(findings, fleet::v1::FINDING_KIND_HIGH_RESIDUAL_EDGE);
  ASSERT_NE(residual, nullptr);
  EXPECT_EQ(residual->edge_from(), 10);
  EXPECT_EQ(residual->edge_to(), 1);
  EXPECT_EQ(residual->finding_state(), fleet::v1::FINDING_STATE_OPEN);
  EXPECT_EQ(residual->finding_id(), 1);  // the most severe first
  int residual_findings = 0;
  for (const auto& finding : findings)
    residual_findings += finding.finding_kind() == fleet::v1::FINDING_KIND_HIGH_RESIDUAL_EDGE;
  EXPECT_EQ(residual_findings, 1) << "the consistent merge edges are not outliers";
}

TEST(MapRepairTest, AHypothesisTheRerunDidNotAcceptIsUnconfirmed) {
  const Scenario s = MakeScenario();
  // The server's rerun kept the run in its own component: it accepted neither merge edge.
  Map rerun = s.parent;
  for (int i = 0; i < kChain; ++i) (void)rerun.graph.AddNode({.id = 20 + i, .pose = SE2(0.5 * i, 3.0, 0.0)});
  const fleet::v1::RunReport report = ReportWithRerun(rerun);
  const auto findings = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &report});
  const auto* unconfirmed = FindKind(findings, fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS);
  ASSERT_NE(unconfirmed, nullptr);
  EXPECT_EQ(unconfirmed->hypothesis(), 4);
  const auto evidence = nlohmann::json::parse(unconfirmed->evidence_json());
  EXPECT_TRUE(evidence["joins_components"].get<bool>());
  EXPECT_EQ(evidence["edges"].size(), 2u);
  EXPECT_NE(unconfirmed->summary().find("merge"), std::string::npos);

  // When the rerun made the same edges, the hypothesis is confirmed: no finding.
  const fleet::v1::RunReport agreeing = ReportWithRerun(s.child);
  const auto confirmed = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &agreeing});
  EXPECT_EQ(FindKind(confirmed, fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS), nullptr);
}

TEST(MapRepairTest, CuttingAProtrusionClearsOnlyTheRunsCellsAndResolvesTheFinding) {
  const Scenario s = MakeScenario();
  fleet::v1::RunReport report = ReportWithRerun(s.child);
  fleet::v1::ProtrusionRegion* region = report.add_protrusion_regions();
  region->set_id(7);
  region->set_predicted_class("protrusion");
  region->set_probability(0.9);
  // Around run nodes 24..26 (x 2.0..3.0 at y = 3), far from home's patches.
  for (const double value : {1.8, 2.6, 3.2, 3.4}) region->add_world_bbox(value);
  const auto before = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &report});
  const auto* open = FindKind(before, fleet::v1::FINDING_KIND_PROTRUSION);
  ASSERT_NE(open, nullptr);
  EXPECT_EQ(open->finding_state(), fleet::v1::FINDING_STATE_OPEN);
  ASSERT_EQ(open->world_bbox_size(), 4);

  std::string detail;
  const auto cut = CutRegion(
      s.child, NodesAddedByRun(s.child, s.parent),
      {open->world_bbox(0), open->world_bbox(1), open->world_bbox(2), open->world_bbox(3)}, &detail);
  ASSERT_THAT(cut, IsOk());
  for (int i = 0; i < kChain; ++i)
    EXPECT_EQ(cut->local_maps.at(i).cells, s.child.local_maps.at(i).cells) << "home node " << i;
  const auto after = FindMapFindings({.map = &*cut, .run_parent = &s.parent, .report = &report});
  const auto* resolved = FindKind(after, fleet::v1::FINDING_KIND_PROTRUSION);
  ASSERT_NE(resolved, nullptr);
  EXPECT_EQ(resolved->finding_state(), fleet::v1::FINDING_STATE_RESOLVED);
  const auto area_before = KnownArea(s.child), area_after = KnownArea(*cut);
  ASSERT_THAT(area_before, IsOk());
  ASSERT_THAT(area_after, IsOk());
  EXPECT_LT(*area_after, *area_before - 0.5);
  // Nothing of the run's left in the box: a second cut is refused.
  EXPECT_EQ(
      CutRegion(*cut, NodesAddedByRun(s.child, s.parent), {1.8, 2.6, 3.2, 3.4}, &detail).status().code(),
      slamcore::StatusCode::kInvalidArgument);
  EXPECT_EQ(CutRegion(s.child, {}, {1.0, 1.0, 0.0, 2.0}, &detail).status().code(),
            slamcore::StatusCode::kInvalidArgument);
}

TEST(MapRepairTest, AProtrusionTheRunsViewsShowIsAFindingWhateverTheModelSays) {
  const Scenario s = MakeScenario();
  fleet::v1::RunReport report = ReportWithRerun(s.child);
  const auto add_region = [&](int id, const std::string& decided_by, double probability) {
    fleet::v1::ProtrusionRegion* region = report.add_protrusion_regions();
    region->set_id(id);
    region->set_predicted_class("protrusion");
    region->set_decided_by(decided_by);
    region->set_probability(probability);
    for (const double value : {1.8, 2.6, 3.2, 3.4}) region->add_world_bbox(value);
  };
  // The map-only model's call below its threshold (0.5) is no finding; the views' is, at the views'
  // severity (0.9), not 0.9 × the model's 0.2.
  add_region(7, "classifier", 0.2);
  add_region(8, "views", 0.2);
  const auto findings = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &report});
  std::vector<const fleet::v1::MapFinding*> protrusions;
  for (const auto& finding : findings) {
    if (finding.finding_kind() == fleet::v1::FINDING_KIND_PROTRUSION) protrusions.push_back(&finding);
  }
  ASSERT_EQ(protrusions.size(), 1u);
  EXPECT_DOUBLE_EQ(protrusions[0]->severity(), 0.9);
  EXPECT_NE(protrusions[0]->summary().find("views show the robot slipped"), std::string::npos);
  const auto evidence = nlohmann::json::parse(protrusions[0]->evidence_json());
  EXPECT_EQ(evidence["region_id"], 8);
  EXPECT_EQ(evidence["decided_by"], "views");
  EXPECT_DOUBLE_EQ(evidence["probability"].get<double>(), 0.2);
  // The model's call at its threshold or above is a finding at 0.9 × its probability, and says so.
  report.mutable_protrusion_regions(0)->set_probability(0.8);
  const auto both = FindMapFindings({.map = &s.child, .run_parent = &s.parent, .report = &report});
  int count = 0;
  for (const auto& finding : both) {
    if (finding.finding_kind() != fleet::v1::FINDING_KIND_PROTRUSION) continue;
    ++count;
    if (nlohmann::json::parse(finding.evidence_json())["decided_by"] == "classifier") {
      EXPECT_DOUBLE_EQ(finding.severity(), 0.9 * 0.8);
      EXPECT_NE(finding.summary().find("probability 0.80 by the map-only model"), std::string::npos);
    }
  }
  EXPECT_EQ(count, 2);
}

constexpr std::size_t kCentreCell = 10 * 20 + 10;

/// The scenario's child with a later run on top: nodes 40..42 after the run's last node, and the run's node 25
/// seen again (its patch's centre cell, free before, observed as occupied).
Map LaterVersion(const Map& child) {
  Map later = child;
  for (int i = 0; i < 3; ++i) {
    const NodeId id = 40 + i;
    EXPECT_THAT(later.graph.AddNode({.id = id, .pose = SE2(0.5 * (kChain + i), 3.0, 0.0)}), IsOk());
    later.local_maps[id] = Patch();
    AddMotion(later, i == 0 ? 20 + kChain - 1 : id - 1, id);
  }
  later.local_maps.at(25).cells[kCentreCell] = 100;
  return later;
}

TEST(MapRepairTest, ARepairCarriedOntoALaterVersionDoesWhatItDidAndKeepsWhatCameSince) {
  const Scenario s = MakeScenario();
  const Map later = LaterVersion(s.child);
  std::string detail;
  // An edge rejection: the later version loses the same edge, keeps its own nodes, and is re-optimised.
  const auto rejected = RejectEdge(s.child, 22, 2, 102, &detail);
  ASSERT_THAT(rejected, IsOk());
  const auto carried_edge = CarryRepairForward(s.child, *rejected, later, &detail);
  ASSERT_THAT(carried_edge, IsOk());
  EXPECT_EQ(carried_edge->graph.num_edges(), later.graph.num_edges() - 1);
  EXPECT_EQ(carried_edge->graph.num_nodes(), later.graph.num_nodes());
  for (const Edge& edge : carried_edge->graph.edges())
    EXPECT_FALSE(edge.from == 22 && edge.to == 2) << "the rejected edge";
  EXPECT_EQ(detail, "1 edge(s) removed and 0 cells of 0 patches changed as the repair did");

  // A cut of the run's cells around nodes 24..26: the same cells go unknown in the later version, except the one its
  // own run observed again (node 25's centre), which keeps the later observation.
  const auto cut = CutRegion(s.child, NodesAddedByRun(s.child, s.parent), {1.8, 2.6, 3.2, 3.4}, &detail);
  ASSERT_THAT(cut, IsOk());
  std::int64_t cut_cells = 0, cut_patches = 0;
  for (const auto& [node, patch] : cut->local_maps) {
    const std::int64_t before = cut_cells;
    for (std::size_t i = 0; i < patch.cells.size(); ++i)
      cut_cells += patch.cells[i] != s.child.local_maps.at(node).cells[i];
    cut_patches += cut_cells > before;
  }
  ASSERT_GT(cut_cells, 0);
  ASSERT_EQ(cut->local_maps.at(25).cells[kCentreCell], -1) << "the box holds node 25's centre";
  const auto carried_cut = CarryRepairForward(s.child, *cut, later, &detail);
  ASSERT_THAT(carried_cut, IsOk());
  for (const auto& [node, patch] : carried_cut->local_maps) {
    const auto& expected =
        cut->local_maps.contains(node) ? cut->local_maps.at(node) : later.local_maps.at(node);
    for (std::size_t i = 0; i < patch.cells.size(); ++i) {
      if (node == 25 && i == kCentreCell) {
        EXPECT_EQ(patch.cells[i], 100) << "observed again since the repair";
      } else {
        EXPECT_EQ(patch.cells[i], expected.cells[i]) << "node " << node << " cell " << i;
      }
    }
  }
  EXPECT_EQ(carried_cut->graph.num_edges(), later.graph.num_edges()) << "a cut removes no edge";
  EXPECT_EQ(detail, "0 edge(s) removed and " + std::to_string(cut_cells - 1) + " cells of " +
                        std::to_string(cut_patches) +
                        " patches changed as the repair did; 1 cells observed again since kept");

  // Nothing left to carry: the later version already lacks the edge.
  const auto again = CarryRepairForward(s.child, *rejected, *carried_edge, &detail);
  EXPECT_EQ(again.status().code(), slamcore::StatusCode::kInvalidArgument);
  EXPECT_NE(again.status().message().find("nothing of the repair applies"), std::string::npos)
      << again.status().message();
}

TEST(MapRepairTest, ExportWritesMapServerFilesAndG2oThatReadBack) {
  const Scenario s = MakeScenario();
  const auto map_server = ExportMap(s.child, "map_server", "robot-1-v3");
  ASSERT_THAT(map_server, IsOk());
  ASSERT_EQ(map_server->size(), 2u);
  EXPECT_EQ((*map_server)[0].name(), "robot-1-v3.pgm");
  EXPECT_EQ((*map_server)[1].name(), "robot-1-v3.yaml");
  EXPECT_EQ((*map_server)[1].content().rfind("image: robot-1-v3.pgm\n", 0), 0u);
  const auto grid = RenderHomeGrid(s.child);
  ASSERT_THAT(grid, IsOk());
  const auto decoded =
      slamcore::DecodePgm((*map_server)[0].content(), grid->resolution, grid->origin_x, grid->origin_y);
  ASSERT_THAT(decoded, IsOk());
  EXPECT_EQ(decoded->cells, grid->cells);

  const auto g2o = ExportMap(s.child, "g2o", "robot-1-v3");
  ASSERT_THAT(g2o, IsOk());
  std::istringstream in((*g2o)[0].content());
  const auto graph = slamcore::ReadPoseGraph(in, "export");
  ASSERT_THAT(graph, IsOk());
  EXPECT_EQ(graph->num_nodes(), s.child.graph.num_nodes());
  EXPECT_EQ(graph->num_edges(), s.child.graph.num_edges());

  EXPECT_EQ(ExportMap(s.child, "png", "x").status().code(), slamcore::StatusCode::kInvalidArgument);
  EXPECT_EQ(ExportMap(Map{}, "g2o", "x").status().code(), slamcore::StatusCode::kInvalidArgument);
}

TEST(MapRepairTest, EdgeHypothesisSurvivesTheWireFormat) {
  const Scenario s = MakeScenario();
  const auto back = FromProto(ToProto(s.child), "snapshot");
  ASSERT_THAT(back, IsOk());
  int with_hypothesis = 0;
  for (const Edge& edge : back->graph.edges()) with_hypothesis += edge.hypothesis == 4 ? 1 : 0;
  EXPECT_EQ(with_hypothesis, 2);
}

}  // namespace
}  // namespace analyzer
