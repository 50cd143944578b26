#include "analyzer/map_repair.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "analyzer/run_analysis.h"
#include "analyzer/map_metadata.h"
#include "slamcore/graph_io.h"
#include "slamcore/linear_initialization.h"
#include "slamcore/optimizer.h"

namespace analyzer {
namespace {

using nlohmann::json;
using slamcore::Edge;
using slamcore::EdgeKind;
using slamcore::Map;
using slamcore::NodeId;
using slamcore::Result;
using slamcore::Status;

json EdgeJson(const Edge& edge, double chi2) {
  json out = {{"from", edge.from}, {"to", edge.to}, {"chi2", chi2}};
  if (edge.view) out["view"] = *edge.view;
  if (edge.hypothesis) out["hypothesis"] = *edge.hypothesis;
  return out;
}

json DecisionJson(const fleet::v1::Decision& decision) {
  return {{"time", decision.time()},
          {"kind", decision.kind()},
          {"node", decision.node()},
          {"view", decision.view()},
          {"hypothesis", decision.hypothesis()},
          {"hypothesis_kind", decision.hypothesis_kind()},
          {"reason", decision.reason()}};
}

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

/// What rejecting one of a run's hypotheses takes out of the map: its own observation edges and, when it was
/// a merge, the run's observation edges that rest on it. Before a merge the run's observations of the other
/// component could only feed merge hypotheses, so every observation edge joining the two parts that the run
/// placed at or after the merge was placed in the frame the merge set up (a direct edge gated against it, or
/// a hypothesis accepted in the merged map): without them the map is what it would be had the merge never
/// been accepted, its two parts apart again. Leaving them would keep the parts joined at the merge's
/// alignment with less of the evidence that set it, a map worse than either.
struct Rejection {
  std::set<std::size_t> edges;  // indices into graph.edges(): the hypothesis's and those resting on it
  std::size_t own_edges = 0;
  bool merge = false;
};
Rejection RejectionOf(const slamcore::PoseGraph& graph, const std::set<NodeId>& run_nodes,
                      std::int64_t hypothesis) {
  // When the run placed each of its observation edges: a hypothesis's at its acceptance (its last robot node
  // in the run), a direct edge at its robot node. The run's nodes are numbered in creation order.
  const auto of_run = [&](const Edge& edge) {
    return edge.kind == EdgeKind::kObservation && run_nodes.contains(edge.from);
  };
  std::map<std::int64_t, NodeId> accepted_at;
  for (const Edge& edge : graph.edges()) {
    if (of_run(edge) && edge.hypothesis) {
      NodeId& at = accepted_at.try_emplace(*edge.hypothesis, edge.from).first->second;
      at = std::max(at, edge.from);
    }
  }
  const auto placed_at = [&](const Edge& edge) {
    return edge.hypothesis ? accepted_at.at(*edge.hypothesis) : edge.from;
  };
  Rejection rejection;
  for (std::size_t i = 0; i < graph.num_edges(); ++i) {
    if (of_run(graph.edges()[i]) && graph.edges()[i].hypothesis == hypothesis) rejection.edges.insert(i);
  }
  rejection.own_edges = rejection.edges.size();
  if (rejection.edges.empty()) return rejection;
  // The map as it was just before the acceptance: without the run's observation edges placed since.
  const NodeId accepted = accepted_at.at(hypothesis);
  slamcore::PoseGraph before = graph;
  before.RemoveEdgesIf([&](const Edge& edge) { return of_run(edge) && placed_at(edge) >= accepted; });
  const auto joined = std::find_if(rejection.edges.begin(), rejection.edges.end(), [&](std::size_t i) {
    return !before.SameComponent(graph.edges()[i].from, graph.edges()[i].to);
  });
  if (joined == rejection.edges.end()) return rejection;
  rejection.merge = true;
  const slamcore::ComponentId run_side = before.ComponentOf(graph.edges()[*joined].from);
  const slamcore::ComponentId other_side = before.ComponentOf(graph.edges()[*joined].to);
  for (std::size_t i = 0; i < graph.num_edges(); ++i) {
    const Edge& edge = graph.edges()[i];
    if (!of_run(edge) || placed_at(edge) < accepted) continue;
    const slamcore::ComponentId from = before.ComponentOf(edge.from), to = before.ComponentOf(edge.to);
    if ((from == run_side && to == other_side) || (from == other_side && to == run_side)) {
      rejection.edges.insert(i);
    }
  }
  return rejection;
}

/// Calls `visit(node, cell_index, world_centre)` for every known cell of the patches of `nodes` that lie in
/// the component `component`, with the cell's centre in that component's frame.
template <typename Visit>
void ForEachKnownPatchCell(const Map& map, const std::set<NodeId>& nodes, slamcore::ComponentId component,
                           Visit visit) {
  for (const NodeId node : nodes) {
    const auto patch = map.local_maps.find(node);
    if (patch == map.local_maps.end() || !map.graph.HasNode(node) || map.graph.ComponentOf(node) != component)
      continue;
    const slamcore::SE2 world_T_patch = map.graph.node(node).pose * patch->second.node_T_origin;
    const slamcore::LocalMapEvent& cells = patch->second;
    for (int row = 0; row < cells.height; ++row) {
      for (int col = 0; col < cells.width; ++col) {
        const std::size_t index = static_cast<std::size_t>(row) * cells.width + col;
        if (cells.cells[index] < 0) continue;
        visit(node, index,
              world_T_patch *
                  slamcore::Vector2((col + 0.5) * cells.resolution, (row + 0.5) * cells.resolution));
      }
    }
  }
}

bool Inside(const slamcore::Vector2& point, const std::array<double, 4>& box, double margin) {
  return point.x() >= box[0] - margin && point.y() >= box[1] - margin && point.x() <= box[2] + margin &&
         point.y() <= box[3] + margin;
}

std::int64_t RunCellsInside(const Map& map, const std::set<NodeId>& run_nodes,
                            const std::array<double, 4>& box) {
  if (map.graph.num_nodes() == 0) return 0;
  std::int64_t count = 0;
  ForEachKnownPatchCell(
      map, run_nodes, HomeComponent(map.graph),
      [&](NodeId, std::size_t, const slamcore::Vector2& centre) { count += Inside(centre, box, 0.0); });
  return count;
}

void ResidualFindings(const Map& map, const std::set<NodeId>& run_nodes, const FindingOptions& options,
                      std::vector<fleet::v1::MapFinding>* findings) {
  const slamcore::PoseGraph& graph = map.graph;
  std::vector<double> chi2(graph.num_edges(), 0.0);
  std::vector<double> observation_chi2;
  for (std::size_t i = 0; i < graph.num_edges(); ++i) {
    if (graph.edges()[i].kind != EdgeKind::kObservation) continue;
    chi2[i] = slamcore::EdgeChi2(graph, graph.edges()[i]);
    observation_chi2.push_back(chi2[i]);
  }
  if (observation_chi2.empty()) return;
  std::nth_element(observation_chi2.begin(), observation_chi2.begin() + observation_chi2.size() / 2,
                   observation_chi2.end());
  const double median = observation_chi2[observation_chi2.size() / 2];
  const double threshold = std::max(options.residual_chi2, options.residual_peer_factor * median);
  // One finding per hypothesis of the run (its edges stand or fall together), else one per edge.
  std::map<std::pair<std::int64_t, std::size_t>, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < graph.num_edges(); ++i) {
    const Edge& edge = graph.edges()[i];
    if (edge.kind != EdgeKind::kObservation || chi2[i] <= threshold) continue;
    const bool of_run_hypothesis = edge.hypothesis && run_nodes.contains(edge.from);
    groups[of_run_hypothesis ? std::pair{*edge.hypothesis, std::size_t{0}} : std::pair{std::int64_t{-1}, i}]
        .push_back(i);
  }
  for (const auto& [key, members] : groups) {
    std::size_t worst = members.front();
    json edges = json::array();
    for (const std::size_t i : members) {
      if (chi2[i] > chi2[worst]) worst = i;
      edges.push_back(EdgeJson(graph.edges()[i], chi2[i]));
    }
    const Edge& edge = graph.edges()[worst];
    fleet::v1::MapFinding finding;
    finding.set_finding_kind(fleet::v1::FINDING_KIND_HIGH_RESIDUAL_EDGE);
    finding.set_severity(std::clamp(0.5 + 0.1 * std::log2(chi2[worst] / threshold), 0.5, 0.95));
    finding.set_finding_state(fleet::v1::FINDING_STATE_OPEN);
    const std::string subject =
        key.first >= 0
            ? std::to_string(members.size()) + " edge(s) of hypothesis " + std::to_string(key.first)
            : "edge " + std::to_string(edge.from) + "→" + std::to_string(edge.to);
    finding.set_summary(subject + ": χ² up to " + Fixed(chi2[worst], 1) +
                        " after optimisation (observation edges' median " + Fixed(median, 2) + ")");
    if (key.first >= 0) finding.set_hypothesis(key.first);
    finding.set_edge_from(edge.from);
    finding.set_edge_to(edge.to);
    finding.set_evidence_json(
        json{{"edges", edges}, {"median_chi2", median}, {"threshold", threshold}}.dump());
    findings->push_back(std::move(finding));
  }
}

void UnconfirmedHypothesisFindings(const Map& map, const std::set<NodeId>& run_nodes,
                                   const fleet::v1::RunReport& report,
                                   std::vector<fleet::v1::MapFinding>* findings) {
  std::set<std::pair<NodeId, std::int64_t>>
      rerun_edges;  // (robot node, view) of the rerun's observation edges
  for (const fleet::v1::Edge& edge : report.rerun_child().edges()) {
    if (edge.kind() == fleet::v1::Edge::KIND_OBSERVATION && edge.has_view())
      rerun_edges.emplace(edge.from(), edge.view());
  }
  std::map<std::int64_t, std::set<std::size_t>> by_hypothesis;
  for (std::size_t i = 0; i < map.graph.num_edges(); ++i) {
    const Edge& edge = map.graph.edges()[i];
    if (edge.kind == EdgeKind::kObservation && edge.hypothesis && run_nodes.contains(edge.from)) {
      by_hypothesis[*edge.hypothesis].insert(i);
    }
  }
  for (const auto& [hypothesis, members] : by_hypothesis) {
    int confirmed = 0;
    std::set<std::int64_t> views;
    json edges = json::array();
    for (const std::size_t i : members) {
      const Edge& edge = map.graph.edges()[i];
      if (edge.view) {
        views.insert(*edge.view);
        confirmed += rerun_edges.contains({edge.from, *edge.view}) ? 1 : 0;
      }
      edges.push_back(EdgeJson(edge, slamcore::EdgeChi2(map.graph, edge)));
    }
    if (2 * confirmed >= static_cast<int>(members.size())) continue;
    json decisions = json::array();
    for (const fleet::v1::Decision& decision : report.decisions()) {
      if (views.contains(decision.view()) && decision.kind() != "direct_edge" && decisions.size() < 40) {
        decisions.push_back(DecisionJson(decision));
      }
    }
    const bool merge = RejectionOf(map.graph, run_nodes, hypothesis).merge;
    const Edge& first = map.graph.edges()[*members.begin()];
    fleet::v1::MapFinding finding;
    finding.set_finding_kind(fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS);
    finding.set_severity(merge ? 0.8 : 0.7);
    finding.set_finding_state(fleet::v1::FINDING_STATE_OPEN);
    finding.set_summary(std::string(merge ? "merge" : "loop closure") + " by hypothesis " +
                        std::to_string(hypothesis) + " (" + std::to_string(members.size()) + " edges, " +
                        std::to_string(confirmed) +
                        " confirmed): the robot accepted it, the server's rerun with '" +
                        report.parameter_set() + "' did not");
    finding.set_hypothesis(hypothesis);
    finding.set_edge_from(first.from);
    finding.set_edge_to(first.to);
    finding.set_evidence_json(json{
        {"edges", edges},
        {"joins_components", merge},
        {"confirmed_edges", confirmed},
        {"parameter_set", report.parameter_set()},
        {"rerun_decisions",
         decisions}}.dump());
    findings->push_back(std::move(finding));
  }
}

void ProtrusionFindings(const Map& map, const std::set<NodeId>& run_nodes, const fleet::v1::RunReport& report,
                        const FindingOptions& options, std::vector<fleet::v1::MapFinding>* findings) {
  for (const fleet::v1::ProtrusionRegion& region : report.protrusion_regions()) {
    // The run's own views showing the slip are evidence in their own right (analyzer::ClassifyRegions),
    // whatever the map-only model's probability; the model's calls count from its threshold up.
    const bool seen_by_views = region.decided_by() == "views";
    if (region.predicted_class() != "protrusion" ||
        (!seen_by_views && region.probability() < options.protrusion_probability) ||
        region.world_bbox_size() != 4) {
      continue;
    }
    const std::array<double, 4> box = {region.world_bbox(0), region.world_bbox(1), region.world_bbox(2),
                                       region.world_bbox(3)};
    const std::int64_t cells = RunCellsInside(map, run_nodes, box);
    fleet::v1::MapFinding finding;
    finding.set_finding_kind(fleet::v1::FINDING_KIND_PROTRUSION);
    finding.set_severity(seen_by_views ? 0.9 : 0.9 * region.probability());
    finding.set_finding_state(cells > 0 ? fleet::v1::FINDING_STATE_OPEN : fleet::v1::FINDING_STATE_RESOLVED);
    finding.set_summary("protrusion region " + std::to_string(region.id()) + " (" +
                        Fixed((box[2] - box[0]) * (box[3] - box[1]), 2) + " m², " +
                        (seen_by_views
                             ? std::string("the run's views show the robot slipped")
                             : "probability " + Fixed(region.probability(), 2) + " by the map-only model") +
                        ")" + (cells > 0 ? "" : ": cut out"));
    for (const double value : box) finding.add_world_bbox(value);
    finding.set_evidence_json(
        json{{"region_id", region.id()},
             {"decided_by", region.decided_by()},
             {"probability", region.probability()},
             {"run_cells_inside", cells},
             {"image_bbox", std::vector<int>(region.bbox().begin(), region.bbox().end())}}
            .dump());
    findings->push_back(std::move(finding));
  }
}

void UndoneMergeFindings(const fleet::v1::RunReport& report, std::vector<fleet::v1::MapFinding>* findings) {
  std::map<std::int64_t, json> conditional;  // hypothesis → its decisions, once conditionally accepted
  for (const fleet::v1::Decision& decision : report.decisions()) {
    if (decision.hypothesis_kind() != "merge") continue;
    if (decision.kind() == "conditionally_accepted") conditional[decision.hypothesis()] = json::array();
    const auto it = conditional.find(decision.hypothesis());
    if (it == conditional.end()) continue;
    it->second.push_back(DecisionJson(decision));
    if (decision.kind() != "rejected") continue;
    const double accepted_at = it->second.front()["time"].get<double>();
    fleet::v1::MapFinding finding;
    finding.set_finding_kind(fleet::v1::FINDING_KIND_UNDONE_MERGE);
    finding.set_severity(0.3);
    finding.set_finding_state(fleet::v1::FINDING_STATE_INFO);
    finding.set_summary("the rerun merged conditionally at t=" + Fixed(accepted_at, 1) +
                        " s and undid it at t=" + Fixed(decision.time(), 1) + " s (" + decision.reason() +
                        ")");
    finding.set_evidence_json(
        json{{"rerun_hypothesis", decision.hypothesis()}, {"rerun_decisions", it->second}}.dump());
    findings->push_back(std::move(finding));
    conditional.erase(it);
  }
}

/// Recovery hypotheses the rerun accepted and later retracted when better-supported evidence contradicted
/// them (correlated wrong observations: slamcore/src/mapper_consistency.cc). Informational: the rerun's map
/// no longer holds them; where the robot's map still does, "unconfirmed_hypothesis" says so.
void RetractedHypothesisFindings(const fleet::v1::RunReport& report,
                                 std::vector<fleet::v1::MapFinding>* findings) {
  std::map<std::int64_t, json> accepted;  // hypothesis → its acceptance decision
  for (const fleet::v1::Decision& decision : report.decisions()) {
    if (decision.hypothesis_kind() != "recovery") continue;
    if (decision.kind() == "accepted") accepted[decision.hypothesis()] = DecisionJson(decision);
    if (decision.kind() != "retracted") continue;
    fleet::v1::MapFinding finding;
    finding.set_finding_kind(fleet::v1::FINDING_KIND_RETRACTED_HYPOTHESIS);
    finding.set_severity(0.4);
    finding.set_finding_state(fleet::v1::FINDING_STATE_INFO);
    const auto it = accepted.find(decision.hypothesis());
    finding.set_summary(
        "the rerun accepted recovery hypothesis " + std::to_string(decision.hypothesis()) +
        (it != accepted.end() ? " at t=" + Fixed(it->second["time"].get<double>(), 1) + " s" : "") +
        " and retracted it at t=" + Fixed(decision.time(), 1) + " s: " + decision.reason());
    finding.set_evidence_json(json{
        {"rerun_hypothesis", decision.hypothesis()},
        {"accepted", it != accepted.end() ? it->second : json(nullptr)},
        {"retracted",
         DecisionJson(decision)}}.dump());
    findings->push_back(std::move(finding));
  }
}

void AmbiguousViewFinding(const Map& map, std::vector<fleet::v1::MapFinding>* findings) {
  json views = json::array();
  for (const slamcore::View& view : map.graph.views()) {
    if (view.ambiguous) views.push_back(view.id);
  }
  if (views.empty()) return;
  fleet::v1::MapFinding finding;
  finding.set_finding_kind(fleet::v1::FINDING_KIND_AMBIGUOUS_VIEW);
  finding.set_severity(0.1);
  finding.set_finding_state(fleet::v1::FINDING_STATE_INFO);
  finding.set_summary(std::to_string(views.size()) + " of " + std::to_string(map.graph.views().size()) +
                      " views are marked ambiguous (discounted as merge evidence)");
  finding.set_evidence_json(json{{"views", views}}.dump());
  findings->push_back(std::move(finding));
}

// The home component's nodes with their local maps: what the home grid is drawn from (empty without any).
Map HomePart(const Map& map) {
  if (map.graph.num_nodes() == 0) return {};
  std::set<NodeId> home;
  for (const NodeId node : map.graph.NodesOf(HomeComponent(map.graph))) home.insert(node);
  return ComponentMap(map, home);
}

}  // namespace

