#include "sim/service_client.h"

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <thread>

#include "fleet/status_codes.h"
#include "fleet/v1/service.grpc.pb.h"
#include "fleet_client/channel.h"
#include "fleet_client/map_stream.h"

namespace sim {
namespace {

std::unique_ptr<grpc::ClientContext> Context(const std::string& token, int seconds = 60) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->AddMetadata("authorization", "Bearer " + token);
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return context;
}

// The project's code of gRPC's (the one table, fleet/status_codes.h); the message names the call and gRPC's code.
slamcore::Status Failed(const char* call, const grpc::Status& status) {
  return slamcore::Status(
      fleet::FromGrpcCode(status.error_code()),
      std::string(call) + ": " + fleet::GrpcCodeName(status.error_code()) + ": " + status.error_message());
}

}  // namespace

class ServiceClient::Impl {
 public:
  Impl(const std::string& server, const std::string& tls_ca) {
    auto channel = fleet_client::CreateFleetChannel(server, tls_ca, 64 << 20);
    maps = fleet::v1::Maps::NewStub(channel);
    jobs = fleet::v1::Reprocessing::NewStub(channel);
    admin = fleet::v1::Admin::NewStub(channel);
  }
  std::unique_ptr<fleet::v1::Maps::Stub> maps;
  std::unique_ptr<fleet::v1::Reprocessing::Stub> jobs;
  std::unique_ptr<fleet::v1::Admin::Stub> admin;
};

ServiceClient::ServiceClient(const std::string& server, const std::string& tls_ca)
    : impl_(std::make_unique<Impl>(server, tls_ca)) {}
ServiceClient::~ServiceClient() = default;

slamcore::Result<FetchedMap> ServiceClient::FetchMap(const std::string& token, const std::string& robot_id,
                                                     std::int64_t held_version) {
  fleet::v1::GetMapRequest request;
  request.set_robot_id(robot_id);
  request.set_held_version(held_version);
  fleet::v1::GetMapResponse response;
  auto context = Context(token);
  const grpc::Status status =
      fleet_client::ReceiveMap(*impl_->maps, *context, request, fleet_client::kDefaultMaxMapBytes, &response);
  FetchedMap fetched;
  if (status.error_code() == grpc::StatusCode::NOT_FOUND) return fetched;  // no approved map yet
  if (!status.ok()) return Failed("Maps.StreamMap", status);
  fetched.up_to_date = response.up_to_date();
  fetched.version = response.version();
  if (!fetched.up_to_date) fetched.snapshot = std::move(*response.mutable_snapshot());
  return fetched;
}

slamcore::Status ServiceClient::WaitForJob(const std::string& token, std::int64_t job_id,
                                           double timeout_seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_seconds);
  auto pause = std::chrono::milliseconds(5);
  while (true) {
    fleet::v1::GetJobRequest request;
    request.set_job_id(job_id);
    fleet::v1::Job job;
    auto context = Context(token);
    const grpc::Status status = impl_->jobs->GetJob(context.get(), request, &job);
    if (!status.ok()) return Failed("Reprocessing.GetJob", status);
    if (job.state() == "done") return slamcore::Status::Ok();
    if (job.state() == "failed" || job.state() == "cancelled") {
      return slamcore::FailedPrecondition("job " + std::to_string(job_id) + " " + job.state() + ": " +
                                          job.last_error());
    }
    if (std::chrono::steady_clock::now() > deadline) {
      return slamcore::Internal("job " + std::to_string(job_id) + " still " + job.state() + " after " +
                                std::to_string(timeout_seconds) + " s");
    }
    std::this_thread::sleep_for(pause);
    pause = std::min(pause * 2, std::chrono::milliseconds(200));
  }
}

slamcore::Result<std::int64_t> ServiceClient::ApprovePending(const std::string& token,
                                                             const std::string& robot_id) {
  fleet::v1::ListMapVersionsRequest list;
  list.set_robot_id(robot_id);
  fleet::v1::ListMapVersionsResponse versions;
  auto context = Context(token);
  grpc::Status status = impl_->maps->ListMapVersions(context.get(), list, &versions);
  if (!status.ok()) return Failed("Maps.ListMapVersions", status);
  std::int64_t approved = 0;
  for (const fleet::v1::MapVersion& version : versions.versions()) {  // oldest first
    if (version.approval_state() != fleet::v1::MAP_APPROVAL_PENDING) continue;
    fleet::v1::ReviewMapVersionRequest review;
    review.set_robot_id(robot_id);
    review.set_version(version.version());
    review.set_approve(true);
    fleet::v1::MapVersion reviewed;
    context = Context(token);
    status = impl_->maps->ReviewMapVersion(context.get(), review, &reviewed);
    if (status.error_code() ==
        grpc::StatusCode::FAILED_PRECONDITION) {  // cannot be carried onto the current map
      review.set_approve(false);
      context = Context(token);
      status = impl_->maps->ReviewMapVersion(context.get(), review, &reviewed);
      if (!status.ok()) return Failed("Maps.ReviewMapVersion (reject)", status);
      continue;
    }
    if (!status.ok()) return Failed("Maps.ReviewMapVersion", status);
    approved = reviewed.version();
  }
  return approved;
}

slamcore::Result<std::string> ServiceClient::MintToken(const std::string& admin_token,
                                                       const std::string& principal) {
  fleet::v1::SetCredentialRequest request;
  request.set_principal(principal);
  fleet::v1::SetCredentialResponse response;
  auto context = Context(admin_token);
  const grpc::Status status = impl_->admin->SetCredential(context.get(), request, &response);
  if (!status.ok()) return Failed("Admin.SetCredential", status);
  return response.token();
}

}  // namespace sim
