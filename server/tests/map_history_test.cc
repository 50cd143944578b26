// MapHistory on a real SQLite file: versions from uploads, findings from the analysis, the repair policy that
// cuts protrusions out of a robot's map after its run is analysed, with and without automatic approval, and
// imported maps compared with the version before them, cut and rolled back.
#include "server/map_history.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "analyzer/map_comparison.h"
#include "analyzer/telemetry_codec.h"
#include "fleet/serialization.h"
#include "server/analysis.h"
#include "server/auth.h"
#include "sqlite_repository_test.h"
#include "status_matchers.h"

namespace server {
namespace {

using slamcore::SE2;

/// A 1 m square patch of free cells with one occupied row, centred on its node.
slamcore::LocalMapEvent Patch() {
  slamcore::LocalMapEvent patch;
  patch.resolution = 0.05;
  patch.width = patch.height = 20;
  patch.node_T_origin = SE2(-0.5, -0.5, 0.0);
  patch.cells.assign(400, 0);
  for (int i = 0; i < 20; ++i) patch.cells[static_cast<std::size_t>(i)] = 100;
  return patch;
}

/// A chain of `count` nodes from `first`, 0.5 m apart along the x axis from `x0`, with patches, joined to the
/// node before `first` when `join` (so the run's nodes are in the home component).
void AddChain(slamcore::Map& map, slamcore::NodeId first, int count, double x0, bool join) {
  for (int i = 0; i < count; ++i) {
    const slamcore::NodeId id = first + i;
    ASSERT_THAT(map.graph.AddNode({.id = id, .pose = SE2(x0 + 0.5 * i, 0.0, 0.0)}), IsOk());
    map.local_maps[id] = Patch();
    if (i == 0 && !join) continue;
    const slamcore::NodeId previous = id - 1;
    slamcore::Edge edge;
    edge.from = previous;
    edge.to = id;
    edge.measurement = map.graph.node(previous).pose.inverse() * map.graph.node(id).pose;
    edge.information = slamcore::Matrix3::Identity() * 100.0;
    ASSERT_THAT(map.graph.AddEdge(edge), IsOk());
  }
}

class MapHistoryTest : public SqliteRepositoryTest {
 protected:
  void SetUp() override {
    SqliteRepositoryTest::SetUp();
    if (HasFatalFailure()) return;
    ASSERT_THAT(repository_->PutRobot({"r1", "vac", "fw", 0}), IsOk());
    ASSERT_THAT(repository_->PutParameterSet({"default", "-"}), IsOk());

    AddChain(parent_, 0, 10, 0.0, false);
    child_ = parent_;
    AddChain(child_, 10, 10, 5.0, true);  // the run drove on past the end of the home map
  }
  /// An upload of robot r1's run whose parent and child maps are given, as ingest builds it.
  storage::UploadBundle Upload(const std::string& run_id, const slamcore::Map* parent,
                               const slamcore::Map& child) {
    storage::UploadBundle upload;
    upload.robot = {"r1", "vac", "fw", 0};
    storage::RunRecord& run = upload.run;
    run.run_id = run_id;
    run.robot_id = "r1";
    if (parent) {
      upload.snapshots.push_back(fleet::SerializeDeterministic(analyzer::ToProto(*parent)));
      run.parent_snapshot_id = Sha256Hex(upload.snapshots.back());
    }
    upload.snapshots.push_back(fleet::SerializeDeterministic(analyzer::ToProto(child)));
    run.child_snapshot_id = Sha256Hex(upload.snapshots.back());
    run.telemetry = "telemetry of " + run_id;
    upload.analysis_job.kind = "analyze_run";
    return upload;
  }

