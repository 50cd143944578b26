// The Repository contract, run against both back-ends: everything but the job queue (job_queue_contract_test)
// and crash behaviour (crash_consistency_test).
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "crypto.h"
#include "test_databases.h"
#include "status_matchers.h"

namespace storage::testing {
namespace {

using internal::SqlBlob;
using internal::SqlValue;

class RepositoryContractTest : public BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (HasFatalFailure()) return;
    for (const char* robot : {"robot-1", "robot-2"}) {
      ASSERT_THAT(repo().PutRobot(RobotRecord{robot, "vac-s", "fw-1.2", 1000}), IsOk());
    }
    ASSERT_THAT(repo().PutParameterSet({"default", "params-a"}), IsOk());
    ASSERT_THAT(repo().PutParameterSet({"tuned", "params-b"}), IsOk());
  }

  static ReportBundle MakeReport(const std::string& run_id, const std::string& parameter_set,
                                 std::int64_t scale, const std::string& robot_id = "robot-1") {
    ReportBundle bundle;
    ReportRecord& r = bundle.report;
    r.robot_id = robot_id;
    r.run_id = run_id;
    r.parameter_set = parameter_set;
    r.recovery_created = 2 * scale;
    r.recovery_accepted = scale;
    r.recovery_retracted = 5 * scale;
    r.merge_created = 3 * scale;
    r.merge_conditionally_accepted = 2 * scale;
    r.merge_conditional_then_rejected = scale;
    r.views_total = 100 * scale;
    r.views_ambiguous = 7 * scale;
    r.started_localized = scale % 2 == 1;
    r.protrusions_found = 4 * scale;
    r.report = "full report of " + run_id + "/" + parameter_set + std::string(3, '\0');
    bundle.decisions = {{1, 1.5, "recovery", "created", 11, 0.9, "d1"},
                        {2, 2.5, "merge", "accepted", 12, 0.8, ""}};
    bundle.ambiguous_views = {{5, 3.0, 3, 0.4, "corridor"}};
    ProtrusionRegionRecord region;
    region.region_id = 1;
    region.bbox = {0.0, 0.5, 1.0, 1.5};
    region.features_json = R"({"height":0.12})";
    region.predicted_class = "cable";
    region.probability = 0.75;
    region.decided_by = "views";
    bundle.protrusion_regions = {region};
    region.region_id = 2;
    region.predicted_class = "sock";
    region.decided_by = "classifier";
    bundle.protrusion_regions.push_back(region);
    return bundle;
  }
};

TEST_P(RepositoryContractTest, OpensAtTheLatestSchemaVersion) {
  auto version = repo().SchemaVersion();
  ASSERT_THAT(version, IsOk());
  EXPECT_EQ(*version, LatestSchemaVersion());
  Reopen();  // migrating an up-to-date database is a no-op
  EXPECT_EQ(*repo().SchemaVersion(), LatestSchemaVersion());
}

TEST_P(RepositoryContractTest, RobotsUpsertKeepingRegistrationTime) {
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-1", "vac-m", "fw-2.0", 5000}), IsOk());
  auto robot = repo().GetRobot("robot-1");
  ASSERT_THAT(robot, IsOk());
  EXPECT_EQ(robot->robot_model, "vac-m");
  EXPECT_EQ(robot->firmware, "fw-2.0");
  EXPECT_EQ(robot->registered_at_ms, 1000);
  EXPECT_EQ(repo().GetRobot("nobody").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(repo().ListRobots()->size(), 2u);
}

TEST_P(RepositoryContractTest, CredentialsKeepOnlyASaltedHash) {
  ASSERT_THAT(repo().SetCredential("robot-1", "s3cret"), IsOk());
  ASSERT_THAT(repo().SetCredential("robot-2", "s3cret"), IsOk());
  EXPECT_TRUE(*repo().VerifyCredential("robot-1", "s3cret"));
  EXPECT_FALSE(*repo().VerifyCredential("robot-1", "wrong"));
  EXPECT_FALSE(*repo().VerifyCredential("stranger", "s3cret"));
  auto rows = RawQuery("SELECT salt, hash FROM credentials ORDER BY principal");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NE(rows[0].Text(0), rows[1].Text(0)) << "each credential has its own salt";
  EXPECT_NE(rows[0].Text(1), rows[1].Text(1)) << "same secret, different hashes";
  EXPECT_EQ(rows[0].Text(1).find("s3cret"), std::string::npos);
}

TEST_P(RepositoryContractTest, SnapshotsAreContentAddressedAndStoredOnce) {
  const std::string bytes = std::string("map\0bytes", 9) + std::string(5000, 'x');
  auto first = repo().PutSnapshot(bytes);
  auto second = repo().PutSnapshot(bytes);
  ASSERT_THAT(first, IsOk());
  ASSERT_THAT(second, IsOk());
  EXPECT_EQ(*first, *second);
  EXPECT_EQ(first->size(), 64u);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM snapshots")[0].Int(0), 1);
  auto read = repo().GetSnapshot(*first);
  ASSERT_THAT(read, IsOk());
  EXPECT_EQ(read->bytes, bytes);
  EXPECT_EQ(repo().GetSnapshot(std::string(64, '0')).status().code(), StatusCode::kNotFound);
}

TEST_P(RepositoryContractTest, RunRoundTripsWithItsTelemetry) {
  RunRecord run = MakeRun("run-1", 10000, 200000);
  run.parent_snapshot_id = *repo().PutSnapshot("parent map");
  run.child_snapshot_id = *repo().PutSnapshot("child map");
  ASSERT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted);
  auto read = repo().GetRun(RunKey{"robot-1", "run-1"});
  ASSERT_THAT(read, IsOk());
  EXPECT_EQ(read->telemetry, run.telemetry);
  EXPECT_EQ(read->telemetry_size, 200000);
  EXPECT_EQ(read->parent_snapshot_id, run.parent_snapshot_id);
  EXPECT_EQ(read->child_snapshot_id, run.child_snapshot_id);
  EXPECT_EQ(read->robot_model, "vac-s");
  EXPECT_LT(RawQuery("SELECT LENGTH(telemetry) FROM runs")[0].Int(0), 200000) << "stored compressed";
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "run-2"}).status().code(), StatusCode::kNotFound);
}

