// Crash consistency on both back-ends: a writer process killed with SIGKILL in the middle of a transaction
// leaves a valid database in which each run is either wholly present or absent.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <functional>
#include <thread>

#include "crypto.h"
#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

class CrashConsistencyTest : public BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (HasFatalFailure()) return;
    ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-1", "vac-s", "fw-1.2", 1}), IsOk());
    repo_.reset();  // no database handle crosses fork()
  }

  void ExpectDatabaseValid() {
    if (GetParam() == Backend::kSqlite) {
      auto rows = RawQuery("PRAGMA integrity_check");
      ASSERT_FALSE(rows.empty());
      EXPECT_EQ(rows[0].Text(0), "ok");
    }
    auto version = repo().SchemaVersion();
    ASSERT_THAT(version, IsOk());
    EXPECT_EQ(*version, LatestSchemaVersion());
  }

  /// Runs `body` in a child process on its own connection and SIGKILLs it once it reaches fault `point`
  /// (inside the transaction, before COMMIT).
  void KillWriterAt(const std::string& point, const std::function<void(internal::SqlRepository&)>& body) {
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      auto repository = internal::OpenSqlRepository(url_, OpenOptions{});
      if (!repository.ok()) _exit(2);
      (*repository)->SetFaultHookForTesting([&](const std::string& at) {
        if (at != point) return;
        (void)!write(ready[1], "x", 1);
        pause();
      });
      body(**repository);
      _exit(3);
    }
    char byte = 0;
    ASSERT_EQ(read(ready[0], &byte, 1), 1) << "the child never reached " << point;
    ASSERT_EQ(kill(child, SIGKILL), 0);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
  }
};

TEST_P(CrashConsistencyTest, WriterKilledInsideTheTransactionLeavesNoTrace) {
  const RunRecord run = MakeRun("big-run", 1000, 8 << 20);  // 8 MiB of telemetry
  // Killed after the run row is written, before COMMIT.
  KillWriterAt("insert_run:before_commit",
               [&](internal::SqlRepository& repository) { (void)repository.InsertRun(run); });
  if (HasFatalFailure()) return;

  Reopen();
  ExpectDatabaseValid();
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "big-run"}).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0), 0);
  EXPECT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted) << "the database stays writable";
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "big-run"})->telemetry, run.telemetry);
}

TEST_P(CrashConsistencyTest, AnUploadKilledBeforeItsCommitLeavesNoTrace) {
  UploadBundle upload;
  upload.robot = {"robot-1", "vac-s", "fw-2.0", 0};
  upload.snapshots = {"child map"};
  upload.run = MakeRun("run-1", 1000, 1 << 20);
  upload.run.child_snapshot_id = internal::Sha256Hex("child map");
  upload.analysis_job.kind = "analyze_run";
  upload.map_version.robot_id = "robot-1";
  upload.map_version.snapshot_id = *upload.run.child_snapshot_id;
  upload.map_version.run_id = "run-1";
  // Killed once the robot, the map, the run, the job and the map version are written, before COMMIT.
  KillWriterAt("store_upload:before_commit",
               [&](internal::SqlRepository& repository) { (void)repository.StoreUpload(upload); });
  if (HasFatalFailure()) return;

  Reopen();
  ExpectDatabaseValid();
  EXPECT_EQ(repo().GetRobot("robot-1")->firmware, "fw-1.2") << "the robot as it was";
  for (const char* table : {"snapshots", "runs", "jobs", "map_versions"})
    EXPECT_EQ(RawQuery(std::string("SELECT COUNT(*) FROM ") + table)[0].Int(0), 0) << table;
  auto stored = repo().StoreUpload(upload);
  ASSERT_THAT(stored, IsOk()) << "the client's retry stores it";
  EXPECT_EQ(stored->map_version.version, 1);
  EXPECT_GT(stored->analysis_job_id, 0);
}

