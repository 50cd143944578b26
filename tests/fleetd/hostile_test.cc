// Hostile clients against a real fleetd on loopback (issue 16): one test per confirmed attack. Each asserts
// the status code, that nothing was stored or leaked, that fleetd stayed up and answered a legitimate
// request meanwhile, and records fleetd's peak RSS (VmHWM) as a test property.
#include <gtest/gtest.h>
#include <zlib.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <tuple>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "fleetd_process.h"
#include "status_matchers.h"

namespace fleetd_test {
namespace {

using fleet::v1::RunFile;
using fleet::v1::UploadRunResponse;

int StatusOf(const std::string& response) {
  return response.size() > 12 ? std::stoi(response.substr(9, 3)) : -1;
}

class HostileTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    server_ = new FleetdProcess();
    ASSERT_TRUE(server_->ok());
    auto channel = server_->Channel();
    ingest_ = fleet::v1::Ingest::NewStub(channel).release();
    queries_ = fleet::v1::Queries::NewStub(channel).release();
    reprocessing_ = fleet::v1::Reprocessing::NewStub(channel).release();
    admin_ = fleet::v1::Admin::NewStub(channel).release();
    engineer_ = new std::string(Token("engineer:hostile-test"));
    // Two robots' first runs, stored legitimately: what the attacks try to reach.
    for (const RunFile& run : SimulatedRuns()) {
      if (robots_.contains(run.header().robot_id())) continue;
      UploadRunResponse response;
      const grpc::Status status = Upload(*ingest_, RobotToken(run.header().robot_id()), run, &response);
      ASSERT_THAT(status, IsOk());
      robots_[run.header().robot_id()] = response.child_snapshot_id();
      if (robots_.size() == 2) break;
    }
    ASSERT_EQ(robots_.size(), 2u);
  }
  static void TearDownTestSuite() {
    delete ingest_;
    delete queries_;
    delete reprocessing_;
    delete admin_;
    EXPECT_EQ(server_->Stop(), 0) << "fleetd exits 0 on SIGTERM";
    delete server_;
    delete engineer_;
  }

  static std::string Token(const std::string& principal) { return IssueToken(*admin_, principal); }
  static std::string RobotToken(const std::string& robot_id) {
    return fleetd_test::RobotToken(*admin_, robot_id);
  }
  static int CountRuns() { return fleetd_test::CountRuns(*queries_, *engineer_); }
  /// A run of robot `index` (0 or 1) from the simulation, with a fresh run id.
  static RunFile RunOf(int index, const std::string& run_id) {
    auto it = robots_.begin();
    std::advance(it, index);
    for (const RunFile& run : SimulatedRuns()) {
      if (run.header().robot_id() != it->first) continue;
      RunFile copy = run;
      copy.mutable_header()->set_run_id(run_id);
      return copy;
    }
    return {};
  }
  static std::string RobotId(int index) {
    auto it = robots_.begin();
    std::advance(it, index);
    return it->first;
  }

  /// fleetd is alive and answers a legitimate request (a robot's own upload history and an engineer's
  /// listing); records its peak RSS.
  void ExpectStillServing() {
    EXPECT_EQ(kill(server_->pid(), 0), 0) << "fleetd is running";
    std::string body;
    EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots", &body, *engineer_), 200) << body;
    EXPECT_NE(body.find(RobotId(0)), std::string::npos);
    EXPECT_GE(CountRuns(), 2);
    std::ifstream status("/proc/" + std::to_string(server_->pid()) + "/status");
    for (std::string line; std::getline(status, line);) {
      if (line.rfind("VmHWM:", 0) == 0) {
        RecordProperty("fleetd_peak_rss", line.substr(6));
        std::printf("fleetd peak RSS: %s\n", line.substr(6).c_str());
      }
    }
  }