TEST_P(RepositoryContractTest, SameRunTwiceStoresOneRun) {
  const RunRecord run = MakeRun("run-1", 10000);
  EXPECT_EQ(*repo().InsertRun(run), InsertOutcome::kInserted);
  EXPECT_EQ(*repo().InsertRun(run), InsertOutcome::kAlreadyPresent);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0), 1);
}

TEST_P(RepositoryContractTest, DifferentPayloadUnderTheSameRunIdIsAConflict) {
  RunRecord run = MakeRun("run-1", 10000);
  ASSERT_THAT(repo().InsertRun(run), IsOk());
  run.telemetry[10] ^= 1;
  EXPECT_EQ(repo().InsertRun(run).status().code(), StatusCode::kAlreadyExists);
  run = MakeRun("run-1", 10001);
  EXPECT_EQ(repo().InsertRun(run).status().code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "run-1"})->started_at_ms, 10000) << "the first payload stays";
}

/// An upload as ingest stores it: robot-1's run with its child map (and a parent map sent along).
UploadBundle MakeUpload(const std::string& run_id, const std::string& child_map,
                        const std::string& parent_map = "") {
  UploadBundle upload;
  upload.robot = {"robot-1", "vac-s", "fw-2.0", 0};
  upload.run = MakeRun(run_id, 10000);
  if (!parent_map.empty()) {
    upload.snapshots.push_back(parent_map);
    upload.run.parent_snapshot_id = internal::Sha256Hex(parent_map);
  }
  upload.snapshots.push_back(child_map);
  upload.run.child_snapshot_id = internal::Sha256Hex(child_map);
  upload.analysis_job = {.kind = "analyze_run", .payload = run_id, .robot_id = "robot-1"};
  upload.map_version.robot_id = "robot-1";
  upload.map_version.snapshot_id = *upload.run.child_snapshot_id;
  upload.map_version.origin = MapOrigin::kUpload;
  upload.map_version.run_id = run_id;
  upload.map_version.approval = MapApproval::kApproved;
  MapFindingRecord finding;
  finding.finding_id = 1;
  finding.summary = "a loose edge";
  upload.findings = {finding};
  return upload;
}

TEST_P(RepositoryContractTest, AnUploadIsStoredWholeAndARetryAddsNothing) {
  auto stored = repo().StoreUpload(MakeUpload("run-1", "child map", "parent map"));
  ASSERT_THAT(stored, IsOk());
  EXPECT_EQ(stored->run, InsertOutcome::kInserted);
  EXPECT_EQ(stored->map_version.version, 1);
  EXPECT_EQ(stored->map_version.open_findings, 1);
  EXPECT_EQ(repo().GetRobot("robot-1")->firmware, "fw-2.0");
  EXPECT_EQ(repo().GetSnapshot(internal::Sha256Hex("parent map"))->bytes, "parent map");
  EXPECT_EQ(repo().GetSnapshot(internal::Sha256Hex("child map"))->bytes, "child map");
  EXPECT_EQ(repo().GetRun(RunKey{"robot-1", "run-1"})->telemetry, MakeRun("run-1", 10000).telemetry);
  auto job = repo().GetJob(stored->analysis_job_id);
  ASSERT_THAT(job, IsOk());
  EXPECT_EQ(job->payload, "run-1");
  EXPECT_EQ(repo().ListMapFindings("robot-1", 1)->size(), 1u);

  // The same upload again (a client retrying after a lost answer): the same version, no second job.
  auto retried = repo().StoreUpload(MakeUpload("run-1", "child map", "parent map"));
  ASSERT_THAT(retried, IsOk());
  EXPECT_EQ(retried->run, InsertOutcome::kAlreadyPresent);
  EXPECT_EQ(retried->analysis_job_id, 0);
  EXPECT_EQ(retried->map_version.version, 1);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM jobs")[0].Int(0), 1);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM map_versions")[0].Int(0), 1);

  // The next run, built on the first run's map, sent by id: the parent is not sent again.
  UploadBundle next = MakeUpload("run-2", "next child map");
  next.run.parent_snapshot_id = internal::Sha256Hex("child map");
  next.map_version.parent_version = 1;
  auto second = repo().StoreUpload(next);
  ASSERT_THAT(second, IsOk());
  EXPECT_EQ(second->map_version.version, 2);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM snapshots")[0].Int(0), 3);
}

TEST_P(RepositoryContractTest, AnUploadThatFailsLeavesNothingBehind) {
  ASSERT_THAT(repo().StoreUpload(MakeUpload("run-1", "child map")), IsOk());
  const auto count = [&](const std::string& table) {
    return RawQuery("SELECT COUNT(*) FROM " + table)[0].Int(0);
  };
  // A different payload under the same run id: refused before anything of it is kept, even the robot's
  // new firmware and the new map, which were written earlier in the same transaction.
  UploadBundle conflicting = MakeUpload("run-1", "another child map");
  conflicting.robot.firmware = "fw-3.0";
  EXPECT_EQ(repo().StoreUpload(conflicting).status().code(), StatusCode::kAlreadyExists);
  // A parent map that is neither sent nor stored: the run cannot name it.
  UploadBundle orphan = MakeUpload("run-2", "third child map");
  orphan.run.parent_snapshot_id = std::string(64, 'a');
  EXPECT_EQ(repo().StoreUpload(orphan).status().code(), StatusCode::kFailedPrecondition);
  // A map version of another robot's run is no part of this upload.
  UploadBundle mismatched = MakeUpload("run-3", "fourth child map");
  mismatched.map_version.robot_id = "robot-2";
  EXPECT_EQ(repo().StoreUpload(mismatched).status().code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(repo().GetRobot("robot-1")->firmware, "fw-2.0");
  EXPECT_EQ(count("snapshots"), 1);
  EXPECT_EQ(count("runs"), 1);
  EXPECT_EQ(count("jobs"), 1);
  EXPECT_EQ(count("map_versions"), 1);
  EXPECT_EQ(count("map_findings"), 1);
}

TEST_P(RepositoryContractTest, RunMustNameStoredRobotAndSnapshots) {
  EXPECT_EQ(repo().InsertRun(MakeRun("run-1", 0, 10, "unregistered")).status().code(),
            StatusCode::kFailedPrecondition);
  RunRecord run = MakeRun("run-2", 0);
  run.parent_snapshot_id = std::string(64, 'a');
  EXPECT_EQ(repo().InsertRun(run).status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0), 0);
}

