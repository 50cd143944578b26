// The name tables of records' states (records.h), and what a read does with a stored spelling outside them.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>

#include "status_matchers.h"
#include "test_databases.h"

namespace storage::testing {
namespace {

namespace fs = std::filesystem;

/// Every value's name parses back to it, names are distinct, lower case and non-empty.
template <typename E, std::size_t N>
void ExpectRoundTrip(const std::array<E, N>& values) {
  std::set<std::string_view> names;
  for (E value : values) {
    const std::string_view name = Name(value);
    EXPECT_FALSE(name.empty());
    EXPECT_EQ(name.find_first_not_of("abcdefghijklmnopqrstuvwxyz_"), std::string_view::npos) << name;
    EXPECT_TRUE(names.insert(name).second) << name << " names two values";
    auto parsed = Parse<E>(name);
    ASSERT_THAT(parsed, IsOk());
    EXPECT_EQ(*parsed, value) << name;
  }
}

TEST(RecordNamesTest, EveryValueRoundTrips) {
  ExpectRoundTrip(kMapOrigins);
  ExpectRoundTrip(kMapApprovals);
  ExpectRoundTrip(kMapActions);
  ExpectRoundTrip(kFindingStates);
  ExpectRoundTrip(kFindingKinds);
  ExpectRoundTrip(kJobStates);
}

TEST(RecordNamesTest, SpellingsAreTheStoredOnes) {
  // Existing databases hold these; a change here needs a migration.
  EXPECT_EQ(Name(MapOrigin::kUpload), "upload");
  EXPECT_EQ(Name(MapOrigin::kImport), "import");
  EXPECT_EQ(Name(MapApproval::kStale), "stale");
  EXPECT_EQ(Name(MapAction::kCutRegion), "cut_region");
  EXPECT_EQ(Name(FindingState::kInfo), "info");
  EXPECT_EQ(Name(FindingKind::kHighResidualEdge), "high_residual_edge");
  EXPECT_EQ(Name(FindingKind::kLostRegion), "lost_region");
  EXPECT_EQ(Name(JobState::kCancelled), "cancelled");
}

TEST(RecordNamesTest, AnUnknownSpellingIsRefusedByName) {
  EXPECT_THAT(Parse<MapOrigin>("uplaod"),
              StatusIs(StatusCode::kInvalidArgument, "map version origin \"uplaod\""));
  EXPECT_THAT(Parse<MapApproval>("Approved"),
              StatusIs(StatusCode::kInvalidArgument, "\"Approved\" is not approved"));
  EXPECT_THAT(Parse<MapAction>("cut_finding"), StatusIs(StatusCode::kInvalidArgument, "\"cut_finding\""));
  EXPECT_THAT(Parse<FindingState>(""), StatusIs(StatusCode::kInvalidArgument,
                                                "finding state \"\" is not open, "
                                                "resolved or info"));
  EXPECT_THAT(Parse<FindingKind>("wall"), StatusIs(StatusCode::kInvalidArgument, "finding kind \"wall\""));
  EXPECT_THAT(Parse<JobState>("sleeping"), StatusIs(StatusCode::kInvalidArgument, "job state \"sleeping\""));
  // Long input is cut in the message.
  auto long_name = Parse<MapOrigin>(std::string(1000, 'x'));
  ASSERT_FALSE(long_name.ok());
  EXPECT_LT(long_name.status().message().size(), 200u);
}

/// Runs `sql` on the SQLite file at `path` without the repository (a value no program of ours writes).
void Corrupt(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
  EXPECT_EQ(rc, SQLITE_OK) << (error ? error : "");
  sqlite3_free(error);
  sqlite3_close(db);
}

TEST(RecordNamesTest, AStoredStateOutsideItsSetIsReportedWhenRead) {
  const std::string path =
      (fs::temp_directory_path() / ("storage_states_" + std::to_string(getpid()) + ".db")).string();
  fs::remove(path);
  {
    auto opened = OpenRepository("sqlite:" + path);
    ASSERT_THAT(opened, IsOk());
    Repository& repository = **opened;
    ASSERT_THAT(repository.PutRobot(RobotRecord{"robot-1", "vac-s", "fw-1", 1}), IsOk());
    const std::string snapshot = *repository.PutSnapshot("map");
    MapVersionRecord version;
    version.robot_id = "robot-1";
    version.snapshot_id = snapshot;
    version.origin = MapOrigin::kImport;
    version.action = MapAction::kImport;
    version.approval = MapApproval::kApproved;
    ASSERT_THAT(
        repository.AppendMapVersion(version, std::nullopt,
                                    {{1, FindingKind::kNewRegion, 0.5, "x", FindingState::kOpen, "{}"}}),
        IsOk());
    NewJob job;
    job.kind = "analyze_run";
    ASSERT_THAT(repository.EnqueueJob(job), IsOk());
  }
  Corrupt(path,
          "UPDATE map_versions SET approval = 'approvd'; UPDATE map_findings SET kind = 'wall'; "
          "UPDATE jobs SET state = 'sleeping'");

  auto opened = OpenRepository("sqlite:" + path);
  ASSERT_THAT(opened, IsOk());
  Repository& repository = **opened;
  EXPECT_THAT(repository.ListMapVersions("robot-1"),
              StatusIs(StatusCode::kDataLoss,
                       "map version 1 of robot robot-1: stored map version approval "
                       "\"approvd\" is not approved, pending, rejected or stale"));
  EXPECT_THAT(repository.GetMapVersion("robot-1", 1), StatusIs(StatusCode::kDataLoss, "\"approvd\""));
  EXPECT_THAT(repository.ListMapFindings("robot-1", 1),
              StatusIs(StatusCode::kDataLoss,
                       "finding 1 of map version 1 of robot robot-1: stored finding kind "
                       "\"wall\""));
  EXPECT_THAT(repository.GetJob(1), StatusIs(StatusCode::kDataLoss, "job 1: stored job state \"sleeping\""));
  EXPECT_THAT(repository.ListJobs(std::nullopt, 10), StatusIs(StatusCode::kDataLoss, "\"sleeping\""));

  // An empty action is an upload's "none"; any other spelling is refused like the rest.
  Corrupt(path, "UPDATE map_versions SET approval = 'approved', action = 'explode'");
  EXPECT_THAT(repository.ListMapVersions("robot-1"),
              StatusIs(StatusCode::kDataLoss, "map version action \"explode\""));
  Corrupt(path, "UPDATE map_versions SET action = '', origin = 'import'");
  auto versions = repository.ListMapVersions("robot-1");
  ASSERT_THAT(versions, IsOk());
  EXPECT_FALSE(versions->front().action.has_value());
  opened->reset();
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path + suffix);
}

}  // namespace
}  // namespace storage::testing