TEST_P(CrashConsistencyTest, AnErasureKilledMidwayLeavesTheRobotWhole) {
  Reopen();
  const std::string snapshot = *repo().PutSnapshot("map of robot-1");
  RunRecord run = MakeRun("run-1", 1000, 1000);
  run.child_snapshot_id = snapshot;
  ASSERT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted);
  MapVersionRecord version;
  version.robot_id = "robot-1";
  version.snapshot_id = snapshot;
  version.origin = MapOrigin::kUpload;
  version.run_id = "run-1";
  version.approval = MapApproval::kApproved;
  ASSERT_THAT(repo().AppendMapVersion(version, std::nullopt, {}), IsOk());
  ASSERT_THAT(repo().SetCredential("robot:robot-1", "secret"), IsOk());
  repo_.reset();  // no database handle crosses fork()
  // Killed once every row of the robot is deleted, before the audit entry and COMMIT.
  KillWriterAt("delete_robot:before_audit", [](internal::SqlRepository& repository) {
    (void)repository.DeleteRobot("robot-1", "admin:root");
  });
  if (HasFatalFailure()) return;

  Reopen();
  ExpectDatabaseValid();
  EXPECT_THAT(repo().GetRobot("robot-1"), IsOk()) << "nothing half-deleted";
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "run-1"})->telemetry, run.telemetry);
  EXPECT_THAT(repo().GetSnapshot(snapshot), IsOk());
  EXPECT_EQ(repo().ListMapVersions("robot-1")->size(), 1u);
  EXPECT_TRUE(*repo().VerifyCredential("robot:robot-1", "secret"));
  EXPECT_TRUE(repo().ListAudit(10, std::nullopt)->empty());
  auto erased = repo().DeleteRobot("robot-1", "admin:root");
  ASSERT_THAT(erased, IsOk());
  EXPECT_EQ(erased->runs, 1);
  EXPECT_EQ(erased->snapshots, 1);
}

TEST_P(CrashConsistencyTest, WriterKilledAtARandomMomentLeavesWholeRunsOnly) {
  // The child stores runs 0, 1, 2, ... one per transaction; the parent kills it while it writes. Afterwards
  // the stored runs are exactly a prefix 0..k-1, each intact.
  constexpr std::size_t kTelemetryBytes = 1 << 20;
  int started[2];
  ASSERT_EQ(pipe(started), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto repository = internal::OpenSqlRepository(url_, OpenOptions{});
    if (!repository.ok()) _exit(2);
    (void)!write(started[1], "x", 1);
    for (int i = 0; i < 100000; ++i) {
      if (!(*repository)->InsertRun(MakeRun("run-" + std::to_string(i), i, kTelemetryBytes)).ok()) _exit(4);
    }
    _exit(0);
  }
  char byte = 0;
  ASSERT_EQ(read(started[0], &byte, 1), 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  ASSERT_EQ(kill(child, SIGKILL), 0);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the child finished or failed before it was killed";

  Reopen();
  ExpectDatabaseValid();
  const std::int64_t stored = RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0);
  EXPECT_GT(stored, 0) << "the child should have committed some runs in 700 ms";
  for (std::int64_t i = 0; i <= stored; ++i) {
    auto run = repo().GetRun(RunKey{"robot-1", "run-" + std::to_string(i)});
    if (i < stored) {
      ASSERT_THAT(run, IsOk()) << "run-" << i << ": " << run.status().ToString();
      EXPECT_EQ(run->telemetry, MakeRun("run-" + std::to_string(i), i, kTelemetryBytes).telemetry);
    } else {
      EXPECT_EQ(run.status().code(), StatusCode::kNotFound) << "runs are stored in order";
    }
  }
  std::cout << "[ measured ] " << stored << " runs of 1 MiB committed before SIGKILL\n";
}

INSTANTIATE_TEST_SUITE_P(Backends, CrashConsistencyTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

}  // namespace
}  // namespace storage::testing
