#include "slamcore/g2o_replay.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>

#include "slamcore/optimizer.h"

namespace slamcore {
namespace {

bool SameMeasurement(const SE2& a, const SE2& b) {
  return a.x() == b.x() && a.y() == b.y() && a.theta() == b.theta();
}

}  // namespace

Result<G2oRun> RunFromPoseGraph(const PoseGraph& graph, double seconds_per_node) {
  std::vector<NodeId> ids;
  ids.reserve(graph.num_nodes());
  for (const Node& node : graph.nodes()) ids.push_back(node.id);
  std::sort(ids.begin(), ids.end());
  for (std::size_t k = 1; k < ids.size(); ++k) {
    if (ids[k] != ids[k - 1] + 1) {
      return InvalidArgument("vertex ids must be contiguous for replay: " + std::to_string(ids[k - 1]) +
                             " is followed by " + std::to_string(ids[k]));
    }
  }

  // Node k's odometry: the first edge k−1 → k in file order, else the first k → k−1 (a file that writes its
  // odometry backwards), read inverted.
  struct Odometry {
    const Edge* edge = nullptr;
    bool reversed = false;
  };
  std::map<NodeId, Odometry> odometry_into;
  for (const Edge& edge : graph.edges()) {
    if (edge.to == edge.from + 1 && !odometry_into.contains(edge.to)) odometry_into[edge.to] = {&edge, false};
  }
  for (const Edge& edge : graph.edges()) {
    if (edge.from == edge.to + 1 && !odometry_into.contains(edge.from))
      odometry_into[edge.from] = {&edge, true};
  }
  std::multimap<NodeId, std::size_t> observations_at;  // robot node → loop closures (edge index), file order
  for (std::size_t index = 0; index < graph.num_edges(); ++index) {
    const Edge& edge = graph.edges()[index];
    const NodeId later = std::max(edge.from, edge.to);
    const auto odometry = odometry_into.find(later);
    if (odometry == odometry_into.end() || odometry->second.edge != &edge)
      observations_at.emplace(later, index);
  }

  G2oRun run;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const NodeId id = ids[k];
    const double time = static_cast<double>(k) * seconds_per_node;
    const auto odometry = odometry_into.find(id);
    if (k == 0 || odometry == odometry_into.end()) {
      if (k > 0) run.events.push_back(KidnapEvent{.time = time, .cause = KidnapEvent::Cause::kKidnap});
      // A new component starts at an identity increment from nowhere: the Mapper places its first node.
      run.events.push_back(OdometryEvent{
          .time = time, .increment = SE2::Identity(), .covariance = Matrix3::Identity() * 1e-6});
    } else {
      // Reversed, the increment is the measurement's inverse, whose left perturbations are the measurement's
      // right ones: (z·exp(e))⁻¹ = exp(−e)·z⁻¹ (as for an observation edge that ends at the robot, below).
      const auto& [edge, reversed] = odometry->second;
      run.events.push_back(
          OdometryEvent{.time = time,
                        .increment = reversed ? edge->measurement.inverse() : edge->measurement,
                        .covariance = LeftCovarianceFromEdgeInformation(
                            reversed ? SE2::Identity() : edge->measurement, edge->information)});
    }
    run.events.push_back(ViewCreatedEvent{.time = time, .view = id});
    const auto [begin, end] = observations_at.equal_range(id);
    for (auto it = begin; it != end; ++it) {
      const Edge& edge = graph.edges()[it->second];
      // z = robot_T_view: the measurement when the edge leaves the robot's node, else its inverse. The
      // inverse's left perturbations are the measurement's right ones: (z·exp(e))⁻¹ = exp(−e)·z⁻¹.
      const bool from_robot = edge.from == id;
      const SE2 z = from_robot ? edge.measurement : edge.measurement.inverse();
      const Matrix3 covariance = from_robot
                                     ? LeftCovarianceFromEdgeInformation(edge.measurement, edge.information)
                                     : LeftCovarianceFromEdgeInformation(SE2::Identity(), edge.information);
      run.events.push_back(ViewObservedEvent{.time = time,
                                             .view = from_robot ? edge.to : edge.from,
                                             .robot_T_view = z,
                                             .covariance = covariance});
      run.observation_edges.push_back(it->second);
    }
  }
  return run;
}