Result<slamcore::OccupancyGrid> RenderHomeGrid(const Map& map) {
  const Map part = HomePart(map);
  if (part.local_maps.empty()) return slamcore::OccupancyGrid{};
  slamcore::GlobalGridRenderer renderer;
  RETURN_IF_ERROR(renderer.RenderAll(part));
  return renderer.grid();
}

MapFigures ComputeFigures(const Map& map) {
  MapFigures figures;
  figures.nodes = static_cast<std::int64_t>(map.graph.num_nodes());
  figures.edges = static_cast<std::int64_t>(map.graph.num_edges());
  for (const Edge& edge : map.graph.edges())
    figures.observation_edges += edge.kind == EdgeKind::kObservation ? 1 : 0;
  figures.views = static_cast<std::int64_t>(map.graph.views().size());
  figures.components = static_cast<std::int64_t>(map.graph.NumComponents());
  figures.chi2 = slamcore::Chi2(map.graph);
  return figures;
}

Result<double> KnownArea(const Map& map) {
  ASSIGN_OR_RETURN(const slamcore::OccupancyGrid grid, RenderHomeGrid(map));
  const std::int64_t known =
      static_cast<std::int64_t>(grid.cells.size()) - grid.CountCells(slamcore::CellState::kUnknown);
  return static_cast<double>(known) * grid.resolution * grid.resolution;
}