  static FleetdProcess* server_;
  static fleet::v1::Ingest::Stub* ingest_;
  static fleet::v1::Queries::Stub* queries_;
  static fleet::v1::Reprocessing::Stub* reprocessing_;
  static fleet::v1::Admin::Stub* admin_;
  static std::string* engineer_;
  static std::map<std::string, std::string> robots_;  // robot id → its stored child snapshot id
};

FleetdProcess* HostileTest::server_ = nullptr;
fleet::v1::Ingest::Stub* HostileTest::ingest_ = nullptr;
fleet::v1::Queries::Stub* HostileTest::queries_ = nullptr;
fleet::v1::Reprocessing::Stub* HostileTest::reprocessing_ = nullptr;
fleet::v1::Admin::Stub* HostileTest::admin_ = nullptr;
std::string* HostileTest::engineer_ = nullptr;
std::map<std::string, std::string> HostileTest::robots_;

TEST_F(HostileTest, HttpReadsWithoutATokenGetNothing) {
  const std::string robot = RobotId(0), other = RobotId(1);
  for (const std::string& path :
       std::vector<std::string>{"/api/robots", "/api/runs", "/api/labels", "/api/jobs", "/api/stats",
                                "/metrics", "/api/robots/" + robot + "/maps/current/export/map.pgm",
                                "/api/robots/" + robot + "/maps/current/export/map.g2o"}) {
    std::string body;
    EXPECT_EQ(HttpGet(server_->http_address(), path, &body), 401) << path;
    EXPECT_EQ(body.find(robot), std::string::npos) << path << " leaks the robot id";
    EXPECT_EQ(HttpGet(server_->http_address(), path, &body, "engineer:hostile-test.0000"), 401) << path;
  }
  // A robot reads its own map and nothing else: not the fleet, not another robot's map or runs.
  std::string body;
  const std::string token = RobotToken(robot);
  EXPECT_EQ(
      HttpGet(server_->http_address(), "/api/robots/" + robot + "/maps/current/export/map.g2o", &body, token),
      200);
  EXPECT_NE(body.find("VERTEX_SE2"), std::string::npos);
  EXPECT_EQ(
      HttpGet(server_->http_address(), "/api/robots/" + other + "/maps/current/export/map.g2o", &body, token),
      403);
  EXPECT_EQ(body.find("VERTEX_SE2"), std::string::npos);
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/robots", &body, token), 403);
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/runs", &body, token), 403);
  EXPECT_EQ(HttpGet(server_->http_address(), "/metrics", &body, token), 403);
  // /healthz stays open (probes), and says nothing but "ok".
  EXPECT_EQ(HttpGet(server_->http_address(), "/healthz", &body), 200);
  EXPECT_EQ(body, "ok\n");
  ExpectStillServing();
}

