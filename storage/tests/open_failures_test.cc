// Opening databases that must be refused: not a database, corrupt, written by a newer program, unknown
// URL, unreachable server. Each is a Status with a clear message, never a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

namespace fs = std::filesystem;

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("storage_open_" + std::to_string(getpid()) + "_" + name)).string();
}

TEST(OpenFailuresTest, FileThatIsNotADatabaseIsRefused) {
  const std::string path = TempPath("garbage.db");
  {
    std::ofstream out(path, std::ios::binary);
    for (int i = 0; i < 5000; ++i) out << "this is a text file, not a database " << i << "\n";
  }
  auto opened = OpenRepository("sqlite:" + path);
  ASSERT_THAT(opened, StatusIs(StatusCode::kDataLoss));
  EXPECT_NE(opened.status().message().find("not a SQLite database"), std::string::npos)
      << opened.status().ToString();
  fs::remove(path);
}

TEST(OpenFailuresTest, DatabaseWithCorruptPagesIsRefused) {
  const std::string path = TempPath("corrupt.db");
  {
    auto opened = OpenRepository("sqlite:" + path);
    ASSERT_THAT(opened, IsOk());
  }
  ASSERT_TRUE(fs::exists(path));
  {
    // Keep the 100-byte header, overwrite the schema page and everything after it.
    std::fstream file(path, std::ios::binary | std::ios::in | std::ios::out);
    file.seekp(100);
    const std::string garbage(static_cast<std::size_t>(fs::file_size(path)) - 100, '\x5A');
    file.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  auto reopened = OpenRepository("sqlite:" + path);
  ASSERT_FALSE(reopened.ok());
  EXPECT_EQ(reopened.status().code(), StatusCode::kDataLoss) << reopened.status().ToString();
  fs::remove(path);
  fs::remove(path + "-wal");
  fs::remove(path + "-shm");
}

TEST(OpenFailuresTest, UnknownUrlAndUnreachableServer) {
  EXPECT_EQ(OpenRepository("mysql://localhost/x").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(OpenRepository("sqlite:").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(OpenRepository("sqlite:/nonexistent-dir/x/fleet.db").status().code(), StatusCode::kUnavailable);
  // Port 1 on loopback: nothing listens there.
  auto unreachable = OpenRepository("postgresql://postgres@127.0.0.1:1/fleet?connect_timeout=2");
  EXPECT_EQ(unreachable.status().code(), StatusCode::kUnavailable) << unreachable.status().ToString();
}

class SchemaVersionTest : public BackendTest {};

TEST_P(SchemaVersionTest, DatabaseFromANewerProgramIsRefused) {
  const std::int64_t newer = LatestSchemaVersion() + 6;
  RawQuery("INSERT INTO schema_version (version, applied_at_ms) VALUES ($1, 0)", {internal::SqlValue{newer}});
  repo_.reset();
  auto opened = OpenRepository(url_);
  ASSERT_THAT(opened, StatusIs(StatusCode::kFailedPrecondition));
  EXPECT_EQ(opened.status().message(), "database schema version " + std::to_string(newer) +
                                           " is newer than this program's " +
                                           std::to_string(LatestSchemaVersion()) + "; upgrade the program");
}

INSTANTIATE_TEST_SUITE_P(Backends, SchemaVersionTest, ::testing::Values(Backend::kSqlite, Backend::kPostgres),
                         BackendName);

}  // namespace
}  // namespace storage::testing