  /// The default set's report of the second run, stored as a worker stores it: the rerun agrees with the
  /// robot, one protrusion region around run nodes 13..16 (x 6.5..8.0), clear of the home map (x up to 5.0).
  fleet::v1::RunReport Report(const std::string& decided_by = "classifier") {
    fleet::v1::RunReport report;
    report.set_robot_id("r1");
    report.set_run_id("run-1");
    report.set_parameter_set("default");
    *report.mutable_rerun_child() = analyzer::ToProto(child_);
    fleet::v1::ProtrusionRegion* region = report.add_protrusion_regions();
    region->set_id(1);
    region->set_predicted_class("protrusion");
    region->set_probability(0.93);
    region->set_decided_by(decided_by);
    for (const double value : {6.4, -0.4, 8.1, 0.4}) region->add_world_bbox(value);
    EXPECT_THAT(repository_->PutReport(ToReportBundle(report)), IsOk());
    return report;
  }

  void UploadBoth(MapHistory& history) {
    auto v1 = history.StoreUpload(Upload("run-0", nullptr, parent_), parent_);
    ASSERT_THAT(v1, IsOk());
    auto v2 = history.StoreUpload(Upload("run-1", &parent_, child_), child_);
    ASSERT_THAT(v2, IsOk());
    EXPECT_EQ(v2->version, 2);
    EXPECT_EQ(v2->current_version, 2);
    EXPECT_FALSE(v2->outdated);
    EXPECT_FALSE(v2->already_present);
    EXPECT_GT(v2->analysis_job_id, 0);
    // A retried upload gets the same version, and no second analysis job.
    auto retried = history.StoreUpload(Upload("run-1", &parent_, child_), child_);
    ASSERT_THAT(retried, IsOk());
    EXPECT_EQ(retried->version, 2);
    EXPECT_TRUE(retried->already_present);
    EXPECT_EQ(retried->analysis_job_id, 0);
    EXPECT_EQ(repository_->ListJobs(std::nullopt, 10)->size(), 2u);
  }

  slamcore::Map parent_, child_;
};

TEST_F(MapHistoryTest, WithoutAPolicyAProtrusionIsAnOpenFindingAndTheMapStays) {
  MapHistory history(*repository_, {});
  UploadBoth(history);
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  auto detail = history.Get("r1", 2);
  ASSERT_THAT(detail, IsOk());
  ASSERT_EQ(detail->findings.size(), 1u);
  EXPECT_EQ(detail->findings[0].finding_kind(), fleet::v1::FINDING_KIND_PROTRUSION);
  EXPECT_EQ(detail->findings[0].finding_state(), fleet::v1::FINDING_STATE_OPEN);
  EXPECT_EQ(detail->version.open_findings(), 1);
  std::int64_t current = 0, head = 0;
  EXPECT_EQ(history.List("r1", &current, &head)->size(), 2u);
  EXPECT_EQ(current, 2);
  EXPECT_EQ(head, 2);
}

TEST_F(MapHistoryTest, TheMapsTheAnalysisDecodedGiveWhatStorageGives) {
  MapHistory history(*repository_, {});
  UploadBoth(history);
  const fleet::v1::RunReport report = Report();
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, report), IsOk());
  auto from_storage = history.Get("r1", 2);
  ASSERT_THAT(from_storage, IsOk());
  ASSERT_GT(from_storage->version.known_area_m2(), 0.0);
  auto upload = repository_->GetMapVersionOfRun({"r1", "run-1"});
  ASSERT_THAT(upload, IsOk());

  ASSERT_THAT(repository_->UpdateMapVersionHealth("r1", 2, 0.0, {}), IsOk());
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, report, {parent_, child_, upload->snapshot_id}), IsOk());
  auto from_worker = history.Get("r1", 2);
  ASSERT_THAT(from_worker, IsOk());
  EXPECT_EQ(from_worker->version.known_area_m2(), from_storage->version.known_area_m2());
  ASSERT_EQ(from_worker->findings.size(), from_storage->findings.size());
  for (std::size_t i = 0; i < from_worker->findings.size(); ++i) {
    EXPECT_EQ(from_worker->findings[i].SerializeAsString(), from_storage->findings[i].SerializeAsString());
  }

  // The maps given are the ones used (storage is not read again): a bigger uploaded map, a bigger area...
  slamcore::Map bigger = child_;
  AddChain(bigger, 20, 10, 10.0, true);
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, report, {parent_, bigger, upload->snapshot_id}), IsOk());
  EXPECT_GT(history.Get("r1", 2)->version.known_area_m2(), from_storage->version.known_area_m2());
  // ...unless they were decoded from another snapshot than the version's: then the version's is read.
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, report, {parent_, bigger, "another snapshot"}), IsOk());
  EXPECT_EQ(history.Get("r1", 2)->version.known_area_m2(), from_storage->version.known_area_m2());
}

