#include "slamcore/g2o_replay.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <set>

#include "slamcore/optimizer.h"

namespace slamcore {
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

  std::map<NodeId, const Edge*> odometry_into;         // node k → edge k−1 → k
  std::multimap<NodeId, const Edge*> observations_at;  // robot node → loop closures, file order
  for (const Edge& edge : graph.edges()) {
    if (edge.to == edge.from + 1 && !odometry_into.contains(edge.to)) {
      odometry_into.emplace(edge.to, &edge);
    } else {
      observations_at.emplace(std::max(edge.from, edge.to), &edge);
    }
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
      const Edge& edge = *odometry->second;
      run.events.push_back(
          OdometryEvent{.time = time,
                        .increment = edge.measurement,
                        .covariance = LeftCovarianceFromEdgeInformation(edge.measurement, edge.information)});
    }
    run.events.push_back(ViewCreatedEvent{.time = time, .view = id});
    const auto [begin, end] = observations_at.equal_range(id);
    for (auto it = begin; it != end; ++it) {
      const Edge& edge = *it->second;
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
      run.observation_sources.emplace_back(edge.from, edge.to);
    }
  }
  return run;
}

Result<ReplayResult> ReplayPoseGraph(const PoseGraph& graph, const MapperParams& params) {
  ASSIGN_OR_RETURN(const auto run, RunFromPoseGraph(graph));
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(auto mapper, Mapper::Create(params));

  // Observation events and the file edges they came from, keyed by (robot node, view) as the Mapper
  // reports accepted edges (views carry the file's vertex ids, nodes the Mapper's own).
  std::multimap<std::pair<NodeId, ViewId>, std::size_t> source_of;
  std::size_t observation = 0;
  NodeId robot = -1;
  for (const Event& event : run.events) {
    RETURN_IF_ERROR((mapper)->Process(event));
    if (std::holds_alternative<OdometryEvent>(event)) robot = *(mapper)->CurrentNode();
    if (const auto* observed = std::get_if<ViewObservedEvent>(&event)) {
      source_of.emplace(std::pair{robot, observed->view}, observation++);
    }
  }
  // The run's end may still change what is accepted (the consistent-set check), so read after Finish.
  ReplayResult result;
  result.graph = (mapper)->Finish().graph;
  result.mapper_chi2 = Chi2(result.graph);
  result.statistics = (mapper)->Statistics();
  const std::vector<AcceptedObservation> accepted_edges = (mapper)->accepted_observations();
  std::vector<bool> accepted(run.observation_sources.size(), false);
  for (const AcceptedObservation& edge : accepted_edges) {
    const auto [begin, end] = source_of.equal_range({edge.robot_node, edge.view});
    for (auto it = begin; it != end; ++it) {
      if (!accepted[it->second]) {
        accepted[it->second] = true;
        break;
      }
    }
  }

  OptimizerOptions final_options = params.optimizer;
  final_options.max_iterations = 100;
  final_options.relative_cost_decrease = 1e-10;  // a full solve: its χ² is the reference the back-ends meet
  ASSIGN_OR_RETURN(const auto summary, Optimize(result.graph, final_options));
  result.final_chi2 = summary.final_chi2;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t k = 0; k < accepted.size(); ++k) {
    (accepted[k] ? result.accepted : result.rejected).push_back(run.observation_sources[k]);
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

FilterScore ScoreReplay(const ReplayResult& result, const std::vector<VertexPair>& wrong) {
  // A wrong pair may coincide with a true one (the generator draws vertex pairs at random): such a pair
  // is counted by how many of each were written.
  std::multiset<VertexPair> remaining_wrong(wrong.begin(), wrong.end());
  FilterScore score;
  auto classify = [&](const VertexPair& pair, bool accepted) {
    const auto it = remaining_wrong.find(pair);
    if (it != remaining_wrong.end()) {
      remaining_wrong.erase(it);
      ++score.wrong_total;
      if (accepted) ++score.wrong_accepted;
    } else {
      ++score.true_total;
      if (accepted) ++score.true_accepted;
    }
  };
  for (const VertexPair& pair : result.accepted) classify(pair, true);
  for (const VertexPair& pair : result.rejected) classify(pair, false);
  return score;
}

}  // namespace slamcore
