#include "analyzer/run_analysis.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <unordered_map>

#include "analyzer/telemetry_codec.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_detector.h"
#include "slamcore/slip_detection.h"
#include "slamcore/trajectory_error.h"

namespace analyzer {
namespace {

using slamcore::Decision;
using slamcore::DecisionKind;
using slamcore::HypothesisKind;
using slamcore::NodeId;
using slamcore::Result;
using slamcore::ViewId;

/// An observation as the robot reported it, with the simulator's truth flag when there is one.
struct ReportedObservation {
  NodeId robot_node = -1;
  ViewId view = -1;
  std::optional<bool> truth_wrong;
};

double Seconds(std::chrono::steady_clock::duration duration) {
  return std::chrono::duration<double>(duration).count();
}

fleet::v1::MapperCounts CountsToProto(const slamcore::MapperStatistics& stats) {
  fleet::v1::MapperCounts counts;
  counts.set_direct_edges(stats.direct_edges);
  counts.set_recovery_created(stats.recovery_created);
  counts.set_recovery_accepted(stats.recovery_accepted);
  counts.set_recovery_retracted(stats.recovery_retracted);
  counts.set_slip_corrections(stats.slip_corrections);
  counts.set_recovery_expired(stats.recovery_expired);
  counts.set_recovery_rejected(stats.recovery_rejected);
  counts.set_merge_created(stats.merge_created);
  counts.set_merge_conditionally_accepted(stats.merge_conditionally_accepted);
  counts.set_merge_accepted(stats.merge_accepted);
  counts.set_merge_expired(stats.merge_expired);
  counts.set_merge_rejected(stats.merge_rejected);
  counts.set_merge_conditional_then_rejected(stats.merge_conditional_then_rejected);
  counts.set_views_marked_ambiguous(stats.views_marked_ambiguous);
  counts.set_components_created(stats.components_created);
  return counts;
}

fleet::v1::Decision DecisionToProto(const Decision& decision) {
  fleet::v1::Decision proto;
  proto.set_time(decision.time);
  proto.set_kind(slamcore::DecisionKindName(decision.kind));
  proto.set_node(decision.node);
  proto.set_view(decision.view);
  proto.set_hypothesis(decision.hypothesis);
  if (decision.hypothesis_kind) {
    proto.set_hypothesis_kind(slamcore::HypothesisKindName(*decision.hypothesis_kind));
  }
  proto.set_reason(decision.reason);
  return proto;
}

/// Seconds from the first event to the first merge decision of `kind`, or −1.
double SecondsToMerge(const std::vector<Decision>& decisions, DecisionKind kind, double start) {
  for (const Decision& decision : decisions) {
    if (decision.kind == kind && decision.hypothesis_kind == HypothesisKind::kMerge)
      return decision.time - start;
  }
  return -1.0;
}

/// Protrusion regions between the parent map and the rerun child (RenderComparedGrids).
slamcore::Status DetectProtrusions(const slamcore::Map& parent, const slamcore::Map& child,
                                   bool has_ground_truth, const std::set<NodeId>& slipping_nodes,
                                   const std::unordered_map<NodeId, slamcore::SE2>& truth_poses,
                                   const AnalysisOptions& options, fleet::v1::RunReport* report) {
  for (const std::string& name : slamcore::ProtrusionFeatureNames()) report->add_feature_names(name);
  if (parent.local_maps.empty() || parent.graph.num_nodes() == 0) return slamcore::Status::Ok();
  ASSIGN_OR_RETURN(const auto grids, RenderComparedGrids(parent, child));
  const auto regions = slamcore::ExtractRegions(grids.parent, grids.child);
  std::shared_ptr<const slamcore::ProtrusionClassifier> built_in;
  const slamcore::ProtrusionClassifier* classifier = options.classifier;
  if (classifier == nullptr) {
    if (auto loaded = slamcore::DefaultProtrusionClassifier(); loaded.ok()) built_in = *loaded;
    classifier = built_in.get();
  }
  RETURN_IF_ERROR(regions.status());
  std::optional<RegionCover> truth;
  if (has_ground_truth) {
    // A simulator's truth is for evaluation only: truth that cannot be drawn (stuck nodes placed absurdly
    // far, beyond what a grid may span) labels no region, and the analysis stands without it.
    auto labelled =
        RegionsDrawnAway(child, WhereStuckNodesWere(child, slipping_nodes, truth_poses), grids, *regions);
    if (labelled.ok()) truth = std::move(labelled).value();
  }
  ASSIGN_OR_RETURN(const auto classes, ClassifyRegions(parent, child, grids, *regions, classifier));
  const slamcore::OccupancyGrid& child_grid = grids.child;
  for (std::size_t index = 0; index < regions->size(); ++index) {
    const slamcore::ProtrusionRegion& region = (*regions)[index];
    fleet::v1::ProtrusionRegion* proto = report->add_protrusion_regions();
    proto->set_id(region.id);
    for (const int value : {region.bbox.x, region.bbox.y, region.bbox.width, region.bbox.height})
      proto->add_bbox(value);
    for (const double feature : region.features) proto->add_features(feature);
    if (!region.cells.empty()) {
      double min_x = std::numeric_limits<double>::max(), min_y = min_x, max_x = -min_x, max_y = -min_x;
      for (const std::int32_t cell : region.cells) {
        const double x = child_grid.origin_x + (cell % child_grid.width) * child_grid.resolution;
        const double y = child_grid.origin_y + (cell / child_grid.width) * child_grid.resolution;
        min_x = std::min(min_x, x), max_x = std::max(max_x, x + child_grid.resolution);
        min_y = std::min(min_y, y), max_y = std::max(max_y, y + child_grid.resolution);
      }
      for (const double value : {min_x, min_y, max_x, max_y}) proto->add_world_bbox(value);
    }
    const RegionClass& region_class = classes[index];
    proto->set_predicted_class(region_class.decided_by == RegionClass::DecidedBy::kNone ? "unclassified"
                               : region_class.protrusion                                ? "protrusion"
                                                                                        : "new_space");
    proto->set_probability(region_class.probability);
    proto->set_decided_by(DecidedByName(region_class.decided_by));
    if (region_class.protrusion) report->set_protrusions_found(report->protrusions_found() + 1);
    if (truth) proto->set_truth_protrusion(truth->region_is_covered[index]);
  }
  return slamcore::Status::Ok();
}

}  // namespace

std::optional<double> ComponentwiseRmse(const slamcore::PoseGraph& graph,
                                        const std::unordered_map<NodeId, slamcore::SE2>& truth, int* count) {
  std::map<slamcore::ComponentId, std::pair<std::vector<slamcore::Vector2>, std::vector<slamcore::Vector2>>>
      pairs;
  for (const auto& [node, pose] : truth) {
    if (!graph.HasNode(node)) continue;
    auto& [estimate, reference] = pairs[graph.ComponentOf(node)];
    estimate.push_back(graph.node(node).pose.translation());
    reference.push_back(pose.translation());
  }
  double sum = 0.0;
  *count = 0;
  for (const auto& [component, points] : pairs) {
    const auto rmse = slamcore::AlignedRmse(points.first, points.second);
    if (!rmse.ok()) continue;  // a single-node component carries no trajectory error
    sum += *rmse * *rmse * static_cast<double>(points.first.size());
    *count += static_cast<int>(points.first.size());
  }
  if (*count < 2) return std::nullopt;
  return std::sqrt(sum / *count);
}

slamcore::Map ComponentMap(const slamcore::Map& map, const std::set<NodeId>& nodes) {
  slamcore::Map part;
  for (const NodeId node : nodes) {
    if (!map.graph.HasNode(node)) continue;
    (void)part.graph.AddNode(map.graph.node(node));
    if (const auto it = map.local_maps.find(node); it != map.local_maps.end())
      part.local_maps.emplace(node, it->second);
  }
  return part;
}

std::unordered_map<NodeId, slamcore::SE2> WhereStuckNodesWere(
    const slamcore::Map& child, const std::set<NodeId>& stuck_nodes,
    const std::unordered_map<NodeId, slamcore::SE2>& truth) {
  std::unordered_map<NodeId, slamcore::SE2> really_at;
  std::optional<NodeId> anchor;
  for (const slamcore::Node& node : child.graph.nodes()) {  // in creation order
    if (!stuck_nodes.contains(node.id)) {
      if (truth.contains(node.id)) anchor = node.id;
      continue;
    }
    const auto true_pose = truth.find(node.id);
    if (!anchor || true_pose == truth.end() ||
        child.graph.ComponentOf(*anchor) != child.graph.ComponentOf(node.id)) {
      continue;
    }
    really_at.emplace(node.id, child.graph.node(*anchor).pose * slamcore::SE2::Inverse(truth.at(*anchor)) *
                                   true_pose->second);
  }
  return really_at;
}

Result<RegionCover> RegionsDrawnAway(const slamcore::Map& child,
                                     const std::unordered_map<NodeId, slamcore::SE2>& really_at,
                                     const ComparedGrids& grids,
                                     const std::vector<slamcore::ProtrusionRegion>& regions,
                                     double tolerance_m) {
  const slamcore::OccupancyGrid& child_grid = grids.child;
  RegionCover result;
  result.covered.assign(
      static_cast<std::size_t>(child_grid.width) * static_cast<std::size_t>(child_grid.height), 0);
  // The nodes' patches drawn at their estimates and where the robot was (only nodes of the compared
  // component: the grids render no other).
  std::set<NodeId> placed;
  for (const NodeId node : grids.child_nodes) {
    if (really_at.contains(node) && child.local_maps.contains(node)) placed.insert(node);
  }
  const slamcore::Map drawn = ComponentMap(child, placed);
  slamcore::Map seen = drawn;
  for (slamcore::Node& node : seen.graph.mutable_nodes()) node.pose = really_at.at(node.id);
  std::vector<std::size_t> drawn_away(regions.size(), 0);
  if (!drawn.local_maps.empty()) {
    slamcore::GlobalGridRenderer drawn_renderer, seen_renderer;
    RETURN_IF_ERROR(drawn_renderer.RenderAll(drawn));
    RETURN_IF_ERROR(seen_renderer.RenderAll(seen));
    const slamcore::OccupancyGrid& at_estimate = drawn_renderer.grid();
    const slamcore::OccupancyGrid& in_place = seen_renderer.grid();
    const int reach = static_cast<int>(std::ceil(tolerance_m / in_place.resolution - 1e-9));
    const auto cell_of = [](const slamcore::OccupancyGrid& grid, double x, double y) {
      return std::pair{static_cast<int>(std::floor((x - grid.origin_x) / grid.resolution)),
                       static_cast<int>(std::floor((y - grid.origin_y) / grid.resolution))};
    };
    for (std::size_t k = 0; k < regions.size(); ++k) {
      for (const std::int32_t cell : regions[k].cells) {
        const double x = child_grid.origin_x + (cell % child_grid.width + 0.5) * child_grid.resolution;
        const double y = child_grid.origin_y + (cell / child_grid.width + 0.5) * child_grid.resolution;
        const auto [col, row] = cell_of(at_estimate, x, y);
        if (!at_estimate.InBounds(col, row) || at_estimate.at(col, row) == -1) continue;
        const std::int8_t state = at_estimate.at(col, row);
        // The patches in place give the cell the same state nearby: what the sensor saw there.
        const auto [place_col, place_row] = cell_of(in_place, x, y);
        bool seen_there = false;
        for (int dr = -reach; dr <= reach && !seen_there; ++dr) {
          for (int dc = -reach; dc <= reach && !seen_there; ++dc) {
            seen_there = in_place.InBounds(place_col + dc, place_row + dr) &&
                         in_place.at(place_col + dc, place_row + dr) == state;
          }
        }
        if (seen_there) continue;
        result.covered[static_cast<std::size_t>(cell)] = 1;
        ++drawn_away[k];
      }
    }
  }
  for (std::size_t k = 0; k < regions.size(); ++k) {
    // More than half: a data set's region is labelled by the majority of its cells' truth (ExtractAndLabel).
    result.region_is_covered.push_back(2 * drawn_away[k] > regions[k].cells.size());
  }
  return result;
}

const char* DecidedByName(RegionClass::DecidedBy decided_by) {
  switch (decided_by) {
    case RegionClass::DecidedBy::kViews: return "views";
    case RegionClass::DecidedBy::kClassifier: return "classifier";
    case RegionClass::DecidedBy::kNone: break;
  }
  return "none";
}

Result<std::vector<RegionClass>> ClassifyRegions(const slamcore::Map& parent, const slamcore::Map& child,
                                                 const ComparedGrids& grids,
                                                 const std::vector<slamcore::ProtrusionRegion>& regions,
                                                 const slamcore::ProtrusionClassifier* classifier) {
  ASSIGN_OR_RETURN(const auto findings, slamcore::FindSlipNodes(child));
  // Where the slipped robot was: where it was at the earlier node whose view contradicts its estimate (it
  // had not moved from there; the views say it stood still, or could not have crossed the wall beyond it).
  // That node may have slipped itself (a long episode is judged view by view), and then the robot was where
  // it was at that node's judge: findings come in chain order, so its place is known by then.
  std::unordered_map<NodeId, slamcore::SE2> really_at;
  for (const slamcore::SlipFinding& finding : findings) {
    if (parent.graph.HasNode(finding.node)) continue;
    const auto judge = really_at.find(finding.judged_against);
    const slamcore::SE2 judge_at =
        judge != really_at.end() ? judge->second : child.graph.node(finding.judged_against).pose;
    really_at.emplace(finding.node, judge_at * finding.judge_T_stood);
  }
  ASSIGN_OR_RETURN(const auto cover, RegionsDrawnAway(child, really_at, grids, regions));
  std::vector<RegionClass> classes(regions.size());
  for (std::size_t index = 0; index < regions.size(); ++index) {
    RegionClass& out = classes[index];
    if (classifier != nullptr) {
      ASSIGN_OR_RETURN(out.probability, classifier->Probability(regions[index].features));
      out.protrusion = classifier->IsProtrusion(out.probability);
      out.decided_by = RegionClass::DecidedBy::kClassifier;
    }
    // The views only add protrusions. A view that moved with the wheels does not make a region real: a
    // wall redrawn a cell off after drift is false floor too, and cutting such regions is what keeps
    // lifelong maps healthy (clearing them made the service regime of fleetsim --lifelong no better than
    // the filter alone).
    if (cover.region_is_covered[index]) {
      out.protrusion = true;
      out.decided_by = RegionClass::DecidedBy::kViews;
    }
  }
  return classes;
}

slamcore::ComponentId HomeComponent(const slamcore::PoseGraph& graph) {
  NodeId home = graph.nodes().front().id;
  for (const slamcore::ComponentId component : graph.Components()) {
    if (graph.ComponentSize(component) > graph.ComponentSize(home)) home = component;
  }
  return graph.ComponentOf(home);
}

Result<ComparedGrids> RenderComparedGrids(const slamcore::Map& parent, const slamcore::Map& child) {
  ComparedGrids grids;
  slamcore::GlobalGridRenderer parent_renderer, child_renderer;
  if (parent.graph.num_nodes() == 0 || parent.local_maps.empty()) {
    RETURN_IF_ERROR(child_renderer.RenderAll(child));
    for (const slamcore::Node& node : child.graph.nodes()) grids.child_nodes.push_back(node.id);
    grids.child = child_renderer.grid();
    return grids;
  }
  const slamcore::ComponentId home = HomeComponent(parent.graph);
  std::set<NodeId> parent_nodes, child_nodes;
  for (const NodeId node : parent.graph.NodesOf(home)) parent_nodes.insert(node);
  if (child.graph.HasNode(home)) {
    for (const NodeId node : child.graph.NodesOf(child.graph.ComponentOf(home))) child_nodes.insert(node);
  }
  RETURN_IF_ERROR(parent_renderer.RenderAll(ComponentMap(parent, parent_nodes)));
  RETURN_IF_ERROR(child_renderer.RenderAll(ComponentMap(child, child_nodes)));
  grids.parent = parent_renderer.grid();
  grids.child = child_renderer.grid();
  grids.child_nodes.assign(child_nodes.begin(), child_nodes.end());
  return grids;
}

Result<RunMaps> DecodeRunMaps(const fleet::v1::RunFile& run) {
  RETURN_IF_ERROR(Validate(run.header()));
  RunMaps maps;
  ASSIGN_OR_RETURN(maps.parent, FromProto(run.parent_snapshot(), "parent_snapshot"));
  ASSIGN_OR_RETURN(maps.uploaded_child, FromProto(run.child_snapshot(), "child_snapshot"));
  return maps;
}

Result<fleet::v1::RunReport> AnalyzeRun(const fleet::v1::RunFile& run, const AnalysisOptions& options) {
  ASSIGN_OR_RETURN(const RunMaps maps, DecodeRunMaps(run));
  return AnalyzeRun(run, maps, options);
}

Result<fleet::v1::RunReport> AnalyzeRun(const fleet::v1::RunFile& run, const RunMaps& maps,
                                        const AnalysisOptions& options) {
  RETURN_IF_ERROR(Validate(run.header()));
  const slamcore::Map& parent = maps.parent;
  const slamcore::Map& uploaded_child = maps.uploaded_child;

  const auto replay_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(auto mapper, slamcore::Mapper::Create(options.mapper, parent));
  std::vector<ReportedObservation> observations;
  std::set<NodeId> slipping_nodes;
  bool has_ground_truth = false;
  const double first_time = run.events_size() > 0 ? run.events(0).time() : 0.0;
  for (int k = 0; k < run.events_size(); ++k) {
    const fleet::v1::Event& proto = run.events(k);
    const std::string field = "events[" + std::to_string(k) + "]";
    if (options.keep_going && k % 256 == 0) {
      if (const slamcore::Status status = options.keep_going(); !status.ok()) {
        return slamcore::Status(status.code(), status.message() + " (at " + field + " of " +
                                                   std::to_string(run.events_size()) + ")");
      }
    }
    ASSIGN_OR_RETURN(const auto event, FromProto(proto, field));
    if (const slamcore::Status status = (mapper)->Process(event); !status.ok()) {
      return slamcore::InvalidArgument(field + ": " + status.message());
    }
    if (proto.has_view_observed()) {
      ReportedObservation observation{*(mapper)->CurrentNode(), proto.view_observed().view(), std::nullopt};
      if (proto.view_observed().has_truth_wrong())
        observation.truth_wrong = proto.view_observed().truth_wrong();
      observations.push_back(observation);
    }
    if (proto.has_ground_truth()) {
      has_ground_truth = true;
      if (proto.ground_truth().slipping() && (mapper)->CurrentNode())
        slipping_nodes.insert(*(mapper)->CurrentNode());
    }
  }
  if (options.keep_going) {
    if (const slamcore::Status status = options.keep_going(); !status.ok()) {
      return slamcore::Status(status.code(), status.message() + " (after the replay, before rendering)");
    }
  }
  const std::vector<Decision> decisions = (mapper)->decisions();
  const slamcore::MapperStatistics statistics = (mapper)->Statistics();
  const std::vector<slamcore::AcceptedObservation> accepted = (mapper)->accepted_observations();
  const std::unordered_map<NodeId, slamcore::SE2> truth = (mapper)->ground_truth();
  const slamcore::Map child = (mapper)->Finish();

  fleet::v1::RunReport report;
  report.set_format_version(1);
  report.set_run_id(run.header().run_id());
  report.set_robot_id(run.header().robot_id());
  report.set_parameter_set(options.parameter_set_name);
  report.set_firmware(run.header().firmware());
  report.set_map_version(run.header().map_version());
  report.set_started_at(run.header().started_at());
  *report.mutable_counts() = CountsToProto(statistics);
  for (const Decision& decision : decisions) *report.add_decisions() = DecisionToProto(decision);
  const double to_conditional = SecondsToMerge(decisions, DecisionKind::kConditionallyAccepted, first_time);
  const double to_full = SecondsToMerge(decisions, DecisionKind::kAccepted, first_time);
  report.set_seconds_to_conditional_relocalization(to_conditional);
  report.set_seconds_to_full_relocalization(to_full);
  const double first_join = to_conditional >= 0 ? to_conditional : to_full;
  report.set_started_localized(parent.graph.num_nodes() > 0 && first_join >= 0 &&
                               first_join <= kStartedLocalizedSeconds);
  for (const slamcore::View& view : child.graph.views()) {
    if (view.ambiguous) report.add_ambiguous_views(view.id);
  }
  report.set_views_total(static_cast<int>(child.graph.views().size()));
  report.set_replay_seconds(Seconds(std::chrono::steady_clock::now() - replay_start));

  const auto detection_start = std::chrono::steady_clock::now();
  RETURN_IF_ERROR(
      DetectProtrusions(parent, child, has_ground_truth, slipping_nodes, truth, options, &report));
  report.set_detection_seconds(Seconds(std::chrono::steady_clock::now() - detection_start));

  // Divergence from the map the robot uploaded: sizes, and node positions over the nodes both hold.
  fleet::v1::Divergence& divergence = *report.mutable_divergence();
  auto observation_edges = [](const slamcore::PoseGraph& graph) {
    return static_cast<int>(std::count_if(
        graph.edges().begin(), graph.edges().end(),
        [](const slamcore::Edge& edge) { return edge.kind == slamcore::EdgeKind::kObservation; }));
  };
  divergence.set_robot_nodes(static_cast<int>(uploaded_child.graph.num_nodes()));
  divergence.set_rerun_nodes(static_cast<int>(child.graph.num_nodes()));
  divergence.set_robot_observation_edges(observation_edges(uploaded_child.graph));
  divergence.set_rerun_observation_edges(observation_edges(child.graph));
  std::unordered_map<NodeId, slamcore::SE2> uploaded_poses;
  for (const slamcore::Node& node : uploaded_child.graph.nodes()) uploaded_poses.emplace(node.id, node.pose);
  int common = 0;
  divergence.set_node_position_rms(ComponentwiseRmse(child.graph, uploaded_poses, &common).value_or(0.0));

  if (has_ground_truth) {
    fleet::v1::GroundTruthErrors& errors = *report.mutable_ground_truth();
    int with_truth = 0;
    errors.set_trajectory_rmse(ComponentwiseRmse(child.graph, truth, &with_truth).value_or(0.0));
    errors.set_nodes_with_truth(with_truth);
    std::multiset<std::pair<NodeId, ViewId>> accepted_pairs;
    for (const auto& edge : accepted) accepted_pairs.emplace(edge.robot_node, edge.view);
    for (const ReportedObservation& observation : observations) {
      if (!observation.truth_wrong) continue;
      const auto it = accepted_pairs.find({observation.robot_node, observation.view});
      const bool was_accepted = it != accepted_pairs.end();
      if (was_accepted) accepted_pairs.erase(it);
      if (*observation.truth_wrong) {
        errors.set_wrong_observations(errors.wrong_observations() + 1);
        if (was_accepted) errors.set_wrong_observations_accepted(errors.wrong_observations_accepted() + 1);
      } else {
        errors.set_correct_observations(errors.correct_observations() + 1);
        if (was_accepted)
          errors.set_correct_observations_accepted(errors.correct_observations_accepted() + 1);
      }
    }
  }
  if (options.keep_rerun_child) *report.mutable_rerun_child() = ToProto(child);
  return report;
}

}  // namespace analyzer