TEST_F(MapHistoryTest, FindingsStoredWhileKindAndStateWereStringsReadAsBefore) {
  MapHistory history(*repository_, {});
  UploadBoth(history);
  // The JSON of a finding as servers before the wire enums stored it: kind and state spelled in it.
  const std::string legacy =
      R"({"finding_id":"1","kind":"protrusion","severity":0.8,"summary":"region 3","state":"open",)"
      R"("evidence_json":"{}","world_bbox":[6.5,-0.5,8,0.5]})";
  ASSERT_THAT(repository_->UpdateMapVersionHealth("r1", 2, 10.0,
                                                  {{1, storage::FindingKind::kProtrusion, 0.8, "region 3",
                                                    storage::FindingState::kOpen, legacy}}),
              IsOk());
  auto detail = history.Get("r1", 2);
  ASSERT_THAT(detail, IsOk());
  ASSERT_EQ(detail->findings.size(), 1u);
  EXPECT_EQ(detail->findings[0].finding_kind(), fleet::v1::FINDING_KIND_PROTRUSION);
  EXPECT_EQ(detail->findings[0].finding_state(), fleet::v1::FINDING_STATE_OPEN);
  EXPECT_EQ(detail->findings[0].summary(), "region 3");
  EXPECT_EQ(detail->findings[0].world_bbox_size(), 4);
}

TEST_F(MapHistoryTest, TheCutProtrusionsPolicyRepairsAndWaitsForReview) {
  MapHistory history(*repository_, {.auto_repair = "cut_protrusions", .protrusions = "any"});
  UploadBoth(history);
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  auto repaired = history.Get("r1", 3);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->version.version_action(), fleet::v1::MAP_ACTION_CUT_REGION);
  EXPECT_EQ(repaired->version.created_by(), "policy:cut_protrusions");
  EXPECT_EQ(repaired->version.approval_state(), fleet::v1::MAP_APPROVAL_PENDING);
  EXPECT_EQ(repaired->version.parent_version(), 2);
  ASSERT_EQ(repaired->findings.size(), 1u);
  EXPECT_EQ(repaired->findings[0].finding_state(), fleet::v1::FINDING_STATE_RESOLVED);
  EXPECT_EQ(repaired->version.open_findings(), 0);
  EXPECT_LT(repaired->version.known_area_m2(), history.Get("r1", 2)->version.known_area_m2());
  // Pending: the robot keeps version 2 until an engineer approves.
  bool up_to_date = false;
  fleet::v1::MapSnapshot snapshot;
  EXPECT_EQ(history.Fetch("r1", 2, &up_to_date, &snapshot)->version(), 2);
  EXPECT_TRUE(up_to_date);
  // The worker may analyse the run again (a retry): the policy does not cut twice.
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  std::int64_t current = 0, head = 0;
  EXPECT_EQ(history.List("r1", &current, &head)->size(), 3u);
  EXPECT_EQ(current, 2);
  EXPECT_EQ(head, 3) << "the pending repair is what further repairs start from";
}

