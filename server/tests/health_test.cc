// HealthMonitor (server/health.h) over a real SQLite file: a write that the database refuses (here: locked
// by another connection past the busy timeout) makes fleetd unhealthy even though the last probe passed,
// and the failure ages out after three probe intervals once writes succeed again.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <filesystem>
#include <thread>
#include <vector>

#include "server/health.h"
#include "status_matchers.h"

namespace server {
namespace {

TEST(HealthMonitorTest, ARefusedWriteIsUnhealthyUntilItAges) {
  const std::filesystem::path directory = std::filesystem::temp_directory_path() / "health-monitor-test";
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  const std::string path = (directory / "fleet.db").string();
  storage::OpenOptions options;
  options.sqlite_busy_timeout = std::chrono::milliseconds(50);
  auto repository = storage::OpenRepository("sqlite:" + path, options);
  ASSERT_THAT(repository, IsOk());
  std::vector<bool> reported;
  HealthMonitor health(**repository, "test:1", std::chrono::minutes(1),
                       [&](bool healthy) { reported.push_back(healthy); });
  health.Start();
  EXPECT_TRUE(health.Current().healthy);
  EXPECT_EQ(reported, std::vector<bool>{true});

  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &other), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
  const storage::Status refused = (*repository)->PutRobot({"r1", "model", "fw", 0});
  EXPECT_EQ(refused.code(), storage::StatusCode::kUnavailable) << refused.ToString();
  const HealthMonitor::State state = health.Current();
  EXPECT_FALSE(state.healthy);
  EXPECT_EQ(state.reason.rfind("a write failed ", 0), 0u) << state.reason;
  ASSERT_EQ(sqlite3_exec(other, "COMMIT", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(other);
  EXPECT_THAT((*repository)->PutRobot({"r1", "model", "fw", 0}), IsOk());
  EXPECT_FALSE(health.Current().healthy) << "still within three intervals of the failure";
  health.Stop();

  // With 100 ms probes the failure is old news after 300 ms.
  HealthMonitor quick(**repository, "test:2", std::chrono::milliseconds(100), nullptr);
  quick.Start();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  EXPECT_TRUE(quick.Current().healthy) << quick.Current().reason;
  quick.Stop();
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace server
