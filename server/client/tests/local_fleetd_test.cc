// LocalFleetd against the real fleetd: addresses, the log, flags replacing defaults, the bootstrap token, the
// hook in the child, the exit status, and what it says when fleetd does not start.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <memory>
#include <string>

#include "fleet/v1/service.grpc.pb.h"
#include "fleet_client/channel.h"
#include "fleet_client/local_fleetd.h"
#include "status_matchers.h"

namespace fleet_client {
namespace {

using slamcore::StatusCode;

class LocalFleetdTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/local-fleetd-test-XXXXXX";
    directory_ = mkdtemp(pattern);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  LocalFleetdOptions Options() const {
    LocalFleetdOptions options;
    options.binary = FLEETD_BINARY;
    options.directory = directory_ / "fleetd";
    options.flags = {"--workers", "1"};
    options.admin_token = admin_;
    return options;
  }
  grpc::StatusCode ListRuns(const std::string& address, const std::string& token) const {
    auto queries = fleet::v1::Queries::NewStub(CreateFleetChannel(address, "", 4 << 20));
    grpc::ClientContext context;
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    fleet::v1::ListRunsRequest request;
    fleet::v1::ListRunsResponse response;
    return queries->ListRuns(&context, request, &response).error_code();
  }
  std::filesystem::path directory_;
  const std::string admin_ = RandomToken("admin:client-test");
};

TEST_F(LocalFleetdTest, StartsOnFreePortsWithTheTokenFromTheEnvironmentAndStopsCleanly) {
  LocalFleetd fleetd;
  ASSERT_THAT(fleetd.Start(Options()), IsOk());
  EXPECT_TRUE(fleetd.running());
  EXPECT_THAT(fleetd.grpc_address(), ::testing::StartsWith("127.0.0.1:"));
  EXPECT_THAT(fleetd.http_address(), ::testing::StartsWith("127.0.0.1:"));
  EXPECT_EQ(fleetd.log_path(), directory_ / "fleetd" / "fleetd.log");
  EXPECT_TRUE(std::filesystem::exists(directory_ / "fleetd" / "fleet.db"));
  EXPECT_EQ(ListRuns(fleetd.grpc_address(), admin_), grpc::StatusCode::OK);
  EXPECT_EQ(ListRuns(fleetd.grpc_address(), ""), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(fleetd.Start(Options()), StatusIs(StatusCode::kFailedPrecondition, "already running"));
  EXPECT_EQ(fleetd.Stop(), 0);
  EXPECT_FALSE(fleetd.running());
  EXPECT_EQ(fleetd.Stop(), -1);
  EXPECT_GT(std::filesystem::file_size(directory_ / "fleetd" / "fleetd.log"), 0u);
}

TEST_F(LocalFleetdTest, AFlagReplacesTheDefaultOfItsName) {
  LocalFleetdOptions options = Options();
  options.flags = {"--http", "", "--db", "sqlite:" + (directory_ / "elsewhere.db").string()};
  LocalFleetd fleetd;
  ASSERT_THAT(fleetd.Start(options), IsOk());
  EXPECT_EQ(fleetd.http_address(), "") << "no HTTP listener";
  EXPECT_TRUE(std::filesystem::exists(directory_ / "elsewhere.db"));
  EXPECT_FALSE(std::filesystem::exists(directory_ / "fleetd" / "fleet.db"));
}

TEST_F(LocalFleetdTest, RunsTheHookInTheChildBeforeExec) {
  LocalFleetdOptions options = Options();
  const std::string marker = (directory_ / "in-child").string();
  options.in_child = [marker] { close(::open(marker.c_str(), O_WRONLY | O_CREAT, 0644)); };
  LocalFleetd fleetd;
  ASSERT_THAT(fleetd.Start(options), IsOk());
  EXPECT_TRUE(std::filesystem::exists(marker));
}

TEST_F(LocalFleetdTest, DestructionStopsIt) {
  int pid = -1;
  {
    LocalFleetd fleetd;
    ASSERT_THAT(fleetd.Start(Options()), IsOk());
    pid = fleetd.pid();
    EXPECT_EQ(kill(pid, 0), 0);
  }
  EXPECT_EQ(kill(pid, 0), -1);
  EXPECT_EQ(errno, ESRCH) << "stopped and reaped";
}

TEST_F(LocalFleetdTest, NamesWhatIsWrongWhenItDoesNotStart) {
  LocalFleetdOptions options = Options();
  options.binary = directory_ / "no-such-fleetd";
  LocalFleetd fleetd;
  EXPECT_THAT(fleetd.Start(options), StatusIs(StatusCode::kFailedPrecondition, "is not an executable"));
  options.binary = "/bin/true";  // prints no addresses
  const std::string log = (directory_ / "fleetd" / "fleetd.log").string();
  EXPECT_THAT(fleetd.Start(options), StatusIs(StatusCode::kFailedPrecondition, "did not start (see " + log));
  EXPECT_FALSE(fleetd.running());
  options.flags = {"--no-such-flag"};
  options.binary = FLEETD_BINARY;
  EXPECT_THAT(fleetd.Start(options), StatusIs(StatusCode::kFailedPrecondition, "did not start"));
}

}  // namespace
}  // namespace fleet_client
