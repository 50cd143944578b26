#include "sim/run_simulator.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <unordered_map>

#include "analyzer/run_analysis.h"
#include "analyzer/telemetry_codec.h"
#include "sim/map_health.h"
#include "slamcore/protrusion_detector.h"

namespace sim {
namespace {

using slamcore::Matrix3;
using slamcore::Vector3;
constexpr double kPi = std::numbers::pi;

/// A view in the robot's front-end database, with the truth the simulator keeps about it.
struct ViewRecord {
  slamcore::ViewId id = 0;
  int landmark = 0;
  SE2 world_T_view;  // true robot pose when the view was created (the view's frame)
};

/// Robot controller: drive straight and turn away at obstacles (bump-and-turn coverage), with spells of
/// wall following; the same behaviour a cleaning robot shows.
enum class Behaviour { kStraight, kTurning, kWallFollow };

/// Where a stuck episode began: pushing a wall (or fixture), caught under low furniture, or on a rug border.
enum class StuckAt { kWall, kFurniture, kRug };

/// Heading difference in (−π, π].
double AngleBetween(double a, double b) { return slamcore::WrapAngle(a - b); }

}  // namespace

struct RobotSimulator::State {
  const World& world;
  SimParams params;
  std::string robot_id;
  std::string firmware;
  std::mt19937_64 random;
  double wheel_scale = 1.0;  // systematic odometry error of this robot
  RangeSensor sensor;        // this robot's model's ranging sensor
  MapHealthMeter meter;      // the home's true floor, dilated once: which region cells are false floor
  slamcore::Map map;         // the robot's map, carried from run to run
  std::vector<ViewRecord> views;
  std::unordered_map<int, std::vector<std::size_t>> views_of_landmark;
  std::unordered_map<slamcore::ViewId, std::size_t> view_index;
  slamcore::ViewId next_view_id = 1;
  int run_count = 0;
  std::int64_t map_version = 0;                          // the service's version of `map` (0: none)
  std::optional<fleet::v1::MapSnapshot> taken_map;       // the service's bytes of `map`, until the next run
  std::unordered_map<slamcore::NodeId, SE2> node_truth;  // every node of every run

  State(const World& w, const SimParams& p, std::string id, std::string fw, std::uint64_t seed)
      : world(w), params(p), robot_id(std::move(id)), firmware(std::move(fw)), random(seed), meter(w) {
    std::normal_distribution<double> scale(1.0, params.odometry_scale_error);
    wheel_scale = scale(random);
    sensor = DrawSensor(params, random);
  }

  double Uniform(double low, double high) {
    return std::uniform_real_distribution<double>(low, high)(random);
  }
  double Gaussian(double sigma) {
    return sigma > 0 ? std::normal_distribution<double>(0.0, sigma)(random) : 0.0;
  }
  bool Chance(double probability) { return Uniform(0.0, 1.0) < probability; }
};

RobotSimulator::RobotSimulator(const World& world, const SimParams& params, std::string robot_id,
                               std::string firmware, std::uint64_t seed)
    : state_(std::make_unique<State>(world, params, std::move(robot_id), std::move(firmware), seed)) {}

RobotSimulator::~RobotSimulator() = default;

const RangeSensor& RobotSimulator::sensor() const { return state_->sensor; }

slamcore::Status RobotSimulator::TakeMap(const fleet::v1::MapSnapshot& snapshot, std::int64_t version) {
  ASSIGN_OR_RETURN(auto map, analyzer::FromProto(snapshot, "snapshot"));
  State& s = *state_;
  s.map = std::move(map);
  s.taken_map = snapshot;
  s.map_version = version;
  // The front-end matches only views the map holds (a rollback or a rejected run drops some).
  for (auto& [landmark, indices] : s.views_of_landmark) {
    std::erase_if(indices, [&](std::size_t index) { return !s.map.graph.HasView(s.views[index].id); });
  }
  return slamcore::Status::Ok();
}

void RobotSimulator::SetMapVersion(std::int64_t version) { state_->map_version = version; }
std::int64_t RobotSimulator::map_version() const { return state_->map_version; }
const std::string& RobotSimulator::robot_id() const { return state_->robot_id; }
const slamcore::Map& RobotSimulator::map() const { return state_->map; }
const std::unordered_map<slamcore::NodeId, SE2>& RobotSimulator::node_truth() const {
  return state_->node_truth;
}

namespace {

/// Everything that happens inside one run.
class Run {
 public:
  Run(RobotSimulator::State& state, const std::string& run_id, double started_at)
      : s_(state), p_(state.params), run_id_(run_id), started_at_(started_at) {}