std::set<NodeId> NodesAddedByRun(const Map& map, const Map& run_parent) {
  std::set<NodeId> added;
  for (const slamcore::Node& node : map.graph.nodes()) {
    if (!run_parent.graph.HasNode(node.id)) added.insert(node.id);
  }
  return added;
}

std::vector<fleet::v1::MapFinding> FindMapFindings(const FindingInputs& inputs,
                                                   const FindingOptions& options) {
  std::vector<fleet::v1::MapFinding> findings;
  if (!inputs.map || inputs.map->graph.num_nodes() == 0) return findings;
  const Map& map = *inputs.map;
  std::set<NodeId> run_nodes;
  if (inputs.run_parent) run_nodes = NodesAddedByRun(map, *inputs.run_parent);
  ResidualFindings(map, run_nodes, options, &findings);
  if (inputs.report && inputs.run_parent) {
    UnconfirmedHypothesisFindings(map, run_nodes, *inputs.report, &findings);
    ProtrusionFindings(map, run_nodes, *inputs.report, options, &findings);
  }
  if (inputs.report) UndoneMergeFindings(*inputs.report, &findings);
  if (inputs.report) RetractedHypothesisFindings(*inputs.report, &findings);
  AmbiguousViewFinding(map, &findings);
  std::stable_sort(findings.begin(), findings.end(),
                   [](const auto& a, const auto& b) { return a.severity() > b.severity(); });
  for (std::size_t i = 0; i < findings.size(); ++i)
    findings[i].set_finding_id(static_cast<std::int64_t>(i + 1));
  return findings;
}