TEST_P(RepositoryContractTest, CorruptBlobsAreDataLossNeverData) {
  ASSERT_THAT(repo().InsertRun(MakeRun("run-1", 0, 5000)), IsOk());
  const std::string snapshot = *repo().PutSnapshot("a map snapshot");
  ASSERT_THAT(repo().PutReport(MakeReport("run-1", "default", 1)), IsOk());
  // Flip one stored byte of each blob behind the repository's back.
  auto flip = [&](const std::string& table, const std::string& column, const std::string& key_column,
                  const std::string& key) {
    auto rows = RawQuery("SELECT " + column + " FROM " + table + " WHERE " + key_column + " = $1", {key});
    ASSERT_EQ(rows.size(), 1u);
    std::string bytes = rows[0].Text(0);
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5A);
    RawQuery("UPDATE " + table + " SET " + column + " = $2 WHERE " + key_column + " = $1",
             {key, SqlBlob{bytes}});
  };
  flip("runs", "telemetry", "run_id", "run-1");
  flip("snapshots", "data", "snapshot_id", snapshot);
  flip("reports", "data", "run_id", "run-1");
  auto run = repo().GetRun(RunKey{"robot-1", "run-1"});
  EXPECT_EQ(run.status().code(), StatusCode::kDataLoss) << run.status().ToString();
  EXPECT_NE(run.status().message().find("run-1"), std::string::npos);
  EXPECT_EQ(repo().GetSnapshot(snapshot).status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(repo().GetReport(RunKey{"robot-1", "run-1"}, "default").status().code(), StatusCode::kDataLoss);
  // A checksum that no longer matches is caught too, even when the bytes themselves are intact.
  ASSERT_THAT(repo().PutParameterSet({"third", "params-c"}), IsOk());
  RawQuery("UPDATE parameter_sets SET data_crc32 = data_crc32 + 1 WHERE name = 'third'");
  EXPECT_EQ(repo().GetParameterSet("third").status().code(), StatusCode::kDataLoss);
}

TEST_P(RepositoryContractTest, ReportsOfParameterSetsSitSideBySide) {
  ASSERT_THAT(repo().InsertRun(MakeRun("run-1", 0)), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("run-1", "default", 1)), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("run-1", "tuned", 2)), IsOk());
  EXPECT_EQ(*repo().ListReportParameterSets(RunKey{"robot-1", "run-1"}),
            (std::vector<std::string>{"default", "tuned"}));
  auto tuned = repo().GetReport(RunKey{"robot-1", "run-1"}, "tuned");
  ASSERT_THAT(tuned, IsOk());
  EXPECT_EQ(tuned->merge_created, 6);
  EXPECT_EQ(tuned->recovery_retracted, 10);
  EXPECT_FALSE(tuned->started_localized);
  EXPECT_EQ(tuned->report, MakeReport("run-1", "tuned", 2).report.report);
  auto decisions = repo().ListDecisions(RunKey{"robot-1", "run-1"}, "default");
  ASSERT_EQ(decisions->size(), 2u);
  EXPECT_EQ((*decisions)[1].outcome, "accepted");
  EXPECT_DOUBLE_EQ((*decisions)[0].score, 0.9);
  ASSERT_EQ(repo().ListAmbiguousViews(RunKey{"robot-1", "run-1"}, "default")->size(), 1u);
  EXPECT_EQ((*repo().ListAmbiguousViews(RunKey{"robot-1", "run-1"}, "default"))[0].detail, "corridor");
  auto regions = repo().ListProtrusionRegions(RunKey{"robot-1", "run-1"}, "tuned");
  ASSERT_EQ(regions->size(), 2u);
  EXPECT_EQ((*regions)[0].features_json, R"({"height":0.12})");
  EXPECT_DOUBLE_EQ((*regions)[0].bbox.max_y, 1.5);
  EXPECT_EQ((*regions)[0].decided_by, "views");
  EXPECT_EQ((*regions)[1].decided_by, "classifier");
  EXPECT_EQ(repo().GetReport(RunKey{"robot-1", "run-1"}, "other").status().code(), StatusCode::kNotFound);
}

TEST_P(RepositoryContractTest, ReportNeedsAStoredRunAndParameterSet) {
  ASSERT_THAT(repo().InsertRun(MakeRun("run-1", 0)), IsOk());
  EXPECT_EQ(repo().PutReport(MakeReport("run-1", "unknown", 1)).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().PutReport(MakeReport("run-9", "default", 1)).code(), StatusCode::kFailedPrecondition);
}

TEST_P(RepositoryContractTest, ReplacingAReportKeepsEngineersLabels) {
  ASSERT_THAT(repo().InsertRun(MakeRun("run-1", 0)), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("run-1", "default", 1)), IsOk());
  ASSERT_THAT(repo().LabelProtrusionRegion(RunKey{"robot-1", "run-1"}, "default", 2, "shoe", "alice"),
              IsOk());
  EXPECT_EQ(repo().LabelProtrusionRegion(RunKey{"robot-1", "run-1"}, "default", 9, "shoe", "alice").code(),
            StatusCode::kNotFound);
  ReportBundle retried = MakeReport("run-1", "default", 3);
  retried.decisions.pop_back();
  ASSERT_THAT(repo().PutReport(retried), IsOk());
  EXPECT_EQ(repo().GetReport(RunKey{"robot-1", "run-1"}, "default")->merge_created, 9);
  EXPECT_EQ(repo().ListDecisions(RunKey{"robot-1", "run-1"}, "default")->size(), 1u);
  auto labelled = repo().ListLabelledRegions("default", 10);
  ASSERT_EQ(labelled->size(), 1u);
  EXPECT_EQ((*labelled)[0].region_id, 2);
  EXPECT_EQ((*labelled)[0].label, "shoe");
  EXPECT_EQ((*labelled)[0].labelled_by, "alice");
  EXPECT_EQ((*labelled)[0].run_id, "run-1");
  EXPECT_TRUE(repo().ListLabelledRegions("tuned", 10)->empty());
}

