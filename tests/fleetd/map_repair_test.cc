// The map repair loop end to end, against a real fleetd on loopback: a robot whose own back-end runs with
// permissive parameters accepts a wrong merge (a look-alike seen as the real thing); the run's upload becomes
// a map version, the server's analysis finds the merge (its rerun with the fleet's default parameters does not
// accept it), an engineer rejects the merge, approves the repaired version, the robot downloads it, and the
// repaired map's error against the simulator's ground truth is back to where it was before the wrong merge.
// Also: undo restores the earlier map byte for byte, concurrent repairs of one map never interleave, a robot
// uploading on an outdated map is told the current version, and exports read back.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "analyzer/run_analysis.h"
#include "analyzer/telemetry_codec.h"
#include "fleet/serialization.h"
#include "fleet_client/uploader.h"
#include "fleetd_process.h"
#include "sim/run_simulator.h"
#include "sim/service_client.h"
#include "slamcore/graph_io.h"
#include "test_data.h"
#include "status_matchers.h"

namespace fleetd_test {
namespace {

using fleet::v1::RunFile;
using NodeTruth = std::unordered_map<slamcore::NodeId, slamcore::SE2>;

constexpr const char* kRobot = "repair-robot";

/// The robot's own back-end: a merge on a single observation, no conditional stage, no consistency checks.
slamcore::MapperParams PermissiveParameters() { return sim::UnprotectedMapperParams(); }

/// (robot node, view) of every observation the simulator marks wrong, by the node current at its time.
std::set<std::pair<slamcore::NodeId, std::int64_t>> WrongObservations(const RunFile& run) {
  std::vector<std::pair<double, slamcore::NodeId>> node_times;
  for (const auto& node : run.child_snapshot().nodes()) node_times.emplace_back(node.time(), node.id());
  std::sort(node_times.begin(), node_times.end());
  std::set<std::pair<slamcore::NodeId, std::int64_t>> wrong;
  for (const auto& event : run.events()) {
    if (!event.has_view_observed() || !event.view_observed().truth_wrong()) continue;
    auto after = std::upper_bound(node_times.begin(), node_times.end(),
                                  std::pair{event.time(), std::numeric_limits<slamcore::NodeId>::max()});
    if (after != node_times.begin()) wrong.emplace(std::prev(after)->second, event.view_observed().view());
  }
  return wrong;
}

/// Ground truth of the run's nodes, from a replay with the robot's parameters (the same map, node for node).
NodeTruth TruthOf(const RunFile& run, const slamcore::MapperParams& params) {
  auto parent = analyzer::FromProto(run.parent_snapshot(), "parent");
  EXPECT_THAT(parent, IsOk());
  auto mapper = slamcore::Mapper::Create(params, *parent);
  EXPECT_THAT(mapper, IsOk());
  auto events = analyzer::FromProto(run.events(), "events");
  EXPECT_THAT(events, IsOk());
  for (const auto& event : *events) EXPECT_THAT((*mapper)->Process(event), IsOk());
  return (*mapper)->ground_truth();
}

double Rmse(const fleet::v1::MapSnapshot& snapshot, const NodeTruth& truth) {
  auto map = analyzer::FromProto(snapshot, "map");
  EXPECT_THAT(map, IsOk());
  int count = 0;
  return analyzer::ComponentwiseRmse(map->graph, truth, &count).value_or(-1.0);
}

struct Scenario {
  std::vector<RunFile> runs;  // the robot's runs up to and including the wrong merge
  std::int64_t wrong_hypothesis = -1;
  std::size_t wrong_edges = 0;
  NodeTruth truth;  // every node of every run
};

/// Simulates one robot run by run until a run's child map holds exactly one wrong hypothesis that joined
/// two components (a wrong merge). Deterministic: the same seeds find the same run every time.
Scenario FindWrongMerge() {
  const auto worlds = sim::ListWorlds(test_data::Sample() / "floorplans");
  EXPECT_THAT(worlds, IsOk());
  sim::SimParams params;
  params.run_minutes = 6.0;
  params.start_off_dock_probability = 1.0;  // every run has to merge into the home map
  params.lookalike_probability = 0.15;
  params.recognition_failure_probability = 0.0;
  params.kidnap_probability = 0.0;
  params.reboot_probability = 0.0;
  params.stuck_rate_scale = 0.0;
  params.mapper = PermissiveParameters();
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    auto world = sim::LoadWorld((*worlds)[seed % worlds->size()], seed);
    EXPECT_THAT(world, IsOk());
    // Only look-alikes mislead the front-end here (no symmetric object seen from the other side), so that a
    // run with exactly one wrong merge is common.
    for (sim::Landmark& landmark : world->landmarks) landmark.symmetric = false;
    sim::RobotSimulator robot(*world, params, kRobot, "fw-repair", seed);
    Scenario scenario;
    for (int k = 0; k < 6; ++k) {
      auto outcome = robot.SimulateRun("repair-run-" + std::to_string(seed) + "-" + std::to_string(k),
                                       1.76e9 + 3600.0 * k);
      if (!outcome.ok()) {
        ADD_FAILURE() << outcome.status().ToString();
        return {};
      }
      const RunFile& run = outcome->run;
      scenario.runs.push_back(run);
      for (const auto& [node, pose] : TruthOf(run, params.mapper)) scenario.truth[node] = pose;
      if (k == 0) continue;
      const auto wrong = WrongObservations(run);
      std::map<std::int64_t, std::size_t> wrong_by_hypothesis;
      std::set<slamcore::NodeId> parent_nodes;
      for (const auto& node : run.parent_snapshot().nodes()) parent_nodes.insert(node.id());
      for (const auto& edge : run.child_snapshot().edges()) {
        if (edge.has_hypothesis() && edge.has_view() && wrong.contains({edge.from(), edge.view()})) {
          ++wrong_by_hypothesis[edge.hypothesis()];
        }
      }
      if (wrong_by_hypothesis.size() != 1) {
        if (!wrong_by_hypothesis.empty()) break;  // several wrong hypotheses: try another robot
        continue;
      }
      // A merge: without the hypothesis's edges the run's first node is not connected to the home map.
      auto child = analyzer::FromProto(run.child_snapshot(), "child");
      EXPECT_THAT(child, IsOk());
      const std::int64_t hypothesis = wrong_by_hypothesis.begin()->first;
      slamcore::PoseGraph without = child->graph;
      without.RemoveEdgesIf([&](const slamcore::Edge& edge) {
        return edge.hypothesis == hypothesis && !parent_nodes.contains(edge.from);
      });
      const slamcore::NodeId home = run.parent_snapshot().nodes(0).id();
      slamcore::NodeId first_new = -1;
      for (const auto& node : run.child_snapshot().nodes()) {
        if (!parent_nodes.contains(node.id())) {
          first_new = node.id();
          break;
        }
      }
      if (first_new < 0 || without.SameComponent(home, first_new)) break;
      scenario.wrong_hypothesis = hypothesis;
      scenario.wrong_edges = wrong_by_hypothesis.begin()->second;
      std::printf("wrong merge: seed %llu, run %d, hypothesis %lld with %zu wrong edge(s)\n",
                  static_cast<unsigned long long>(seed), k, static_cast<long long>(hypothesis),
                  scenario.wrong_edges);
      return scenario;
    }
  }
  return {};
}

/// One robot in the sample's first floor plan, cleaning daily for 3 minutes and uploading each run as itself
/// (runs "<prefix>-<day>"); it keeps the version each upload became as the map it holds.
class DailyRobot {
 public:
  DailyRobot(const std::string& server, const std::string& token, std::string prefix)
      : world_(LoadFirstWorld()),
        robot_(world_, Params(), kRobot, "fw-follow", 5),
        prefix_(std::move(prefix)) {
    fleet_client::UploaderOptions options;
    options.server = server;
    options.token = token;
    uploader_ = std::make_unique<fleet_client::Uploader>(options);
  }