Status Reoptimize(Map& map) {
  if (map.graph.num_nodes() == 0) return Status::Ok();
  RETURN_IF_ERROR(slamcore::InitializeLinear(map.graph));
  slamcore::OptimizerOptions options;
  options.max_iterations = 50;
  auto summary = slamcore::Optimize(map.graph, options);
  return summary.ok() ? Status::Ok() : summary.status();
}

Result<Map> RejectEdge(const Map& map, NodeId from, NodeId to, std::optional<slamcore::ViewId> view,
                       std::string* detail) {
  bool motion_only = false;
  std::optional<std::size_t> target;
  for (std::size_t i = 0; i < map.graph.num_edges() && !target; ++i) {
    const Edge& edge = map.graph.edges()[i];
    if (edge.from != from || edge.to != to || (view && edge.view != view)) continue;
    if (edge.kind == EdgeKind::kMotion) {
      motion_only = true;
      continue;
    }
    target = i;
  }
  const std::string name = "edge " + std::to_string(from) + "→" + std::to_string(to) +
                           (view ? " (view " + std::to_string(*view) + ")" : "");
  if (!target) {
    return slamcore::InvalidArgument(
        motion_only ? name + " is a motion (odometry) edge; only observation edges can be rejected"
                    : "the map has no observation " + name);
  }
  Map repaired = map;
  const std::size_t components_before = repaired.graph.NumComponents();
  std::size_t index = 0;
  repaired.graph.RemoveEdgesIf([&](const Edge&) { return index++ == *target; });
  RETURN_IF_ERROR(Reoptimize(repaired));
  *detail = "rejected observation " + name + "; components " + std::to_string(components_before) + " → " +
            std::to_string(repaired.graph.NumComponents());
  return repaired;
}