TEST_P(RepositoryContractTest, ParameterSetsAndModelsAreImmutableOnceStored) {
  EXPECT_EQ(*repo().PutParameterSet({"default", "params-a"}), InsertOutcome::kAlreadyPresent);
  EXPECT_EQ(repo().PutParameterSet({"default", "changed"}).status().code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(repo().GetParameterSet("default")->serialized, "params-a");
  EXPECT_EQ(*repo().ListParameterSetNames(), (std::vector<std::string>{"default", "tuned"}));

  ASSERT_EQ(*repo().PutModel({"protrusion", 1, "weights-1", true}), InsertOutcome::kInserted);
  ASSERT_EQ(*repo().PutModel({"protrusion", 2, "weights-2", false}), InsertOutcome::kInserted);
  EXPECT_EQ(repo().PutModel({"protrusion", 2, "other", false}).status().code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(repo().GetActiveModel("protrusion")->version, 1);
  ASSERT_THAT(repo().ActivateModel("protrusion", 2), IsOk());
  auto active = repo().GetActiveModel("protrusion");
  EXPECT_EQ(active->version, 2);
  EXPECT_EQ(active->bytes, "weights-2");
  EXPECT_FALSE(repo().GetModel("protrusion", 1)->active);
  EXPECT_EQ(repo().ActivateModel("protrusion", 7).code(), StatusCode::kNotFound);
  EXPECT_EQ(repo().GetActiveModel("other").status().code(), StatusCode::kNotFound);
}

TEST_P(RepositoryContractTest, ListRunsPagesByStartTimeThenRunId) {
  // Ties on started_at_ms are broken by run_id, so no run is skipped or repeated across pages.
  for (int i = 0; i < 7; ++i) {
    ASSERT_THAT(repo().InsertRun(MakeRun("run-" + std::to_string(i), 1000 * (i / 2), 10,
                                         i % 3 == 0 ? "robot-2" : "robot-1")),
                IsOk());
  }
  std::vector<std::string> seen;
  std::optional<RunCursor> cursor;
  int pages = 0;
  do {
    auto page = repo().ListRuns(RunFilter{}, 3, cursor);
    ASSERT_THAT(page, IsOk());
    for (const RunRecord& run : page->runs) {
      seen.push_back(run.run_id);
      EXPECT_TRUE(run.telemetry.empty());
      EXPECT_EQ(run.telemetry_size, 10);
    }
    cursor = page->next;
    ++pages;
  } while (cursor && pages < 10);
  EXPECT_EQ(pages, 3);
  EXPECT_EQ(seen, (std::vector<std::string>{"run-0", "run-1", "run-2", "run-3", "run-4", "run-5", "run-6"}));

  RunFilter by_robot;
  by_robot.robot_id = "robot-2";
  by_robot.started_from_ms = 1;
  auto page = repo().ListRuns(by_robot, 10, std::nullopt);
  ASSERT_EQ(page->runs.size(), 2u);  // run-3 (t=1000) and run-6 (t=3000); run-0 starts at 0
  EXPECT_EQ(page->runs[0].run_id, "run-3");
  EXPECT_FALSE(page->next);
  EXPECT_EQ(repo().ListRuns(RunFilter{}, 0, std::nullopt).status().code(), StatusCode::kInvalidArgument);
}

TEST_P(RepositoryContractTest, AggregatesFleetStatisticsInTheDatabase) {
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-3", "vac-m", "fw-2.0", 0}), IsOk());
  const std::int64_t day = 86400000;
  ASSERT_THAT(repo().InsertRun(MakeRun("a", 0 * day + 5)), IsOk());
  ASSERT_THAT(repo().InsertRun(MakeRun("b", 1 * day + 5, 10, "robot-2")), IsOk());
  RunRecord c = MakeRun("c", 1 * day + 9, 10, "robot-3");
  c.firmware = "fw-2.0";
  ASSERT_THAT(repo().InsertRun(c), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("a", "default", 1)), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("b", "default", 2, "robot-2")), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("c", "default", 3, "robot-3")), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("a", "tuned", 10)), IsOk());

  RunFilter defaults;
  defaults.parameter_set = "default";
  auto all = repo().Aggregate(defaults);
  ASSERT_THAT(all, IsOk());
  EXPECT_EQ(all->reports, 3);
  EXPECT_EQ(all->robots, 3);
  EXPECT_EQ(all->merge_created, 3 * (1 + 2 + 3));
  EXPECT_EQ(all->views_total, 600);
  EXPECT_EQ(all->started_localized, 2);  // scales 1 and 3
  EXPECT_EQ(all->protrusions_found, 24);
  EXPECT_EQ(all->recovery_retracted, 5 * (1 + 2 + 3));

  RunFilter narrow = defaults;
  narrow.firmware = "fw-1.2";
  narrow.started_from_ms = day;
  narrow.started_before_ms = 2 * day;
  auto one = repo().Aggregate(narrow);
  EXPECT_EQ(one->reports, 1);
  EXPECT_EQ(one->recovery_accepted, 2);

  EXPECT_EQ(repo().Aggregate(RunFilter{})->reports, 4) << "no parameter set: every report counts";
  RunFilter nothing;
  nothing.robot_id = "robot-9";
  EXPECT_EQ(repo().Aggregate(nothing)->reports, 0);

  auto by_day = repo().AggregateBy(defaults, GroupBy::kDay);
  ASSERT_EQ(by_day->size(), 2u);
  EXPECT_EQ((*by_day)[0].key, "0");
  EXPECT_EQ((*by_day)[1].key, "1");
  EXPECT_EQ((*by_day)[1].statistics.reports, 2);
  auto by_set = repo().AggregateBy(RunFilter{}, GroupBy::kParameterSet);
  ASSERT_EQ(by_set->size(), 2u);
  EXPECT_EQ((*by_set)[1].key, "tuned");
  EXPECT_EQ((*by_set)[1].statistics.merge_created, 30);
  auto by_firmware = repo().AggregateBy(defaults, GroupBy::kFirmware);
  ASSERT_EQ(by_firmware->size(), 2u);
  EXPECT_EQ((*by_firmware)[1].key, "fw-2.0");
  EXPECT_EQ(repo().AggregateBy(defaults, GroupBy::kRobot)->size(), 3u);
  EXPECT_EQ(repo().AggregateBy(defaults, GroupBy::kRobotModel)->size(), 1u);
}

