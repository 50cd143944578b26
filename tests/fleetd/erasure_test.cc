// Erasure and retention end to end (issue 16): a real fleetd on a SQLite file, the real fleetctl binary. An
// admin deletes one robot with `fleetctl robots delete`; nothing of it is served afterwards, its token stops
// working, the other robot is whole and the audit log says who did it. Then the same database is served by a
// fleetd with retention on: run events and finished jobs go, reports and map versions stay, both audited.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "fleetd_process.h"
#include "status_matchers.h"

namespace fleetd_test {
namespace {

using fleet::v1::RunFile;

struct Command {
  int exit_code = -1;
  std::string out;
};

/// Runs fleetctl against `server` with `token` and the arguments; stdout and the exit code.
Command Fleetctl(const FleetdProcess& server, const std::string& token, const std::string& arguments) {
  const std::string command = std::string(FLEETCTL_BINARY) + " --server " + server.grpc_address() +
                              " --token " + token + " " + arguments + " 2>&1";
  Command result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) result.out.append(buffer, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

/// Waits until no job is queued or leased (every analysis finished).
bool WaitForIdleQueue(fleet::v1::Reprocessing::Stub& reprocessing, const std::string& token) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (std::chrono::steady_clock::now() < until) {
    int busy = 0;
    for (const char* state : {"queued", "leased"}) {
      fleet::v1::ListJobsRequest request;
      request.set_state(state);
      fleet::v1::ListJobsResponse response;
      auto context = Context(token);
      if (!reprocessing.ListJobs(context.get(), request, &response).ok()) return false;
      busy += response.jobs_size();
    }
    if (busy == 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return false;
}

int JobCount(fleet::v1::Reprocessing::Stub& reprocessing, const std::string& token) {
  fleet::v1::ListJobsRequest request;
  request.set_limit(1000);
  fleet::v1::ListJobsResponse response;
  auto context = Context(token);
  return reprocessing.ListJobs(context.get(), request, &response).ok() ? response.jobs_size() : -1;
}

std::vector<fleet::v1::RunSummary> RunsOf(fleet::v1::Queries::Stub& queries, const std::string& token,
                                          const std::string& robot) {
  fleet::v1::ListRunsRequest request;
  request.mutable_filter()->set_robot_id(robot);
  request.set_page_size(1000);
  fleet::v1::ListRunsResponse response;
  auto context = Context(token);
  EXPECT_THAT(queries.ListRuns(context.get(), request, &response), IsOk());
  return {response.runs().begin(), response.runs().end()};
}

TEST(ErasureAndRetention, AnAdminDeletesARobotThroughFleetctlAndRetentionPrunesTheRest) {
  std::filesystem::path database;
  std::string erased, kept;
  auto first = std::make_unique<FleetdProcess>();  // kept until the end: its directory holds the database
  {
    FleetdProcess& server = *first;
    ASSERT_THAT(server, IsOk());
    database = server.directory() / "fleet.db";
    auto channel = server.Channel();
    auto ingest = fleet::v1::Ingest::NewStub(channel);
    auto queries = fleet::v1::Queries::NewStub(channel);
    auto reprocessing = fleet::v1::Reprocessing::NewStub(channel);
    auto admin = fleet::v1::Admin::NewStub(channel);
    auto maps = fleet::v1::Maps::NewStub(channel);
    const std::string engineer = IssueToken(*admin, "engineer:erasure-test");
    for (const RunFile& run : SimulatedRuns()) {
      fleet::v1::UploadRunResponse response;
      const grpc::Status status =
          Upload(*ingest, RobotToken(*admin, run.header().robot_id()), run, &response);
      ASSERT_THAT(status, IsOk());
      if (erased.empty()) erased = run.header().robot_id();
      if (run.header().robot_id() != erased && kept.empty()) kept = run.header().robot_id();
    }
    ASSERT_FALSE(kept.empty()) << "the simulation has two robots";
    ASSERT_TRUE(WaitForIdleQueue(*reprocessing, engineer));
    const std::size_t kept_runs = RunsOf(*queries, engineer, kept).size();
    ASSERT_GT(RunsOf(*queries, engineer, erased).size(), 0u);

    // Refused without the confirmation, and for anyone but an admin: nothing deleted.
    EXPECT_EQ(Fleetctl(server, FleetdProcess::AdminToken(), "robots delete " + erased + " --confirm " + kept)
                  .exit_code,
              1);
    const Command by_engineer =
        Fleetctl(server, engineer, "robots delete " + erased + " --confirm " + erased);
    EXPECT_EQ(by_engineer.exit_code, 1);
    EXPECT_NE(by_engineer.out.find("PERMISSION_DENIED"), std::string::npos) << by_engineer.out;
    EXPECT_GT(RunsOf(*queries, engineer, erased).size(), 0u);

    const std::string robot_token = RobotToken(*admin, erased);
    const auto started = std::chrono::steady_clock::now();
    const Command deleted = Fleetctl(server, FleetdProcess::AdminToken(),
                                     "--json robots delete " + erased + " --confirm " + erased);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    ASSERT_EQ(deleted.exit_code, 0) << deleted.out;
    std::printf("[ measured ] fleetctl robots delete: %.3f s (the process included): %s\n", seconds,
                deleted.out.c_str());
    const nlohmann::json counts = nlohmann::json::parse(deleted.out);
    EXPECT_GT(std::stoll(counts.at("runs").get<std::string>()), 0) << deleted.out;
    EXPECT_GT(std::stoll(counts.at("reports").get<std::string>()), 0) << deleted.out;
    EXPECT_GT(std::stoll(counts.at("map_versions").get<std::string>()), 0) << deleted.out;
    EXPECT_GT(std::stoll(counts.at("snapshots").get<std::string>()), 0) << deleted.out;
    EXPECT_GT(std::stoll(counts.at("jobs").get<std::string>()), 0) << deleted.out;
    EXPECT_EQ(std::stoll(counts.at("credentials").get<std::string>()), 1) << deleted.out;

    // Nothing of it is served any more; its token no longer works; the other robot is whole.
    EXPECT_TRUE(RunsOf(*queries, engineer, erased).empty());
    std::string body;
    const int history = HttpGet(server.http_address(), "/api/robots/" + erased + "/maps", &body, engineer);
    if (history == 200) {
      EXPECT_EQ(nlohmann::json::parse(body).at("versions").size(), 0u) << body;
    } else {
      EXPECT_EQ(history, 404) << body;
    }
    EXPECT_EQ(HttpGet(server.http_address(), "/api/robots", &body, engineer), 200);
    EXPECT_EQ(body.find("\"" + erased + "\""), std::string::npos) << body;
    fleet::v1::GetMapRequest get_map;
    get_map.set_robot_id(erased);
    fleet::v1::GetMapResponse map;
    auto robot_context = Context(robot_token);
    EXPECT_EQ(maps->GetMap(robot_context.get(), get_map, &map).error_code(),
              grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_EQ(RunsOf(*queries, engineer, kept).size(), kept_runs);
    EXPECT_EQ(HttpGet(server.http_address(), "/api/robots/" + kept + "/maps/current/export/map.g2o", &body,
                      engineer),
              200);

    const Command audit = Fleetctl(server, FleetdProcess::AdminToken(), "--json audit");
    ASSERT_EQ(audit.exit_code, 0) << audit.out;
    std::vector<nlohmann::json> erasures;
    bool minted_audited = false;  // credentials minted are admin actions too
    const nlohmann::json listed = nlohmann::json::parse(audit.out);
    for (const nlohmann::json& entry : listed.at("entries")) {
      if (entry.at("action") == "delete_robot") erasures.push_back(entry);
      if (entry.at("action") == "set_credential" && entry.at("subject") == "robot:" + erased) {
        minted_audited = entry.at("actor").get<std::string>().rfind("admin:", 0) == 0;
      }
    }
    ASSERT_EQ(erasures.size(), 1u) << audit.out;
    EXPECT_EQ(erasures[0].at("subject"), erased);
    EXPECT_EQ(erasures[0].at("actor").get<std::string>().rfind("admin:", 0), 0u);
    EXPECT_TRUE(minted_audited) << audit.out;
    EXPECT_EQ(Fleetctl(server, engineer, "audit").exit_code, 1) << "the audit log is for admins";
    EXPECT_EQ(server.Stop(), 0);
  }

  // The same database under a retention policy of a few seconds, applied every second.
  FleetdProcess server({"--db", "sqlite:" + database.string(), "--retain-runs-days", "0.00005",
                        "--retain-jobs-days", "0.00005", "--retention-interval-seconds", "1"});
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  auto queries = fleet::v1::Queries::NewStub(channel);
  auto reprocessing = fleet::v1::Reprocessing::NewStub(channel);
  auto admin = fleet::v1::Admin::NewStub(channel);
  const std::string engineer = IssueToken(*admin, "engineer:retention-test");
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (JobCount(*reprocessing, engineer) != 0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(JobCount(*reprocessing, engineer), 0) << "finished jobs are pruned";
  const std::vector<fleet::v1::RunSummary> runs = RunsOf(*queries, engineer, kept);
  ASSERT_FALSE(runs.empty());
  for (const auto& run : runs) {
    EXPECT_EQ(run.telemetry_bytes(), 0) << run.run_id() << ": its events were pruned";
    fleet::v1::GetRunReportRequest request;
    request.set_run_id(run.run_id());
    fleet::v1::GetRunReportResponse report;
    auto context = Context(engineer);
    EXPECT_THAT(queries->GetRunReport(context.get(), request, &report), IsOk()) << "reports are kept";
  }
  std::string body;
  EXPECT_EQ(
      HttpGet(server.http_address(), "/api/robots/" + kept + "/maps/current/export/map.g2o", &body, engineer),
      200)
      << "map versions are kept";
  // Reprocessing skips runs without events instead of failing on them.
  fleet::v1::StartJobRequest start;
  start.set_parameter_set("default");
  fleet::v1::Job job;
  auto start_context = Context(engineer);
  ASSERT_THAT(reprocessing->StartJob(start_context.get(), start, &job), IsOk());
  for (const auto job_until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
       std::chrono::steady_clock::now() < job_until;) {
    fleet::v1::GetJobRequest get;
    get.set_job_id(job.job_id());
    fleet::v1::Job now;
    auto context = Context(engineer);
    ASSERT_THAT(reprocessing->GetJob(context.get(), get, &now), IsOk())
        << "watched well within its retention";
    if (now.state() != "queued" && now.state() != "leased") {
      EXPECT_EQ(now.state(), "done") << now.last_error();
      EXPECT_EQ(now.progress_total(), 0) << "no run has events left to rerun";
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const Command audit = Fleetctl(server, FleetdProcess::AdminToken(), "--json audit");
  ASSERT_EQ(audit.exit_code, 0) << audit.out;
  std::set<std::string> actions;
  const nlohmann::json log = nlohmann::json::parse(audit.out);
  for (const auto& entry : log.at("entries")) {
    actions.insert(entry.at("action").get<std::string>());
    if (entry.at("action").get<std::string>().rfind("prune_", 0) == 0) {
      EXPECT_EQ(entry.at("actor"), "fleetd:retention");
    }
  }
  EXPECT_EQ(actions,
            (std::set<std::string>{"delete_robot", "prune_jobs", "prune_run_events", "set_credential"}))
      << audit.out;
  EXPECT_EQ(server.Stop(), 0);
}

}  // namespace
}  // namespace fleetd_test