Result<Map> RejectHypothesis(const Map& map, const std::set<NodeId>& run_nodes, std::int64_t hypothesis,
                             std::string* detail) {
  const Rejection rejection = RejectionOf(map.graph, run_nodes, hypothesis);
  if (rejection.edges.empty()) {
    return slamcore::InvalidArgument("the map has no edge that hypothesis " + std::to_string(hypothesis) +
                                     " of its run added (already rejected, or a hypothesis of another run)");
  }
  Map repaired = map;
  const std::size_t components_before = repaired.graph.NumComponents();
  std::size_t index = 0;
  repaired.graph.RemoveEdgesIf([&](const Edge&) { return rejection.edges.contains(index++); });
  RETURN_IF_ERROR(Reoptimize(repaired));
  const std::size_t resting = rejection.edges.size() - rejection.own_edges;
  *detail = "rejected hypothesis " + std::to_string(hypothesis) + (rejection.merge ? " (a merge)" : "") +
            ": " + std::to_string(rejection.own_edges) + " edge(s) removed" +
            (resting > 0 ? ", and " + std::to_string(resting) +
                               " later observation edge(s) of the run that joined the parts it merged"
                         : "") +
            "; components " + std::to_string(components_before) + " → " +
            std::to_string(repaired.graph.NumComponents());
  return repaired;
}