// The default: the map-only model's calls wait for an engineer (on robot-drawn maps it also calls real new
// floor a protrusion); what the run's own views show is cut.
TEST_F(MapHistoryTest, CuttingOnlyWhatTheViewsShowLeavesTheModelsCallsToAnEngineer) {
  MapHistory history(*repository_, {.auto_repair = "cut_protrusions"});
  UploadBoth(history);
  // The map-only model's call: an open finding, no repair.
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report("classifier")), IsOk());
  std::int64_t current = 0, head = 0;
  EXPECT_EQ(history.List("r1", &current, &head)->size(), 2u);
  auto detail = history.Get("r1", 2);
  ASSERT_THAT(detail, IsOk());
  ASSERT_EQ(detail->findings.size(), 1u);
  EXPECT_EQ(detail->findings[0].finding_state(), fleet::v1::FINDING_STATE_OPEN);
  // The same region shown by the run's own views (a reanalysis): cut.
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report("views")), IsOk());
  auto repaired = history.Get("r1", 3);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->version.version_action(), fleet::v1::MAP_ACTION_CUT_REGION);
  EXPECT_EQ(repaired->version.created_by(), "policy:cut_protrusions");
  EXPECT_EQ(repaired->version.open_findings(), 0);
}

TEST_F(MapHistoryTest, ARejectedRepairIsASideBranchAndRepairsContinueFromItsBase) {
  MapHistory history(*repository_, {.auto_repair = "cut_protrusions", .protrusions = "any"});
  UploadBoth(history);
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  ASSERT_THAT(history.Review("r1", 3, /*approve=*/false, "engineer:ana"), IsOk());
  std::int64_t current = 0, head = 0;
  ASSERT_THAT(history.List("r1", &current, &head), IsOk());
  EXPECT_EQ(head, 2);
  // The rejected version cannot be continued; its base can.
  RepairRequest rollback;
  rollback.robot_id = "r1";
  rollback.base_version = 3;
  rollback.action = Rollback{};
  rollback.requested_by = "engineer:ana";
  EXPECT_EQ(history.Repair(rollback).status().code(), storage::StatusCode::kAborted);
  rollback.base_version = 2;
  auto rolled_back = history.Repair(rollback);
  ASSERT_THAT(rolled_back, IsOk());
  EXPECT_EQ(rolled_back->version.version(), 4);
  EXPECT_EQ(rolled_back->version.parent_version(), 2);
  // Approving it makes it current; an older pending version could then no longer become current.
  RepairRequest undo = rollback;
  undo.base_version = 4;
  undo.action = Undo{};
  ASSERT_THAT(history.Repair(undo), IsOk());                           // version 5, pending
  ASSERT_THAT(history.Review("r1", 5, true, "engineer:ana"), IsOk());  // current: 5
  EXPECT_EQ(history.Review("r1", 4, true, "engineer:ana").status().code(),
            storage::StatusCode::kFailedPrecondition);
}

TEST_F(MapHistoryTest, WithAutomaticApprovalTheRobotGetsTheCutMapAtOnce) {
  MapHistory history(*repository_,
                     {.auto_repair = "cut_protrusions", .protrusions = "any", .auto_approve = true});
  UploadBoth(history);
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  bool up_to_date = true;
  fleet::v1::MapSnapshot snapshot;
  auto current = history.Fetch("r1", 2, &up_to_date, &snapshot);
  ASSERT_THAT(current, IsOk());
  EXPECT_FALSE(up_to_date);
  EXPECT_EQ(current->version(), 3);
  EXPECT_EQ(current->approved_by(), "policy:cut_protrusions");
  EXPECT_EQ(snapshot.nodes_size(), 20);
}

