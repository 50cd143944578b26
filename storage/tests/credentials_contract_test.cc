// The credential lifecycle on both back-ends (revocation, listing, the epochs other processes poll, the
// last admin), the health probe's write, and that no error of opening a database carries its password.
#include <gtest/gtest.h>

#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

class CredentialsContractTest : public BackendTest {};

TEST_P(CredentialsContractTest, ARevokedSecretIsRefusedAndListedAsRevoked) {
  ASSERT_THAT(repo().SetCredential("robot:r1", "secret-one"), IsOk());
  ASSERT_THAT(repo().SetCredential("admin:ops", "secret-admin"), IsOk());
  ASSERT_TRUE(*repo().VerifyCredential("robot:r1", "secret-one"));
  ASSERT_THAT(repo().RevokeCredential("robot:r1"), IsOk());
  EXPECT_FALSE(*repo().VerifyCredential("robot:r1", "secret-one"));
  EXPECT_FALSE(*repo().VerifyCredential("robot:r1", ""));
  EXPECT_THAT(repo().RevokeCredential("robot:r1"), IsOk()) << "revoking twice is fine";
  EXPECT_EQ(repo().RevokeCredential("robot:nobody").code(), StatusCode::kNotFound);

  auto all = repo().ListCredentials("", "", 100, false);
  ASSERT_THAT(all, IsOk());
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].principal, "admin:ops");
  EXPECT_FALSE((*all)[0].revoked);
  EXPECT_EQ((*all)[1].principal, "robot:r1");
  EXPECT_TRUE((*all)[1].revoked);
  EXPECT_EQ(repo().ListCredentials("robot:", "", 100, true)->size(), 0u);
  EXPECT_EQ(repo().ListCredentials("admin:", "", 100, true)->size(), 1u);
  EXPECT_EQ(repo().ListCredentials("", "admin:ops", 100, false)->size(), 1u) << "keyset page after admin:ops";
  EXPECT_EQ(repo().ListCredentials("", "", 0, false).status().code(), StatusCode::kInvalidArgument);
  // Minting again brings the principal back with the new secret only.
  ASSERT_THAT(repo().SetCredential("robot:r1", "secret-two"), IsOk());
  EXPECT_TRUE(*repo().VerifyCredential("robot:r1", "secret-two"));
  EXPECT_FALSE(*repo().VerifyCredential("robot:r1", "secret-one"));
}

TEST_P(CredentialsContractTest, TheLastAdminCannotBeRevoked) {
  ASSERT_THAT(repo().SetCredential("admin:a", "secret-a"), IsOk());
  ASSERT_THAT(repo().SetCredential("admin:b", "secret-b"), IsOk());
  EXPECT_THAT(repo().RevokeCredential("admin:a"), IsOk());
  const Status last = repo().RevokeCredential("admin:b");
  EXPECT_THAT(last, StatusIs(StatusCode::kFailedPrecondition));
  EXPECT_EQ(last.message(), "admin:b is the last admin with a credential; mint another admin first");
  EXPECT_TRUE(*repo().VerifyCredential("admin:b", "secret-b"));
}

TEST_P(CredentialsContractTest, ChangesAreReportedOnceInCommitOrder) {
  ASSERT_THAT(repo().SetCredential("robot:r0", "zero"), IsOk());
  auto start = repo().CredentialChangesSince(-1, 100);
  ASSERT_THAT(start, IsOk());
  EXPECT_TRUE(start->principals.empty()) << "a new poller starts at the newest epoch";
  EXPECT_GT(start->epoch, 0);
  ASSERT_THAT(repo().SetCredential("robot:r1", "one"), IsOk());
  ASSERT_THAT(repo().SetCredential("robot:r2", "two"), IsOk());
  auto first = repo().CredentialChangesSince(start->epoch, 100);
  ASSERT_THAT(first, IsOk());
  EXPECT_EQ(first->principals, (std::vector<std::string>{"robot:r1", "robot:r2"}));
  EXPECT_FALSE(first->truncated);
  EXPECT_GT(first->epoch, start->epoch);
  EXPECT_TRUE(repo().CredentialChangesSince(first->epoch, 100)->principals.empty()) << "nothing new";
  ASSERT_THAT(repo().RevokeCredential("robot:r1"), IsOk());
  auto revoked = repo().CredentialChangesSince(first->epoch, 100);
  EXPECT_EQ(revoked->principals, std::vector<std::string>{"robot:r1"});
  // More changes than the limit: the caller is told to drop everything.
  ASSERT_THAT(repo().SetCredential("robot:r3", "three"), IsOk());
  ASSERT_THAT(repo().SetCredential("robot:r4", "four"), IsOk());
  auto truncated = repo().CredentialChangesSince(revoked->epoch, 1);
  EXPECT_TRUE(truncated->truncated);
  EXPECT_EQ(truncated->principals.size(), 1u);
}

TEST_P(CredentialsContractTest, TheHealthProbeWritesAndNoFailureIsRecorded) {
  EXPECT_THAT(repo().ProbeWrite("host:1"), IsOk());
  EXPECT_THAT(repo().ProbeWrite("host:2"), IsOk());
  const auto rows = RawQuery("SELECT prober FROM health_probe");
  ASSERT_EQ(rows.size(), 1u) << "one row, however many probes";
  EXPECT_EQ(rows.front().Text(0), "host:2");
  EXPECT_FALSE(repo().LastWriteFailure().has_value());
}

INSTANTIATE_TEST_SUITE_P(Backends, CredentialsContractTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

TEST(DatabaseUrlTest, PasswordsAreRedactedInUrlsAndOpenErrors) {
  EXPECT_EQ(RedactDatabaseUrl("postgresql://fleet:pa%40ss@db:5432/fleet"),
            "postgresql://fleet:***@db:5432/fleet");
  EXPECT_EQ(RedactDatabaseUrl("postgres://fleet@db/fleet?password=hunter2&sslmode=require"),
            "postgres://fleet@db/fleet?password=***&sslmode=require");
  EXPECT_EQ(RedactDatabaseUrl("sqlite:/var/lib/fleet.db"), "sqlite:/var/lib/fleet.db");
  EXPECT_EQ(DatabaseUrlPasswords("postgresql://fleet:pa%40ss@db/fleet"),
            (std::vector<std::string>{"pa%40ss", "pa@ss"}));
  // Every way opening can fail: unknown scheme, a bad percent-escape libpq echoes, nothing listening.
  for (const std::string url :
       {"mysql://fleet:Sw0rdfish-77@127.0.0.1:1/fleet",
        "postgresql://fleet:Sw0rdfish-77%zz@127.0.0.1:1/fleet",
        "postgresql://fleet:Sw0rdfish-77@127.0.0.1:1/fleet?connect_timeout=2",
        "postgresql://fleet@127.0.0.1:1/fleet?password=Sw0rdfish-77&connect_timeout=2",
        "postgresql://fleet:Sw0rdfish-77@127.0.0.1:notaport/fleet"}) {
    auto opened = OpenRepository(url);
    ASSERT_FALSE(opened.ok()) << url;
    EXPECT_EQ(opened.status().message().find("Sw0rdfish"), std::string::npos) << opened.status().message();
  }
}

}  // namespace
}  // namespace storage::testing