Result<Map> CutRegion(const Map& map, const std::set<NodeId>& run_nodes,
                      const std::array<double, 4>& world_bbox, std::string* detail) {
  if (!(world_bbox[0] < world_bbox[2] && world_bbox[1] < world_bbox[3])) {
    return slamcore::InvalidArgument("region: min_x < max_x and min_y < max_y are required");
  }
  if (map.graph.num_nodes() == 0) return slamcore::InvalidArgument("the map is empty");
  Map repaired = map;
  std::int64_t cleared = 0;
  std::set<NodeId> touched;
  // Half a patch cell of margin: the renderer samples patches at grid cell centres, so a patch cell whose
  // centre lies just outside the box still paints cells inside it.
  ForEachKnownPatchCell(map, run_nodes, HomeComponent(map.graph),
                        [&](NodeId node, std::size_t index, const slamcore::Vector2& centre) {
                          const double margin = 0.5 * map.local_maps.at(node).resolution;
                          if (!Inside(centre, world_bbox, margin)) return;
                          repaired.local_maps.at(node).cells[index] = -1;
                          ++cleared;
                          touched.insert(node);
                        });
  if (cleared == 0)
    return slamcore::InvalidArgument("the run's occupancy patches have no known cells in the region");
  *detail = "cut region [" + Fixed(world_bbox[0], 2) + ", " + Fixed(world_bbox[1], 2) + "] – [" +
            Fixed(world_bbox[2], 2) + ", " + Fixed(world_bbox[3], 2) + "]: " + std::to_string(cleared) +
            " cells of " + std::to_string(touched.size()) + " patches made unknown";
  return repaired;
}

