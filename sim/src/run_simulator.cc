#include "sim/run_simulator.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analyzer/run_analysis.h"
#include "analyzer/telemetry_codec.h"

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
  slamcore::Map map;         // the robot's map, carried from run to run
  std::vector<ViewRecord> views;
  std::unordered_map<int, std::vector<std::size_t>> views_of_landmark;
  std::unordered_map<slamcore::ViewId, std::size_t> view_index;
  slamcore::ViewId next_view_id = 1;
  int run_count = 0;

  State(const World& w, const SimParams& p, std::string id, std::string fw, std::uint64_t seed)
      : world(w), params(p), robot_id(std::move(id)), firmware(std::move(fw)), random(seed) {
    std::normal_distribution<double> scale(1.0, params.odometry_scale_error);
    wheel_scale = scale(random);
  }

  double Uniform(double low, double high) { return std::uniform_real_distribution<double>(low, high)(random); }
  double Gaussian(double sigma) { return sigma > 0 ? std::normal_distribution<double>(0.0, sigma)(random) : 0.0; }
  bool Chance(double probability) { return Uniform(0.0, 1.0) < probability; }
};

RobotSimulator::RobotSimulator(const World& world, const SimParams& params, std::string robot_id,
                               std::string firmware, std::uint64_t seed)
    : state_(std::make_unique<State>(world, params, std::move(robot_id), std::move(firmware), seed)) {}

RobotSimulator::~RobotSimulator() = default;

namespace {

/// Everything that happens inside one run.
class Run {
 public:
  Run(RobotSimulator::State& state, const std::string& run_id, double started_at)
      : s_(state), p_(state.params), run_id_(run_id), started_at_(started_at) {}

  slamcore::Result<RunOutcome> Simulate();

 private:
  slamcore::Status Emit(const slamcore::Event& event, const std::function<void(fleet::v1::Event&)>& annotate = {});
  void StepPhysics();
  slamcore::Status MaybeKeyframe();
  slamcore::Status Keyframe();
  slamcore::Status ObserveLandmarks();
  slamcore::Status EmitPatch();
  slamcore::Status Kidnap(bool reboot);
  bool Visible(const Landmark& landmark) const;
  double ViewingDirection(const Landmark& landmark) const;

  RobotSimulator::State& s_;
  const SimParams& p_;
  std::string run_id_;
  double started_at_;
  std::unique_ptr<slamcore::Mapper> mapper_;
  RunOutcome outcome_;