  std::pair<sim::RunOutcome, fleet_client::UploadOutcome> RunAndUpload(int day) {
    auto outcome = robot_.SimulateRun(prefix_ + "-" + std::to_string(day), 1.76e9 + 86400.0 * day);
    EXPECT_THAT(outcome, IsOk());
    const fleet_client::UploadOutcome uploaded = uploader_->Upload(outcome->run);
    EXPECT_TRUE(uploaded.ok) << uploaded.message;
    robot_.SetMapVersion(uploaded.map_version);
    return {std::move(outcome).value(), uploaded};
  }
  sim::RobotSimulator& robot() { return robot_; }

 private:
  static sim::World LoadFirstWorld() {
    const auto worlds = sim::ListWorlds(test_data::Sample() / "floorplans");
    EXPECT_THAT(worlds, IsOk());
    EXPECT_FALSE(worlds->empty());
    auto world = sim::LoadWorld(worlds->front(), 5);
    EXPECT_THAT(world, IsOk());
    return std::move(world).value();
  }
  static sim::SimParams Params() {
    sim::SimParams params;
    params.run_minutes = 3.0;
    return params;
  }

  sim::World world_;
  sim::RobotSimulator robot_;
  std::string prefix_;
  std::unique_ptr<fleet_client::Uploader> uploader_;
};

class MapRepairTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_THAT(server_, IsOk());
    auto channel = server_.Channel();
    ingest_ = fleet::v1::Ingest::NewStub(channel);
    maps_ = fleet::v1::Maps::NewStub(channel);
    admin_ = fleet::v1::Admin::NewStub(channel);
    engineer_ = Token("engineer:erin");
    robot_ = Token(std::string("robot:") + kRobot);
  }

  std::string Token(const std::string& principal) {
    fleet::v1::SetCredentialRequest request;
    request.set_principal(principal);
    fleet::v1::SetCredentialResponse response;
    auto context = Context(FleetdProcess::AdminToken());
    EXPECT_THAT(admin_->SetCredential(context.get(), request, &response), IsOk());
    return response.token();
  }

  grpc::Status Repair(fleet::v1::RepairMapRequest request, fleet::v1::RepairMapResponse* response) {
    request.set_robot_id(kRobot);
    auto context = Context(engineer_, 120);
    return maps_->RepairMap(context.get(), request, response);
  }

  fleet::v1::GetMapVersionResponse Version(std::int64_t version) {
    fleet::v1::GetMapVersionRequest request;
    request.set_robot_id(kRobot);
    request.set_version(version);
    request.set_include_snapshot(true);
    fleet::v1::GetMapVersionResponse response;
    auto context = Context(engineer_);
    const grpc::Status status = maps_->GetMapVersion(context.get(), request, &response);
    EXPECT_THAT(status, IsOk());
    return response;
  }

  FleetdProcess server_;
  std::unique_ptr<fleet::v1::Ingest::Stub> ingest_;
  std::unique_ptr<fleet::v1::Maps::Stub> maps_;
  std::unique_ptr<fleet::v1::Admin::Stub> admin_;
  std::string engineer_, robot_;
};

