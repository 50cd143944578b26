// The Repository contract for tenancy, erasure, retention and the audit log, run against both back-ends:
// run ids are per robot; deleting a robot leaves nothing of it in any table (blobs included) and leaves the
// other robots whole; retention prunes run events and finished jobs in bounded batches.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <set>

#include "blob_codec.h"
#include "migrations.h"
#include "postgres_database.h"
#include "sqlite_database.h"
#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

using internal::SqlBlob;
using internal::SqlValue;

constexpr const char* kErased = "erased-robot";
constexpr const char* kKept = "kept-robot";

std::int64_t NowMsForTest() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class TenancyContractTest : public BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (HasFatalFailure()) return;
    for (const char* robot : {kErased, kKept}) {
      ASSERT_THAT(repo().PutRobot(RobotRecord{robot, "vac-s", "fw-1.2", 1000}), IsOk());
    }
    ASSERT_THAT(repo().PutParameterSet({"default", "params-a"}), IsOk());
    ASSERT_THAT(repo().PutParameterSet({"tuned", "params-b"}), IsOk());
  }

  static ReportBundle Report(const std::string& robot, const std::string& run_id, const std::string& set) {
    ReportBundle bundle;
    bundle.report.robot_id = robot;
    bundle.report.run_id = run_id;
    bundle.report.parameter_set = set;
    bundle.report.report = "report of " + robot + "/" + run_id + "/" + set;
    bundle.decisions = {{1, 1.5, "recovery", "created", 11, 0.9, "d1"}};
    bundle.ambiguous_views = {{5, 3.0, 3, 0.4, "corridor"}};
    ProtrusionRegionRecord region;
    region.region_id = 1;
    region.features_json = "{}";
    region.predicted_class = "protrusion";
    bundle.protrusion_regions = {region};
    return bundle;
  }

  static MapVersionRecord Version(const std::string& robot, const std::string& snapshot,
                                  const std::string& run_id) {
    MapVersionRecord version;
    version.robot_id = robot;
    version.snapshot_id = snapshot;
    version.origin = MapOrigin::kUpload;
    version.run_id = run_id;
    version.approval = MapApproval::kApproved;
    version.created_by = "robot:" + robot;
    return version;
  }

  /// Every table of the schema (but schema_version), read from the database's own catalogue.
  std::vector<std::string> Tables() {
    const std::string sql =
        GetParam() == Backend::kSqlite
            ? "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'"
            : "SELECT table_name FROM information_schema.tables WHERE table_schema = current_schema()";
    std::vector<std::string> tables;
    for (const auto& row : RawQuery(sql)) {
      if (row.Text(0) != "schema_version") tables.push_back(row.Text(0));
    }
    return tables;
  }

  /// Rows per table whose text or bytes mention `needle` anywhere.
  std::map<std::string, int> RowsMentioning(const std::string& needle) {
    std::map<std::string, int> found;
    for (const std::string& table : Tables()) {
      for (const auto& row : RawQuery("SELECT * FROM " + table)) {
        for (std::size_t i = 0; i < row.size(); ++i) {
          if (!row.IsNull(i) && row.Text(i).find(needle) != std::string::npos) {
            ++found[table];
            break;
          }
        }
      }
    }
    return found;
  }

  std::int64_t Count(const std::string& sql, const std::vector<SqlValue>& params = {}) {
    return RawQuery(sql, params)[0].Int(0);
  }

  /// A robot's two runs with reports of both sets, a labelled region, two map versions with findings, a
  /// reprocessing job with a child and a credential; the second version carries metadata. Its first run builds on `parent` when set.
  void Populate(const std::string& robot, const std::optional<std::string>& parent, std::string* child_out) {
    const std::string child = *repo().PutSnapshot("child map of " + robot);
    const std::string repaired = *repo().PutSnapshot("repaired map of " + robot);
    for (const std::string run_id : {"run-1", "run-2"}) {
      RunRecord run = MakeRun(run_id, 1000, 200, robot);
      run.telemetry = "events of " + robot + " " + run_id;  // searchable: compressed blobs are checked by id
      if (run_id == "run-1") run.parent_snapshot_id = parent;
      run.child_snapshot_id = child;
      ASSERT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted);
      for (const char* set : {"default", "tuned"})
        ASSERT_THAT(repo().PutReport(Report(robot, run_id, set)), IsOk());
    }
    ASSERT_THAT(repo().LabelProtrusionRegion({robot, "run-1"}, "default", 1, "protrusion", "engineer:ana"),
                IsOk());
    ASSERT_THAT(repo().AppendMapVersion(
                    Version(robot, child, "run-1"), std::nullopt,
                    {{1, FindingKind::kProtrusion, 0.5, "region of " + robot, FindingState::kOpen, "{}"}}),
                IsOk());
    MapVersionRecord repair = Version(robot, repaired, "run-1");
    repair.origin = MapOrigin::kRepair;
    repair.parent_version = 1;
    repair.metadata = "rooms of " + robot;
    ASSERT_THAT(repo().AppendMapVersion(
                    repair, std::nullopt,
                    {{1, FindingKind::kHighResidualEdge, 0.1, "edge", FindingState::kOpen, "{}"}}),
                IsOk());
    NewJob parent_job{"reprocess", "filter " + robot, 3, std::nullopt, 1, robot};
    const std::int64_t parent_id = *repo().EnqueueJob(parent_job);
    ASSERT_THAT(repo().EnqueueJob(NewJob{"analyze_run", "run-1 of " + robot, 3, parent_id, 0, robot}),
                IsOk());
    ASSERT_THAT(repo().SetCredential("robot:" + robot, "secret of " + robot), IsOk());
    if (child_out) *child_out = child;
  }
};