TEST_P(RepositoryContractTest, InjectionAttemptsInValuesAreHarmless) {
  const std::string attacks[] = {"x'; DROP TABLE runs; --",    "' OR '1'='1", "robot-1' --",
                                 "\"; DELETE FROM robots; --", "$1",          "robot-1%"};
  ASSERT_THAT(repo().InsertRun(MakeRun("run-1", 0)), IsOk());
  ASSERT_THAT(repo().PutReport(MakeReport("run-1", "default", 1)), IsOk());
  for (const std::string& attack : attacks) {
    RunFilter filter;
    filter.robot_id = attack;
    EXPECT_TRUE(repo().ListRuns(filter, 10, std::nullopt)->runs.empty()) << attack;
    EXPECT_EQ(repo().Aggregate(filter)->reports, 0) << attack;
    filter = RunFilter{};
    filter.firmware = attack;
    filter.parameter_set = attack;
    EXPECT_EQ(repo().Aggregate(filter)->reports, 0) << attack;
    EXPECT_EQ(repo().GetRun(RunKey{"robot-1", attack}).status().code(), StatusCode::kNotFound) << attack;
    EXPECT_FALSE(*repo().VerifyCredential(attack, attack));
  }
  // The same strings are stored and returned verbatim as data.
  ASSERT_THAT(repo().PutRobot(RobotRecord{attacks[0], attacks[1], attacks[2], 1}), IsOk());
  ASSERT_THAT(repo().InsertRun(MakeRun(attacks[1], 5, 10, attacks[0])), IsOk());
  EXPECT_EQ(repo().GetRun(RunKey{attacks[0], attacks[1]})->robot_id, attacks[0]);
  RunFilter exact;
  exact.robot_id = attacks[0];
  EXPECT_EQ(repo().ListRuns(exact, 10, std::nullopt)->runs.size(), 1u);
  EXPECT_EQ(RawQuery("SELECT COUNT(*) FROM runs")[0].Int(0), 2) << "the runs table survived";
  EXPECT_EQ(repo().ListRobots()->size(), 3u);
}

