// Weak secrets are refused at start (server/secrets.h): the placeholders shipped in deploy/, look-alikes,
// repetitions and low-entropy strings; random ones pass.
#include <gtest/gtest.h>

#include "server/secrets.h"
#include "status_matchers.h"

namespace server {
namespace {

TEST(SecretsTest, PlaceholdersAndLowEntropyAreRefusedNamingWhy) {
  const auto refused = [](const std::string& secret, std::size_t min_length = 32) {
    const slamcore::Status status = CheckSecretStrength("bootstrap_admin_token", secret, min_length);
    EXPECT_EQ(status.code(), slamcore::StatusCode::kInvalidArgument) << secret;
    EXPECT_EQ(status.message().find(secret), std::string::npos) << "the secret is never quoted";
    return status.message();
  };
  // The values deploy/ shipped (Kubernetes Secret, compose defaults).
  EXPECT_NE(refused("change-me-to-a-long-random-secret").find("placeholder (contains \"changeme\")"),
            std::string::npos);
  EXPECT_NE(refused("change-me", 8).find("changeme"), std::string::npos);
  EXPECT_NE(refused("fleet-local", 8).find("fleetlocal"), std::string::npos);
  EXPECT_NE(refused("local-trial-only-secret", 8).find("placeholder"), std::string::npos);
  EXPECT_NE(refused("CHANGE_ME_PLEASE_0123456789abcdef0123").find("changeme"), std::string::npos);
  EXPECT_NE(refused("q7Zp").find("shorter than 32 characters"), std::string::npos);
  EXPECT_NE(refused(std::string(64, 'a')).find("repetition"), std::string::npos);
  EXPECT_NE(refused("00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff").find("repetition"),
            std::string::npos);
  EXPECT_NE(refused("aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaab").find("low entropy"), std::string::npos);
}

TEST(SecretsTest, RandomSecretsPass) {
  for (const std::string secret :
       {"3f9c2a7d1e0b4c8a9f6e5d4c3b2a1908", "e1b7a3f0c95d2846a7f1c3e9b0d5a286c4f7e2d1b9a03c58",
        "Xk9vQ2mLp7RtW4zN8bYc3HdJ6fGs1AeU"}) {
    EXPECT_THAT(CheckSecretStrength("secret", secret, 32), IsOk()) << secret;
  }
}

}  // namespace
}  // namespace server