TEST_P(TenancyContractTest, RunIdsArePerRobot) {
  RunRecord mine = MakeRun("run-7", 1000, 100, kKept);
  RunRecord squatted = MakeRun("run-7", 1000, 100, kErased);
  squatted.telemetry = "someone else's events";
  // Robot A stores robot B's next run id first; B's own upload of it is a different run, stored too.
  ASSERT_EQ(*repo().InsertRun(squatted), InsertOutcome::kInserted);
  ASSERT_EQ(*repo().InsertRun(mine), InsertOutcome::kInserted);
  EXPECT_EQ(*repo().InsertRun(mine), InsertOutcome::kAlreadyPresent) << "idempotent per robot";
  RunRecord changed = mine;
  changed.telemetry = "different events";
  auto conflict = repo().InsertRun(changed);
  EXPECT_THAT(conflict, StatusIs(StatusCode::kAlreadyExists));
  EXPECT_NE(conflict.status().message().find(kKept), std::string::npos) << conflict.status().message();
  EXPECT_EQ(repo().GetRun({kKept, "run-7"})->telemetry, mine.telemetry);
  EXPECT_EQ(repo().GetRun({kErased, "run-7"})->telemetry, squatted.telemetry);
  EXPECT_EQ(*repo().ListRunRobots("run-7", 10), (std::vector<std::string>{kErased, kKept}));
  EXPECT_TRUE(repo().ListRunRobots("run-8", 10)->empty());

  // Reports, labels and map versions of one run id stay apart per robot.
  ASSERT_THAT(repo().PutReport(Report(kKept, "run-7", "default")), IsOk());
  EXPECT_EQ(repo().GetReport({kErased, "run-7"}, "default").status().code(), StatusCode::kNotFound);
  EXPECT_TRUE(repo().ListProtrusionRegions({kErased, "run-7"}, "default")->empty());
  EXPECT_EQ(repo().LabelProtrusionRegion({kErased, "run-7"}, "default", 1, "x", "y").code(),
            StatusCode::kNotFound);
  ASSERT_THAT(repo().PutReport(Report(kErased, "run-7", "default")), IsOk());
  EXPECT_EQ(repo().GetReport({kKept, "run-7"}, "default")->report, "report of kept-robot/run-7/default");
  EXPECT_EQ(repo().ListProtrusionRegions({kKept, "run-7"}, "default")->front().robot_id, kKept);
  const std::string snapshot = *repo().PutSnapshot("map");
  EXPECT_EQ(repo().AppendMapVersion(Version(kErased, snapshot, "run-7"), std::nullopt, {})->version, 1);
  auto kept = repo().AppendMapVersion(Version(kKept, snapshot, "run-7"), std::nullopt, {});
  ASSERT_THAT(kept, IsOk());
  EXPECT_EQ(repo().GetMapVersionOfRun({kKept, "run-7"})->robot_id, kKept);

  // Both runs page apart even with the same start and id.
  auto first = repo().ListRuns(RunFilter{}, 1, std::nullopt);
  ASSERT_THAT(first, IsOk());
  ASSERT_TRUE(first->next);
  auto second = repo().ListRuns(RunFilter{}, 1, first->next);
  ASSERT_THAT(second, IsOk());
  ASSERT_EQ(second->runs.size(), 1u);
  EXPECT_NE(first->runs[0].robot_id, second->runs[0].robot_id);
  EXPECT_FALSE(second->next);
  // A cursor without a robot (from before run ids were per robot) continues after the whole group.
  EXPECT_TRUE(repo().ListRuns(RunFilter{}, 10, RunCursor{1000, "run-7", ""})->runs.empty());
  EXPECT_EQ(repo().Aggregate(RunFilter{})->reports, 2);
}