TEST_F(MapHistoryTest, TheRepairFindingsPolicyActsOnlyOnFindingsAtLeastAsSevereAsItsThreshold) {
  {
    MapHistory history(*repository_,
                       {.auto_repair = "repair_findings", .min_severity = 1.0, .protrusions = "any"});
    UploadBoth(history);
    ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
    std::int64_t current = 0, head = 0;
    EXPECT_EQ(history.List("r1", &current, &head)->size(), 2u)
        << "a protrusion below severity 1 is left open";
    EXPECT_EQ(history.Get("r1", 2)->findings[0].finding_state(), fleet::v1::FINDING_STATE_OPEN);
  }
  MapHistory history(
      *repository_,
      {.auto_repair = "repair_findings", .min_severity = 0.1, .protrusions = "any", .auto_approve = true});
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  auto repaired = history.Get("r1", 3);
  ASSERT_THAT(repaired, IsOk());
  EXPECT_EQ(repaired->version.version_action(), fleet::v1::MAP_ACTION_CUT_REGION);
  EXPECT_EQ(repaired->version.created_by(), "policy:repair_findings");
  EXPECT_EQ(repaired->version.approval_state(), fleet::v1::MAP_APPROVAL_APPROVED);
  EXPECT_EQ(repaired->version.open_findings(), 0);
  // Analysed again (a retried job): the repaired version is the head, nothing is left to repair.
  ASSERT_THAT(history.OnRunAnalysed({"r1", "run-1"}, Report()), IsOk());
  std::int64_t current = 0, head = 0;
  EXPECT_EQ(history.List("r1", &current, &head)->size(), 3u);
  EXPECT_EQ(current, 3);
}

/// A map-only snapshot: a 6 × 5 m grid with a walled room [x0, x1] × [0.5, 4] (and a second one beside it
/// when `kitchen`), the dock at (1, 0.6).
fleet::v1::MapSnapshot ImportedRooms(bool kitchen) {
  auto grid = slamcore::OccupancyGrid::Create(160, 100, 0.05);
  EXPECT_THAT(grid, IsOk());
  const auto room = [&](double x0, double x1) {
    for (int row = 10; row <= 80; ++row) {
      for (int col = static_cast<int>(x0 / 0.05); col <= static_cast<int>(x1 / 0.05); ++col) {
        const bool edge = row == 10 || row == 80 || col == static_cast<int>(x0 / 0.05) ||
                          col == static_cast<int>(x1 / 0.05);
        if (grid->at(col, row) != 100 || !edge) grid->at(col, row) = edge ? 100 : 0;
      }
    }
  };
  room(0.5, 4.0);
  if (kitchen) room(4.0, 7.5);
  fleet::v1::MapSnapshot snapshot = analyzer::ToProto(analyzer::MapOfGrid(*grid));
  snapshot.mutable_imported()->set_format("valetudo");
  snapshot.mutable_imported()->mutable_dock()->set_x(1.0);
  snapshot.mutable_imported()->mutable_dock()->set_y(0.6);
  return snapshot;
}

/// What an export said besides its grid: one named room per room of ImportedRooms, a no-go zone, a wall.
fleet::v1::MapMetadata RoomsMetadata(bool kitchen) {
  fleet::v1::MapMetadata metadata;
  metadata.set_format("valetudo");
  metadata.set_resolution(0.05);
  const auto room = [&](const char* id, const char* name, int x0) {
    fleet::v1::MapRoom* added = metadata.add_rooms();
    added->set_segment_id(id);
    added->set_name(name);
    added->set_pixel_count(60);
    for (const int value : {x0, -20, 60}) added->add_runs(value);
  };
  room("1", "Living room", 11);
  if (kitchen) room("2", "Kitchen", 81);
  fleet::v1::MapShape* zone = metadata.add_zones();
  zone->set_type("no_go_area");
  for (const double value : {1.0, 1.0, 2.0, 1.0, 2.0, 2.0}) zone->add_xy(value);
  fleet::v1::MapShape* wall = metadata.add_virtual_walls();
  wall->set_type("virtual_wall");
  for (const double value : {0.6, 3.0, 3.0, 3.0}) wall->add_xy(value);
  return metadata;
}

std::vector<std::string> RoomNames(const std::optional<fleet::v1::MapMetadata>& metadata) {
  std::vector<std::string> names;
  if (metadata) {
    for (const fleet::v1::MapRoom& room : metadata->rooms()) names.push_back(room.name());
  }
  return names;
}

