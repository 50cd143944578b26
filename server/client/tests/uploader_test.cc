// The upload client without a server: which failures it retries, token files, snapshot ids, and an upload to
// a port nobody listens on.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <grpcpp/support/status_code_enum.h>
#include <openssl/sha.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "fleet/serialization.h"
#include "fleet_client/uploader.h"

namespace fleet_client {
namespace {

TEST(RetryableUploadTest, RetriesWhatMaySucceedLaterOnly) {
  EXPECT_TRUE(RetryableUpload(grpc::StatusCode::UNAVAILABLE, "database is read-only"));
  EXPECT_TRUE(RetryableUpload(grpc::StatusCode::DEADLINE_EXCEEDED, ""));
  EXPECT_TRUE(RetryableUpload(grpc::StatusCode::ABORTED, ""));
  EXPECT_TRUE(
      RetryableUpload(grpc::StatusCode::RESOURCE_EXHAUSTED, "rate limit exceeded for robot:r1; retry later"));
  EXPECT_FALSE(RetryableUpload(grpc::StatusCode::RESOURCE_EXHAUSTED,
                               "Received message larger than max (70000000 vs. 67108864)"));
  EXPECT_FALSE(RetryableUpload(grpc::StatusCode::INVALID_ARGUMENT, "events[3]: not finite"));
  EXPECT_FALSE(RetryableUpload(grpc::StatusCode::PERMISSION_DENIED, ""));
  EXPECT_FALSE(RetryableUpload(grpc::StatusCode::UNAUTHENTICATED, ""));
}

class TokenFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/fleet-client-test-XXXXXX";
    directory_ = mkdtemp(pattern);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string Write(const std::string& text) {
    const std::string path = (directory_ / "token").string();
    std::ofstream(path) << text;
    return path;
  }
  std::filesystem::path directory_;
};

TEST_F(TokenFileTest, OneTokenWithoutTheSurroundingWhitespace) {
  std::string error;
  EXPECT_EQ(ReadTokenFile(Write("  robot:r1.abc\n"), &error), "robot:r1.abc");
}

TEST_F(TokenFileTest, RefusesMissingEmptyAndSeveralLines) {
  std::string error;
  EXPECT_EQ(ReadTokenFile((directory_ / "absent").string(), &error), std::nullopt);
  EXPECT_THAT(error, ::testing::HasSubstr("cannot read it"));
  EXPECT_EQ(ReadTokenFile(Write(" \n"), &error), std::nullopt);
  EXPECT_THAT(error, ::testing::HasSubstr("1..512 characters"));
  EXPECT_EQ(ReadTokenFile(Write("robot:r1.abc\nrobot:r2.def\n"), &error), std::nullopt);
  EXPECT_THAT(error, ::testing::HasSubstr("one token on one line"));
}

TEST(SnapshotIdTest, HexSha256OfTheDeterministicBytes) {
  fleet::v1::MapSnapshot snapshot;
  snapshot.set_format_version(1);
  snapshot.add_nodes()->set_id(7);
  const std::string bytes = fleet::SerializeDeterministic(snapshot);
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), digest);
  char hex[2 * SHA256_DIGEST_LENGTH + 1];
  for (int k = 0; k < SHA256_DIGEST_LENGTH; ++k) std::snprintf(hex + 2 * k, 3, "%02x", digest[k]);
  EXPECT_EQ(SnapshotId(snapshot), hex);
  snapshot.add_nodes()->set_id(8);
  EXPECT_NE(SnapshotId(snapshot), hex);
}

TEST(UploaderTest, NobodyListeningIsUnavailableAfterEveryAttempt) {
  UploaderOptions options;
  options.server = "127.0.0.1:1";
  options.token = "robot:r1.abc";
  options.max_attempts = 2;
  options.initial_backoff = std::chrono::milliseconds(1);
  options.deadline_seconds = 10;
  fleet::v1::RunFile run;
  run.mutable_header()->set_run_id("r1-run0");
  const UploadOutcome outcome = Uploader(options).Upload(run);
  EXPECT_FALSE(outcome.ok);
  EXPECT_EQ(outcome.code, grpc::StatusCode::UNAVAILABLE);
  EXPECT_THAT(outcome.message, ::testing::StartsWith("UNAVAILABLE: "));
  EXPECT_EQ(outcome.attempts, 2);
  EXPECT_EQ(outcome.run_id, "r1-run0");
}

}  // namespace
}  // namespace fleet_client
