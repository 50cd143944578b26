// ServiceClient against a fake fleetd in this process that answers every call with a chosen gRPC status: a
// failed call is the project's status of that code (the one table, fleet/status_codes.h), its message naming
// the call and gRPC's code.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <memory>
#include <string>

#include "fleet/status_codes.h"
#include "fleet/v1/service.grpc.pb.h"
#include "sim/service_client.h"
#include "status_matchers.h"

namespace sim {
namespace {

using slamcore::StatusCode;

class RefusingMaps final : public fleet::v1::Maps::Service {
 public:
  std::atomic<int> code{grpc::StatusCode::UNAVAILABLE};
  grpc::Status StreamMap(grpc::ServerContext*, const fleet::v1::GetMapRequest*,
                         grpc::ServerWriter<fleet::v1::GetMapResponse>*) override {
    return {static_cast<grpc::StatusCode>(code.load()), "told to refuse"};
  }
  grpc::Status ListMapVersions(grpc::ServerContext*, const fleet::v1::ListMapVersionsRequest*,
                               fleet::v1::ListMapVersionsResponse*) override {
    return {static_cast<grpc::StatusCode>(code.load()), "told to refuse"};
  }
};

class RefusingAdmin final : public fleet::v1::Admin::Service {
 public:
  grpc::Status SetCredential(grpc::ServerContext*, const fleet::v1::SetCredentialRequest*,
                             fleet::v1::SetCredentialResponse*) override {
    return {grpc::StatusCode::PERMISSION_DENIED, "needs the admin role"};
  }
};

class RefusingReprocessing final : public fleet::v1::Reprocessing::Service {
 public:
  grpc::Status GetJob(grpc::ServerContext*, const fleet::v1::GetJobRequest*, fleet::v1::Job*) override {
    return {grpc::StatusCode::NOT_FOUND, "no job 7"};
  }
};

class ServiceClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&maps_);
    builder.RegisterService(&admin_);
    builder.RegisterService(&jobs_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    address_ = "127.0.0.1:" + std::to_string(port);
  }
  void TearDown() override { server_->Shutdown(); }

  RefusingMaps maps_;
  RefusingAdmin admin_;
  RefusingReprocessing jobs_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

TEST_F(ServiceClientTest, EachGrpcCodeIsTheProjectCodeOfTheOneTable) {
  ServiceClient client(address_);
  for (int code = 1; code <= 16; ++code) {
    if (code == grpc::StatusCode::NOT_FOUND) continue;  // "no approved map yet": up to date
    maps_.code = code;
    const auto fetched = client.FetchMap("robot:r1.secret", "r1", 0);
    const std::string name = fleet::GrpcCodeName(code);
    EXPECT_THAT(fetched, StatusIs(fleet::FromGrpcCode(static_cast<grpc::StatusCode>(code)),
                                  "Maps.StreamMap: " + name + ": told to refuse"));
  }
}

TEST_F(ServiceClientTest, SameNamedCodesStayTheirNameOthersTheNearestMeaning) {
  ServiceClient client(address_);
  const std::pair<grpc::StatusCode, StatusCode> expected[] = {
      {grpc::StatusCode::UNAVAILABLE, StatusCode::kUnavailable},
      {grpc::StatusCode::INVALID_ARGUMENT, StatusCode::kInvalidArgument},
      {grpc::StatusCode::FAILED_PRECONDITION, StatusCode::kFailedPrecondition},
      {grpc::StatusCode::ABORTED, StatusCode::kAborted},
      {grpc::StatusCode::INTERNAL, StatusCode::kInternal},
      {grpc::StatusCode::RESOURCE_EXHAUSTED, StatusCode::kUnavailable},
      {grpc::StatusCode::UNAUTHENTICATED, StatusCode::kFailedPrecondition},
  };
  for (const auto& [grpc_code, code] : expected) {
    maps_.code = grpc_code;
    EXPECT_THAT(client.ApprovePending("engineer:e.secret", "r1"), StatusIs(code, "Maps.ListMapVersions: "));
  }
  EXPECT_THAT(client.MintToken("admin:root.secret", "robot:r1"),
              StatusIs(StatusCode::kFailedPrecondition,
                       "Admin.SetCredential: PERMISSION_DENIED: needs the admin role"));
  EXPECT_THAT(client.WaitForJob("engineer:e.secret", 7),
              StatusIs(StatusCode::kNotFound, "Reprocessing.GetJob: NOT_FOUND"));
}

TEST_F(ServiceClientTest, NoApprovedMapYetIsUpToDate) {
  maps_.code = grpc::StatusCode::NOT_FOUND;
  const auto fetched = ServiceClient(address_).FetchMap("robot:r1.secret", "r1", 0);
  ASSERT_THAT(fetched, IsOk());
  EXPECT_TRUE(fetched->up_to_date);
}

TEST(ServiceClientWithoutServerTest, NobodyListeningIsUnavailable) {
  EXPECT_THAT(ServiceClient("127.0.0.1:1").MintToken("admin:root.secret", "robot:r1"),
              StatusIs(StatusCode::kUnavailable, "Admin.SetCredential: UNAVAILABLE: "));
}

}  // namespace
}  // namespace sim