TEST_P(RepositoryContractTest, RejectsMalformedInputWithAStatus) {
  EXPECT_EQ(repo().PutRobot(RobotRecord{}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().InsertRun(MakeRun("", 0)).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().InsertRun(MakeRun(std::string("nul\0id", 6), 0)).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().InsertRun(MakeRun(std::string(500, 'r'), 0)).status().code(),
            StatusCode::kInvalidArgument);
  RunRecord backwards = MakeRun("run-1", 100);
  backwards.ended_at_ms = 50;
  EXPECT_EQ(repo().InsertRun(backwards).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().SetCredential("robot-1", "").code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(repo().ListLabelledRegions("", 0).status().code(), StatusCode::kInvalidArgument);
}

static MapVersionRecord MakeVersion(const std::string& robot, const std::string& snapshot, MapOrigin origin,
                                    const std::string& run_id = "") {
  MapVersionRecord version;
  version.robot_id = robot;
  version.snapshot_id = snapshot;
  version.origin = origin;
  version.run_id = run_id;
  version.approval = origin == MapOrigin::kUpload ? MapApproval::kApproved : MapApproval::kPending;
  version.created_by = origin == MapOrigin::kUpload ? "robot:" + robot : "engineer:ana";
  version.nodes = 10;
  version.known_area_m2 = 12.5;
  return version;
}

TEST_P(RepositoryContractTest, MapVersionsNumberPerRobotWithLineageAndFindings) {
  const std::string a = *repo().PutSnapshot("map a"), b = *repo().PutSnapshot("map b");
  ASSERT_EQ(*repo().InsertRun(MakeRun("run-1", 1000, 10)), InsertOutcome::kInserted);
  auto first = repo().AppendMapVersion(
      MakeVersion("robot-1", a, MapOrigin::kUpload, "run-1"), std::nullopt,
      {{1, FindingKind::kProtrusion, 0.8, "region 3", FindingState::kOpen, R"({"x":1})"},
       {2, FindingKind::kAmbiguousView, 0.1, "4 views", FindingState::kInfo, "{}"}});
  ASSERT_THAT(first, IsOk());
  EXPECT_EQ(first->version, 1);
  EXPECT_EQ(first->open_findings, 1) << "info findings are not open";
  // Retrying the upload's version returns the one already made.
  auto retried =
      repo().AppendMapVersion(MakeVersion("robot-1", b, MapOrigin::kUpload, "run-1"), std::nullopt, {});
  ASSERT_THAT(retried, IsOk());
  EXPECT_EQ(retried->version, 1);
  EXPECT_EQ(retried->snapshot_id, a);

  MapVersionRecord repair = MakeVersion("robot-1", b, MapOrigin::kRepair, "run-1");
  repair.parent_version = 1;
  repair.action = MapAction::kCutRegion;
  auto second = repo().AppendMapVersion(repair, 1, {});
  ASSERT_THAT(second, IsOk());
  EXPECT_EQ(second->version, 2);
  // Another robot counts from 1.
  auto other = repo().AppendMapVersion(MakeVersion("robot-2", b, MapOrigin::kRollback), std::nullopt, {});
  ASSERT_THAT(other, IsOk());
  EXPECT_EQ(other->version, 1);

  auto versions = repo().ListMapVersions("robot-1");
  ASSERT_THAT(versions, IsOk());
  ASSERT_EQ(versions->size(), 2u);
  EXPECT_EQ((*versions)[1].parent_version, 1);
  EXPECT_EQ((*versions)[1].action, MapAction::kCutRegion);
  EXPECT_DOUBLE_EQ((*versions)[0].known_area_m2, 12.5);
  EXPECT_EQ(repo().GetMapVersionOfRun(RunKey{"robot-1", "run-1"})->version, 1);
  EXPECT_EQ(repo().GetMapVersionOfRun(RunKey{"robot-1", "run-9"}).status().code(), StatusCode::kNotFound);
  auto findings = repo().ListMapFindings("robot-1", 1);
  ASSERT_THAT(findings, IsOk());
  ASSERT_EQ(findings->size(), 2u);
  EXPECT_EQ((*findings)[0].detail_json, R"({"x":1})");

  // Findings of a version are replaced as a whole, with its open count and known area.
  ASSERT_THAT(repo().UpdateMapVersionHealth(
                  "robot-1", 2, 40.25,
                  {{1, FindingKind::kHighResidualEdge, 0.7, "edge 3→9", FindingState::kOpen, "{}"},
                   {2, FindingKind::kProtrusion, 0.6, "region", FindingState::kOpen, "{}"}}),
              IsOk());
  EXPECT_EQ(repo().GetMapVersion("robot-1", 2)->open_findings, 2);
  EXPECT_DOUBLE_EQ(repo().GetMapVersion("robot-1", 2)->known_area_m2, 40.25);
  ASSERT_THAT(repo().UpdateMapVersionHealth("robot-1", 2, 40.25, {}), IsOk());
  EXPECT_EQ(repo().GetMapVersion("robot-1", 2)->open_findings, 0);
  EXPECT_TRUE(repo().ListMapFindings("robot-1", 2)->empty());
  EXPECT_EQ(repo().UpdateMapVersionHealth("robot-1", 7, 0.0, {}).code(), StatusCode::kNotFound);
}

TEST_P(RepositoryContractTest, TheCurrentVersionAndTheVersionOfASnapshotAreTheNewestThatFit) {
  const std::string a = *repo().PutSnapshot("map a"), b = *repo().PutSnapshot("map b");
  EXPECT_FALSE(repo().GetCurrentMapVersion("robot-1")->has_value()) << "no versions yet";
  EXPECT_FALSE(repo().GetCurrentMapVersion("robot-9")->has_value()) << "no such robot: no current version";
  // v1 a approved, v2 b approved, v3 a pending, v4 b rejected.
  for (const auto& [snapshot, approval] :
       std::vector<std::pair<std::string, MapApproval>>{{a, MapApproval::kApproved},
                                                        {b, MapApproval::kApproved},
                                                        {a, MapApproval::kPending},
                                                        {b, MapApproval::kPending}}) {
    MapVersionRecord version = MakeVersion("robot-1", snapshot, MapOrigin::kRollback);
    version.approval = approval;
    ASSERT_THAT(repo().AppendMapVersion(version, std::nullopt, {}), IsOk());
  }
  ASSERT_THAT(repo().ReviewMapVersion("robot-1", 4, false, "engineer:ana"), IsOk());
  auto current = repo().GetCurrentMapVersion("robot-1");
  ASSERT_THAT(current, IsOk());
  ASSERT_TRUE(current->has_value());
  EXPECT_EQ((*current)->version, 2) << "the newest approved, not the newest";
  EXPECT_EQ((*current)->snapshot_id, b);
  EXPECT_EQ((*repo().FindMapVersionOfSnapshot("robot-1", a))->version, 3);
  EXPECT_EQ((*repo().FindMapVersionOfSnapshot("robot-1", b))->version, 4) << "whatever its approval";
  EXPECT_FALSE(repo().FindMapVersionOfSnapshot("robot-2", a)->has_value()) << "another robot's versions";
  EXPECT_FALSE(repo().FindMapVersionOfSnapshot("robot-1", std::string(64, 'f'))->has_value());
}

TEST_P(RepositoryContractTest, TheRobotsPageSummarisesEachHistoryAndPagesByRobot) {
  // robot-1: v1 upload (approved), v2 repair (pending, 2 open findings), v3 rejected, v4 pending (1 open).
  // robot-2: no versions. robot-3: v1 approved, v2 approved. robot-4: v1 pending.
  const std::string a = *repo().PutSnapshot("map a");
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-3", "vac-l", "fw-3.0", 7000}), IsOk());
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-4", "vac-s", "fw-3.0", 8000}), IsOk());
  ASSERT_EQ(*repo().InsertRun(MakeRun("run-1", 1000, 10)), InsertOutcome::kInserted);
  ASSERT_THAT(
      repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kUpload, "run-1"), std::nullopt, {}),
      IsOk());
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 1,
                                      {{1, FindingKind::kProtrusion, 0.8, "r", FindingState::kOpen, "{}"},
                                       {2, FindingKind::kProtrusion, 0.7, "s", FindingState::kOpen, "{}"}}),
              IsOk());
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 2, {}), IsOk());
  ASSERT_THAT(repo().ReviewMapVersion("robot-1", 3, false, "engineer:ana"), IsOk());
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 2,
                                      {{1, FindingKind::kProtrusion, 0.9, "t", FindingState::kOpen, "{}"}}),
              IsOk());
  for (int i = 0; i < 2; ++i) {
    MapVersionRecord approved = MakeVersion("robot-3", a, MapOrigin::kRollback);
    approved.approval = MapApproval::kApproved;
    ASSERT_THAT(repo().AppendMapVersion(approved, std::nullopt, {}), IsOk());
  }
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-4", a, MapOrigin::kRollback), std::nullopt, {}),
              IsOk());

  const auto Page = [](const std::string& after, int limit, bool only_pending) {
    RobotSummaryQuery query;
    query.after_robot_id = after;
    query.limit = limit;
    query.only_pending = only_pending;
    return query;
  };
  auto all = repo().ListRobotSummaries(RobotSummaryQuery{});
  ASSERT_THAT(all, IsOk());
  EXPECT_EQ(all->total, 4);
  EXPECT_FALSE(all->more);
  ASSERT_EQ(all->robots.size(), 4u);
  const RobotMapSummary& one = all->robots[0];
  EXPECT_EQ(one.robot.robot_id, "robot-1");
  EXPECT_EQ(one.versions, static_cast<std::int64_t>(repo().ListMapVersions("robot-1")->size()));
  EXPECT_EQ(one.versions, 4);
  EXPECT_EQ(one.current_version, 1) << "the newest approved version";
  EXPECT_EQ(one.pending_versions, 2);
  EXPECT_EQ(one.newest_approval, MapApproval::kPending);
  EXPECT_EQ(one.newest_open_findings, 1) << "the newest version's, not v2's";
  const RobotMapSummary& two = all->robots[1];
  EXPECT_EQ(two.robot.robot_model, "vac-s");
  EXPECT_EQ(two.versions, 0);
  EXPECT_EQ(two.current_version, 0);
  EXPECT_FALSE(two.newest_approval.has_value());
  EXPECT_EQ(all->robots[2].current_version, 2);
  EXPECT_EQ(all->robots[2].pending_versions, 0);
  EXPECT_EQ(all->robots[2].newest_approval, MapApproval::kApproved);
  EXPECT_EQ(all->robots[3].robot.firmware, "fw-3.0");
  EXPECT_EQ(all->robots[3].current_version, 0);

  // Keyset pages of two: robot-1, robot-2, then robot-3, robot-4 and no more.
  auto first = repo().ListRobotSummaries(Page("", 2, false));
  ASSERT_THAT(first, IsOk());
  ASSERT_EQ(first->robots.size(), 2u);
  EXPECT_TRUE(first->more);
  auto second = repo().ListRobotSummaries(Page(first->robots.back().robot.robot_id, 2, false));
  ASSERT_THAT(second, IsOk());
  ASSERT_EQ(second->robots.size(), 2u);
  EXPECT_EQ(second->robots[0].robot.robot_id, "robot-3");
  EXPECT_FALSE(second->more);

  // Only robots waiting for review: robot-1 and robot-4, paged the same way.
  auto pending = repo().ListRobotSummaries(Page("", 1, true));
  ASSERT_THAT(pending, IsOk());
  EXPECT_EQ(pending->total, 2);
  ASSERT_EQ(pending->robots.size(), 1u);
  EXPECT_EQ(pending->robots[0].robot.robot_id, "robot-1");
  EXPECT_TRUE(pending->more);
  pending = repo().ListRobotSummaries(Page("robot-1", 1, true));
  ASSERT_THAT(pending, IsOk());
  ASSERT_EQ(pending->robots.size(), 1u);
  EXPECT_EQ(pending->robots[0].robot.robot_id, "robot-4");
  EXPECT_FALSE(pending->more);

  auto single = repo().GetRobotSummary("robot-3");
  ASSERT_THAT(single, IsOk());
  EXPECT_EQ(single->versions, 2);
  EXPECT_EQ(repo().GetRobotSummary("robot-9").status().code(), StatusCode::kNotFound);
  for (const int limit : {0, -1, kMaxRobotPage + 1}) {
    auto refused = repo().ListRobotSummaries(Page("", limit, false));
    EXPECT_EQ(refused.status().code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(refused.status().message(), ::testing::HasSubstr("limit"));
  }
}