TEST_F(MapRepairTest, AWrongMergeIsFoundRepairedApprovedAndHandedBack) {
  const Scenario scenario = FindWrongMerge();
  ASSERT_GE(scenario.wrong_hypothesis, 0) << "no simulated run accepted exactly one wrong merge";
  const RunFile& merged_run = scenario.runs.back();

  // The robot uploads its runs in order; each child map becomes the robot's current version.
  std::int64_t merged_version = 0;
  for (const RunFile& run : scenario.runs) {
    fleet::v1::UploadRunResponse response;
    const grpc::Status status = Upload(*ingest_, robot_, run, &response);
    ASSERT_THAT(status, IsOk());
    EXPECT_FALSE(response.map_outdated());
    EXPECT_EQ(response.current_map_version(), response.map_version());
    merged_version = response.map_version();
  }
  ASSERT_EQ(merged_version, static_cast<std::int64_t>(scenario.runs.size()));

  // The analysis finds the merge: the server's rerun with the default parameters did not accept it.
  fleet::v1::GetMapVersionResponse merged;
  const fleet::v1::MapFinding* finding = nullptr;
  for (int attempt = 0; attempt < 240 && !finding; ++attempt) {
    merged = Version(merged_version);
    for (const auto& candidate : merged.findings()) {
      if (candidate.finding_kind() == fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS &&
          candidate.hypothesis() == scenario.wrong_hypothesis) {
        finding = &candidate;
      }
    }
    if (!finding) std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  ASSERT_NE(finding, nullptr) << "no finding names hypothesis " << scenario.wrong_hypothesis;
  EXPECT_EQ(finding->finding_state(), fleet::v1::FINDING_STATE_OPEN);
  EXPECT_NE(finding->evidence_json().find("\"joins_components\":true"), std::string::npos)
      << finding->evidence_json();
  EXPECT_GE(merged.version().open_findings(), 1);

  // The engineer rejects the merge: a pending version, not yet the robot's.
  fleet::v1::RepairMapRequest reject;
  reject.set_base_version(merged_version);
  reject.set_reject_hypothesis(finding->hypothesis());
  reject.set_reason("look-alike merged the run into the wrong room");
  fleet::v1::RepairMapResponse repaired;
  grpc::Status status = Repair(reject, &repaired);
  ASSERT_THAT(status, IsOk());
  const std::int64_t repaired_version = repaired.version().version();
  EXPECT_EQ(repaired_version, merged_version + 1);
  EXPECT_EQ(repaired.version().approval_state(), fleet::v1::MAP_APPROVAL_PENDING);
  EXPECT_EQ(repaired.version().parent_version(), merged_version);
  EXPECT_EQ(repaired.version().created_by(), "engineer:erin");
  EXPECT_EQ(repaired.version().observation_edges(),
            merged.version().observation_edges() - static_cast<std::int64_t>(scenario.wrong_edges));
  for (const auto& after : repaired.findings()) {
    EXPECT_FALSE(after.finding_kind() == fleet::v1::FINDING_KIND_UNCONFIRMED_HYPOTHESIS &&
                 after.hypothesis() == scenario.wrong_hypothesis);
  }

  fleet::v1::GetMapRequest fetch;
  fetch.set_robot_id(kRobot);
  fetch.set_held_version(merged_version);
  fleet::v1::GetMapResponse held;
  auto context = Context(robot_);
  ASSERT_THAT(maps_->GetMap(context.get(), fetch, &held), IsOk());
  EXPECT_TRUE(held.up_to_date()) << "a pending repair is not handed to the robot";

  fleet::v1::ReviewMapVersionRequest approve;
  approve.set_robot_id(kRobot);
  approve.set_version(repaired_version);
  approve.set_approve(true);
  fleet::v1::MapVersion approved;
  context = Context(engineer_);
  ASSERT_THAT(maps_->ReviewMapVersion(context.get(), approve, &approved), IsOk());
  EXPECT_EQ(approved.approval_state(), fleet::v1::MAP_APPROVAL_APPROVED);
  EXPECT_TRUE(approved.current());

  fleet::v1::GetMapResponse downloaded;
  context = Context(robot_);
  ASSERT_THAT(maps_->GetMap(context.get(), fetch, &downloaded), IsOk());
  ASSERT_FALSE(downloaded.up_to_date());
  EXPECT_EQ(downloaded.version().version(), repaired_version);
  EXPECT_EQ(fleet::SerializeDeterministic(downloaded.snapshot()).size(),
            fleet::SerializeDeterministic(Version(repaired_version).snapshot()).size());

  // Error against ground truth: before the wrong merge (the parent map), with it, after the repair, and the
  // same run mapped by the default parameters (no wrong merge at all).
  const double before = Rmse(merged_run.parent_snapshot(), scenario.truth);
  const double wrong = Rmse(merged_run.child_snapshot(), scenario.truth);
  const double after = Rmse(downloaded.snapshot(), scenario.truth);
  auto default_report = analyzer::AnalyzeRun(merged_run, {});
  ASSERT_THAT(default_report, IsOk());
  const double default_rerun = Rmse(default_report->rerun_child(), scenario.truth);
  std::printf(
      "trajectory RMSE vs ground truth (m): parent %.3f, with the wrong merge %.3f, repaired %.3f, "
      "default-parameter rerun %.3f\n",
      before, wrong, after, default_rerun);
  RecordProperty("rmse_parent", std::to_string(before));
  RecordProperty("rmse_wrong_merge", std::to_string(wrong));
  RecordProperty("rmse_repaired", std::to_string(after));
  RecordProperty("rmse_default_rerun", std::to_string(default_rerun));
  ASSERT_GT(before, 0.0);
  EXPECT_GT(wrong, 2.0 * after) << "the wrong merge made the map worse and the repair undid that";
  EXPECT_LE(after, std::max(before, default_rerun) * 1.25 + 0.02)
      << "back to the level before the wrong merge";

  // Undo restores the earlier version exactly: the very same content-addressed map.
  fleet::v1::RepairMapRequest undo;
  undo.set_base_version(repaired_version);
  undo.set_undo(true);
  fleet::v1::RepairMapResponse undone;
  ASSERT_THAT(Repair(undo, &undone), IsOk());
  EXPECT_EQ(undone.version().snapshot_id(), merged.version().snapshot_id());
  EXPECT_EQ(undone.version().version_origin(), fleet::v1::MAP_ORIGIN_UNDO);
  EXPECT_EQ(fleet::SerializeDeterministic(Version(undone.version().version()).snapshot()),
            fleet::SerializeDeterministic(merged.snapshot()));

  // Concurrent repairs of one map: all start from the same newest version; exactly one is appended.
  const std::int64_t head = undone.version().version();
  std::vector<std::future<grpc::StatusCode>> racers;
  for (int i = 0; i < 4; ++i) {
    racers.push_back(std::async(std::launch::async, [&] {
      fleet::v1::RepairMapRequest rollback;
      rollback.set_base_version(head);
      rollback.set_rollback(true);
      fleet::v1::RepairMapResponse ignored;
      return Repair(rollback, &ignored).error_code();
    }));
  }
  std::map<grpc::StatusCode, int> outcomes;
  for (auto& racer : racers) ++outcomes[racer.get()];
  EXPECT_EQ(outcomes[grpc::StatusCode::OK], 1);
  EXPECT_EQ(outcomes[grpc::StatusCode::ABORTED], 3);

  // The robot's next run was built on the map it had before the repair: it is told the current version.
  // (Its upload is kept, as a "stale" version.)
  RunFile next = merged_run;
  next.mutable_header()->set_run_id("repair-run-after");
  next.mutable_header()->set_parent_snapshot_id(merged.version().snapshot_id());
  *next.mutable_parent_snapshot() = merged_run.child_snapshot();
  fleet::v1::UploadRunResponse outdated;
  status = Upload(*ingest_, robot_, next, &outdated);
  ASSERT_THAT(status, IsOk());
  EXPECT_TRUE(outdated.map_outdated());
  EXPECT_EQ(outdated.current_map_version(), repaired_version);
  // A run's version names as its parent the newest version holding the parent's snapshot when it came in
  // (here a later version holding the merged map's snapshot again, not the merge itself).
  const auto newest_holding = [&](const std::string& snapshot, std::int64_t below) {
    std::int64_t newest = 0;
    for (std::int64_t v = 1; v < below; ++v) {
      if (Version(v).version().snapshot_id() == snapshot) newest = v;
    }
    return newest;
  };
  const std::string& parent_snapshot = merged.version().snapshot_id();
  EXPECT_GT(newest_holding(parent_snapshot, outdated.map_version()), merged_version);
  EXPECT_EQ(Version(outdated.map_version()).version().parent_version(),
            newest_holding(parent_snapshot, outdated.map_version()));
  // The same parent named by id only (ingest looks its version up once and hands it on): the same rule.
  RunFile by_id = next;
  by_id.mutable_header()->set_run_id("repair-run-after-by-id");
  UploadOptions by_id_options;
  by_id_options.send_parent = false;
  by_id_options.parent_id = parent_snapshot;
  fleet::v1::UploadRunResponse named;
  status = Upload(*ingest_, robot_, by_id, &named, by_id_options);
  ASSERT_THAT(status, IsOk());
  EXPECT_TRUE(named.map_outdated());
  EXPECT_EQ(Version(named.map_version()).version().parent_version(),
            newest_holding(parent_snapshot, named.map_version()));

  // Export: map_server files and a g2o graph that reads back.
  for (const std::string format : {"map_server", "g2o"}) {
    fleet::v1::ExportMapRequest request;
    request.set_robot_id(kRobot);
    request.set_version(repaired_version);
    request.set_format(format);
    fleet::v1::ExportMapResponse exported;
    context = Context(engineer_);
    ASSERT_THAT(maps_->ExportMap(context.get(), request, &exported), IsOk());
    ASSERT_EQ(exported.files_size(), format == "g2o" ? 1 : 2);
    for (const auto& file : exported.files()) EXPECT_FALSE(file.content().empty()) << file.name();
    if (format == "g2o") {
      std::istringstream in(exported.files(0).content());
      auto graph = slamcore::ReadPoseGraph(in, "export");
      ASSERT_THAT(graph, IsOk());
      EXPECT_EQ(static_cast<std::int64_t>(graph->num_nodes()), repaired.version().nodes());
    }
  }
}

TEST_F(MapRepairTest, RobotsGetOnlyTheirOwnMapAndBadRepairsAreRefused) {
  const auto& runs = SimulatedRuns();
  ASSERT_FALSE(runs.empty());
  const RunFile& run = runs.front();
  const std::string owner = Token("robot:" + run.header().robot_id());
  fleet::v1::UploadRunResponse uploaded;
  ASSERT_THAT(Upload(*ingest_, owner, run, &uploaded), IsOk());
  ASSERT_EQ(uploaded.map_version(), 1);

  fleet::v1::GetMapRequest fetch;
  fetch.set_robot_id(run.header().robot_id());
  fleet::v1::GetMapResponse response;
  auto context = Context(robot_);  // another robot's token
  EXPECT_EQ(maps_->GetMap(context.get(), fetch, &response).error_code(), grpc::StatusCode::PERMISSION_DENIED);
  context = Context(owner);
  ASSERT_THAT(maps_->GetMap(context.get(), fetch, &response), IsOk());
  EXPECT_FALSE(response.up_to_date());
  EXPECT_EQ(response.snapshot().nodes_size(), run.child_snapshot().nodes_size());

  fleet::v1::RepairMapRequest request;
  request.set_robot_id(run.header().robot_id());
  request.set_base_version(1);
  fleet::v1::RepairMapResponse repaired;
  // Robots may not repair; engineers must name an action, a real edge, and a repair that exists.
  context = Context(owner);
  request.set_rollback(true);
  EXPECT_EQ(maps_->RepairMap(context.get(), request, &repaired).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  context = Context(engineer_);
  EXPECT_EQ(maps_->RepairMap(context.get(), request, &repaired).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION)
      << "a first run has no parent to roll back to";
  request.set_undo(true);
  context = Context(engineer_);
  EXPECT_EQ(maps_->RepairMap(context.get(), request, &repaired).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION)
      << "an upload is not a repair";
  for (const auto& edge : run.child_snapshot().edges()) {
    if (edge.kind() != fleet::v1::Edge::KIND_MOTION) continue;
    request.mutable_reject_edge()->set_from(edge.from());
    request.mutable_reject_edge()->set_to(edge.to());
    break;
  }
  context = Context(engineer_);
  const grpc::Status motion = maps_->RepairMap(context.get(), request, &repaired);
  EXPECT_EQ(motion.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(motion.error_message().find("motion"), std::string::npos) << motion.error_message();
  request.set_base_version(9);
  context = Context(engineer_);
  EXPECT_EQ(maps_->RepairMap(context.get(), request, &repaired).error_code(), grpc::StatusCode::NOT_FOUND);
  request.clear_action();
  context = Context(engineer_);
  EXPECT_EQ(maps_->RepairMap(context.get(), request, &repaired).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);

  fleet::v1::ReviewMapVersionRequest review;
  review.set_robot_id(run.header().robot_id());
  review.set_version(1);
  review.set_approve(true);
  fleet::v1::MapVersion reviewed;
  context = Context(engineer_);
  EXPECT_EQ(maps_->ReviewMapVersion(context.get(), review, &reviewed).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION)
      << "only pending versions are reviewed";
}

// A robot that follows the service: before its next run it asks Maps.GetMap, takes the repaired and approved
// version, runs on it (naming it in the run's header and as its parent snapshot), and the server records that
// the run was built on the repaired version: the upload is approved (not stale), its version's parent is the
// repair, and the run's report names the version.
TEST_F(MapRepairTest, AFollowingRobotRunsOnTheApprovedRepairAndTheServerRecordsIt) {
  DailyRobot daily(server_.grpc_address(), robot_, "follow-run");
  sim::RobotSimulator& robot = daily.robot();
  sim::ServiceClient service(server_.grpc_address());
  const auto run_and_upload = [&](int day) { return daily.RunAndUpload(day); };
  auto [first, first_upload] = run_and_upload(0);
  EXPECT_EQ(first.run.header().map_version(), 0) << "a first run holds no version of the service";
  auto [second, second_upload] = run_and_upload(1);
  EXPECT_EQ(second.run.header().map_version(), first_upload.map_version);
  ASSERT_EQ(second_upload.map_version, 2);
  ASSERT_FALSE(second_upload.map_outdated);

  // Nothing newer than what the robot holds: up to date.
  auto fetched = service.FetchMap(robot_, kRobot, robot.map_version());
  ASSERT_THAT(fetched, IsOk());
  EXPECT_TRUE(fetched->up_to_date);

  // The engineer repairs version 2 (back to the map before its run) and approves it.
  fleet::v1::RepairMapRequest rollback;
  rollback.set_base_version(2);
  rollback.set_rollback(true);
  rollback.set_reason("the second run's map is not trusted");
  fleet::v1::RepairMapResponse repaired;
  ASSERT_THAT(Repair(rollback, &repaired), IsOk());
  const std::int64_t repaired_version = repaired.version().version();
  auto approved = service.ApprovePending(engineer_, kRobot);
  ASSERT_THAT(approved, IsOk());
  ASSERT_EQ(*approved, repaired_version);

  // Before its next run the robot takes it.
  fetched = service.FetchMap(robot_, kRobot, robot.map_version());
  ASSERT_THAT(fetched, IsOk());
  ASSERT_FALSE(fetched->up_to_date);
  EXPECT_EQ(fetched->version.version(), repaired_version);
  EXPECT_EQ(fetched->version.version_origin(), fleet::v1::MAP_ORIGIN_ROLLBACK);
  ASSERT_THAT(robot.TakeMap(fetched->snapshot, fetched->version.version()), IsOk());
  EXPECT_EQ(robot.map().graph.num_nodes(), static_cast<std::size_t>(first.run.child_snapshot().nodes_size()))
      << "the rolled-back map is the first run's";
  fleet::v1::MapSnapshot broken;
  auto* dangling = broken.add_edges();  // an edge between nodes the snapshot does not hold
  dangling->set_from(1);
  dangling->set_to(2);
  EXPECT_FALSE(robot.TakeMap(broken, 99).ok()) << "a snapshot that does not decode is refused";
  EXPECT_EQ(robot.map_version(), repaired_version) << "and the map taken before is kept";

  auto [third, third_upload] = run_and_upload(2);
  EXPECT_EQ(third.run.header().map_version(), repaired_version);
  EXPECT_EQ(fleet_client::SnapshotId(third.run.parent_snapshot()), repaired.version().snapshot_id());
  EXPECT_FALSE(third_upload.map_outdated) << "built on the current map";
  EXPECT_EQ(third_upload.current_map_version, third_upload.map_version);
  const fleet::v1::GetMapVersionResponse recorded = Version(third_upload.map_version);
  EXPECT_EQ(recorded.version().parent_version(), repaired_version);
  EXPECT_EQ(recorded.version().approval_state(), fleet::v1::MAP_APPROVAL_APPROVED);

  // The analysis' report names the version the run ran on.
  ASSERT_THAT(service.WaitForJob(engineer_, third_upload.analysis_job_id, 120), IsOk());
  auto queries = fleet::v1::Queries::NewStub(server_.Channel());
  fleet::v1::GetRunReportRequest request;
  request.set_run_id("follow-run-2");
  request.set_robot_id(kRobot);
  fleet::v1::GetRunReportResponse report;
  auto context = Context(engineer_);
  ASSERT_THAT(queries->GetRunReport(context.get(), request, &report), IsOk());
  EXPECT_EQ(report.report().map_version(), repaired_version);
}

// Review after the robot moved on: a repair proposed on version 2 waits for review while the robot runs again
// on version 2 (the current one) and uploads version 4. Approving the repair then carries it onto version 4 as
// a new approved version, which the robot gets next; the proposal itself becomes stale. A rollback cannot be
// carried (it would drop the runs since): its approval is refused with the reason.
TEST_F(MapRepairTest, ARepairApprovedAfterTheRobotMovedOnIsCarriedOntoItsCurrentMap) {
  DailyRobot daily(server_.grpc_address(), robot_, "carry-run");
  sim::RobotSimulator& robot = daily.robot();
  const auto run_and_upload = [&](int day) { return daily.RunAndUpload(day).second.map_version; };
  const auto review = [&](std::int64_t version, fleet::v1::MapVersion* reviewed) {
    fleet::v1::ReviewMapVersionRequest request;
    request.set_robot_id(kRobot);
    request.set_version(version);
    request.set_approve(true);
    auto context = Context(engineer_, 120);
    return maps_->ReviewMapVersion(context.get(), request, reviewed);
  };
  ASSERT_EQ(run_and_upload(0), 1);
  ASSERT_EQ(run_and_upload(1), 2);

  // The proposal: reject one observation edge that the second run added, left for review.
  const fleet::v1::GetMapVersionResponse first = Version(1), second = Version(2);
  std::set<std::int64_t> first_nodes;
  for (const auto& node : first.snapshot().nodes()) first_nodes.insert(node.id());
  fleet::v1::RepairMapRequest proposal;
  proposal.set_base_version(2);
  proposal.set_reason("this closure looks wrong");
  for (const auto& edge : second.snapshot().edges()) {
    if (edge.kind() != fleet::v1::Edge::KIND_OBSERVATION || first_nodes.contains(edge.from())) continue;
    proposal.mutable_reject_edge()->set_from(edge.from());
    proposal.mutable_reject_edge()->set_to(edge.to());
    if (edge.has_view()) proposal.mutable_reject_edge()->set_view(edge.view());
    break;
  }
  ASSERT_TRUE(proposal.has_reject_edge()) << "the second run added an observation edge";
  fleet::v1::RepairMapResponse proposed;
  ASSERT_THAT(Repair(proposal, &proposed), IsOk());
  ASSERT_EQ(proposed.version().version(), 3);
  ASSERT_EQ(proposed.version().approval_state(), fleet::v1::MAP_APPROVAL_PENDING);

  // The robot runs again on version 2, still its current map: version 4, approved, built on 2.
  ASSERT_EQ(run_and_upload(2), 4);
  ASSERT_EQ(Version(4).version().parent_version(), 2);
  ASSERT_TRUE(Version(4).version().current());

  fleet::v1::MapVersion carried;
  const grpc::Status approved = review(3, &carried);
  ASSERT_THAT(approved, IsOk());
  EXPECT_EQ(carried.version(), 5);
  EXPECT_EQ(carried.parent_version(), 4);
  EXPECT_EQ(carried.version_origin(), fleet::v1::MAP_ORIGIN_REPAIR);
  EXPECT_EQ(carried.version_action(), fleet::v1::MAP_ACTION_REJECT_EDGE);
  EXPECT_EQ(carried.approval_state(), fleet::v1::MAP_APPROVAL_APPROVED);
  EXPECT_TRUE(carried.current());
  EXPECT_EQ(carried.reason(), "this closure looks wrong");
  EXPECT_NE(carried.action_detail().find("carried forward from version 3"), std::string::npos)
      << carried.action_detail();
  EXPECT_NE(carried.action_detail().find("1 edge(s) removed"), std::string::npos) << carried.action_detail();
  EXPECT_EQ(Version(3).version().approval_state(), fleet::v1::MAP_APPROVAL_STALE)
      << "the proposal is superseded";
  // Version 5 is version 4 without the edge: every node of the third run is there.
  const fleet::v1::GetMapVersionResponse fourth = Version(4), fifth = Version(5);
  EXPECT_EQ(fifth.snapshot().nodes_size(), fourth.snapshot().nodes_size());
  EXPECT_EQ(fifth.snapshot().edges_size(), fourth.snapshot().edges_size() - 1);
  for (const auto& edge : fifth.snapshot().edges()) {
    EXPECT_FALSE(edge.from() == proposal.reject_edge().from() && edge.to() == proposal.reject_edge().to() &&
                 edge.kind() == fleet::v1::Edge::KIND_OBSERVATION)
        << "the rejected edge is gone";
  }
  sim::ServiceClient service(server_.grpc_address());
  auto fetched = service.FetchMap(robot_, kRobot, robot.map_version());
  ASSERT_THAT(fetched, IsOk());
  EXPECT_EQ(fetched->version.version(), 5) << "the robot gets the carried repair next";
  EXPECT_EQ(review(3, &carried).error_code(), grpc::StatusCode::FAILED_PRECONDITION) << "reviewed already";

  // A rollback proposed on version 5, overtaken by the robot's next run, cannot be carried.
  fleet::v1::RepairMapRequest rollback;
  rollback.set_base_version(5);
  rollback.set_rollback(true);
  ASSERT_THAT(Repair(rollback, &proposed), IsOk());
  ASSERT_EQ(proposed.version().version(), 6);
  ASSERT_THAT(robot.TakeMap(fetched->snapshot, fetched->version.version()), IsOk());
  ASSERT_EQ(run_and_upload(3), 7);
  const grpc::Status refused = review(6, &carried);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(refused.error_message().find("a rollback cannot be carried onto a later map"), std::string::npos)
      << refused.error_message();
  EXPECT_EQ(Version(6).version().approval_state(), fleet::v1::MAP_APPROVAL_PENDING)
      << "a refused approval changes nothing";

  // The simulated engineer's weekly review: approves what can be carried, rejects what cannot.
  auto reviewed = service.ApprovePending(engineer_, kRobot);
  ASSERT_THAT(reviewed, IsOk());
  EXPECT_EQ(*reviewed, 0) << "nothing was approved";
  EXPECT_EQ(Version(6).version().approval_state(), fleet::v1::MAP_APPROVAL_REJECTED);
}

}  // namespace
}  // namespace fleetd_test