TEST_F(MapHistoryTest, ImportsAreComparedCutAndRolledBack) {
  MapHistory history(*repository_, MapPolicy{});
  auto v1 = history.Import("home", ImportedRooms(false), RoomsMetadata(false), "valetudo:a.json", "", true,
                           "engineer:e");
  ASSERT_THAT(v1, IsOk());
  // The first import has nothing to compare with, nor to roll back to.
  EXPECT_TRUE(history.Get("home", 1)->findings.empty());
  RepairRequest rollback{
      .robot_id = "home", .base_version = 1, .action = Rollback{}, .requested_by = "engineer:e"};
  EXPECT_EQ(history.Repair(rollback).status().code(), storage::StatusCode::kFailedPrecondition);

  // Bad metadata is refused naming the field, and nothing is stored.
  fleet::v1::MapSnapshot bad = ImportedRooms(true);
  bad.mutable_imported()->mutable_dock()->set_x(std::nan(""));
  auto refused = history.Import("home", bad, RoomsMetadata(true), "valetudo:b.json", "", false, "engineer:e");
  ASSERT_EQ(refused.status().code(), storage::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.status().message().find("snapshot.imported.dock"), std::string::npos)
      << refused.status().ToString();
  fleet::v1::MapMetadata absurd = RoomsMetadata(true);
  for (int i = 0; i < 1001; ++i) *absurd.add_zones() = absurd.zones(0);
  refused = history.Import("home", ImportedRooms(true), absurd, "valetudo:b.json", "", false, "engineer:e");
  ASSERT_EQ(refused.status().code(), storage::StatusCode::kInvalidArgument);
  EXPECT_NE(refused.status().message().find("metadata.zones: 1002 shapes, more than the limit 1000"),
            std::string::npos)
      << refused.status().ToString();
  fleet::v1::MapMetadata long_name = RoomsMetadata(true);
  long_name.mutable_rooms(1)->set_name(std::string(300, 'k'));
  refused =
      history.Import("home", ImportedRooms(true), long_name, "valetudo:b.json", "", false, "engineer:e");
  EXPECT_NE(refused.status().message().find("metadata.rooms[1].name: 300 bytes"), std::string::npos)
      << refused.status().ToString();
  EXPECT_EQ(repository_->ListMapVersions("home")->size(), 1u);  // nothing stored

  // The second export: the same home, now with a kitchen.
  auto v2 = history.Import("home", ImportedRooms(true), RoomsMetadata(true), "valetudo:b.json", "", false,
                           "engineer:e");
  ASSERT_THAT(v2, IsOk());
  EXPECT_EQ(v2->version(), 2);
  auto detail = history.Get("home", 2);
  ASSERT_THAT(detail, IsOk());
  EXPECT_EQ(RoomNames(detail->metadata), (std::vector<std::string>{"Living room", "Kitchen"}));
  EXPECT_EQ(detail->metadata->zones_size(), 1);
  EXPECT_EQ(detail->metadata->virtual_walls_size(), 1);
  EXPECT_EQ(RoomNames(history.Get("home", 1)->metadata), (std::vector<std::string>{"Living room"}));
  std::int64_t kitchen = 0;
  int alignments = 0, new_regions = 0;
  for (const fleet::v1::MapFinding& finding : detail->findings) {
    alignments += finding.finding_kind() == fleet::v1::FINDING_KIND_ALIGNMENT ? 1 : 0;
    if (finding.finding_kind() == fleet::v1::FINDING_KIND_NEW_REGION) {
      ++new_regions;
      kitchen = finding.finding_id();
      EXPECT_GT(finding.world_bbox(0), 3.9);
      EXPECT_LT(finding.world_bbox(2), 7.6);
    }
    EXPECT_NE(finding.finding_kind(), fleet::v1::FINDING_KIND_MISALIGNED) << finding.summary();
  }
  EXPECT_EQ(alignments, 1);
  ASSERT_EQ(new_regions, 1);

  // Edits that need a pose graph are refused; a cut takes the kitchen back to unknown and its finding is gone.
  RepairRequest edge{.robot_id = "home",
                     .base_version = 2,
                     .action = RejectEdge{.from = 0, .to = 1},
                     .requested_by = "engineer:e"};
  EXPECT_EQ(history.Repair(edge).status().code(), storage::StatusCode::kFailedPrecondition);
  RepairRequest cut{.robot_id = "home",
                    .base_version = 2,
                    .action = CutFinding{kitchen},
                    .reason = "not ours",
                    .requested_by = "engineer:e"};
  auto cut_version = history.Repair(cut);
  ASSERT_THAT(cut_version, IsOk());
  EXPECT_EQ(cut_version->version.approval_state(), fleet::v1::MAP_APPROVAL_PENDING);
  EXPECT_EQ(cut_version->version.version_action(), fleet::v1::MAP_ACTION_CUT_REGION);
  for (const fleet::v1::MapFinding& finding : cut_version->findings)
    EXPECT_NE(finding.finding_kind(), fleet::v1::FINDING_KIND_NEW_REGION);
  EXPECT_LT(cut_version->version.known_area_m2(), v2->known_area_m2() - 5.0);
  fleet::v1::MapSnapshot cut_snapshot;
  ASSERT_THAT(history.Get("home", 3, &cut_snapshot), IsOk());
  EXPECT_TRUE(cut_snapshot.imported().has_dock());  // kept for the next comparison and the hand-back
  // The cut keeps the metadata of the version it cut (its rooms and zones), and hands it back.
  EXPECT_EQ(RoomNames(cut_version->metadata), (std::vector<std::string>{"Living room", "Kitchen"}));
  EXPECT_EQ(RoomNames(history.Get("home", 3)->metadata),
            (std::vector<std::string>{"Living room", "Kitchen"}));
  auto handed_back = history.Export("home", 3, "valetudo");
  ASSERT_THAT(handed_back, IsOk());
  EXPECT_NE(handed_back->front().content().find("\"name\":\"Living room\""), std::string::npos);
  EXPECT_NE(handed_back->front().content().find("\"no_go_area\""), std::string::npos);
  // A cut's region must be a new region.
  cut.base_version = 3;
  cut.action = CutFinding{1};
  EXPECT_EQ(history.Repair(cut).status().code(), storage::StatusCode::kInvalidArgument);

  // Roll back: the map before the import, the very snapshot of version 1.
  rollback.base_version = 3;
  auto rolled = history.Repair(rollback);
  ASSERT_THAT(rolled, IsOk());
  EXPECT_EQ(rolled->version.version_origin(), fleet::v1::MAP_ORIGIN_ROLLBACK);
  EXPECT_EQ(rolled->version.snapshot_id(), v1->snapshot_id());
  // …with version 1's metadata: the rooms of the map it restores.
  EXPECT_EQ(RoomNames(history.Get("home", 4)->metadata), (std::vector<std::string>{"Living room"}));
  // Undoing the roll-back gives the cut map again, with its metadata.
  RepairRequest undo{.robot_id = "home", .base_version = 4, .action = Undo{}, .requested_by = "engineer:e"};
  auto undone = history.Repair(undo);
  ASSERT_THAT(undone, IsOk());
  EXPECT_EQ(RoomNames(undone->metadata), (std::vector<std::string>{"Living room", "Kitchen"}));
}

}  // namespace
TEST(RepairActionTest, NamesRoundTripAndUnknownNamesAreRefusedNamingTheField) {
  for (const char* name : {"reject_edge", "reject_hypothesis", "cut_finding", "rollback", "undo"}) {
    auto action = RepairActionNamed(name, "action");
    ASSERT_THAT(action, IsOk()) << name;
    EXPECT_STREQ(RepairActionName(*action), name);
  }
  auto unknown = RepairActionNamed("explode", "action");
  EXPECT_THAT(unknown, StatusIs(storage::StatusCode::kInvalidArgument));
  EXPECT_NE(unknown.status().message().find("action: \"explode\""), std::string::npos)
      << unknown.status().message();
}