TEST_P(TenancyContractTest, UpgradeFromSchema3KeysEveryRunByItsRobot) {
  // A database written by the previous program (schema 3), then opened by this one.
  const std::string url = *NewDatabaseUrl(GetParam());
  {
    auto database = GetParam() == Backend::kSqlite
                        ? internal::OpenSqliteDatabase(url.substr(7), std::chrono::milliseconds(5000))
                        : internal::OpenPostgresDatabase(url, 1);
    ASSERT_THAT(database, IsOk());
    ASSERT_THAT(internal::MigrateTo(**database, 3), IsOk());
    internal::SqlRepository old(std::move(database).value());
    ASSERT_THAT(old.PutRobot(RobotRecord{kKept, "vac-s", "fw-1.2", 1}), IsOk());
    ASSERT_THAT(old.PutParameterSet({"default", "p"}), IsOk());
    const std::string snapshot = *old.PutSnapshot("map");
    const internal::EncodedBlob blob = internal::EncodeBlob("bytes");
    ASSERT_THAT(
        old.database().InTransaction(
            internal::TransactionMode::kWrite,
            [&](internal::SqlTransaction& t) {
              RETURN_IF_ERROR(t.Exec(
                  "INSERT INTO runs (run_id, robot_id, firmware, robot_model, started_at_ms, ended_at_ms, "
                  "child_snapshot_id, "
                  "telemetry, telemetry_crc32, telemetry_size, payload_sha256, uploaded_at_ms) VALUES "
                  "('old-run', $1, 'fw', "
                  "'vac', 5, 6, $2, $3, $4, $5, 'digest', 7)",
                  {std::string(kKept), snapshot, SqlBlob{blob.compressed}, blob.crc32, blob.raw_size}));
              RETURN_IF_ERROR(
                  t.Exec("INSERT INTO reports (run_id, parameter_set, recovery_created, recovery_accepted, "
                         "merge_created, "
                         "merge_conditionally_accepted, merge_conditional_then_rejected, views_total, "
                         "views_ambiguous, "
                         "started_localized, protrusions_found, data, data_crc32, data_size, created_at_ms, "
                         "recovery_retracted) "
                         "VALUES ('old-run', 'default', 4, 1, 0, 0, 0, 9, 2, 1, 1, $1, $2, $3, 8, 3)",
                         {SqlBlob{blob.compressed}, blob.crc32, blob.raw_size}));
              RETURN_IF_ERROR(
                  t.Exec("INSERT INTO protrusion_regions (run_id, parameter_set, region_id, min_x, min_y, "
                         "max_x, max_y, "
                         "features_json, predicted_class, probability, label, labelled_by) VALUES "
                         "('old-run', 'default', 1, 0, 0, "
                         "1, 1, '{}', 'protrusion', 0.9, 'new_space', 'engineer:ana')",
                         {}));
              return t.Exec(
                  "INSERT INTO map_versions (robot_id, version, snapshot_id, origin, run_id, action, "
                  "action_detail, created_by, "
                  "reason, created_at_ms, approval, approved_by, approved_at_ms, nodes, edges, "
                  "observation_edges, views, "
                  "components, known_area_m2, chi2, open_findings) VALUES ($1, 1, $2, 'upload', 'old-run', "
                  "'', '', 'r', '', "
                  "1, 'approved', '', 0, 0, 0, 0, 0, 0, 0, 0, 0)",
                  {std::string(kKept), snapshot});
            }),
        IsOk());
  }
  auto upgraded = internal::OpenSqlRepository(url, OpenOptions{});
  ASSERT_THAT(upgraded, IsOk());
  internal::SqlRepository& repository = **upgraded;
  EXPECT_EQ(*repository.SchemaVersion(), LatestSchemaVersion());
  auto report = repository.GetReport({kKept, "old-run"}, "default");
  ASSERT_THAT(report, IsOk());
  EXPECT_EQ(report->recovery_created, 4);
  EXPECT_EQ(report->recovery_retracted, 3);
  EXPECT_EQ(repository.ListProtrusionRegions({kKept, "old-run"}, "default")->front().label, "new_space");
  EXPECT_EQ(repository.ListProtrusionRegions({kKept, "old-run"}, "default")->front().decided_by, "")
      << "a region analysed before migration 9 does not say what decided it";
  EXPECT_EQ(repository.GetMapVersionOfRun({kKept, "old-run"})->version, 1);
  EXPECT_EQ(repository.GetRun({kKept, "old-run"})->telemetry, "bytes");
  EXPECT_EQ(report->report, "bytes");
  EXPECT_EQ(repository.Aggregate(RunFilter{})->views_ambiguous, 2);
  // The later migrations' tables work on the rebuilt ones: metadata of a new version, a credential's epoch.
  MapVersionRecord imported = Version(kKept, *repository.PutSnapshot("imported map"), "");
  imported.origin = MapOrigin::kImport;
  imported.parent_version = 1;
  imported.metadata = "rooms";
  auto appended = repository.AppendMapVersion(imported, std::nullopt, {});
  ASSERT_THAT(appended, IsOk());
  EXPECT_EQ(*repository.GetMapMetadata(kKept, appended->version), "rooms");
  ASSERT_THAT(repository.SetCredential("robot:" + std::string(kKept), "secret"), IsOk());
  EXPECT_EQ(repository.CredentialChangesSince(0, 10)->principals,
            std::vector<std::string>{"robot:" + std::string(kKept)});
}