namespace {

/// What identifies an edge across versions of one map: its ends, kind, view, hypothesis and measurement
/// (measurements are constants of the graph; re-optimisation moves poses only).
using EdgeKey = std::tuple<NodeId, NodeId, int, std::int64_t, std::int64_t, double, double, double>;

EdgeKey KeyOf(const Edge& edge) {
  return {edge.from,
          edge.to,
          static_cast<int>(edge.kind),
          edge.view.value_or(-1),
          edge.hypothesis.value_or(-1),
          edge.measurement.x(),
          edge.measurement.y(),
          edge.measurement.theta()};
}

bool SamePatchShape(const slamcore::LocalMapEvent& a, const slamcore::LocalMapEvent& b) {
  return a.width == b.width && a.height == b.height && a.resolution == b.resolution &&
         a.cells.size() == b.cells.size();
}

}  // namespace

Result<Map> CarryRepairForward(const Map& base, const Map& repaired, const Map& target, std::string* detail) {
  // The edges the repair removed, counted (parallel edges with one key are possible).
  std::map<EdgeKey, int> removed;
  for (const Edge& edge : base.graph.edges()) ++removed[KeyOf(edge)];
  for (const Edge& edge : repaired.graph.edges()) {
    const auto it = removed.find(KeyOf(edge));
    if (it != removed.end() && --it->second == 0) removed.erase(it);
  }
  Map carried = target;
  std::size_t edges_removed = 0;
  if (!removed.empty()) {
    edges_removed = carried.graph.RemoveEdgesIf([&](const Edge& edge) {
      if (edge.kind == EdgeKind::kMotion) return false;  // repairs never remove odometry
      const auto it = removed.find(KeyOf(edge));
      if (it == removed.end()) return false;
      if (--it->second == 0) removed.erase(it);
      return true;
    });
  }
  // The patch cells the repair changed, where the target still holds what the base held.
  std::int64_t cells_changed = 0, cells_kept = 0;
  std::set<NodeId> patches;
  for (const auto& [node, after] : repaired.local_maps) {
    const auto before = base.local_maps.find(node);
    const auto now = carried.local_maps.find(node);
    if (before == base.local_maps.end() || now == carried.local_maps.end()) continue;
    if (!SamePatchShape(before->second, after) || !SamePatchShape(before->second, now->second)) continue;
    for (std::size_t i = 0; i < after.cells.size(); ++i) {
      if (after.cells[i] == before->second.cells[i]) continue;
      if (now->second.cells[i] != before->second.cells[i]) {
        ++cells_kept;
        continue;
      }
      now->second.cells[i] = after.cells[i];
      ++cells_changed;
      patches.insert(node);
    }
  }
  if (edges_removed == 0 && cells_changed == 0) {
    return slamcore::InvalidArgument(
        "nothing of the repair applies to the later version: the edges it removed and the cells it changed "
        "are gone "
        "or were observed again");
  }
  if (edges_removed > 0) RETURN_IF_ERROR(Reoptimize(carried));
  *detail = std::to_string(edges_removed) + " edge(s) removed and " + std::to_string(cells_changed) +
            " cells of " + std::to_string(patches.size()) + " patches changed as the repair did" +
            (cells_kept > 0 ? "; " + std::to_string(cells_kept) + " cells observed again since kept"
                            : std::string());
  return carried;
}