TEST(MapStatesTest, WireValuesAreStoragesNamesUpperCased) {
  const auto expect_named = [](const std::string& wire_name, const std::string& prefix,
                               std::string_view name) {
    std::string upper(name);
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    EXPECT_EQ(wire_name, prefix + upper);
  };
  for (storage::MapOrigin value : storage::kMapOrigins) {
    expect_named(fleet::v1::MapOrigin_Name(ToProto(value)), "MAP_ORIGIN_", storage::Name(value));
    EXPECT_EQ(*FromProto(ToProto(value), "origin"), value);
    EXPECT_EQ(NameOf(ToProto(value)), storage::Name(value));
  }
  for (storage::MapApproval value : storage::kMapApprovals) {
    expect_named(fleet::v1::MapApproval_Name(ToProto(value)), "MAP_APPROVAL_", storage::Name(value));
    EXPECT_EQ(*FromProto(ToProto(value), "approval"), value);
  }
  for (storage::MapAction value : storage::kMapActions) {
    expect_named(fleet::v1::MapAction_Name(ToProto(value)), "MAP_ACTION_", storage::Name(value));
    EXPECT_EQ(*FromProto(ToProto(value), "action"), value);
  }
  for (storage::FindingKind value : storage::kFindingKinds) {
    expect_named(fleet::v1::FindingKind_Name(ToProto(value)), "FINDING_KIND_", storage::Name(value));
    EXPECT_EQ(*FromProto(ToProto(value), "kind"), value);
  }
  for (storage::FindingState value : storage::kFindingStates) {
    expect_named(fleet::v1::FindingState_Name(ToProto(value)), "FINDING_STATE_", storage::Name(value));
    EXPECT_EQ(*FromProto(ToProto(value), "state"), value);
  }
  // Every wire value but UNSPECIFIED has a storage value.
  EXPECT_EQ(fleet::v1::MapOrigin_ARRAYSIZE, static_cast<int>(storage::kMapOrigins.size()) + 1);
  EXPECT_EQ(fleet::v1::MapApproval_ARRAYSIZE, static_cast<int>(storage::kMapApprovals.size()) + 1);
  EXPECT_EQ(fleet::v1::MapAction_ARRAYSIZE, static_cast<int>(storage::kMapActions.size()) + 1);
  EXPECT_EQ(fleet::v1::FindingKind_ARRAYSIZE, static_cast<int>(storage::kFindingKinds.size()) + 1);
  EXPECT_EQ(fleet::v1::FindingState_ARRAYSIZE, static_cast<int>(storage::kFindingStates.size()) + 1);
}