Result<ReplayResult> ReplayPoseGraph(const PoseGraph& graph, const MapperParams& params) {
  ASSIGN_OR_RETURN(const auto run, RunFromPoseGraph(graph));
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(auto mapper, Mapper::Create(params));

  // Observation events and the file edges they came from, keyed by (robot node, view) as the Mapper's
  // edges carry them (views carry the file's vertex ids, nodes the Mapper's own).
  std::multimap<std::pair<NodeId, ViewId>, std::size_t> source_of;
  std::vector<SE2> measurement_of;  // by observation
  NodeId robot = -1;
  for (const Event& event : run.events) {
    RETURN_IF_ERROR((mapper)->Process(event));
    if (std::holds_alternative<OdometryEvent>(event)) robot = *(mapper)->CurrentNode();
    if (const auto* observed = std::get_if<ViewObservedEvent>(&event)) {
      source_of.emplace(std::pair{robot, observed->view}, measurement_of.size());
      measurement_of.push_back(observed->robot_T_view);
    }
  }
  // The run's end may still change what is accepted (the consistent-set check), so read after Finish.
  ReplayResult result;
  result.graph = (mapper)->Finish().graph;
  result.mapper_chi2 = Chi2(result.graph);
  result.statistics = (mapper)->Statistics();
  result.consistent_set_checks = (mapper)->consistent_set_checks();
  result.decisions = (mapper)->decisions();
  // An observation edge of G came from the observation at its (robot node, view) whose measurement it
  // carries: two loop closures of the file between the same vertices are told apart by it.
  std::vector<bool> accepted(run.observation_edges.size(), false);
  for (const Edge& edge : result.graph.edges()) {
    if (edge.kind != EdgeKind::kObservation || !edge.view) continue;
    // Not a structured binding: Debian 12's clang 14 cannot capture one in a lambda.
    const auto sources = source_of.equal_range({edge.from, *edge.view});
    const auto first_untaken = [&](auto&& also) -> std::optional<std::size_t> {
      for (auto it = sources.first; it != sources.second; ++it) {
        if (!accepted[it->second] && also(it->second)) return it->second;
      }
      return std::nullopt;
    };
    std::optional<std::size_t> source =
        first_untaken([&](std::size_t k) { return SameMeasurement(measurement_of[k], edge.measurement); });
    if (!source) source = first_untaken([](std::size_t) { return true; });
    if (source) accepted[*source] = true;
  }

  OptimizerOptions final_options = params.optimizer;
  final_options.max_iterations = 100;
  final_options.relative_cost_decrease = 1e-10;  // a full solve: its χ² is the reference the back-ends meet
  ASSIGN_OR_RETURN(const auto summary, Optimize(result.graph, final_options));
  result.final_chi2 = summary.final_chi2;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t k = 0; k < accepted.size(); ++k) {
    const std::size_t index = run.observation_edges[k];
    const Edge& source = graph.edges()[index];
    (accepted[k] ? result.accepted : result.rejected).emplace_back(source.from, source.to);
    (accepted[k] ? result.accepted_edges : result.rejected_edges).push_back(index);
  }
  return result;
}

double FilterScore::Precision() const {
  const int accepted = true_accepted + wrong_accepted;
  return accepted == 0 ? 1.0 : static_cast<double>(true_accepted) / accepted;
}

double FilterScore::Recall() const {
  return true_total == 0 ? 1.0 : static_cast<double>(true_accepted) / true_total;
}

FilterScore ScoreReplay(const ReplayResult& result, std::size_t first_wrong_edge,
                        const std::vector<bool>& agrees_with_optimum) {
  FilterScore score;
  for (const bool accepted : {true, false}) {
    for (const std::size_t edge : accepted ? result.accepted_edges : result.rejected_edges) {
      if (edge < first_wrong_edge) {
        ++score.true_total;
        score.true_accepted += accepted;
      } else if (edge - first_wrong_edge < agrees_with_optimum.size() &&
                 agrees_with_optimum[edge - first_wrong_edge]) {
        ++score.agreeing_total;
        score.agreeing_accepted += accepted;
      } else {
        ++score.wrong_total;
        score.wrong_accepted += accepted;
      }
    }
  }
  return score;
}

}  // namespace slamcore
