// The failed-attempt locks of server::Authenticator against a real SQLite credential store (the gRPC path,
// with timing, is tests/fleetd/hostile_test.cc's AddressFloodTest).
#include "server/auth.h"

#include <gtest/gtest.h>

#include <string>

#include "sqlite_repository_test.h"
#include "status_matchers.h"

namespace server {
namespace {

class AuthenticatorTest : public SqliteRepositoryTest {
 protected:
  std::string Issue(Authenticator& authenticator, const std::string& name) {
    auto principal = ParsePrincipal(name);
    EXPECT_THAT(principal, IsOk());
    auto token = authenticator.IssueToken(*principal);
    EXPECT_THAT(token, IsOk());
    return token.ok() ? *token : "";
  }
  static std::string WrongToken(const std::string& principal) {
    return "Bearer " + principal + "." + std::string(64, 'f');
  }
  // Seconds from "; retry in <n> s", -1 when the message has none.
  static int RetryIn(const std::string& message) {
    const std::size_t at = message.find("; retry in ");
    return at == std::string::npos ? -1 : std::stoi(message.substr(at + 11));
  }
};

TEST_F(AuthenticatorTest, ABurstOfFailuresLocksThePrincipalAndTheAddressAndSaysForHowLong) {
  Authenticator authenticator(*repository_, std::chrono::seconds(60));
  const std::string robot = Issue(authenticator, "robot:r1");
  const std::string engineer = Issue(authenticator, "engineer:e1");

  int hashed = 0;
  std::string refusal;
  for (int k = 0; k < 30 && refusal.empty(); ++k) {
    const auto verdict = authenticator.Authenticate(WrongToken("robot:r1"), "10.0.0.7");
    ASSERT_EQ(verdict.outcome, Authenticator::Outcome::kUnauthenticated);
    if (verdict.message.find("too many failed attempts") != std::string::npos) {
      refusal = verdict.message;
    } else {
      EXPECT_EQ(verdict.message, "authorization: invalid token for robot:r1");
      ++hashed;
    }
  }
  ASSERT_FALSE(refusal.empty()) << "30 wrong secrets never locked robot:r1";
  // kFailureBurst in quick succession; one more when a slow machine spent over a second on them.
  EXPECT_GE(hashed, static_cast<int>(Authenticator::kFailureBurst));
  EXPECT_LE(hashed, static_cast<int>(Authenticator::kFailureBurst) + 1);
  // Locked until all but kFailuresKeptAtUnlock failures decay: about ten seconds from here.
  const int lock_seconds =
      static_cast<int>((Authenticator::kFailureBurst - Authenticator::kFailuresKeptAtUnlock) *
                       Authenticator::kFailureRefillSeconds);
  EXPECT_GE(RetryIn(refusal), lock_seconds - 1) << refusal;
  EXPECT_LE(RetryIn(refusal), lock_seconds + 1) << refusal;

  // The principal's own valid token, never verified before, from another address: refused (principal lock).
  auto own = authenticator.Authenticate("Bearer " + robot, "10.0.0.8");
  EXPECT_EQ(own.outcome, Authenticator::Outcome::kUnauthenticated);
  EXPECT_GT(RetryIn(own.message), 0) << own.message;
  // Another principal's valid token from the flooding address: refused (address lock).
  auto same_address = authenticator.Authenticate("Bearer " + engineer, "10.0.0.7");
  EXPECT_EQ(same_address.outcome, Authenticator::Outcome::kUnauthenticated);
  EXPECT_NE(same_address.message.find("or from this address"), std::string::npos) << same_address.message;
  // The same token from another address: accepted, and from then on answered by the cache even from the
  // locked address.
  auto elsewhere = authenticator.Authenticate("Bearer " + engineer, "10.0.0.9");
  EXPECT_EQ(elsewhere.outcome, Authenticator::Outcome::kOk) << elsewhere.message;
  EXPECT_EQ(elsewhere.principal.name, "engineer:e1");
  auto cached = authenticator.Authenticate("Bearer " + engineer, "10.0.0.7");
  EXPECT_EQ(cached.outcome, Authenticator::Outcome::kOk) << cached.message;
}

TEST_F(AuthenticatorTest, FailuresBelowTheBurstLockNothing) {
  Authenticator authenticator(*repository_, std::chrono::seconds(60));
  const std::string robot = Issue(authenticator, "robot:r2");
  for (int k = 0; k + 1 < static_cast<int>(Authenticator::kFailureBurst); ++k) {
    const auto verdict = authenticator.Authenticate(WrongToken("robot:r2"), "10.0.0.7");
    EXPECT_EQ(verdict.message, "authorization: invalid token for robot:r2");
  }
  auto valid = authenticator.Authenticate("Bearer " + robot, "10.0.0.7");
  EXPECT_EQ(valid.outcome, Authenticator::Outcome::kOk) << valid.message;
}

}  // namespace
}  // namespace server