  double time_ = 0.0;
  SE2 truth_;                // world_T_robot
  SE2 measured_increment_;   // odometry accumulated since the last node
  double measured_distance_ = 0.0, measured_rotation_ = 0.0;
  Matrix3 increment_covariance_ = Matrix3::Zero();
  bool slipping_ = false, slipped_since_node_ = false;
  double slip_until_ = 0.0;
  Behaviour behaviour_ = Behaviour::kStraight;
  double turn_remaining_ = 0.0;
  double behaviour_until_ = 0.0;
  int nodes_ = 0;
  double first_merge_time_ = -1.0;
  std::size_t decisions_seen_ = 0;
};

slamcore::Status Run::Emit(const slamcore::Event& event, const std::function<void(fleet::v1::Event&)>& annotate) {
  if (const slamcore::Status status = mapper_->Process(event); !status.ok()) {
    return slamcore::Internal("robot " + s_.robot_id + " run " + run_id_ + ": " + status.message());
  }
  fleet::v1::Event proto = analyzer::ToProto(event);
  if (annotate) annotate(proto);
  *outcome_.run.add_events() = std::move(proto);
  return slamcore::Status::Ok();
}

void Run::StepPhysics() {
  const double dt = p_.step_seconds;
  // Slip episodes start at random (Poisson) and last a while: the wheels keep turning, the robot stays.
  if (!slipping_ && s_.Chance(p_.slip_episodes_per_hour * dt / 3600.0)) {
    slipping_ = true;
    slip_until_ = time_ + s_.Uniform(p_.slip_min_seconds, p_.slip_max_seconds);
    ++outcome_.slip_episodes;
  }
  if (slipping_ && time_ >= slip_until_) slipping_ = false;

  // Commanded motion from the behaviour.
  double forward = 0.0, turn = 0.0;
  if (time_ >= behaviour_until_ && behaviour_ != Behaviour::kTurning) {
    behaviour_ = s_.Chance(p_.wall_follow_share) ? Behaviour::kWallFollow : Behaviour::kStraight;
    behaviour_until_ = time_ + s_.Uniform(10.0, 40.0);
  }
  if (behaviour_ == Behaviour::kTurning) {
    const double step = std::copysign(std::min(std::abs(turn_remaining_), p_.turn_rate * dt), turn_remaining_);
    turn = step;
    turn_remaining_ -= step;
    if (std::abs(turn_remaining_) < 1e-9) behaviour_ = Behaviour::kStraight;
  } else {
    forward = p_.speed * dt;
    if (behaviour_ == Behaviour::kWallFollow) {
      // Keep a wall about 0.1 m off the right side.
      const double right = s_.world.grid.CastRay(truth_.translation(), truth_.theta() - kPi / 2, 1.0) - p_.robot_radius;
      turn = std::clamp(0.8 * (right - 0.1), -0.6, 0.6) * -dt * 2.0;
    }
  }

  // The robot's true motion: blocked by obstacles, and nothing at all while slipping.
  if (!slipping_) {
    const SE2 next = truth_ * SE2(forward, 0.0, turn);
    if (forward > 0.0 && !s_.world.grid.DiscIsFree(next.translation(), p_.robot_radius)) {
      behaviour_ = Behaviour::kTurning;
      turn_remaining_ = (s_.Chance(0.5) ? 1.0 : -1.0) * s_.Uniform(0.6 * kPi, 1.1 * kPi);
      forward = 0.0;
      turn = 0.0;
    } else {
      truth_ = next;
    }
  }
  // What the wheels report: the commanded motion (also while stuck), scaled by this robot's wheel error,
  // plus noise growing with distance and rotation.
  const double measured_forward = forward * s_.wheel_scale + s_.Gaussian(p_.odometry_noise_per_metre * std::sqrt(forward));
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
  slipped_since_node_ = slipped_since_node_ || slipping_;
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
  SLAMCORE_RETURN_IF_ERROR(Emit(slamcore::OdometryEvent{.time = time_, .increment = measured_increment_,
                                                        .covariance = covariance}));
  const bool slipped = slipped_since_node_;
  SLAMCORE_RETURN_IF_ERROR(Emit(slamcore::GroundTruthEvent{.time = time_, .world_T_robot = truth_},
                                [slipped](fleet::v1::Event& event) { event.mutable_ground_truth()->set_slipping(slipped); }));
  measured_increment_ = SE2();
  increment_covariance_.setZero();
  measured_distance_ = measured_rotation_ = 0.0;
  slipped_since_node_ = false;
  ++nodes_;
  SLAMCORE_RETURN_IF_ERROR(ObserveLandmarks());
  if (nodes_ % p_.patch_every_nodes == 0) SLAMCORE_RETURN_IF_ERROR(EmitPatch());
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
  if (std::abs(AngleBetween(ViewingDirection(landmark), truth_.theta())) > 0.5 * p_.view_field_of_view) return false;
  // A textured face is seen from its front only; symmetric furniture from anywhere.
  if (!landmark.symmetric &&
      std::abs(AngleBetween(std::atan2(-to_landmark.y(), -to_landmark.x()), landmark.pose.theta())) > 1.4) {
    return false;
  }
  return s_.world.grid.LineOfSight(truth_.translation(), landmark.pose.translation());
}

slamcore::Status Run::ObserveLandmarks() {
  int observations_here = 0;
  bool created_here = false;
  for (const Landmark& landmark : s_.world.landmarks) {
    if (!Visible(landmark)) continue;
    const auto known = s_.views_of_landmark.find(landmark.id);
    if (known == s_.views_of_landmark.end() || known->second.empty()) {
      if (created_here) continue;  // the front-end creates at most one view per frame
      const ViewRecord record{s_.next_view_id++, landmark.id, truth_};
      SLAMCORE_RETURN_IF_ERROR(Emit(slamcore::ViewCreatedEvent{.time = time_, .view = record.id}));
      s_.view_index.emplace(record.id, s_.views.size());
      s_.views_of_landmark[landmark.id].push_back(s_.views.size());
      s_.views.push_back(record);
      created_here = true;
      continue;
    }
    if (observations_here >= 2 || !s_.Chance(p_.recognition_probability)) continue;

    // Which view does the front-end match? Usually one of this landmark's own; sometimes a look-alike's.
    const ViewRecord* matched = &s_.views[known->second.front()];
    SE2 world_T_matched_landmark = landmark.pose;  // what the front-end believes it is looking at
    bool wrong = false;
    if (s_.Chance(p_.lookalike_probability)) {
      for (const Landmark& other : s_.world.landmarks) {
        if (other.id == landmark.id || other.appearance != landmark.appearance) continue;
        const auto other_views = s_.views_of_landmark.find(other.id);
        if (other_views == s_.views_of_landmark.end() || other_views->second.empty()) continue;
        matched = &s_.views[other_views->second.front()];
        world_T_matched_landmark = other.pose;
        wrong = true;
        break;
      }
    }
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
      const SE2 flip = SE2(landmark.pose.translation(), 0.0) * SE2(0.0, 0.0, kPi) *
                       SE2(-landmark.pose.translation(), 0.0);
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
    SLAMCORE_RETURN_IF_ERROR(Emit(
        slamcore::ViewObservedEvent{.time = time_, .view = matched->id, .robot_T_view = z, .covariance = covariance},
        [wrong](fleet::v1::Event& event) { event.mutable_view_observed()->set_truth_wrong(wrong); }));
    ++observations_here;
    ++outcome_.observations;
    if (wrong) ++outcome_.wrong_observations;
  }
  return slamcore::Status::Ok();
}

slamcore::Status Run::EmitPatch() {
  // A short-range ranging sensor: rays over 360° from the TRUE pose, drawn into a patch in the node's
  // frame, plus the robot's footprint as free. While slipping the sensor keeps seeing the same place, but
  // the node's estimated pose moves on with the wheels: rendered at the estimated poses, these patches
  // paint free space where the robot never was — the erroneous protrusion of paper IV-C.
  const double resolution = 0.05;
  const int size = static_cast<int>(std::ceil(2.0 * p_.patch_range / resolution));
  slamcore::LocalMapEvent patch;
  patch.time = time_;
  patch.resolution = resolution;
  patch.width = size;
  patch.height = size;
  patch.node_T_origin = SE2(-p_.patch_range, -p_.patch_range, 0.0);
  patch.cells.assign(static_cast<std::size_t>(size) * size, -1);
  auto mark = [&](const Vector2& in_node, std::int8_t value) {
    const int col = static_cast<int>(std::floor((in_node.x() + p_.patch_range) / resolution));
    const int row = static_cast<int>(std::floor((in_node.y() + p_.patch_range) / resolution));
    if (col < 0 || row < 0 || col >= size || row >= size) return;
    std::int8_t& cell = patch.cells[static_cast<std::size_t>(row) * size + col];
    if (cell != 100) cell = value;
  };
  constexpr int kRays = 72;
  for (int k = 0; k < kRays; ++k) {
    const double angle = 2 * kPi * k / kRays;
    const double range = s_.world.grid.CastRay(truth_.translation(), truth_.theta() + angle, p_.patch_range);
    const Vector2 direction(std::cos(angle), std::sin(angle));
    for (double d = 0.0; d < range; d += 0.5 * resolution) mark(d * direction, 0);
    if (range < p_.patch_range) mark((range + 0.5 * resolution) * direction, 100);
  }
  for (double dx = -p_.robot_radius; dx <= p_.robot_radius; dx += resolution) {
    for (double dy = -p_.robot_radius; dy <= p_.robot_radius; dy += resolution) {
      if (std::hypot(dx, dy) <= p_.robot_radius) mark(Vector2(dx, dy), 0);
    }
  }
  return Emit(patch);
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
  return Emit(slamcore::KidnapEvent{.time = time_, .cause = reboot ? slamcore::KidnapEvent::Cause::kReboot
                                                                 : slamcore::KidnapEvent::Cause::kKidnap});
}

slamcore::Result<RunOutcome> Run::Simulate() {
  auto mapper = slamcore::Mapper::Create(p_.mapper, s_.map);
  if (!mapper.ok()) return mapper.status();
  mapper_ = std::move(mapper).value();
  outcome_.had_parent = s_.map.graph.num_nodes() > 0;
  *outcome_.run.mutable_parent_snapshot() = analyzer::ToProto(s_.map);

  // Start on the dock, give or take a few centimetres, or where a person put the robot down.
  truth_ = s_.world.dock * SE2(s_.Gaussian(0.02), s_.Gaussian(0.02), s_.Gaussian(0.03));
  if (s_.Chance(p_.start_off_dock_probability)) {
    const std::vector<Vector2> spots = s_.world.FreeSpots(p_.robot_radius + 0.05, 1, s_.random);
    if (!spots.empty()) truth_ = SE2(spots.front(), s_.Uniform(-kPi, kPi));
  }
  const double duration = p_.run_minutes * 60.0;
  const double kidnap_at = s_.Chance(p_.kidnap_probability) ? s_.Uniform(0.2, 0.8) * duration : -1.0;
  const double reboot_at = s_.Chance(p_.reboot_probability) ? s_.Uniform(0.2, 0.8) * duration : -1.0;
  SLAMCORE_RETURN_IF_ERROR(Keyframe());  // the first node, at the dock
  bool kidnapped = false, rebooted = false;
  while (time_ < duration) {
    StepPhysics();
    if (!kidnapped && kidnap_at > 0 && time_ >= kidnap_at) {
      kidnapped = true;
      SLAMCORE_RETURN_IF_ERROR(Kidnap(false));
      SLAMCORE_RETURN_IF_ERROR(Keyframe());
      continue;
    }
    if (!rebooted && reboot_at > 0 && time_ >= reboot_at) {
      rebooted = true;
      SLAMCORE_RETURN_IF_ERROR(Kidnap(true));
      SLAMCORE_RETURN_IF_ERROR(Keyframe());
      continue;
    }
    SLAMCORE_RETURN_IF_ERROR(MaybeKeyframe());
  }

  outcome_.statistics = mapper_->Statistics();
  outcome_.started_localized =
      outcome_.had_parent && first_merge_time_ >= 0.0 && first_merge_time_ <= analyzer::kStartedLocalizedSeconds;
  outcome_.simulated_seconds = time_;
  s_.map = mapper_->Finish();
  for (const slamcore::View& view : s_.map.graph.views()) {
    ++outcome_.views_total;
    if (view.ambiguous) ++outcome_.views_ambiguous;
  }
  *outcome_.run.mutable_child_snapshot() = analyzer::ToProto(s_.map);

  fleet::v1::RunHeader& header = *outcome_.run.mutable_header();
  header.set_format_version(analyzer::kTelemetryFormatVersion);
  header.set_robot_id(s_.robot_id);
  header.set_run_id(run_id_);
  header.set_firmware(s_.firmware);
  header.set_robot_model("fleetsim-vac1");
  header.set_home_id(s_.world.name);
  header.set_started_at(started_at_);
  header.set_ended_at(started_at_ + time_);
  header.set_event_count(static_cast<std::uint64_t>(outcome_.run.events_size()));
  return std::move(outcome_);
}

}  // namespace

slamcore::Result<RunOutcome> RobotSimulator::SimulateRun(const std::string& run_id, double started_at) {
  ++state_->run_count;
  Run run(*state_, run_id, started_at);
  return run.Simulate();
}

}  // namespace sim