TEST_P(TenancyContractTest, ForeignKeysNameTheRebuiltTablesAfterEveryMigration) {
  // Migration 4 renames runs_v4 & co. to their old names; map_metadata (5) must reference map_versions, and no
  // foreign key may be left naming a *_v4 table or a dropped one.
  const std::string sql =
      GetParam() == Backend::kSqlite
          ? "SELECT m.name, f.\"table\" FROM sqlite_master m JOIN pragma_foreign_key_list(m.name) f "
            "WHERE m.type = 'table' ORDER BY 1, 2"
          : "SELECT conrelid::regclass::text, confrelid::regclass::text FROM pg_constraint WHERE contype = "
            "'f' "
            "ORDER BY 1, 2";
  std::set<std::pair<std::string, std::string>> references;
  for (const auto& row : RawQuery(sql)) references.insert({row.Text(0), row.Text(1)});
  const std::set<std::pair<std::string, std::string>> expected = {{"ambiguous_views", "reports"},
                                                                  {"decisions", "reports"},
                                                                  {"jobs", "jobs"},
                                                                  {"map_findings", "map_versions"},
                                                                  {"map_metadata", "map_versions"},
                                                                  {"map_versions", "robots"},
                                                                  {"map_versions", "snapshots"},
                                                                  {"protrusion_regions", "reports"},
                                                                  {"reports", "parameter_sets"},
                                                                  {"reports", "runs"},
                                                                  {"runs", "robots"},
                                                                  {"runs", "snapshots"}};
  EXPECT_EQ(references, expected);
}

