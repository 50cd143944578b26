// Validation of every event before the Mapper changes anything (mapper.h's error contract).
#include <cmath>
#include <sstream>

#include "mapper_impl.h"

namespace slamcore {
namespace {

std::string Prefix(const char* name, double time) {
  std::ostringstream prefix;
  prefix << name << " at t=" << time << ": ";
  return prefix.str();
}

bool IsFinite(const SE2& pose) { return pose.vector().allFinite(); }

Status CheckCovariance(const std::string& prefix, const Matrix3& covariance) {
  if (const Status status = CheckPositiveDefinite(covariance, "covariance"); !status.ok()) {
    return InvalidArgument(prefix + status.message());
  }
  // The information used for edges is the inverse; it must pass the graph's own check too.
  const Matrix3 information = covariance.inverse();
  if (const Status status =
          CheckPositiveDefinite(0.5 * (information + information.transpose()), "information");
      !status.ok()) {
    return InvalidArgument(prefix + status.message() + " (covariance is too badly conditioned)");
  }
  return Status::Ok();
}

}  // namespace

Status Mapper::Impl::CheckTime(const char* name, double time) const {
  if (!std::isfinite(time)) return InvalidArgument(Prefix(name, time) + "time is not finite");
  if (time < time_) {
    std::ostringstream message;
    message << Prefix(name, time) << "time goes backwards (the previous event was at t=" << time_ << ")";
    return FailedPrecondition(message.str());
  }
  return Status::Ok();
}

Status Mapper::Impl::CheckHasNode(const char* name, double time) const {
  if (!current_node_) {
    return FailedPrecondition(Prefix(name, time) + "no node yet (the first OdometryEvent creates it)");
  }
  if (start_new_component_) {
    return FailedPrecondition(Prefix(name, time) +
                              "no node since the KidnapEvent (the next OdometryEvent creates it)");
  }
  return Status::Ok();
}

Status Mapper::Impl::Validate(const OdometryEvent& event) const {
  constexpr const char* kName = "OdometryEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  const std::string prefix = Prefix(kName, event.time);
  if (!IsFinite(event.increment)) return InvalidArgument(prefix + "increment has a NaN or infinite entry");
  RETURN_IF_ERROR(CheckCovariance(prefix, event.covariance));
  if (current_node_ && !start_new_component_) {
    const SE2 pose = map_.graph.node(*current_node_).pose * event.increment;
    if (!IsFinite(pose) || !std::isfinite(odometer_ + event.increment.translation().norm())) {
      return InvalidArgument(prefix + "the composed pose is not finite");
    }
  }
  return Status::Ok();
}

Status Mapper::Impl::Validate(const ViewCreatedEvent& event) const {
  constexpr const char* kName = "ViewCreatedEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  RETURN_IF_ERROR(CheckHasNode(kName, event.time));
  if (map_.graph.HasView(event.view)) {
    return InvalidArgument(Prefix(kName, event.time) + "view " + std::to_string(event.view) +
                           " already exists");
  }
  return Status::Ok();
}

Status Mapper::Impl::Validate(const ViewObservedEvent& event) const {
  constexpr const char* kName = "ViewObservedEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  RETURN_IF_ERROR(CheckHasNode(kName, event.time));
  const std::string prefix = Prefix(kName, event.time);
  if (!map_.graph.HasView(event.view)) {
    return NotFound(prefix + "view " + std::to_string(event.view) + " does not exist");
  }
  if (!IsFinite(event.robot_T_view))
    return InvalidArgument(prefix + "robot_T_view has a NaN or infinite entry");
  return CheckCovariance(prefix, event.covariance);
}

Status Mapper::Impl::Validate(const LocalMapEvent& event) const {
  constexpr const char* kName = "LocalMapEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  RETURN_IF_ERROR(CheckHasNode(kName, event.time));
  const std::string prefix = Prefix(kName, event.time);
  if (!std::isfinite(event.resolution) || event.resolution <= 0.0) {
    return InvalidArgument(prefix + "resolution must be positive and finite");
  }
  if (event.width <= 0 || event.height <= 0)
    return InvalidArgument(prefix + "width and height must be positive");
  const auto expected = static_cast<std::size_t>(event.width) * static_cast<std::size_t>(event.height);
  if (event.cells.size() != expected) {
    return InvalidArgument(prefix + "has " + std::to_string(event.cells.size()) +
                           " cells, width × height = " + std::to_string(expected));
  }
  if (!IsFinite(event.node_T_origin))
    return InvalidArgument(prefix + "node_T_origin has a NaN or infinite entry");
  for (std::size_t i = 0; i < event.cells.size(); ++i) {
    if (event.cells[i] < -1 || event.cells[i] > 100) {
      return InvalidArgument(prefix + "cell " + std::to_string(i) + " is " + std::to_string(event.cells[i]) +
                             ", not -1 (unknown) or 0..100");
    }
  }
  return Status::Ok();
}

Status Mapper::Impl::Validate(const KidnapEvent& event) const {
  constexpr const char* kName = "KidnapEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  if (event.cause != KidnapEvent::Cause::kKidnap && event.cause != KidnapEvent::Cause::kReboot) {
    return InvalidArgument(Prefix(kName, event.time) + "unknown cause " +
                           std::to_string(static_cast<int>(event.cause)));
  }
  return Status::Ok();
}

Status Mapper::Impl::Validate(const GroundTruthEvent& event) const {
  constexpr const char* kName = "GroundTruthEvent";
  RETURN_IF_ERROR(CheckTime(kName, event.time));
  if (!IsFinite(event.world_T_robot)) {
    return InvalidArgument(Prefix(kName, event.time) + "world_T_robot has a NaN or infinite entry");
  }
  return Status::Ok();
}

}  // namespace slamcore