Result<std::vector<fleet::v1::ExportedFile>> ExportMap(const Map& map, const std::string& format,
                                                       const std::string& stem,
                                                       const fleet::v1::MapMetadata* metadata) {
  if (map.graph.num_nodes() == 0) return slamcore::InvalidArgument("the map is empty: nothing to export");
  std::vector<fleet::v1::ExportedFile> files;
  if (format == "g2o") {
    std::ostringstream out;
    slamcore::WritePoseGraph(map.graph, out, slamcore::GraphFormat::kG2o);
    fleet::v1::ExportedFile& file = files.emplace_back();
    file.set_name(stem + ".g2o");
    file.set_content(out.str());
    return files;
  }
  if (format != "map_server" && format != "valetudo") {
    return slamcore::InvalidArgument(
        "format \"" + format +
        "\": expected \"map_server\" (PGM + YAML), \"g2o\" or \"valetudo\" (ValetudoMap JSON)");
  }
  ASSIGN_OR_RETURN(auto grid, RenderHomeGrid(map));
  if (grid.width == 0)
    return slamcore::InvalidArgument("the map has no occupancy patches: no " + format + " image");
  if (format == "valetudo") {
    ASSIGN_OR_RETURN(auto json, WriteValetudoMap(grid, metadata ? *metadata : fleet::v1::MapMetadata()));
    fleet::v1::ExportedFile& file = files.emplace_back();
    file.set_name(stem + ".json");
    file.set_content(std::move(json));
    return files;
  }
  fleet::v1::ExportedFile& image = files.emplace_back();
  image.set_name(stem + ".pgm");
  image.set_content(slamcore::EncodePgm(grid));
  fleet::v1::ExportedFile& yaml = files.emplace_back();
  yaml.set_name(stem + ".yaml");
  yaml.set_content(slamcore::MapServerYaml(grid, stem + ".pgm"));
  return files;
}

}  // namespace analyzer
