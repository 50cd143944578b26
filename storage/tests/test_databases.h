// Test databases for the contract suites: a fresh SQLite file, or a fresh database on a throwaway
// PostgreSQL server that the test process starts itself on loopback (initdb + pg_ctl into a temp dir) and
// stops at exit. A missing PostgreSQL installation FAILS the PostgreSQL tests; they never skip.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "open_repository.h"
#include "storage/repository.h"

namespace storage::testing {

enum class Backend { kSqlite, kPostgres };

std::string BackendName(const ::testing::TestParamInfo<Backend>& info);

/// A URL of a new, empty database, or an error naming what is missing.
Result<std::string> NewDatabaseUrl(Backend backend);

/// Base fixture: a fresh database per test, opened as repo().
class BackendTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override;
  void TearDown() override;
  /// Closes and reopens (e.g. after a child process wrote to the database).
  void Reopen();
  internal::SqlRepository& repo() { return *repo_; }
  /// Runs raw SQL (tests only: to corrupt data or read columns the API hides).
  internal::SqlRows RawQuery(const std::string& sql, const std::vector<internal::SqlValue>& params = {});

  std::string url_;
  std::unique_ptr<internal::SqlRepository> repo_;
};

/// A registered robot "robot-1" and a run with `telemetry_bytes` of deterministic telemetry.
RunRecord MakeRun(const std::string& run_id, std::int64_t started_at_ms, std::size_t telemetry_bytes = 1000,
                  const std::string& robot_id = "robot-1");

}  // namespace storage::testing