TEST_F(HostileTest, ForeignHostAndCrossOriginWritesAreRefused) {
  const std::string& address = server_->http_address();
  const std::string auth = "Authorization: Bearer " + *engineer_ + "\r\n";
  // DNS rebinding: a page on attacker.example resolved to 127.0.0.1 sends its own name as Host.
  std::string response = HttpRaw(address, "GET /api/robots HTTP/1.1\r\nHost: attacker.example:" +
                                              address.substr(address.rfind(':') + 1) + "\r\n" + auth +
                                              "Connection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(response), 421) << response;
  EXPECT_EQ(response.find(RobotId(0)), std::string::npos);
  response =
      HttpRaw(address, "GET /api/robots HTTP/1.1\r\n" + auth + "Connection: close\r\n\r\n");  // no Host
  EXPECT_GE(StatusOf(response), 400) << response;
  EXPECT_LT(StatusOf(response), 500) << response;
  EXPECT_EQ(response.find(RobotId(0)), std::string::npos);
  // A write from another origin, even with a valid token, is refused before it runs.
  const std::string body = R"({"action": "rollback", "reason": "cross-site"})";
  response = HttpRaw(address, "POST /api/robots/" + RobotId(0) +
                                  "/maps/current/review HTTP/1.1\r\nHost: " + address + "\r\n" + auth +
                                  "Origin: http://attacker.example\r\nContent-Length: " +
                                  std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
  EXPECT_EQ(StatusOf(response), 403) << response;
  // Security headers on every answer, no-store on the API.
  response = HttpRaw(
      address, "GET /api/robots HTTP/1.1\r\nHost: " + address + "\r\n" + auth + "Connection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(response), 200);
  for (const char* header :
       {"Content-Security-Policy: default-src 'self'", "X-Content-Type-Options: nosniff",
        "X-Frame-Options: DENY", "Referrer-Policy: no-referrer", "Cache-Control: no-store"}) {
    EXPECT_NE(response.find(header), std::string::npos) << header;
  }
  ExpectStillServing();
}

// A 1 MiB body of deflated JSON could inflate to 256 MiB and build a document ten times that: the map page's
// upload inflates no further than 32 MiB, and refuses what lies past it by name.
TEST_F(HostileTest, ADeflatedMapUploadThatInflatesTooFarIsRefusedByName) {
  const std::string& address = server_->http_address();
  std::string text = R"({"__class": "ValetudoMap", "metaData": {"version": 2}, "pad": ")";
  text += std::string(40u << 20, ' ');
  text += "\"}";
  uLongf deflated_size = compressBound(static_cast<uLong>(text.size()));
  std::string deflated(deflated_size, '\0');
  ASSERT_EQ(compress2(reinterpret_cast<Bytef*>(deflated.data()), &deflated_size,
                      reinterpret_cast<const Bytef*>(text.data()), static_cast<uLong>(text.size()), 9),
            Z_OK);
  deflated.resize(deflated_size);
  ASSERT_LT(deflated.size(), 1u << 20);
  const std::string response =
      HttpRaw(address, "POST /api/robots/" + RobotId(0) + "/maps/import HTTP/1.1\r\nHost: " + address +
                           "\r\nAuthorization: Bearer " + *engineer_ +
                           "\r\nContent-Type: application/json\r\nContent-Length: " +
                           std::to_string(deflated.size()) + "\r\nConnection: close\r\n\r\n" + deflated);
  EXPECT_EQ(StatusOf(response), 400) << response.substr(0, 400);
  EXPECT_NE(response.find("inflates to more than 33554432 bytes"), std::string::npos)
      << response.substr(0, 400);
  ExpectStillServing();
}

// A few hundred bytes of export may describe a huge map: pixels at two far corners span a grid of 64 million
// cells, and 800 runs of three numbers cover 16 million pixels. The map page refuses both by name, before the
// memory is taken, and stores nothing.
TEST_F(HostileTest, ASmallMapUploadThatDescribesAHugeMapIsRefusedByWhatItWouldCost) {
  const std::string& address = server_->http_address();
  const auto upload = [&](const std::string& body) {
    return HttpRaw(address, "POST /api/robots/" + RobotId(1) + "/maps/import HTTP/1.1\r\nHost: " + address +
                                "\r\nAuthorization: Bearer " + *engineer_ +
                                "\r\nContent-Type: application/json\r\nContent-Length: " +
                                std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
  };
  const auto export_of = [](const std::string& layers) {
    return R"({"__class": "ValetudoMap", "metaData": {"version": 2}, "size": {"x": 20000, "y": 20000}, )"
           R"("pixelSize": 5, "entities": [], "layers": [)" +
           layers + "]}";
  };
  std::string versions_before;
  ASSERT_EQ(HttpGet(address, "/api/robots/" + RobotId(1) + "/maps", &versions_before, *engineer_), 200);

  const auto expect_refused_naming = [&](const std::string& body, const std::string& naming) {
    const std::string response = upload(body);
    EXPECT_EQ(StatusOf(response), 400) << response.substr(0, 400);
    EXPECT_NE(response.find(naming), std::string::npos) << response.substr(0, 400);
  };
  const std::string corners = export_of(R"({"type": "floor", "compressedPixels": [0, 0, 1, 7999, 7999, 1]})");
  ASSERT_LT(corners.size(), 300u);
  expect_refused_naming(corners,
                        "their pixels span 8000 x 8000 map pixels, a grid of 64320400 cells with the margin, "
                        "more than the 16000000 this import accepts");
  std::string runs;
  for (int row = 0; row < 801; ++row) runs += (row ? ", 0, " : "0, ") + std::to_string(row) + ", 20000";
  expect_refused_naming(export_of(R"({"type": "floor", "compressedPixels": [)" + runs + "]}"),
                        "layers[0].compressedPixels: more than the 16000000 pixels left of the 16000000 all "
                        "layers together may cover");

  std::string versions_after;
  ASSERT_EQ(HttpGet(address, "/api/robots/" + RobotId(1) + "/maps", &versions_after, *engineer_), 200);
  EXPECT_EQ(versions_after, versions_before);
  ExpectStillServing();
}

// An id no upload can have is refused by its syntax, not looked up and echoed: a 20 kB run id came back
// in a NOT_FOUND message too large for the reply's metadata (RESOURCE_EXHAUSTED, which says retry).
TEST_F(HostileTest, IdsNoUploadCanHaveAreInvalidNotMissing) {
  for (const std::string& run_id : {std::string(20'000, 'a'), std::string("a/b"), std::string(129, 'r')}) {
    fleet::v1::GetRunReportRequest request;
    request.set_run_id(run_id);
    fleet::v1::GetRunReportResponse response;
    auto context = Context(*engineer_);
    const grpc::Status status = queries_->GetRunReport(context.get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_LT(status.error_message().size(), 200u);
  }
  // The same over HTTP: 400 naming the field, not 404, on every route that takes a run or robot id.
  const std::string long_id(129, 'r');
  for (const std::string& path :
       {"/api/runs/" + long_id, std::string("/api/runs/a%2Fb/map/info.json"), "/api/robots/" + long_id,
        "/api/robots/" + long_id + "/maps", std::string("/api/robots/a%20b/maps/current"),
        "/api/robots/" + long_id + "/maps/1/export/map.pgm"}) {
    std::string body;
    EXPECT_EQ(HttpGet(server_->http_address(), path, &body, *engineer_), 400) << path << ": " << body;
    const bool names_field =
        body.find("run_id: ") != std::string::npos || body.find("robot_id: ") != std::string::npos;
    EXPECT_TRUE(names_field) << path << ": " << body;
  }
  // A robot's reads of runs are looked up before the route (its own runs only): the id is checked first.
  std::string body;
  EXPECT_EQ(
      HttpGet(server_->http_address(), "/api/runs/" + std::string(1000, 'a'), &body, RobotToken(RobotId(0))),
      400)
      << body.substr(0, 200);
  EXPECT_LT(body.size(), 200u);
  ExpectStillServing();
}

// proto3 strings must be UTF-8: gRPC refuses such a request before any handler, and fleetd's answer says
// what is wrong instead of gRPC's bare INTERNAL. An upload whose header holds such bytes stores nothing.
TEST_F(HostileTest, AStringThatIsNotUtf8IsAnInvalidArgumentNotAnInternalError) {
  fleet::v1::GetRunReportRequest request;
  request.set_run_id("run-\xff\xfe");
  fleet::v1::GetRunReportResponse response;
  auto context = Context(*engineer_);
  const grpc::Status status = queries_->GetRunReport(context.get(), request, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("/fleet.v1.Queries/GetRunReport"), std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("not UTF-8"), std::string::npos) << status.error_message();

  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-utf8");
  run.mutable_header()->set_firmware("fw-\xc3\x28");
  UploadRunResponse uploaded;
  const grpc::Status upload = Upload(*ingest_, RobotToken(RobotId(0)), run, &uploaded);
  EXPECT_NE(upload.error_code(), grpc::StatusCode::OK);
  EXPECT_NE(upload.error_code(), grpc::StatusCode::INTERNAL) << upload.error_message();
  EXPECT_NE(upload.error_message().find("header: the stream ended before message[0] (or it did not parse"),
            std::string::npos)
      << upload.error_message();
  EXPECT_EQ(CountRuns(), before);
  ExpectStillServing();
}

TEST_F(HostileTest, APatchAt400MetresPerCellIsRefusedBeforeStoring) {
  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-400m");
  auto* snapshot = run.mutable_child_snapshot();
  ASSERT_GT(snapshot->nodes_size(), 0);
  snapshot->clear_local_maps();
  for (int k = 0; k < std::min(100, snapshot->nodes_size()); ++k) {
    auto* patch = snapshot->add_local_maps();
    patch->set_node(snapshot->nodes(k).id());
    auto* local = patch->mutable_local_map();
    local->set_resolution(400.0);
    local->set_width(1);
    local->set_height(1);
    local->set_cells(std::string(1, '\x64'));
    local->mutable_node_t_origin();
  }
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, RobotToken(RobotId(0)), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("child_snapshot.local_maps[0].local_map.resolution: 400 m/cell"),
            std::string::npos)
      << status.error_message();
  EXPECT_EQ(CountRuns(), before);
  ExpectStillServing();
}

TEST_F(HostileTest, UnboundedParameterSetsAreRefused) {
  for (const auto& [name, field, set] :
       std::vector<std::tuple<std::string, std::string, std::function<void(fleet::v1::MapperParameters&)>>>{
           {"expiry-1e300", "hypothesis_expiry_seconds",
            [](auto& m) { m.set_hypothesis_expiry_seconds(1e300); }},
           {"window-2p31", "local_window_nodes", [](auto& m) { m.set_local_window_nodes(2147483647); }}}) {
    fleet::v1::PutParameterSetRequest request;
    request.mutable_parameter_set()->set_name(name);
    set(*request.mutable_parameter_set()->mutable_mapper());
    fleet::v1::PutParameterSetResponse response;
    auto context = Context(*engineer_);
    const grpc::Status status = reprocessing_->PutParameterSet(context.get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << name;
    EXPECT_NE(status.error_message().find(field), std::string::npos) << status.error_message();
    std::string body;
    EXPECT_EQ(HttpGet(server_->http_address(), "/api/meta", &body, *engineer_), 200);
    EXPECT_EQ(body.find(name), std::string::npos) << name << " was stored";
  }
  ExpectStillServing();
}

// A flood of wrong secrets from loopback blocks every not-yet-verified token from that address for minutes
// (by design: the address limit), so it runs against its own fleetd, leaving the suite's server unblocked.
TEST(AddressFloodTest, WrongSecretsCostLittleAndAreLimitedBeforeHashing) {
  // 300 wrong secrets for an existing principal, and 300 for unknown ones: both answer fast (no PBKDF2),
  // and after a burst the known one is refused before any hashing.
  FleetdProcess server;
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  auto admin = fleet::v1::Admin::NewStub(channel);
  auto queries = fleet::v1::Queries::NewStub(channel);
  auto maps = fleet::v1::Maps::NewStub(channel);
  const std::string robot = "flood-robot";
  const std::string robot_token = IssueToken(*admin, "robot:" + robot);
  const std::string engineer_token =
      IssueToken(*admin, "engineer:flood-test");  // never used before the flood
  const auto get_map = [&](const std::string& token) {
    fleet::v1::GetMapRequest request;
    request.set_robot_id(robot);
    fleet::v1::GetMapResponse map;
    auto context = Context(token);
    return maps->GetMap(context.get(), request, &map);
  };
  // The revocation poll (every second) drops a freshly minted principal's cache entries; verify after it.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  ASSERT_NE(get_map(robot_token).error_code(), grpc::StatusCode::UNAUTHENTICATED);

  auto attempt = [&](const std::string& principal) {
    fleet::v1::ListRunsRequest request;
    fleet::v1::ListRunsResponse response;
    auto context = Context(principal + "." + std::string(64, 'f'));
    const auto start = std::chrono::steady_clock::now();
    const grpc::Status status = queries->ListRuns(context.get(), request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
    return std::make_pair(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                          status.error_message());
  };
  double known = 0.0, unknown = 0.0;
  int refused_before_hashing = 0;
  std::string refusal;
  const auto flood_start = std::chrono::steady_clock::now();
  for (int k = 0; k < 300; ++k) {
    auto [seconds, message] = attempt("robot:" + robot);
    known += seconds;
    if (message.find("too many failed attempts") != std::string::npos) {
      ++refused_before_hashing;
      refusal = message;
    }
  }
  const double flood_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - flood_start).count();
  for (int k = 0; k < 300; ++k) unknown += attempt("robot:nobody-" + std::to_string(k)).first;
  std::printf(
      "300 wrong secrets: known principal %.3f s (%d refused before hashing), unknown principals %.3f s\n",
      known, refused_before_hashing, unknown);
  EXPECT_LT(known, 10.0) << "PBKDF2 cost 57 s here";
  // Only the burst, then kFailureBurst - kFailuresKeptAtUnlock more each time the lock ends (one per refill
  // interval on average), reach the hash; every other one is refused first. The limits are fleetd's
  // documented ones (server/include/server/auth.h).
  constexpr double kFailureBurst = 20.0, kFailureRefillSeconds = 1.0;
  const int hashed_at_most = static_cast<int>(kFailureBurst + flood_seconds / kFailureRefillSeconds) + 1;
  EXPECT_GE(refused_before_hashing, 300 - hashed_at_most) << refusal;
  EXPECT_NE(refusal.find("; retry in "), std::string::npos) << refusal;
  // The robot's own token, verified before the flood, still works (the cache answers first).
  EXPECT_NE(get_map(robot_token).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  // A valid token not yet verified is refused from the flooding address while its lock holds. The lock's
  // own answer says how long: wait for a refusal that holds at least two more seconds (a lock that just
  // ended takes at most kFailureBurst - kFailuresKeptAtUnlock more failures to close again).
  // Bounded by time, not by count: under a sanitizer one refused attempt takes ~20 ms, so a lock's last
  // second alone outlasts dozens of attempts.
  int lock_seconds = 0;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  for (int k = 0; lock_seconds < 2 && std::chrono::steady_clock::now() < give_up; ++k) {
    const std::string message = attempt("robot:nobody-after-" + std::to_string(k)).second;
    const std::size_t at = message.find("; retry in ");
    if (at != std::string::npos) lock_seconds = std::stoi(message.substr(at + 11));
  }
  ASSERT_GE(lock_seconds, 2) << "the flooding address never locked";
  fleet::v1::ListRunsRequest request;
  fleet::v1::ListRunsResponse response;
  auto context = Context(engineer_token);
  const grpc::Status engineer = queries->ListRuns(context.get(), request, &response);
  EXPECT_EQ(engineer.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_NE(engineer.error_message().find("or from this address"), std::string::npos)
      << engineer.error_message();
  EXPECT_EQ(server.Stop(), 0);
}

TEST_F(HostileTest, TimesOutsideTheCenturyAreRefused) {
  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-time");
  run.mutable_header()->set_started_at(-9.2e15);
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, RobotToken(RobotId(0)), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("header.started_at: -9.2e+15 is outside 2000-01-01..2100-01-01"),
            std::string::npos)
      << status.error_message();
  EXPECT_EQ(CountRuns(), before);
  ExpectStillServing();
}

TEST_F(HostileTest, AParentFromAnotherRobotsHistoryIsRefused) {
  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-parent");
  UploadOptions options;
  options.send_parent = false;
  options.parent_id = robots_.at(RobotId(1));  // robot B's stored child map, named by id only
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, RobotToken(RobotId(0)), run, &response, options);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_NE(status.error_message().find("is not stored for robot " + RobotId(0)), std::string::npos);
  EXPECT_EQ(CountRuns(), before);
  ExpectStillServing();
}

TEST_F(HostileTest, ARobotTakingAnotherRobotsNextRunIdTakesNothing) {
  const int before = CountRuns();
  const std::string a = RobotId(0), b = RobotId(1), next = "hostile-next-run-of-b";
  // Robot A uploads first, under the id robot B will use for its next run.
  UploadRunResponse squatted;
  grpc::Status status = Upload(*ingest_, RobotToken(a), RunOf(0, next), &squatted);
  ASSERT_THAT(status, IsOk());
  // B's real upload of that id is stored and acknowledged OK; a retry of it is the same run.
  const RunFile real = RunOf(1, next);
  UploadRunResponse response;
  status = Upload(*ingest_, RobotToken(b), real, &response);
  ASSERT_THAT(status, IsOk());
  EXPECT_FALSE(response.already_present());
  EXPECT_EQ(response.run_id(), next);
  EXPECT_EQ(CountRuns(), before + 2) << "both runs are stored";
  status = Upload(*ingest_, RobotToken(b), real, &response);
  ASSERT_THAT(status, IsOk());
  EXPECT_TRUE(response.already_present());
  // The same robot, the same id, other content: a clear refusal, nothing stored.
  RunFile changed = real;
  changed.mutable_header()->set_firmware(changed.header().firmware() + "-changed");
  status = Upload(*ingest_, RobotToken(b), changed, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::ALREADY_EXISTS) << status.error_message();
  EXPECT_NE(status.error_message().find("of robot " + b), std::string::npos) << status.error_message();
  EXPECT_EQ(CountRuns(), before + 2);

  // A reads only its own run of that id; B's answers like a missing run.
  std::string body;
  const std::string token_a = RobotToken(a);
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/runs/" + next, &body, token_a), 200) << body;
  EXPECT_EQ(nlohmann::json::parse(body).at("run").at("robot_id"), a);
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/runs/" + next + "?robot=" + b, &body, token_a), 404)
      << body;
  EXPECT_EQ(body.find(b), std::string::npos) << "B's run is not revealed";
  EXPECT_EQ(
      HttpGet(server_->http_address(), "/api/runs/" + next + "/map/info.json?robot=" + b, &body, token_a),
      404);
  // An engineer names the robot; the id alone is ambiguous and says so.
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/runs/" + next + "?robot=" + b, &body, *engineer_), 200)
      << body;
  EXPECT_EQ(nlohmann::json::parse(body).at("run").at("robot_id"), b);
  EXPECT_EQ(HttpGet(server_->http_address(), "/api/runs/" + next, &body, *engineer_), 400) << body;
  EXPECT_NE(body.find("name the robot"), std::string::npos) << body;
  fleet::v1::GetRunReportRequest request;
  request.set_run_id(next);
  fleet::v1::GetRunReportResponse report;
  auto context = Context(*engineer_);
  EXPECT_EQ(queries_->GetRunReport(context.get(), request, &report).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  ExpectStillServing();
}

TEST_F(HostileTest, HeaderInjectionThroughARobotIdIsRefused) {
  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-crlf");
  run.mutable_header()->set_robot_id("x\r\nSet-Cookie: a=b");
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, FleetdProcess::AdminToken(), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("header.robot_id"), std::string::npos) << status.error_message();
  EXPECT_EQ(CountRuns(), before);
  // Nor does an id in a URL come back as a header line.
  const std::string& address = server_->http_address();
  const std::string answer =
      HttpRaw(address,
              "GET /api/robots/x%0d%0aSet-Cookie:%20a=b/maps/current/export/map.yaml "
              "HTTP/1.1\r\nHost: " +
                  address + "\r\nAuthorization: Bearer " + *engineer_ + "\r\nConnection: close\r\n\r\n");
  EXPECT_GE(StatusOf(answer), 400) << answer;
  EXPECT_EQ(answer.find("\r\nSet-Cookie"), std::string::npos) << answer;
  ExpectStillServing();
}

TEST_F(HostileTest, BytesAfterAValidChildSnapshotAreRefused) {
  const int before = CountRuns();
  RunFile run = RunOf(0, "hostile-trailing");
  run.mutable_child_snapshot()
      ->GetReflection()
      ->MutableUnknownFields(run.mutable_child_snapshot())
      ->AddVarint(99, 1);
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, RobotToken(RobotId(0)), run, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("child_snapshot: carries bytes that are no field"), std::string::npos)
      << status.error_message();
  EXPECT_EQ(CountRuns(), before);
  ExpectStillServing();
}

TEST_F(HostileTest, AnEngineersUploadForARobotIsTheirsAndWaitsForReview) {
  const std::string robot = RobotId(1);
  std::string before;
  ASSERT_EQ(HttpGet(server_->http_address(), "/api/robots/" + robot + "/maps", &before, *engineer_), 200);
  const int current = nlohmann::json::parse(before).at("current_version").get<int>();
  RunFile run = RunOf(1, "hostile-engineer-upload");
  UploadOptions options;
  options.send_parent = false;
  options.parent_id = robots_.at(robot);  // built on the robot's current map
  UploadRunResponse response;
  const grpc::Status status = Upload(*ingest_, *engineer_, run, &response, options);
  ASSERT_THAT(status, IsOk());
  std::string body;
  ASSERT_EQ(HttpGet(server_->http_address(), "/api/robots/" + robot + "/maps", &body, *engineer_), 200);
  const auto history = nlohmann::json::parse(body);
  bool found = false;
  for (const auto& version : history.at("versions")) {
    if (version.at("run_id") != "hostile-engineer-upload") continue;
    found = true;
    EXPECT_EQ(version.at("created_by"), "engineer:hostile-test");
    EXPECT_EQ(version.at("approval"), "pending");
  }
  EXPECT_TRUE(found) << body;
  EXPECT_EQ(history.at("current_version").get<int>(), current) << "the robot's map did not change unreviewed";
  ExpectStillServing();
}

// A run whose analysis outlasts its budget (here 1 µs) fails with a clear error instead of holding its
// lease forever; fleetd keeps serving.
TEST(HostileBudgetTest, AnAnalysisPastItsBudgetFailsWithAClearError) {
  FleetdProcess server({"--analysis-budget-seconds", "0.000001"});
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  auto ingest = fleet::v1::Ingest::NewStub(channel);
  auto admin = fleet::v1::Admin::NewStub(channel);
  const RunFile& run = SimulatedRuns().front();
  UploadRunResponse response;
  ASSERT_THAT(Upload(*ingest, FleetdProcess::AdminToken(), run, &response), IsOk());
  std::string body, state;
  nlohmann::json job;
  for (int k = 0; k < 240 && state != "failed"; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    ASSERT_EQ(
        HttpGet(server.http_address(), "/api/jobs?kind=analyze_run", &body, FleetdProcess::AdminToken()),
        200);
    const auto jobs = nlohmann::json::parse(body).at("jobs");
    if (jobs.empty()) continue;
    job = jobs.front();
    state = job.at("state").get<std::string>();
  }
  EXPECT_EQ(state, "failed") << job.dump();
  EXPECT_NE(
      job.value("last_error", "").find("analysis budget: run " + run.header().run_id() + " took longer than"),
      std::string::npos)
      << job.dump();
  EXPECT_EQ(HttpGet(server.http_address(), "/healthz", &body), 200);
  EXPECT_EQ(server.Stop(), 0);
}

}  // namespace
}  // namespace fleetd_test
