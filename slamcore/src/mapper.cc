// Mapper: public API, event dispatch and the parts of a run that are not decisions (nodes, views, local
// maps, kidnap, expiry, the decision log). See mapper_impl.h for the design choices.
#include "slamcore/mapper.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "mapper_impl.h"
#include "slamcore/occupancy_grid.h"

namespace slamcore {

using internal::Hypothesis;

const char* DecisionKindName(DecisionKind kind) {
  switch (kind) {
    case DecisionKind::kDirectEdge: return "direct_edge";
    case DecisionKind::kHypothesisCreated: return "hypothesis_created";
    case DecisionKind::kHypothesisUpdated: return "hypothesis_updated";
    case DecisionKind::kConditionallyAccepted: return "conditionally_accepted";
    case DecisionKind::kAccepted: return "accepted";
    case DecisionKind::kRejected: return "rejected";
    case DecisionKind::kExpired: return "expired";
    case DecisionKind::kViewMarkedAmbiguous: return "view_marked_ambiguous";
    case DecisionKind::kComponentCreated: return "component_created";
    case DecisionKind::kComponentsMerged: return "components_merged";
    case DecisionKind::kRetracted: return "retracted";
    case DecisionKind::kSlipCorrected: return "slip_corrected";
  }
  return "unknown";
}

const char* HypothesisKindName(HypothesisKind kind) {
  return kind == HypothesisKind::kMerge ? "merge" : "recovery";
}

// ---- Impl: construction and dispatch -------------------------------------------------------------------

Mapper::Impl::Impl(const MapperParams& params, Map parent)
    : params_(params),
      map_(std::move(parent)),
      incremental_({.initial_region_nodes = params.local_window_nodes,
                    .max_iterations = params.optimizer.max_iterations,
                    .relative_cost_decrease = params.optimizer.relative_cost_decrease}),
      ambiguity_(params.ambiguity_window_distance, params.ambiguity_min_rejections) {
  for (const Node& node : map_.graph.nodes()) {
    next_node_id_ = std::max(next_node_id_, node.id + 1);
    odometer_ = std::max(odometer_, node.odometer);
  }
  for (const View& view : map_.graph.views())
    view_creation_order_.emplace(view.id, view_creation_order_.size());
  first_run_node_ = next_node_id_;
}

Status Mapper::Impl::Process(const Event& event) {
  RETURN_IF_ERROR(std::visit([this](const auto& e) { return Validate(e); }, event));
  // From here on nothing can fail on data.
  std::visit(
      [this](const auto& e) {
        time_ = e.time;
        if constexpr (std::is_same_v<std::decay_t<decltype(e)>, OdometryEvent>) {
          Apply(e);  // moves the robot first, so that expiry sees the distance of this step
          ExpireHypotheses();
        } else {
          ExpireHypotheses();  // before a new observation could join an expired hypothesis
          Apply(e);
        }
      },
      event);
  MaybeCheckConsistentSet();
  RefreshOverlay();
  return Status::Ok();
}

// ---- Impl: events --------------------------------------------------------------------------------------

void Mapper::Impl::Apply(const OdometryEvent& event) {
  Node node;
  node.id = next_node_id_++;
  node.time = event.time;
  const bool new_component = start_new_component_ || !current_node_;
  observed_at_current_node_ = false;
  if (new_component) {
    node.pose = SE2::Identity();
    node.odometer = odometer_;
    slip_reference_.reset();
  } else {
    odometer_ += event.increment.translation().norm();
    node.pose = map_.graph.node(*current_node_).pose * event.increment;
    node.odometer = odometer_;
  }
  // Both cannot fail: the id is fresh, and the event was validated (finite pose, positive definite
  // information) before we got here.
  (void)map_.graph.AddNode(node);
  if (new_component) {
    map_test_.marginals.reset();
    robot_relative_covariance_.setZero();
    start_new_component_ = false;
    current_node_ = node.id;
    Log(DecisionKind::kComponentCreated, -1, nullptr, new_component_reason_);
  } else {
    Edge edge;
    edge.from = *current_node_;
    edge.to = node.id;
    edge.measurement = event.increment;
    edge.information = EdgeInformationFromLeftCovariance(event.increment, event.covariance);
    edge.kind = EdgeKind::kMotion;
    (void)map_.graph.AddEdge(edge);
    current_node_ = node.id;
    if (slip_reference_) slip_reference_->since.push_back(node.id);
    MoveRobot(event.increment, event.covariance);
  }
  if (latest_ground_truth_) ground_truth_[node.id] = latest_ground_truth_->world_T_robot;
  ambiguity_.Forget(odometer_);
}

void Mapper::Impl::MoveRobot(const SE2& increment, const Matrix3& covariance) {
  // Eq. (3) for every hypothesis, and for the robot's own relative uncertainty.
  const internal::PoseGaussian motion = internal::MotionFromIncrement(increment, covariance);
  for (Hypothesis& hypothesis : hypotheses_)
    hypothesis.state = internal::PredictMotion(hypothesis.state, motion);
  if (contested_) {
    for (Contradiction& contradiction : contested_->contradictions)
      contradiction.state = internal::PredictMotion(contradiction.state, motion);
  }
  if (map_test_.marginals)
    map_test_.robot_T_factorized = internal::PredictMotion(map_test_.robot_T_factorized, motion);
  robot_relative_covariance_ =
      internal::PredictMotion({SE2::Identity(), robot_relative_covariance_}, motion).covariance;
}

void Mapper::Impl::Apply(const ViewCreatedEvent& event) {
  (void)map_.graph.AddView(View{.id = event.view, .node = *current_node_, .ambiguous = false});
  view_creation_order_.emplace(event.view, view_creation_order_.size());
}

void Mapper::Impl::Apply(const ViewObservedEvent& event) {
  observed_at_current_node_ = true;
  DecideObservation(event);
}

void Mapper::Impl::Apply(const LocalMapEvent& event) {
  const NodeId node = *current_node_;
  if (params_.correct_slip_from_views && ValidateLocalMap(node, event).ok()) {
    SlipReference judged(node, event);  // the judge of the next local map
    CorrectSlip(node, judged.judge);
    slip_reference_ = std::move(judged);
  }
  map_.local_maps[node] = event;
}

void Mapper::Impl::CorrectSlip(NodeId node, const ViewSlipJudge& view) {
  if (!slip_reference_ || slip_reference_->since.empty() || slip_reference_->since.back() != node ||
      observed_at_current_node_) {
    return;
  }
  const SlipDetectionParams judged;  // slip_detection.h's defaults, as the analysis judges
  const PoseGraph& graph = map_.graph;
  const SE2 reference_pose = graph.node(slip_reference_->node).pose;
  double path_m = 0.0;
  NodeId previous = slip_reference_->node;
  for (const NodeId next : slip_reference_->since) {
    path_m += (graph.node(next).pose.translation() - graph.node(previous).pose.translation()).norm();
    if (next != node) previous = next;
  }
  if (path_m > judged.max_path_m) return;
  const SE2 claimed = graph.node(node).pose;  // a copy: the node moves below
  const SE2 reference_T_claimed = reference_pose.inverse() * claimed;
  const std::optional<SE2> stood = slip_reference_->judge.StoodShort(view, reference_T_claimed, judged);
  if (!stood) return;
  // The motion edge into the node now says where the views put it; the node goes there, and the filter's
  // states, which odometry carried to the claimed pose, move with it: one more odometry increment, exact.
  const SE2 corrected = reference_pose * *stood;
  const SE2 claimed_T_corrected = claimed.inverse() * corrected;
  Matrix3 information = Matrix3::Identity();
  map_.graph.RemoveEdgesIf([&](const Edge& edge) {
    if (edge.kind != EdgeKind::kMotion || edge.from != previous || edge.to != node) return false;
    information = edge.information;
    return true;
  });
  Edge edge;
  edge.from = previous;
  edge.to = node;
  edge.measurement = graph.node(previous).pose.inverse() * corrected;
  edge.information = information;
  edge.kind = EdgeKind::kMotion;
  (void)map_.graph.AddEdge(edge);
  map_.graph.mutable_node(node).pose = corrected;
  NoteGraphChanged(GraphChange::kEdgesRemoved);
  MoveRobot(claimed_T_corrected, Matrix3::Zero());
  char reason[160];
  std::snprintf(
      reason, sizeof(reason),
      "slip: its local map stood %.2f m short of where odometry put it, %.2f m from node %lld's; moved there",
      (reference_T_claimed.translation() - stood->translation()).norm(),
      reference_T_claimed.translation().norm(), static_cast<long long>(slip_reference_->node));
  Log(DecisionKind::kSlipCorrected, -1, nullptr, reason);
}

void Mapper::Impl::Apply(const KidnapEvent& event) {
  const std::string cause = event.cause == KidnapEvent::Cause::kReboot ? "reboot" : "kidnap";
  slip_reference_.reset();
  // Every hypothesis state robot_T_ref assumed continuous odometry; after a kidnap it means nothing.
  std::vector<std::int64_t> open;
  for (const Hypothesis& hypothesis : hypotheses_) open.push_back(hypothesis.id);
  for (const std::int64_t id : open)
    DropHypothesis(id, DecisionKind::kRejected, "robot lost its position (" + cause + ")");
  ambiguity_.ForgetAccepted();
  contested_.reset();  // its contradictions' states assumed continuous odometry too
  start_new_component_ = true;
  new_component_reason_ = "first node after a " + cause;
}

void Mapper::Impl::Apply(const GroundTruthEvent& event) {
  latest_ground_truth_ = event;
  // "At or before the node's creation": an entry with the node's own time still belongs to it.
  if (current_node_ && map_.graph.node(*current_node_).time == event.time) {
    ground_truth_[*current_node_] = event.world_T_robot;
  }
}

void Mapper::Impl::ExpireHypotheses() {
  std::vector<std::pair<std::int64_t, std::string>> expired;
  for (const Hypothesis& hypothesis : hypotheses_) {
    std::ostringstream reason;
    if (time_ - hypothesis.last_time > params_.hypothesis_expiry_seconds) {
      reason << "no observation for " << time_ - hypothesis.last_time << " s";
    } else if (odometer_ - hypothesis.last_odometer > params_.hypothesis_expiry_distance) {
      reason << "no observation for " << odometer_ - hypothesis.last_odometer << " m";
    } else {
      continue;
    }
    expired.emplace_back(hypothesis.id, reason.str());
  }
  for (const auto& [id, reason] : expired) DropHypothesis(id, DecisionKind::kExpired, reason);
}

void Mapper::Impl::Log(DecisionKind kind, ViewId view, const Hypothesis* hypothesis, std::string reason) {
  if (hypothesis) {
    Log(kind, view, hypothesis->id, hypothesis->kind, std::move(reason));
  } else {
    Log(kind, view, -1, std::nullopt, std::move(reason));
  }
}

void Mapper::Impl::Log(DecisionKind kind, ViewId view, std::int64_t hypothesis,
                       std::optional<HypothesisKind> hypothesis_kind, std::string reason) {
  Decision decision;
  decision.time = time_;
  decision.kind = kind;
  decision.node = current_node_.value_or(-1);
  decision.view = view;
  decision.hypothesis = hypothesis;
  decision.hypothesis_kind = hypothesis_kind;
  decision.reason = std::move(reason);
  decisions_.push_back(std::move(decision));
}

Map Mapper::Impl::Finish() {
  std::vector<std::int64_t> open;
  for (const Hypothesis& hypothesis : hypotheses_) open.push_back(hypothesis.id);
  for (const std::int64_t id : open) DropHypothesis(id, DecisionKind::kExpired, "run ended");
  if (current_node_) CheckConsistentSet("the run ended");
  // The incremental back-end solves the robot's component once to convergence (the deferred direct edges
  // and what the check changed with it), so the child map is at its optimum, not only within the wildfire
  // tolerance.
  if (params_.optimize_after_accept && UsesIncrementalBackend() && current_node_) {
    pending_seeds_.push_back(*current_node_);
    (void)incremental_.SolveComponents(map_.graph, pending_seeds_);
    pending_seeds_.clear();
  }
  return std::move(map_);
}

// ---- Impl: reads through G′ ----------------------------------------------------------------------------

std::optional<SE2> Mapper::Impl::CurrentPose() const {
  if (!current_node_) return std::nullopt;
  return PoseOf(*current_node_);
}

SE2 Mapper::Impl::PoseOf(NodeId node) const {
  if (!map_.graph.HasNode(node)) return SE2::Identity();  // documented in mapper.h
  return overlay_ ? overlay_->PoseOf(node) : map_.graph.node(node).pose;
}

bool Mapper::Impl::SameComponentInView(NodeId a, NodeId b) const {
  if (!map_.graph.HasNode(a) || !map_.graph.HasNode(b)) return false;
  return overlay_ ? overlay_->SameComponent(a, b) : map_.graph.SameComponent(a, b);
}

// ---- Mapper --------------------------------------------------------------------------------------------

Result<std::unique_ptr<Mapper>> Mapper::Create(const MapperParams& params, Map parent) {
  RETURN_IF_ERROR(params.Validate());
  for (const auto& [node, local_map] : parent.local_maps) {
    if (!parent.graph.HasNode(node)) {
      return InvalidArgument("parent map: local map at node " + std::to_string(node) +
                             ", which does not exist");
    }
  }
  return std::unique_ptr<Mapper>(new Mapper(std::make_unique<Impl>(params, std::move(parent))));
}

Mapper::Mapper(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Mapper::~Mapper() = default;

Status Mapper::Process(const Event& event) { return impl_->Process(event); }
std::optional<NodeId> Mapper::CurrentNode() const { return impl_->CurrentNode(); }
std::optional<SE2> Mapper::CurrentPose() const { return impl_->CurrentPose(); }
SE2 Mapper::PoseOf(NodeId node) const { return impl_->PoseOf(node); }
bool Mapper::SameComponentInView(NodeId a, NodeId b) const { return impl_->SameComponentInView(a, b); }
bool Mapper::HasConditionalMerge() const { return impl_->HasConditionalMerge(); }
const Map& Mapper::map() const { return impl_->map(); }
const std::vector<Decision>& Mapper::decisions() const { return impl_->decisions(); }
const std::vector<AcceptedObservation>& Mapper::accepted_observations() const {
  return impl_->accepted_observations();
}
const std::unordered_map<NodeId, SE2>& Mapper::ground_truth() const { return impl_->ground_truth(); }
Map Mapper::Finish() { return impl_->Finish(); }

MapperStatistics Mapper::Statistics() const { return ComputeStatistics(impl_->decisions()); }
ConsistentSetChecks Mapper::consistent_set_checks() const { return impl_->consistent_set_checks(); }

}  // namespace slamcore