TEST_P(TenancyContractTest, DeletingARobotLeavesNothingOfItAndOthersWhole) {
  std::string kept_child;
  Populate(kKept, std::nullopt, &kept_child);
  ASSERT_FALSE(HasFatalFailure());
  // The erased robot's first run builds on the kept robot's map: that snapshot is shared and must survive.
  std::string erased_child;
  Populate(kErased, kept_child, &erased_child);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_THAT(repo().SetCredential("engineer:ana", "secret of ana"), IsOk());
  const std::map<std::string, int> kept_before = RowsMentioning(kKept);
  const std::int64_t snapshots_before = Count("SELECT COUNT(*) FROM snapshots");
  const std::int64_t epoch_before = repo().CredentialChangesSince(-1, 100)->epoch;

  auto erased = repo().DeleteRobot(kErased, "admin:root");
  ASSERT_THAT(erased, IsOk());
  EXPECT_EQ(erased->runs, 2);
  EXPECT_EQ(erased->reports, 4) << "every parameter set";
  EXPECT_EQ(erased->decisions, 4);
  EXPECT_EQ(erased->ambiguous_views, 4);
  EXPECT_EQ(erased->protrusion_regions, 4);
  EXPECT_EQ(erased->map_versions, 2);
  EXPECT_EQ(erased->map_findings, 2);
  EXPECT_EQ(erased->snapshots, 2) << "its child and repaired maps; the kept robot's parent map stays";
  EXPECT_EQ(erased->jobs, 2);
  EXPECT_EQ(erased->credentials, 1);
  EXPECT_EQ(erased->map_metadata, 1);
  // Its credential row is gone, so the erasure's epoch tells every poller to drop its cached tokens.
  auto changes = repo().CredentialChangesSince(epoch_before, 100);
  ASSERT_THAT(changes, IsOk());
  EXPECT_TRUE(changes->truncated) << "an erased credential leaves no row to name";
  EXPECT_GT(changes->epoch, epoch_before);
  EXPECT_FALSE(repo().CredentialChangesSince(changes->epoch, 100)->truncated) << "reported once";

  // Nothing names it in any table but the audit entry that records the erasure.
  std::map<std::string, int> left = RowsMentioning(kErased);
  EXPECT_EQ(left["audit_log"], 1);
  left.erase("audit_log");
  EXPECT_TRUE(left.empty()) << "rows of the erased robot left in " << left.begin()->first;
  EXPECT_EQ(repo().GetRobot(kErased).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(repo().GetSnapshot(erased_child).status().code(), StatusCode::kNotFound)
      << "content-addressed blob gone";
  EXPECT_EQ(Count("SELECT COUNT(*) FROM snapshots"), snapshots_before - 2);
  EXPECT_FALSE(*repo().VerifyCredential("robot:" + std::string(kErased), "secret of erased-robot"));
  EXPECT_EQ(Count("SELECT COUNT(*) FROM jobs WHERE robot_id IS NULL OR robot_id <> $1", {std::string(kKept)}),
            0);

  // The other robot is whole, its shared snapshot included.
  EXPECT_EQ(RowsMentioning(kKept), kept_before);
  EXPECT_THAT(repo().GetSnapshot(kept_child), IsOk());
  EXPECT_EQ(repo().GetRun({kKept, "run-2"})->telemetry, "events of kept-robot run-2");
  EXPECT_EQ(*repo().ListReportParameterSets({kKept, "run-1"}),
            (std::vector<std::string>{"default", "tuned"}));
  EXPECT_EQ(repo().ListMapVersions(kKept)->size(), 2u);
  EXPECT_TRUE(*repo().VerifyCredential("robot:" + std::string(kKept), "secret of kept-robot"));
  EXPECT_TRUE(*repo().VerifyCredential("engineer:ana", "secret of ana"));

  auto audit = repo().ListAudit(10, std::nullopt);
  ASSERT_EQ(audit->size(), 1u);
  EXPECT_EQ((*audit)[0].actor, "admin:root");
  EXPECT_EQ((*audit)[0].action, "delete_robot");
  EXPECT_EQ((*audit)[0].subject, kErased);
  EXPECT_NE((*audit)[0].detail_json.find("\"runs\":2"), std::string::npos) << (*audit)[0].detail_json;

  // A second delete finds nothing and writes nothing.
  EXPECT_EQ(repo().DeleteRobot(kErased, "admin:root").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(repo().ListAudit(10, std::nullopt)->size(), 1u);
}

TEST_P(TenancyContractTest, RetentionPrunesOldRunEventsInBatchesKeepingReportsAndMaps) {
  std::string child;
  Populate(kKept, std::nullopt, &child);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_EQ(*repo().InsertRun(MakeRun("run-3", 1000, 200, kKept)), InsertOutcome::kInserted);
  RawQuery("UPDATE runs SET uploaded_at_ms = 100 WHERE run_id <> 'run-3'");
  EXPECT_EQ(*repo().PruneRunTelemetry(200, 1), 1);
  EXPECT_EQ(*repo().PruneRunTelemetry(200, 1), 1);
  EXPECT_EQ(*repo().PruneRunTelemetry(200, 1), 0) << "only the two old runs";
  auto pruned = repo().GetRun({kKept, "run-1"});
  ASSERT_THAT(pruned, IsOk());
  EXPECT_TRUE(pruned->telemetry.empty());
  EXPECT_EQ(pruned->telemetry_size, 0);
  EXPECT_TRUE(pruned->telemetry_pruned_at_ms.has_value());
  EXPECT_EQ(pruned->child_snapshot_id, child);
  EXPECT_FALSE(repo().GetRun({kKept, "run-3"})->telemetry_pruned_at_ms.has_value());
  EXPECT_EQ(repo().GetRun({kKept, "run-3"})->telemetry.size(), 200u);
  EXPECT_THAT(repo().GetReport({kKept, "run-1"}, "tuned"), IsOk()) << "reports are kept";
  EXPECT_EQ(repo().ListMapVersions(kKept)->size(), 2u) << "map versions are kept";
  EXPECT_THAT(repo().GetSnapshot(child), IsOk());
  EXPECT_EQ(repo().ListRuns(RunFilter{}, 10, std::nullopt)->runs.size(), 3u);
  EXPECT_EQ(repo().PruneRunTelemetry(200, 0).status().code(), StatusCode::kInvalidArgument);
}

TEST_P(TenancyContractTest, RetentionDeletesFinishedJobsChildrenBeforeParents) {
  const auto lease_and = [&](bool complete) {
    auto lease = repo().LeaseJob("worker", std::chrono::milliseconds(60000), "");
    ASSERT_THAT(lease, IsOk());
    ASSERT_TRUE(lease->has_value());
    ASSERT_THAT(complete ? repo().CompleteJob(**lease) : repo().FailJob(**lease, "no"), IsOk());
  };
  const std::int64_t parent = *repo().EnqueueJob(NewJob{"reprocess", "p", 1});
  const std::int64_t child = *repo().EnqueueJob(NewJob{"analyze_run", "c", 1, parent});
  lease_and(true);
  lease_and(false);  // max_attempts 1: failed
  const std::int64_t cancelled = *repo().EnqueueJob(NewJob{"analyze_run", "x", 1});
  ASSERT_THAT(repo().CancelJob(cancelled), IsOk());
  const std::int64_t recent = *repo().EnqueueJob(NewJob{"analyze_run", "r", 1});
  lease_and(true);
  const std::int64_t queued = *repo().EnqueueJob(NewJob{"analyze_run", "q", 1});
  RawQuery("UPDATE jobs SET updated_at_ms = 100 WHERE job_id <> $1", {recent});

  EXPECT_EQ(*repo().PruneFinishedJobs(200, 1000), 2) << "the child and the cancelled job; the parent waits";
  EXPECT_THAT(repo().GetJob(parent), IsOk());
  EXPECT_EQ(repo().GetJob(child).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(*repo().PruneFinishedJobs(200, 1000), 1) << "then the parent";
  EXPECT_EQ(*repo().PruneFinishedJobs(200, 1000), 0);
  EXPECT_EQ(repo().GetJob(queued)->state, JobState::kQueued) << "unfinished jobs stay, however old";
  EXPECT_EQ(repo().GetJob(recent)->state, JobState::kDone) << "finished within the retention period";
  EXPECT_EQ(repo().PruneFinishedJobs(200, 10001).status().code(), StatusCode::kInvalidArgument);
}

TEST_P(TenancyContractTest, ErasureAndRetentionOfFiveHundredRunsAreMeasured) {
  constexpr int kRuns = 500;
  for (int i = 0; i < kRuns; ++i) {
    const std::string run_id = "run-" + std::to_string(i);
    ASSERT_EQ(*repo().InsertRun(MakeRun(run_id, 1000 + i, 4096, kKept)), InsertOutcome::kInserted);
    ASSERT_THAT(repo().PutReport(Report(kKept, run_id, "default")), IsOk());
    ASSERT_EQ(*repo().InsertRun(MakeRun(run_id, 1000 + i, 4096, kErased)), InsertOutcome::kInserted);
    ASSERT_THAT(repo().PutReport(Report(kErased, run_id, "default")), IsOk());
  }
  auto started = std::chrono::steady_clock::now();
  std::int64_t pruned = 0;
  for (std::int64_t batch; (batch = *repo().PruneRunTelemetry(NowMsForTest() + 1000, 500)) > 0;)
    pruned += batch;
  const double prune_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(pruned, 2 * kRuns);
  started = std::chrono::steady_clock::now();
  auto erased = repo().DeleteRobot(kErased, "admin:root");
  const double delete_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ASSERT_THAT(erased, IsOk());
  EXPECT_EQ(erased->runs, kRuns);
  EXPECT_EQ(erased->reports, kRuns);
  std::printf(
      "[ measured ] %s: retention of %d runs' events %.3f s (batches of 500); erasure of a robot with %d "
      "runs "
      "and reports %.3f s\n",
      GetParam() == Backend::kSqlite ? "SQLite" : "PostgreSQL", 2 * kRuns, prune_seconds, kRuns,
      delete_seconds);
  EXPECT_EQ(repo().ListRuns(RunFilter{}, 1000, std::nullopt)->runs.size(), static_cast<std::size_t>(kRuns));
}

TEST_P(TenancyContractTest, AuditLogListsNewestFirstAndPages) {
  for (int i = 0; i < 3; ++i) {
    ASSERT_THAT(repo().AppendAudit(AuditEntry{0, 0, "fleetd:retention", "prune_jobs", "policy", "{}"}),
                IsOk());
  }
  auto page = repo().ListAudit(2, std::nullopt);
  ASSERT_EQ(page->size(), 2u);
  EXPECT_GT((*page)[0].entry_id, (*page)[1].entry_id);
  EXPECT_GT((*page)[0].at_ms, 0);
  auto rest = repo().ListAudit(2, (*page)[1].entry_id);
  ASSERT_EQ(rest->size(), 1u);
  EXPECT_LT((*rest)[0].entry_id, (*page)[1].entry_id);
  EXPECT_EQ(repo().AppendAudit(AuditEntry{}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().ListAudit(0, std::nullopt).status().code(), StatusCode::kInvalidArgument);
}

INSTANTIATE_TEST_SUITE_P(Backends, TenancyContractTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

}  // namespace
}  // namespace storage::testing