TEST_P(RepositoryContractTest, AMapVersionBasedOnAnOldHeadIsAborted) {
  const std::string a = *repo().PutSnapshot("map a");
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRollback), std::nullopt, {}),
              IsOk());
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRollback), 1, {}), IsOk());
  auto stale = repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRollback), 1, {});
  EXPECT_EQ(stale.status().code(), StatusCode::kAborted) << stale.status().ToString();
  EXPECT_EQ(repo().ListMapVersions("robot-1")->size(), 2u) << "nothing written";
  // Rejected and stale versions are side branches: the head stays at the newest approved or pending one.
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 2, {}),
              IsOk());  // 3, pending
  ASSERT_THAT(repo().ReviewMapVersion("robot-1", 3, false, "engineer:ana"), IsOk());
  MapVersionRecord outdated_upload = MakeVersion("robot-1", a, MapOrigin::kUpload, "run-x");
  outdated_upload.approval = MapApproval::kStale;
  ASSERT_EQ(*repo().InsertRun(MakeRun("run-x", 5000, 10)), InsertOutcome::kInserted);
  ASSERT_EQ(repo().AppendMapVersion(outdated_upload, std::nullopt, {})->version, 4);
  EXPECT_EQ(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 3, {}).status().code(),
            StatusCode::kAborted);
  auto continued = repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 2, {});
  ASSERT_THAT(continued, IsOk());
  EXPECT_EQ(continued->version, 5);
  // References are checked.
  EXPECT_EQ(repo()
                .AppendMapVersion(MakeVersion("nobody", a, MapOrigin::kRollback), std::nullopt, {})
                .status()
                .code(),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo()
                .AppendMapVersion(MakeVersion("robot-1", std::string(64, 'f'), MapOrigin::kRollback),
                                  std::nullopt, {})
                .status()
                .code(),
            StatusCode::kFailedPrecondition);
  MapVersionRecord orphan = MakeVersion("robot-1", a, MapOrigin::kRepair);
  orphan.parent_version = 9;
  EXPECT_EQ(repo().AppendMapVersion(orphan, std::nullopt, {}).status().code(),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo()
                .AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kUpload), std::nullopt, {})
                .status()
                .code(),
            StatusCode::kInvalidArgument)
      << "an upload version names its run";
}

TEST_P(RepositoryContractTest, AVersionThatSupersedesAPendingOneMarksItStaleInTheSameTransaction) {
  const std::string a = *repo().PutSnapshot("map a"), b = *repo().PutSnapshot("map b");
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRollback), std::nullopt, {}),
              IsOk());  // 1
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", b, MapOrigin::kRepair), 1, {}),
              IsOk());  // 2, pending
  MapVersionRecord carried = MakeVersion("robot-1", b, MapOrigin::kRepair);
  carried.parent_version = 1;
  carried.approval = MapApproval::kApproved;
  carried.approved_by = "engineer:bo";
  carried.supersedes_pending = 2;
  auto appended = repo().AppendMapVersion(carried, 2, {});
  ASSERT_THAT(appended, IsOk());
  EXPECT_EQ(appended->version, 3);
  const auto superseded = repo().GetMapVersion("robot-1", 2);
  EXPECT_EQ(superseded->approval, MapApproval::kStale);
  EXPECT_EQ(superseded->approved_by, "engineer:bo");
  // Superseding a version that is no longer pending writes nothing.
  auto again = repo().AppendMapVersion(carried, 3, {});
  EXPECT_EQ(again.status().code(), StatusCode::kAborted) << again.status().ToString();
  EXPECT_NE(again.status().message().find("version 2 of robot robot-1 is no longer pending"),
            std::string::npos)
      << again.status().message();
  EXPECT_EQ(repo().ListMapVersions("robot-1")->size(), 3u) << "nothing written";
}