  slamcore::Result<RunOutcome> Simulate();

 private:
  slamcore::Status Emit(const slamcore::Event& event,
                        const std::function<void(fleet::v1::Event&)>& annotate = {});
  void StepPhysics();
  slamcore::Status MaybeKeyframe();
  slamcore::Status Keyframe();
  slamcore::Status ObserveLandmarks();
  slamcore::Status EmitPatch();
  slamcore::Status Kidnap(bool reboot);
  bool StartStuck(StuckAt where, double probability);
  bool CameraBlind() const;
  slamcore::Status LabelRegions();
  bool Visible(const Landmark& landmark) const;
  double ViewingDirection(const Landmark& landmark) const;

  RobotSimulator::State& s_;
  const SimParams& p_;
  std::string run_id_;
  double started_at_;
  std::unique_ptr<slamcore::Mapper> mapper_;
  slamcore::Map parent_;
  RunOutcome outcome_;

  double time_ = 0.0;
  SE2 truth_;               // world_T_robot
  SE2 measured_increment_;  // odometry accumulated since the last node
  double measured_distance_ = 0.0, measured_rotation_ = 0.0;
  Matrix3 increment_covariance_ = Matrix3::Zero();
  bool stuck_ = false, stuck_since_node_ = false;
  StuckAt stuck_at_ = StuckAt::kWall;
  double stuck_until_ = 0.0;
  double stuck_turn_per_metre_ = 0.0;  // the claimed heading change while stuck
  std::set<slamcore::NodeId> stuck_nodes_;
  Behaviour behaviour_ = Behaviour::kStraight;
  double turn_remaining_ = 0.0;
  double behaviour_until_ = 0.0;
  int nodes_ = 0;
  double first_merge_time_ = -1.0;
  std::size_t decisions_seen_ = 0;
  // By landmark: its last recognition, and whether the front-end took a look-alike for it in that pass.
  struct LookalikePass {
    double last_time = 0.0;
    bool confused = false;
    bool counted = false;  // its look-alike matches counted as a pass already
  };
  std::unordered_map<int, LookalikePass> lookalike_passes_;
};

slamcore::Status Run::Emit(const slamcore::Event& event,
                           const std::function<void(fleet::v1::Event&)>& annotate) {
  if (const slamcore::Status status = mapper_->Process(event); !status.ok()) {
    return slamcore::Internal("robot " + s_.robot_id + " run " + run_id_ + ": " + status.message());
  }
  fleet::v1::Event proto = analyzer::ToProto(event);
  if (annotate) annotate(proto);
  *outcome_.run.add_events() = std::move(proto);
  return slamcore::Status::Ok();
}

bool Run::StartStuck(StuckAt where, double probability) {
  if (!s_.Chance(std::min(1.0, probability * p_.stuck_rate_scale))) return false;
  stuck_ = true;
  stuck_at_ = where;
  // The stasis detection and escape fire after min + an exponential time (the robot notices late).
  const double extra =
      p_.stuck_mean_extra_seconds > 0
          ? std::exponential_distribution<double>(1.0 / p_.stuck_mean_extra_seconds)(s_.random)
          : 0.0;
  stuck_until_ = time_ + std::min(p_.stuck_max_seconds, p_.stuck_min_seconds + extra);
  stuck_turn_per_metre_ = s_.Gaussian(p_.stuck_heading_drift_per_metre);
  ++(where == StuckAt::kWall        ? outcome_.stuck_at_wall
     : where == StuckAt::kFurniture ? outcome_.stuck_under_furniture
                                    : outcome_.stuck_on_rug);
  return true;
}

bool Run::CameraBlind() const {
  // Face against a wall the camera sees a blank surface; under furniture it sees the dark underside.
  return (stuck_ && stuck_at_ != StuckAt::kRug) ||
         s_.world.SurfaceAt(truth_.translation()) == Surface::kUnderFurniture;
}

void Run::StepPhysics() {
  const double dt = p_.step_seconds;
  if (stuck_ && time_ >= stuck_until_) {
    // Escape: back off from what held the robot and turn away, as after a bump.
    stuck_ = false;
    behaviour_ = Behaviour::kTurning;
    turn_remaining_ = (s_.Chance(0.5) ? 1.0 : -1.0) * s_.Uniform(0.6 * kPi, 1.1 * kPi);
  }

  // Commanded motion from the behaviour.
  double forward = 0.0, turn = 0.0;
  if (stuck_) {
    // The wheels keep pushing in the direction the robot was going; one grips less, so the claimed heading drifts.
    forward = p_.speed * dt;
    turn = stuck_turn_per_metre_ * forward;
  } else {
    if (time_ >= behaviour_until_ && behaviour_ != Behaviour::kTurning) {
      behaviour_ = s_.Chance(p_.wall_follow_share) ? Behaviour::kWallFollow : Behaviour::kStraight;
      behaviour_until_ = time_ + s_.Uniform(10.0, 40.0);
    }
    if (behaviour_ == Behaviour::kTurning) {
      const double step =
          std::copysign(std::min(std::abs(turn_remaining_), p_.turn_rate * dt), turn_remaining_);
      turn = step;
      turn_remaining_ -= step;
      if (std::abs(turn_remaining_) < 1e-9) behaviour_ = Behaviour::kStraight;
    } else {
      forward = p_.speed * dt;
      if (behaviour_ == Behaviour::kWallFollow) {
        // Keep a wall about 0.1 m off the right side.
        const double right =
            s_.world.grid.CastRay(truth_.translation(), truth_.theta() - kPi / 2, 1.0) - p_.robot_radius;
        turn = std::clamp(0.8 * (right - 0.1), -0.6, 0.6) * -dt * 2.0;
      }
    }
  }

  // The robot's true motion. Contacts are where it can get stuck: a bump into a wall, driving under low
  // furniture, climbing onto a rug.
  if (stuck_) {
    const SE2 creep = truth_ * SE2(p_.stuck_creep_share * forward, 0.0, 0.0);
    if (p_.stuck_creep_share > 0 && s_.world.grid.DiscIsFree(creep.translation(), p_.robot_radius))
      truth_ = creep;
  } else {
    const SE2 next = truth_ * SE2(forward, 0.0, turn);
    if (forward > 0.0 && !s_.world.grid.DiscIsFree(next.translation(), p_.robot_radius)) {
      if (!StartStuck(StuckAt::kWall, p_.wall_wedge_probability)) {
        behaviour_ = Behaviour::kTurning;
        turn_remaining_ = (s_.Chance(0.5) ? 1.0 : -1.0) * s_.Uniform(0.6 * kPi, 1.1 * kPi);
        forward = 0.0;
        turn = 0.0;
      }
    } else {
      const Surface here = s_.world.SurfaceAt(truth_.translation());
      const Surface there = forward > 0.0 ? s_.world.SurfaceAt(next.translation()) : here;
      truth_ = next;
      if (there == Surface::kUnderFurniture && here != Surface::kUnderFurniture) {
        StartStuck(StuckAt::kFurniture, s_.world.FeatureAt(next.translation())->catch_probability);
      } else if (there == Surface::kRug && here == Surface::kFloor) {
        StartStuck(StuckAt::kRug, s_.world.FeatureAt(next.translation())->catch_probability);
      }
    }
  }
  // What the wheels report: the commanded motion (also while stuck), scaled by this robot's wheel error,
  // plus noise growing with distance and rotation.
  const double measured_forward =
      forward * s_.wheel_scale + s_.Gaussian(p_.odometry_noise_per_metre * std::sqrt(forward));
  const double heading_sigma = p_.odometry_heading_noise_per_metre * std::sqrt(forward) +
                               p_.odometry_heading_noise_per_radian * std::sqrt(std::abs(turn));
  const double measured_turn = turn + s_.Gaussian(heading_sigma);
  const SE2 step(measured_forward, 0.0, measured_turn);
  // Covariance of the accumulated increment (left perturbations): propagate and add this step's noise,
  // expressed at the new end of the increment.
  Matrix3 step_covariance = Matrix3::Zero();
  step_covariance(0, 0) = std::pow(p_.odometry_noise_per_metre, 2) * forward + 1e-8;
  step_covariance(1, 1) = std::pow(0.5 * p_.odometry_noise_per_metre, 2) * forward + 1e-8;
  step_covariance(2, 2) = heading_sigma * heading_sigma + 1e-8;
  const Matrix3 adjoint = measured_increment_.Adjoint();
  increment_covariance_ += adjoint * step_covariance * adjoint.transpose();
  measured_increment_ = measured_increment_ * step;
  measured_distance_ += std::abs(measured_forward);
  measured_rotation_ += std::abs(measured_turn);
  stuck_since_node_ = stuck_since_node_ || stuck_;
  time_ += dt;
}

slamcore::Status Run::MaybeKeyframe() {
  if (measured_distance_ < p_.keyframe_distance && measured_rotation_ < p_.keyframe_rotation) {
    return slamcore::Status::Ok();
  }
  return Keyframe();
}

slamcore::Status Run::Keyframe() {
  // A floor on the covariance: the first node of a run (and one after a kidnap) has no motion behind it.
  const Matrix3 covariance =
      0.5 * (increment_covariance_ + increment_covariance_.transpose()) + Matrix3::Identity() * 1e-8;
  RETURN_IF_ERROR(Emit(
      slamcore::OdometryEvent{.time = time_, .increment = measured_increment_, .covariance = covariance}));
  const bool slipped = stuck_since_node_;
  RETURN_IF_ERROR(
      Emit(slamcore::GroundTruthEvent{.time = time_, .world_T_robot = truth_},
           [slipped](fleet::v1::Event& event) { event.mutable_ground_truth()->set_slipping(slipped); }));
  measured_increment_ = SE2();
  increment_covariance_.setZero();
  measured_distance_ = measured_rotation_ = 0.0;
  stuck_since_node_ = false;
  if (slipped && mapper_->CurrentNode()) {
    stuck_nodes_.insert(*mapper_->CurrentNode());
    ++outcome_.stuck_nodes;
  }
  ++nodes_;
  RETURN_IF_ERROR(ObserveLandmarks());
  const int patch_every = s_.sensor.model == kLidarModel ? p_.lidar_patch_every_nodes : p_.patch_every_nodes;
  if (nodes_ % patch_every == 0) RETURN_IF_ERROR(EmitPatch());
  // The first merge into the parent map: look only at the decisions made since the last node.
  const std::vector<slamcore::Decision>& decisions = mapper_->decisions();
  for (; first_merge_time_ < 0.0 && decisions_seen_ < decisions.size(); ++decisions_seen_) {
    const slamcore::Decision& decision = decisions[decisions_seen_];
    if (decision.kind == slamcore::DecisionKind::kConditionallyAccepted ||
        (decision.kind == slamcore::DecisionKind::kAccepted &&
         decision.hypothesis_kind == slamcore::HypothesisKind::kMerge)) {
      first_merge_time_ = time_;
    }
  }
  return slamcore::Status::Ok();
}

double Run::ViewingDirection(const Landmark& landmark) const {
  const Vector2 to_landmark = landmark.pose.translation() - truth_.translation();
  return std::atan2(to_landmark.y(), to_landmark.x());
}

bool Run::Visible(const Landmark& landmark) const {
  const Vector2 to_landmark = landmark.pose.translation() - truth_.translation();
  const double distance = to_landmark.norm();
  if (distance > p_.view_range || distance < 0.2) return false;
  if (std::abs(AngleBetween(ViewingDirection(landmark), truth_.theta())) > 0.5 * p_.view_field_of_view)
    return false;
  // A textured face is seen from its front only; symmetric furniture from anywhere.
  if (!landmark.symmetric &&
      std::abs(AngleBetween(std::atan2(-to_landmark.y(), -to_landmark.x()), landmark.pose.theta())) > 1.4) {
    return false;
  }
  return s_.world.grid.LineOfSight(truth_.translation(), landmark.pose.translation());
}

slamcore::Status Run::ObserveLandmarks() {
  if (CameraBlind()) return slamcore::Status::Ok();  // no view is created or recognised
  int observations_here = 0;
  bool created_here = false;
  for (const Landmark& landmark : s_.world.landmarks) {
    if (!Visible(landmark)) continue;
    const auto known = s_.views_of_landmark.find(landmark.id);
    if (known == s_.views_of_landmark.end() || known->second.empty()) {
      if (created_here) continue;  // the front-end creates at most one view per frame
      const ViewRecord record{s_.next_view_id++, landmark.id, truth_};
      RETURN_IF_ERROR(Emit(slamcore::ViewCreatedEvent{.time = time_, .view = record.id}));
      s_.view_index.emplace(record.id, s_.views.size());
      s_.views_of_landmark[landmark.id].push_back(s_.views.size());
      s_.views.push_back(record);
      created_here = true;
      continue;
    }
    if (observations_here >= 2 || !s_.Chance(p_.recognition_probability)) continue;

    // Which view does the front-end match? Usually one of this landmark's own; sometimes a look-alike's,
    // drawn per recognition or, with SimParams::lookalike_pass_gap_seconds, per pass.
    const ViewRecord* matched = &s_.views[known->second.front()];
    SE2 world_T_matched_landmark = landmark.pose;  // what the front-end believes it is looking at
    bool wrong = false;
    const auto [pass, first_recognition] = lookalike_passes_.try_emplace(landmark.id);
    const bool new_pass = first_recognition || time_ - pass->second.last_time > p_.lookalike_pass_gap_seconds;
    if (new_pass) {
      pass->second.confused = s_.Chance(p_.lookalike_probability);
      pass->second.counted = false;
    }
    pass->second.last_time = time_;
    bool lookalike_candidate = false;
    for (const Landmark& other : s_.world.landmarks) {
      if (other.id == landmark.id || other.appearance != landmark.appearance) continue;
      const auto other_views = s_.views_of_landmark.find(other.id);
      if (other_views == s_.views_of_landmark.end() || other_views->second.empty()) continue;
      lookalike_candidate = true;
      if (pass->second.confused) {
        matched = &s_.views[other_views->second.front()];
        world_T_matched_landmark = other.pose;
        wrong = true;
      }
      break;
    }
    const bool lookalike = wrong;
    const Landmark& matched_landmark = s_.world.landmarks[static_cast<std::size_t>(matched->landmark)];
    // Relative pose the front-end computes: the robot relative to the matched view, through the object.
    SE2 world_T_view = landmark.pose * world_T_matched_landmark.inverse() * matched->world_T_view;
    // Seen from the side opposite to where the view was created: a non-symmetric face is not recognised;
    // a symmetric object matches with its frame turned by π (paper IV-A, the bed frame).
    const Vector2 creation_offset = matched_landmark.pose.translation() - matched->world_T_view.translation();
    const double creation_direction = std::atan2(creation_offset.y(), creation_offset.x());
    const double now_direction = ViewingDirection(landmark);
    if (std::abs(AngleBetween(now_direction, creation_direction)) > kPi / 2) {
      if (!landmark.symmetric) continue;
      const SE2 flip =
          SE2(landmark.pose.translation(), 0.0) * SE2(0.0, 0.0, kPi) * SE2(-landmark.pose.translation(), 0.0);
      world_T_view = flip * world_T_view;
      wrong = true;
    }
    SE2 z = truth_.inverse() * world_T_view;
    if (s_.Chance(p_.recognition_failure_probability)) {
      z = SE2(s_.Gaussian(0.5), s_.Gaussian(0.5), s_.Gaussian(0.6)) * z;
      wrong = true;
    }
    // Measurement noise, and the covariance the front-end reports for it.
    const Vector3 noise(s_.Gaussian(p_.observation_sigma_xy), s_.Gaussian(p_.observation_sigma_xy),
                        s_.Gaussian(p_.observation_sigma_theta));
    z = SE2::Exp(noise) * z;
    Matrix3 covariance = Matrix3::Zero();
    covariance.diagonal() << std::pow(p_.observation_sigma_xy, 2), std::pow(p_.observation_sigma_xy, 2),
        std::pow(p_.observation_sigma_theta, 2);
    RETURN_IF_ERROR(Emit(
        slamcore::ViewObservedEvent{
            .time = time_, .view = matched->id, .robot_T_view = z, .covariance = covariance},
        [wrong](fleet::v1::Event& event) { event.mutable_view_observed()->set_truth_wrong(wrong); }));
    ++observations_here;
    ++outcome_.observations;
    if (wrong) ++outcome_.wrong_observations;
    outcome_.lookalike_candidates += lookalike_candidate ? 1 : 0;
    if (lookalike) {
      ++outcome_.lookalike_observations;
      if (!pass->second.counted) ++outcome_.lookalike_passes;
      pass->second.counted = true;
    }
  }
  return slamcore::Status::Ok();
}

slamcore::Status Run::EmitPatch() {
  // What the sensor sees from the TRUE pose, in the node's frame: while stuck the node's estimated pose
  // marches on with the wheels, so these patches repeat the true surroundings at false places — the
  // erroneous protrusion of paper IV-C.
  return Emit(ScanAt(s_.world.grid, truth_, s_.sensor, p_.robot_radius, time_));
}

slamcore::Status Run::Kidnap(bool reboot) {
  if (!reboot) {
    // Carried to a free spot at least 3 m away, usually another room.
    const std::vector<Vector2> spots = s_.world.FreeSpots(p_.robot_radius + 0.05, 400, s_.random);
    for (const Vector2& spot : spots) {
      if ((spot - truth_.translation()).norm() < 3.0) continue;
      truth_ = SE2(spot, s_.Uniform(-kPi, kPi));
      break;
    }
  }
  measured_increment_ = SE2();
  increment_covariance_.setZero();
  measured_distance_ = measured_rotation_ = 0.0;
  ++(reboot ? outcome_.reboots : outcome_.kidnaps);
  return Emit(slamcore::KidnapEvent{
      .time = time_,
      .cause = reboot ? slamcore::KidnapEvent::Cause::kReboot : slamcore::KidnapEvent::Cause::kKidnap});
}

slamcore::Status Run::LabelRegions() {
  // The detector's regions between parent and child, labelled by the rule fleetd's reports use; the
  // per-cell truth marks a changed cell as protrusion when a stuck node's patch drew it only because the
  // node was not where its estimate says.
  if (parent_.local_maps.empty() || parent_.graph.num_nodes() == 0) return slamcore::Status::Ok();
  ASSIGN_OR_RETURN(const auto grids, analyzer::RenderComparedGrids(parent_, s_.map));
  ASSIGN_OR_RETURN(const auto regions, slamcore::ExtractRegions(grids.parent, grids.child));
  ASSIGN_OR_RETURN(
      const auto truth,
      analyzer::RegionsDrawnAway(s_.map, analyzer::WhereStuckNodesWere(s_.map, stuck_nodes_, s_.node_truth),
                                 grids, regions));
  // How the analysis would class them (the run's views, then the built-in model), against that truth.
  ASSIGN_OR_RETURN(const auto classifier, slamcore::DefaultProtrusionClassifier());
  ASSIGN_OR_RETURN(const auto classes,
                   analyzer::ClassifyRegions(parent_, s_.map, grids, regions, classifier.get()));
  // Whether a region is floor the home does not have (≥ half of its free cells farther than the map-health
  // margin from true floor): false space whatever drew it (a slip, drift, a wrong loop closure).
  ASSIGN_OR_RETURN(const auto false_floor, s_.meter.FalseFloor(s_.map, s_.node_truth, grids.child));
  for (std::size_t k = 0; k < regions.size(); ++k) {
    const bool protrusion = truth.region_is_covered[k];
    ++(protrusion ? outcome_.truth_protrusion_regions : outcome_.truth_new_space_regions);
    std::size_t free_cells = 0, false_cells = 0;
    for (const std::int32_t cell : regions[k].cells) {
      if (grids.child.cells[static_cast<std::size_t>(cell)] !=
          static_cast<std::int8_t>(slamcore::CellState::kFree))
        continue;
      ++free_cells;
      if (!false_floor.empty()) false_cells += false_floor[static_cast<std::size_t>(cell)];
    }
    const bool false_space = free_cells > 0 && 2 * false_cells >= free_cells;
    if (!protrusion && false_space) ++outcome_.false_floor_new_space_regions;
    outcome_.erroneous_confusion.Add(protrusion || false_space, classes[k].protrusion);
    outcome_.analysis_confusion.Add(protrusion, classes[k].protrusion);
    outcome_.classifier_confusion.Add(protrusion, classifier->IsProtrusion(classes[k].probability));
    outcome_.views_confusion.Add(protrusion,
                                 classes[k].decided_by == analyzer::RegionClass::DecidedBy::kViews);
  }
  if (!p_.keep_truth_pairs) return slamcore::Status::Ok();
  slamcore::GeneratedPair pair;
  pair.parent = grids.parent;
  pair.child = grids.child;
  pair.truth.assign(truth.covered.size(), static_cast<std::uint8_t>(slamcore::TruthLabel::kUnchanged));
  for (std::size_t k = 0; k < regions.size(); ++k) {
    for (const std::int32_t cell : (regions)[k].cells) {
      pair.truth[static_cast<std::size_t>(cell)] = static_cast<std::uint8_t>(
          truth.covered[static_cast<std::size_t>(cell)] ? slamcore::TruthLabel::kProtrusion
                                                        : slamcore::TruthLabel::kNewSpace);
    }
  }
  pair.protrusions = outcome_.truth_protrusion_regions;
  pair.new_spaces = outcome_.truth_new_space_regions;
  outcome_.truth_pair = std::move(pair);
  return slamcore::Status::Ok();
}

slamcore::Result<RunOutcome> Run::Simulate() {
  parent_ = s_.map;
  ASSIGN_OR_RETURN(auto mapper, slamcore::Mapper::Create(p_.mapper, s_.map));
  mapper_ = std::move(mapper);
  outcome_.had_parent = s_.map.graph.num_nodes() > 0;
  // A map taken from the service is named by the very bytes the service holds, so it knows the version.
  *outcome_.run.mutable_parent_snapshot() =
      s_.taken_map ? std::move(*s_.taken_map) : analyzer::ToProto(s_.map);
  s_.taken_map.reset();
  outcome_.map_version = s_.map_version;

  // Start on the dock, give or take a few centimetres, or where a person put the robot down.
  truth_ = s_.world.dock * SE2(s_.Gaussian(0.02), s_.Gaussian(0.02), s_.Gaussian(0.03));
  if (s_.Chance(p_.start_off_dock_probability)) {
    const std::vector<Vector2> spots = s_.world.FreeSpots(p_.robot_radius + 0.05, 1, s_.random);
    if (!spots.empty()) truth_ = SE2(spots.front(), s_.Uniform(-kPi, kPi));
  }
  const double duration = p_.run_minutes * 60.0;
  const double kidnap_at = s_.Chance(p_.kidnap_probability) ? s_.Uniform(0.2, 0.8) * duration : -1.0;
  const double reboot_at = s_.Chance(p_.reboot_probability) ? s_.Uniform(0.2, 0.8) * duration : -1.0;
  RETURN_IF_ERROR(Keyframe());  // the first node, at the dock
  bool kidnapped = false, rebooted = false;
  while (time_ < duration) {
    StepPhysics();
    if (!kidnapped && kidnap_at > 0 && time_ >= kidnap_at) {
      kidnapped = true;
      RETURN_IF_ERROR(Kidnap(false));
      RETURN_IF_ERROR(Keyframe());
      continue;
    }
    if (!rebooted && reboot_at > 0 && time_ >= reboot_at) {
      rebooted = true;
      RETURN_IF_ERROR(Kidnap(true));
      RETURN_IF_ERROR(Keyframe());
      continue;
    }
    RETURN_IF_ERROR(MaybeKeyframe());
  }

  outcome_.statistics = mapper_->Statistics();
  outcome_.started_localized = outcome_.had_parent && first_merge_time_ >= 0.0 &&
                               first_merge_time_ <= analyzer::kStartedLocalizedSeconds;
  outcome_.simulated_seconds = time_;
  for (const auto& [node, pose] : mapper_->ground_truth()) s_.node_truth[node] = pose;
  s_.map = mapper_->Finish();
  for (const slamcore::View& view : s_.map.graph.views()) {
    ++outcome_.views_total;
    if (view.ambiguous) ++outcome_.views_ambiguous;
  }
  *outcome_.run.mutable_child_snapshot() = analyzer::ToProto(s_.map);
  if (p_.label_regions) RETURN_IF_ERROR(LabelRegions());

  fleet::v1::RunHeader& header = *outcome_.run.mutable_header();
  header.set_format_version(analyzer::kTelemetryFormatVersion);
  header.set_robot_id(s_.robot_id);
  header.set_run_id(run_id_);
  header.set_firmware(s_.firmware);
  header.set_robot_model(s_.sensor.model);
  header.set_home_id(s_.world.name);
  header.set_started_at(started_at_);
  header.set_ended_at(started_at_ + time_);
  header.set_event_count(static_cast<std::uint64_t>(outcome_.run.events_size()));
  header.set_map_version(s_.map_version);
  return std::move(outcome_);
}

}  // namespace

slamcore::Result<RunOutcome> RobotSimulator::SimulateRun(const std::string& run_id, double started_at) {
  ++state_->run_count;
  Run run(*state_, run_id, started_at);
  return run.Simulate();
}

RegionConfusion& RegionConfusion::operator+=(const RegionConfusion& other) {
  true_protrusion += other.true_protrusion;
  missed_protrusion += other.missed_protrusion;
  false_protrusion += other.false_protrusion;
  true_new_space += other.true_new_space;
  return *this;
}

std::string RegionConfusion::ToText() const {
  auto percent = [](long part, long whole) { return whole > 0 ? 100.0 * part / whole : 0.0; };
  char text[160];
  std::snprintf(text, sizeof text, "TP %ld, FN %ld, FP %ld, TN %ld (precision %.1f %%, recall %.1f %%)",
                true_protrusion, missed_protrusion, false_protrusion, true_new_space,
                percent(true_protrusion, true_protrusion + false_protrusion),
                percent(true_protrusion, true_protrusion + missed_protrusion));
  return text;
}

}  // namespace sim