TEST(MapStatesTest, UnspecifiedAndUnknownWireValuesAreRefusedNamingTheField) {
  EXPECT_THAT(FromProto(fleet::v1::MAP_ORIGIN_UNSPECIFIED, "version_origin"),
              StatusIs(storage::StatusCode::kInvalidArgument, "version_origin: unspecified"));
  EXPECT_THAT(FromProto(static_cast<fleet::v1::FindingKind>(99), "finding_kind"),
              StatusIs(storage::StatusCode::kInvalidArgument, "finding_kind: 99 is not a known value"));
  EXPECT_EQ(ToProto(std::optional<storage::MapAction>()), fleet::v1::MAP_ACTION_UNSPECIFIED);
  EXPECT_EQ(NameOf(fleet::v1::MAP_ACTION_UNSPECIFIED), "");
}

TEST(RepairActionTest, EachActionIsRecordedAsItsMapAction) {
  EXPECT_EQ(RecordedAction(RejectEdge{.from = 1, .to = 2}), storage::MapAction::kRejectEdge);
  EXPECT_EQ(RecordedAction(RejectHypothesis{3}), storage::MapAction::kRejectHypothesis);
  EXPECT_EQ(RecordedAction(CutFinding{4}), storage::MapAction::kCutRegion);
  EXPECT_EQ(RecordedAction(Rollback{}), storage::MapAction::kRollback);
  EXPECT_EQ(RecordedAction(Undo{}), storage::MapAction::kUndo);
}

}  // namespace server