TEST_P(RepositoryContractTest, ImportedMapVersionsNeedNoRun) {
  const std::string a = *repo().PutSnapshot("map a"), b = *repo().PutSnapshot("map b");
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-9", "", "", 1000}), IsOk());
  MapVersionRecord imported = MakeVersion("robot-9", a, MapOrigin::kImport);
  imported.action = MapAction::kImport;
  imported.action_detail = "valetudo:home.json";
  auto first = repo().AppendMapVersion(imported, std::nullopt, {});
  ASSERT_THAT(first, IsOk());
  imported.snapshot_id = b;
  imported.parent_version = 1;
  auto second = repo().AppendMapVersion(imported, 1, {});
  ASSERT_THAT(second, IsOk());
  auto versions = repo().ListMapVersions("robot-9");
  ASSERT_THAT(versions, IsOk());
  ASSERT_EQ(versions->size(), 2u);
  EXPECT_EQ((*versions)[1].origin, MapOrigin::kImport);
  EXPECT_EQ((*versions)[1].action_detail, "valetudo:home.json");
  EXPECT_EQ((*versions)[1].parent_version, 1);
  EXPECT_TRUE((*versions)[1].run_id.empty());
}

TEST_P(RepositoryContractTest, MetadataIsKeptWithItsVersionAndReadOnlyByGetMapMetadata) {
  const std::string a = *repo().PutSnapshot("map a");
  ASSERT_THAT(repo().PutRobot(RobotRecord{"robot-9", "", "", 1000}), IsOk());
  MapVersionRecord imported = MakeVersion("robot-9", a, MapOrigin::kImport);
  imported.metadata =
      std::string("rooms\0zones", 11) + std::string(100000, 'm');  // opaque bytes, NULs included
  auto first = repo().AppendMapVersion(imported, std::nullopt, {});
  ASSERT_THAT(first, IsOk());
  EXPECT_TRUE(first->metadata.empty());
  imported.metadata.clear();
  ASSERT_THAT(repo().AppendMapVersion(imported, 1, {}), IsOk());
  EXPECT_EQ(*repo().GetMapMetadata("robot-9", 1), std::string("rooms\0zones", 11) + std::string(100000, 'm'));
  EXPECT_EQ(*repo().GetMapMetadata("robot-9", 2), "");   // a version without metadata
  EXPECT_EQ(*repo().GetMapMetadata("robot-9", 99), "");  // no such version
  EXPECT_EQ(*repo().GetMapMetadata("nobody", 1), "");
  EXPECT_TRUE((*repo().ListMapVersions("robot-9"))[0].metadata.empty());  // lists stay light
  // Past the bound: refused, and nothing is appended.
  imported.metadata.assign(kMaxMapMetadataBytes + 1, 'x');
  const auto refused = repo().AppendMapVersion(imported, 2, {});
  EXPECT_THAT(refused, StatusIs(StatusCode::kInvalidArgument));
  EXPECT_NE(refused.status().message().find("metadata"), std::string::npos);
  EXPECT_EQ(repo().ListMapVersions("robot-9")->size(), 2u);
}

TEST_P(RepositoryContractTest, ConcurrentRepairsOfOneMapNeverInterleave) {
  const std::string a = *repo().PutSnapshot("map a");
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRollback), std::nullopt, {}),
              IsOk());
  // Eight writers, each with its own connection, all read head 1 and try to append on it: one wins.
  constexpr int kWriters = 8;
  std::atomic<int> won{0}, aborted{0};
  std::vector<std::thread> writers;
  for (int i = 0; i < kWriters; ++i) {
    writers.emplace_back([&] {
      auto own = OpenRepository(url_);
      if (!own.ok()) return;
      auto appended =
          (*own)->AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), 1,
                                   {{1, FindingKind::kProtrusion, 0.5, "x", FindingState::kOpen, "{}"}});
      if (appended.ok()) ++won;
      if (appended.status().code() == StatusCode::kAborted) ++aborted;
    });
  }
  for (auto& writer : writers) writer.join();
  EXPECT_EQ(won.load(), 1);
  EXPECT_EQ(aborted.load(), kWriters - 1);
  EXPECT_EQ(repo().ListMapVersions("robot-1")->size(), 2u);
  EXPECT_EQ(repo().ListMapFindings("robot-1", 2)->size(), 1u);
}

TEST_P(RepositoryContractTest, OnlyPendingVersionsAreReviewed) {
  const std::string a = *repo().PutSnapshot("map a");
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), std::nullopt, {}),
              IsOk());
  ASSERT_THAT(repo().AppendMapVersion(MakeVersion("robot-1", a, MapOrigin::kRepair), std::nullopt, {}),
              IsOk());
  auto approved = repo().ReviewMapVersion("robot-1", 1, true, "engineer:ana");
  ASSERT_THAT(approved, IsOk());
  EXPECT_EQ(approved->approval, MapApproval::kApproved);
  EXPECT_EQ(approved->approved_by, "engineer:ana");
  EXPECT_GT(approved->approved_at_ms, 0);
  EXPECT_EQ(repo().ReviewMapVersion("robot-1", 1, false, "engineer:bo").status().code(),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(repo().GetMapVersion("robot-1", 1)->approval, MapApproval::kApproved)
      << "a refused review changes nothing";
  EXPECT_EQ(repo().ReviewMapVersion("robot-1", 2, false, "engineer:bo")->approval, MapApproval::kRejected);
  EXPECT_EQ(repo().ReviewMapVersion("robot-1", 3, true, "engineer:bo").status().code(),
            StatusCode::kNotFound);
}

INSTANTIATE_TEST_SUITE_P(Backends, RepositoryContractTest,
                         ::testing::Values(Backend::kSqlite, Backend::kPostgres), BackendName);

}  // namespace
}  // namespace storage::testing
