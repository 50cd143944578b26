#include "sim/follow_service.h"

#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include "fleet/status_codes.h"
#include "sim/service_client.h"

namespace sim {
namespace {

using fleet_client::Uploader;
using fleet_client::UploaderOptions;
using fleet_client::UploadOutcome;

struct Follower {
  FollowServiceOptions options;
  ServiceClient client;
  std::mutex mutex;  // guards uploaders and repairs_taken
  std::map<std::string, std::unique_ptr<Uploader>> uploaders;
  std::map<std::string, int> repairs_taken;  // repaired versions taken since the robot's last run ended

  explicit Follower(const FollowServiceOptions& o)
      : options(o), client(o.uploader.server, o.uploader.tls_ca) {}

  std::string TokenOf(const std::string& robot) {
    return options.robot_token ? options.robot_token(robot) : options.uploader.token;
  }

  Uploader& UploaderOf(const std::string& robot) {
    std::lock_guard lock(mutex);
    auto& uploader = uploaders[robot];
    if (!uploader) {
      UploaderOptions own = options.uploader;
      own.token = TokenOf(robot);
      uploader = std::make_unique<Uploader>(own);
    }
    return *uploader;
  }

  /// Takes the newest approved version when the robot holds an older one.
  slamcore::Status TakeNewestMap(RobotSimulator& robot, const std::string& robot_id) {
    auto fetched = client.FetchMap(TokenOf(robot_id), robot_id, robot.map_version());
    RETURN_IF_ERROR(fetched.status());
    if (fetched->up_to_date || fetched->version.version() <= 0) return slamcore::Status::Ok();
    if (const slamcore::Status taken = robot.TakeMap(fetched->snapshot, fetched->version.version());
        !taken.ok()) {
      return slamcore::InvalidArgument("robot " + robot_id + ": version " +
                                       std::to_string(fetched->version.version()) +
                                       " from Maps.GetMap: " + taken.message());
    }
    if (fetched->version.version_origin() != fleet::v1::MAP_ORIGIN_UPLOAD) {
      std::lock_guard lock(mutex);
      ++repairs_taken[robot_id];
    }
    return slamcore::Status::Ok();
  }
};

}  // namespace

void FollowService(const FollowServiceOptions& options, FleetOptions& fleet) {
  auto follower = std::make_shared<Follower>(options);
  fleet.before_run = [follower](RobotSimulator& robot, int run) -> slamcore::Status {
    const std::string& robot_id = robot.robot_id();
    const FollowServiceOptions& o = follower->options;
    if (o.review_every_runs > 0 && run > 0 && run % o.review_every_runs == 0) {
      RETURN_IF_ERROR(follower->client.ApprovePending(o.engineer_token, robot_id).status());
    }
    return follower->TakeNewestMap(robot, robot_id);
  };
  fleet.after_run = [follower](RobotSimulator& robot, RunOutcome& outcome) -> slamcore::Status {
    const std::string& robot_id = robot.robot_id();
    const UploadOutcome uploaded = follower->UploaderOf(robot_id).Upload(outcome.run);
    if (!uploaded.ok) {
      return slamcore::Status(fleet::FromGrpcCode(static_cast<grpc::StatusCode>(uploaded.code)),
                              "robot " + robot_id + " run " + outcome.run.header().run_id() +
                                  ": upload failed: " + uploaded.message);
    }
    robot.SetMapVersion(uploaded.map_version);  // the robot's map is now this version of its history
    if (!follower->options.engineer_token.empty() && uploaded.analysis_job_id > 0) {
      RETURN_IF_ERROR(follower->client.WaitForJob(follower->options.engineer_token, uploaded.analysis_job_id,
                                                  follower->options.analysis_timeout_seconds));
      RETURN_IF_ERROR(follower->TakeNewestMap(robot, robot_id));
    }
    std::lock_guard lock(follower->mutex);
    outcome.repairs_taken = std::exchange(follower->repairs_taken[robot_id], 0);
    return slamcore::Status::Ok();
  };
}

}  // namespace sim
