// Operating a real fleetd on loopback safely (issue 16): revocation and rotation seen by every process that
// shares the database, a bootstrap token that does not undo a rotation, weak secrets refused at start and
// passwords never logged, TLS with a certificate the test makes, a health check that notices when writes fail
// (a real SQLite file on a full file system), status codes clients can act on, and uploads in flight bounded.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "fleet/serialization.h"
#include "fleet/snapshot_parts.h"
#include "fleet_client/map_stream.h"
#include "fleet_client/uploader.h"
#include "fleetd_process.h"
#include "status_matchers.h"

namespace fleetd_test {
namespace {

using Clock = std::chrono::steady_clock;

grpc::StatusCode ListRunsCode(const std::shared_ptr<grpc::Channel>& channel, const std::string& token) {
  auto queries = fleet::v1::Queries::NewStub(channel);
  fleet::v1::ListRunsRequest request;
  fleet::v1::ListRunsResponse response;
  auto context = Context(token);
  return queries->ListRuns(context.get(), request, &response).error_code();
}

/// Seconds until `done()` holds, polling every 50 ms; -1 when it did not within `limit`.
template <typename Predicate>
double SecondsUntil(Predicate done, double limit) {
  const auto start = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - start).count() < limit) {
    if (done()) return std::chrono::duration<double>(Clock::now() - start).count();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return -1.0;
}

std::string ReadAll(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

std::string TempDirectory() {
  std::string pattern = (std::filesystem::temp_directory_path() / "fleetd-ops-XXXXXX").string();
  return mkdtemp(pattern.data());
}

std::unique_ptr<fleet::v1::Admin::Stub> AdminOf(const FleetdProcess& server) {
  return fleet::v1::Admin::NewStub(server.Channel());
}

grpc::Status Revoke(fleet::v1::Admin::Stub& admin, const std::string& token, const std::string& principal) {
  fleet::v1::RevokeCredentialRequest request;
  request.set_principal(principal);
  fleet::v1::RevokeCredentialResponse response;
  auto context = Context(token);
  return admin.RevokeCredential(context.get(), request, &response);
}

grpc::Status Rotate(fleet::v1::Admin::Stub& admin, const std::string& token, const std::string& principal,
                    std::string* new_token) {
  fleet::v1::RotateCredentialRequest request;
  request.set_principal(principal);
  fleet::v1::SetCredentialResponse response;
  auto context = Context(token);
  grpc::Status status = admin.RotateCredential(context.get(), request, &response);
  *new_token = response.token();
  return status;
}

TEST(OperationsTest, RevocationAndRotationReachEveryProcessSharingTheDatabase) {
  FleetdProcess a;
  ASSERT_THAT(a, IsOk());
  FleetdProcess b({"--db", "sqlite:" + (a.directory() / "fleet.db").string()});
  ASSERT_THAT(b, IsOk());
  auto admin = AdminOf(a);
  const std::string engineer = IssueToken(*admin, "engineer:ops");
  ASSERT_EQ(ListRunsCode(a.Channel(), engineer), grpc::StatusCode::OK);
  ASSERT_EQ(ListRunsCode(b.Channel(), engineer), grpc::StatusCode::OK) << "now cached by b";

  ASSERT_THAT(Revoke(*admin, FleetdProcess::AdminToken(), "engineer:ops"), IsOk());
  EXPECT_EQ(ListRunsCode(a.Channel(), engineer), grpc::StatusCode::UNAUTHENTICATED)
      << "refused at once where revoked";
  const double seen = SecondsUntil(
      [&] { return ListRunsCode(b.Channel(), engineer) == grpc::StatusCode::UNAUTHENTICATED; }, 10.0);
  std::printf("revocation refused by the other process after %.2f s\n", seen);
  EXPECT_GE(seen, 0.0);
  EXPECT_LT(seen, 3.0) << "the credential epoch is polled every second (observed about 1 s)";

  // Rotation: a robot rotates its own token on b; the old one stops working on a as well.
  const std::string robot = IssueToken(*admin, "robot:ops-r1");
  ASSERT_EQ(ListRunsCode(a.Channel(), robot), grpc::StatusCode::PERMISSION_DENIED)
      << "authenticated (and cached)";
  std::string rotated;
  auto admin_b = AdminOf(b);
  ASSERT_THAT(Rotate(*admin_b, robot, "robot:ops-r1", &rotated), IsOk());
  EXPECT_NE(rotated, robot);
  EXPECT_EQ(ListRunsCode(b.Channel(), rotated), grpc::StatusCode::PERMISSION_DENIED)
      << "the new token authenticates";
  const double old_refused = SecondsUntil(
      [&] { return ListRunsCode(a.Channel(), robot) == grpc::StatusCode::UNAUTHENTICATED; }, 10.0);
  EXPECT_GE(old_refused, 0.0);
  EXPECT_LT(old_refused, 3.0);
  std::string ignored;
  EXPECT_EQ(Rotate(*admin_b, rotated, "engineer:ops", &ignored).error_code(),
            grpc::StatusCode::PERMISSION_DENIED)
      << "a robot rotates only its own token";
  EXPECT_EQ(Rotate(*admin, FleetdProcess::AdminToken(), "robot:nobody", &ignored).error_code(),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(Revoke(*admin, rotated, "robot:ops-r1").error_code(), grpc::StatusCode::PERMISSION_DENIED);

  // The last admin stays; the listing shows who is revoked and never a secret.
  EXPECT_EQ(Revoke(*admin, FleetdProcess::AdminToken(), "admin:root").error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  fleet::v1::ListCredentialsRequest list;
  list.set_include_revoked(true);
  fleet::v1::ListCredentialsResponse listed;
  auto context = Context(FleetdProcess::AdminToken());
  ASSERT_THAT(admin->ListCredentials(context.get(), list, &listed), IsOk());
  ASSERT_EQ(listed.credentials_size(), 3);
  EXPECT_EQ(listed.credentials(1).principal(), "engineer:ops");
  EXPECT_TRUE(listed.credentials(1).revoked());
  EXPECT_EQ(listed.credentials(2).role(), "robot");
  EXPECT_EQ(listed.DebugString().find(rotated.substr(rotated.rfind('.') + 1)), std::string::npos);

  // Each change is in the audit log, with who made it.
  fleet::v1::ListAuditLogResponse audit;
  auto audit_context = Context(FleetdProcess::AdminToken());
  ASSERT_THAT(admin->ListAuditLog(audit_context.get(), fleet::v1::ListAuditLogRequest(), &audit), IsOk());
  std::vector<std::tuple<std::string, std::string, std::string>> changes;  // oldest first
  for (const auto& entry : audit.entries())
    changes.emplace(changes.begin(), entry.action(), entry.subject(), entry.actor());
  EXPECT_EQ(changes, (std::vector<std::tuple<std::string, std::string, std::string>>{
                         {"set_credential", "engineer:ops", "admin:root"},
                         {"revoke_credential", "engineer:ops", "admin:root"},
                         {"set_credential", "robot:ops-r1", "admin:root"},
                         {"rotate_credential", "robot:ops-r1", "robot:ops-r1"}}))
      << audit.DebugString();
  // Both listings are bounded: a page past 1000 is refused naming the field, and a robot may not read them.
  fleet::v1::ListCredentialsRequest too_many;
  too_many.set_page_size(1001);
  auto too_many_context = Context(FleetdProcess::AdminToken());
  const grpc::Status refused_page = admin->ListCredentials(too_many_context.get(), too_many, &listed);
  EXPECT_EQ(refused_page.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused_page.error_message().find("page_size"), std::string::npos)
      << refused_page.error_message();
  fleet::v1::ListAuditLogRequest too_long;
  too_long.set_limit(1001);
  auto too_long_context = Context(FleetdProcess::AdminToken());
  const grpc::Status refused_limit = admin->ListAuditLog(too_long_context.get(), too_long, &audit);
  EXPECT_EQ(refused_limit.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused_limit.error_message().find("limit"), std::string::npos) << refused_limit.error_message();
  auto robot_context = Context(rotated);
  EXPECT_EQ(admin->ListAuditLog(robot_context.get(), fleet::v1::ListAuditLogRequest(), &audit).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);

  // Erasing a robot deletes its credential row; the other process still drops the robot's cached token.
  const fleet::v1::RunFile& run = SimulatedRuns().front();
  const std::string uploader = IssueToken(*admin, "robot:" + run.header().robot_id());
  auto ingest = fleet::v1::Ingest::NewStub(a.Channel());
  fleet::v1::UploadRunResponse uploaded;
  ASSERT_THAT(Upload(*ingest, uploader, run, &uploaded), IsOk());
  ASSERT_EQ(ListRunsCode(b.Channel(), uploader), grpc::StatusCode::PERMISSION_DENIED)
      << "authenticated (and cached)";
  fleet::v1::DeleteRobotRequest erase;
  erase.set_robot_id(run.header().robot_id());
  erase.set_confirm(run.header().robot_id());
  fleet::v1::DeleteRobotResponse erased;
  auto erase_context = Context(FleetdProcess::AdminToken());
  ASSERT_THAT(admin->DeleteRobot(erase_context.get(), erase, &erased), IsOk());
  EXPECT_EQ(erased.credentials(), 1);
  const double erased_refused = SecondsUntil(
      [&] { return ListRunsCode(b.Channel(), uploader) == grpc::StatusCode::UNAUTHENTICATED; }, 10.0);
  std::printf("erased robot's token refused by the other process after %.2f s\n", erased_refused);
  EXPECT_GE(erased_refused, 0.0);
  EXPECT_LT(erased_refused, 3.0);
  EXPECT_EQ(b.Stop(), 0);
  EXPECT_EQ(a.Stop(), 0);
}

TEST(OperationsTest, TheBootstrapTokenDoesNotUndoARotationUnlessForced) {
  auto first = std::make_unique<FleetdProcess>();
  ASSERT_TRUE(first->ok());
  const std::string db = "sqlite:" + (first->directory() / "fleet.db").string();
  std::string rotated;
  ASSERT_THAT(Rotate(*AdminOf(*first), FleetdProcess::AdminToken(), "admin:root", &rotated), IsOk());
  EXPECT_EQ(ListRunsCode(first->Channel(), FleetdProcess::AdminToken()), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(first->Stop(), 0);

  // Restarted with the same FLEETD_BOOTSTRAP_ADMIN_TOKEN: an admin exists, so the rotation stands.
  auto second = std::make_unique<FleetdProcess>(std::vector<std::string>{"--db", db});
  ASSERT_TRUE(second->ok());
  EXPECT_EQ(ListRunsCode(second->Channel(), FleetdProcess::AdminToken()), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(ListRunsCode(second->Channel(), rotated), grpc::StatusCode::OK);
  EXPECT_EQ(second->Stop(), 0);
  EXPECT_NE(ReadAll(second->directory() / "fleetd.log").find("bootstrap_token_skipped"), std::string::npos);

  FleetdProcess forced({"--db", db, "--bootstrap-admin-force"});
  ASSERT_THAT(forced, IsOk());
  EXPECT_EQ(ListRunsCode(forced.Channel(), FleetdProcess::AdminToken()), grpc::StatusCode::OK)
      << "explicitly asked";
  EXPECT_EQ(forced.Stop(), 0);
}

struct Finished {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

/// Runs fleetd to completion (it must exit by itself within 20 s) with `env` set and `args`.
Finished RunFleetd(const std::vector<std::string>& args,
                   const std::vector<std::pair<std::string, std::string>>& env) {
  const std::string directory = TempDirectory(), log = directory + "/out.log";
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    dup2(fd, 1);
    dup2(fd, 2);
    unsetenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN");
    unsetenv("FLEETD_DB_URL");
    for (const auto& [name, value] : env) setenv(name.c_str(), value.c_str(), 1);
    std::vector<std::string> all = {FLEETD_BINARY, "--listen", "127.0.0.1:0", "--http", "",
                                    "--role",      "server"};
    all.insert(all.end(), args.begin(), args.end());
    if (std::find(args.begin(), args.end(), "--db") == args.end() &&
        std::none_of(env.begin(), env.end(), [](const auto& e) { return e.first == "FLEETD_DB_URL"; })) {
      all.push_back("--db");
      all.push_back("sqlite:" + directory + "/fleet.db");
    }
    std::vector<char*> argv;
    for (auto& arg : all) argv.push_back(arg.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  Finished run;
  int status = 0;
  const double waited = SecondsUntil([&] { return waitpid(pid, &status, WNOHANG) == pid; }, 20.0);
  if (waited < 0) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  } else if (WIFEXITED(status)) {
    run.exit_code = WEXITSTATUS(status);
  }
  run.output = ReadAll(log);
  std::filesystem::remove_all(directory);
  return run;
}

TEST(OperationsTest, WeakSecretsAreRefusedAtStartAndPasswordsNeverLogged) {
  const std::string strong = "5f0c9e2a7b13d48e6a91c07f3b2d5e84a6c1f9073e2b8d4c5a7f60e19b3d2c8a";
  const std::vector<std::tuple<std::string, std::string, std::string>> refused = {
      {"FLEETD_BOOTSTRAP_ADMIN_TOKEN", "admin:ops.change-me-to-a-long-random-secret",
       "bootstrap_admin_token: looks like a placeholder (contains \"changeme\")"},
      {"FLEETD_BOOTSTRAP_ADMIN_TOKEN", "admin:ops." + std::string(64, 'a'),
       "bootstrap_admin_token: a repetition"},
      {"FLEETD_BOOTSTRAP_ADMIN_TOKEN", "admin:ops.0123456789",
       "bootstrap_admin_token: shorter than 32 characters"},
      {"FLEETD_BOOTSTRAP_ADMIN_TOKEN", "robot:r1." + strong,
       "bootstrap_admin_token: names robot:r1, not an admin"},
      {"FLEETD_DB_URL", "postgresql://fleet:change-me@postgres:5432/fleet",
       "db: the URL's password: looks like a placeholder"},
      {"FLEETD_DB_URL", "postgresql://fleet:fleet-local@postgres:5432/fleet", "looks like a placeholder"},
  };
  for (const auto& [name, value, message] : refused) {
    const Finished run = RunFleetd({}, {{name, value}});
    EXPECT_EQ(run.exit_code, 2) << value << "\n" << run.output;
    EXPECT_NE(run.output.find(message), std::string::npos) << value << "\n" << run.output;
    EXPECT_EQ(run.output.find(value.substr(value.find(':') + 1)), std::string::npos)
        << "the secret was echoed";
  }
  // Opening fails (nothing listens on port 1, a malformed escape, a bad port): no log line has the password.
  const std::string password = "Kq7vX2pL9mZ4rT8wN3bY";
  for (const std::string& url :
       {"postgresql://fleet:" + password + "@127.0.0.1:1/fleet?connect_timeout=2",
        "postgresql://fleet:" + password + "%zz@127.0.0.1:1/fleet",
        "postgresql://fleet:" + password + "@127.0.0.1:notaport/fleet",
        "postgresql://fleet@127.0.0.1:1/fleet?password=" + password + "&connect_timeout=2"}) {
    const Finished run = RunFleetd({}, {{"FLEETD_DB_URL", url}});
    EXPECT_EQ(run.exit_code, 1) << url << "\n" << run.output;
    EXPECT_NE(run.output.find("open_failed"), std::string::npos) << run.output;
    EXPECT_NE(run.output.find("***"), std::string::npos) << run.output;
    EXPECT_EQ(run.output.find(password), std::string::npos) << run.output;
  }
}

/// A self-signed certificate for 127.0.0.1 and localhost, made with the openssl CLI in `directory`.
bool MakeCertificate(const std::string& directory, const std::string& name) {
  const std::string command =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=localhost -addext "
      "subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
      directory + "/" + name + ".key -out " + directory + "/" + name + ".crt >/dev/null 2>&1";
  return std::system(command.c_str()) == 0;
}

TEST(OperationsTest, TlsServesTlsClientsOnlyAndFleetctlReadsItsTokenFromAFile) {
  const std::string directory = TempDirectory();
  ASSERT_TRUE(MakeCertificate(directory, "server"))
      << "openssl req failed (deploy/bootstrap.sh installs openssl)";
  ASSERT_TRUE(MakeCertificate(directory, "other"));
  FleetdProcess server({"--tls-cert", directory + "/server.crt", "--tls-key", directory + "/server.key"});
  ASSERT_THAT(server, IsOk());

  fleet_client::UploaderOptions options;
  options.server = server.grpc_address();
  options.token = FleetdProcess::AdminToken();
  options.tls_ca = directory + "/server.crt";
  options.max_attempts = 1;
  const fleet_client::UploadOutcome uploaded =
      fleet_client::Uploader(options).Upload(SimulatedRuns().front());
  EXPECT_TRUE(uploaded.ok) << uploaded.message;

  // A plaintext client, and a TLS client that trusts another certificate, get nowhere.
  EXPECT_EQ(ListRunsCode(server.Channel(), FleetdProcess::AdminToken()), grpc::StatusCode::UNAVAILABLE);
  options.tls_ca = directory + "/other.crt";
  const fleet_client::UploadOutcome untrusted =
      fleet_client::Uploader(options).Upload(SimulatedRuns().front());
  EXPECT_FALSE(untrusted.ok);
  EXPECT_EQ(untrusted.code, static_cast<int>(grpc::StatusCode::UNAVAILABLE)) << untrusted.message;

  // fleetctl over TLS, its token from a file named in the environment (nothing secret in its argv).
  {
    std::ofstream token(directory + "/token");
    token << FleetdProcess::AdminToken() << "\n";
  }
  const std::string command = "FLEET_SERVER=" + server.grpc_address() + " FLEET_TLS_CA=" + directory +
                              "/server.crt FLEET_TOKEN_FILE=" + directory +
                              "/token " FLEETCTL_BINARY " runs --json";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) output.append(buffer, n);
  EXPECT_EQ(pclose(pipe), 0) << output;
  EXPECT_NE(output.find(SimulatedRuns().front().header().run_id()), std::string::npos) << output;
  EXPECT_EQ(server.Stop(), 0);
  std::filesystem::remove_all(directory);
}

/// Whether this process may make a private mount namespace (root on Linux): tried in a throwaway child.
bool CanMountPrivately() {
  const pid_t pid = fork();
  if (pid == 0) _exit(unshare(CLONE_NEWNS) == 0 ? 0 : 1);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

/// Fills the file system at `directory` until a write fails (ENOSPC).
void Fill(const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  const std::string block(1 << 16, 'x');
  while (::write(fd, block.data(), block.size()) > 0) {}
  ::close(fd);
}

// The database on its own small tmpfs (in fleetd's private mount namespace, so nothing outlives the test):
// filled up, writes fail; uploads answer UNAVAILABLE (retried by the uploader), /healthz and gRPC health say
// so within a probe; freed, fleetd is healthy again. chmod cannot show this: the kernel checks permissions
// when a file is opened, and SQLite keeps its database open.
TEST(OperationsTest, AFullDatabaseIsUnavailableAndUnhealthyUntilFreed) {
  if (!CanMountPrivately())
    GTEST_SKIP() << "needs a private mount namespace (root): unshare(CLONE_NEWNS) refused";
  const std::string directory = TempDirectory(), mount_point = directory + "/db";
  ASSERT_EQ(mkdir(mount_point.c_str(), 0700), 0);
  FleetdProcess server(
      {"--db", "sqlite:" + mount_point + "/fleet.db", "--health-probe-seconds", "0.5", "--workers", "1"},
      [mount_point] {
        if (unshare(CLONE_NEWNS) != 0 || mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
            mount("tmpfs", mount_point.c_str(), "tmpfs", 0, "size=24m") != 0) {
          _exit(111);
        }
      });
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  std::string body;
  ASSERT_EQ(HttpGet(server.http_address(), "/healthz", &body), 200) << body;
  ASSERT_EQ(HealthStatus(channel), 1);
  auto ingest = fleet::v1::Ingest::NewStub(channel);
  fleet::v1::UploadRunResponse response;
  ASSERT_THAT(Upload(*ingest, FleetdProcess::AdminToken(), SimulatedRuns().front(), &response), IsOk());

  // The file system as fleetd sees it, through its root in /proc.
  const std::string filler = "/proc/" + std::to_string(server.pid()) + "/root" + mount_point + "/filler";
  Fill(filler);
  fleet_client::UploaderOptions options;
  options.server = server.grpc_address();
  options.token = FleetdProcess::AdminToken();
  options.max_attempts = 2;
  options.initial_backoff = std::chrono::milliseconds(50);
  fleet_client::UploadOutcome outcome;
  for (int k = 0; k < 12 && (k == 0 || outcome.ok); ++k) {
    fleet::v1::RunFile run = SimulatedRuns()[static_cast<std::size_t>(k) % SimulatedRuns().size()];
    run.mutable_header()->set_run_id("full-" + std::to_string(k));
    outcome = fleet_client::Uploader(options).Upload(run);
  }
  ASSERT_FALSE(outcome.ok) << "a full file system took every upload";
  EXPECT_EQ(outcome.code, static_cast<int>(grpc::StatusCode::UNAVAILABLE)) << outcome.message;
  EXPECT_EQ(outcome.attempts, 2) << "UNAVAILABLE is retried";
  EXPECT_GE(SecondsUntil([&] { return HttpGet(server.http_address(), "/healthz", &body) == 503; }, 3.0), 0.0);
  EXPECT_NE(body.find("storage: "), std::string::npos) << body;
  EXPECT_GE(SecondsUntil([&] { return HealthStatus(channel) == 2; }, 3.0), 0.0) << "gRPC health NOT_SERVING";
  EXPECT_EQ(HttpGet(server.http_address(), "/livez", &body), 200) << "alive: no reason to restart it";

  std::filesystem::remove(filler);
  EXPECT_GE(SecondsUntil([&] { return HttpGet(server.http_address(), "/healthz", &body) == 200; }, 5.0), 0.0)
      << body;
  EXPECT_GE(SecondsUntil([&] { return HealthStatus(channel) == 1; }, 3.0), 0.0);
  fleet::v1::RunFile again = SimulatedRuns().back();
  again.mutable_header()->set_run_id("after-freeing");
  EXPECT_TRUE(fleet_client::Uploader(options).Upload(again).ok);
  EXPECT_EQ(server.Stop(), 0);
  std::filesystem::remove_all(directory);
}

// A lifelong robot's map outgrows one gRPC message long before a run outgrows max_run_bytes (a robot's 39th
// daily run of 10 min: a 17 MB child snapshot against fleetd's 16 MiB). The uploader sends each snapshot in
// parts and fleetd merges them: the stored snapshot is the one a single message would have carried; fleetd
// hands it back in parts too (Maps.StreamMap). Hostile
// parts: a parent part after the child's, and unknown bytes in a later part, are refused; parts that each fit
// a message but together exceed max_run_bytes are refused and nothing is stored.
TEST(OperationsTest, AMapLargerThanOneMessageIsUploadedInParts) {
  FleetdProcess server({"--max-message-bytes", "32768", "--workers", "1"});
  ASSERT_THAT(server, IsOk());
  const fleet::v1::RunFile& run = SimulatedRuns().front();
  ASSERT_GT(run.child_snapshot().ByteSizeLong(), 3u * 32768) << "the simulated map should need parts";
  fleet_client::UploaderOptions options;
  options.server = server.grpc_address();
  options.token = FleetdProcess::AdminToken();
  options.max_attempts = 1;
  options.events_per_chunk = 50;

  options.snapshot_part_bytes = 1 << 20;  // one part over the server's limit: refused as before
  const fleet_client::UploadOutcome whole = fleet_client::Uploader(options).Upload(run);
  EXPECT_FALSE(whole.ok);
  EXPECT_EQ(whole.code, static_cast<int>(grpc::StatusCode::RESOURCE_EXHAUSTED)) << whole.message;

  options.snapshot_part_bytes = 16 << 10;
  const fleet_client::UploadOutcome parts = fleet_client::Uploader(options).Upload(run);
  ASSERT_TRUE(parts.ok) << parts.message;
  EXPECT_EQ(parts.child_snapshot_id, fleet_client::SnapshotId(run.child_snapshot()));
  EXPECT_GT(parts.analysis_job_id, 0);

  // The same map handed back to its robot in parts (Maps.StreamMap): GetMap's answer, message by message.
  auto admin = fleet::v1::Admin::NewStub(server.Channel());
  auto maps = fleet::v1::Maps::NewStub(server.Channel());
  const std::string owner = IssueToken(*admin, "robot:" + run.header().robot_id());
  fleet::v1::GetMapRequest fetch;
  fetch.set_robot_id(run.header().robot_id());
  fleet::v1::GetMapResponse fetched;
  auto whole_context = Context(owner);
  ASSERT_THAT(maps->GetMap(whole_context.get(), fetch, &fetched), IsOk());
  ASSERT_FALSE(fetched.up_to_date());
  fetch.set_part_bytes(16 << 10);
  auto stream_context = Context(owner);
  auto reader = maps->StreamMap(stream_context.get(), fetch);
  fleet::v1::GetMapResponse streamed, merged;
  int streamed_messages = 0;
  while (reader->Read(&streamed)) {
    ++streamed_messages;
    EXPECT_LE(streamed.ByteSizeLong(), (16u << 10) + 1024) << "message " << streamed_messages;
    EXPECT_EQ(streamed.has_version(), streamed_messages == 1) << "the version travels once, first";
    merged.MergeFrom(streamed);
  }
  ASSERT_THAT(reader->Finish(), IsOk());
  EXPECT_GE(streamed_messages, 7) << "117 KB in parts of 16 KiB";
  EXPECT_EQ(fleet::SerializeDeterministic(merged), fleet::SerializeDeterministic(fetched));
  EXPECT_EQ(fleet_client::SnapshotId(merged.snapshot()), parts.child_snapshot_id);
  // The client library's fetch: the same answer; its bound cancels a map larger than it accepts.
  fleet::v1::GetMapResponse received;
  auto receive_context = Context(owner);
  ASSERT_THAT(fleet_client::ReceiveMap(*maps, *receive_context, fetch, 1 << 20, &received), IsOk());
  EXPECT_EQ(fleet::SerializeDeterministic(received), fleet::SerializeDeterministic(fetched));
  auto bounded_context = Context(owner);
  const grpc::Status too_large =
      fleet_client::ReceiveMap(*maps, *bounded_context, fetch, 40 << 10, &received);
  EXPECT_EQ(too_large.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << too_large.error_message();
  EXPECT_NE(too_large.error_message().find("the most this client accepts"), std::string::npos);
  EXPECT_EQ(received.ByteSizeLong(), 0u) << "nothing half-received is kept";
  // Parts the server will not cut, and another robot's map: refused before any part is sent.
  for (const std::int64_t part_bytes : {std::int64_t{100}, std::int64_t{1} << 30}) {
    fetch.set_part_bytes(part_bytes);
    auto context = Context(owner);
    const grpc::Status refused = fleet_client::ReceiveMap(*maps, *context, fetch, 1 << 20, &received);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << part_bytes;
    EXPECT_NE(refused.error_message().find("part_bytes: expected 16384..16777216"), std::string::npos)
        << refused.error_message();
  }
  fetch.set_part_bytes(0);
  const std::string stranger = IssueToken(*admin, "robot:someone-else");
  auto stranger_context = Context(stranger);
  EXPECT_EQ(fleet_client::ReceiveMap(*maps, *stranger_context, fetch, 1 << 20, &received).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  grpc::ClientContext anonymous;
  EXPECT_EQ(fleet_client::ReceiveMap(*maps, anonymous, fetch, 1 << 20, &received).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);

  // Hostile streams, by hand: the header, then these messages; what fleetd answers.
  const auto pieces = fleet::SnapshotParts(run.child_snapshot(), 16 << 10);
  ASSERT_GE(pieces.size(), 3u);
  const auto stream = [&](FleetdProcess& to, const std::string& run_id,
                          const std::vector<fleet::v1::UploadRunRequest>& messages) {
    auto ingest = fleet::v1::Ingest::NewStub(to.Channel());
    auto context = Context(FleetdProcess::AdminToken());
    fleet::v1::UploadRunResponse response;
    auto writer = ingest->UploadRun(context.get(), &response);
    fleet::v1::UploadRunRequest header;
    *header.mutable_header() = run.header();
    header.mutable_header()->set_run_id(run_id);
    header.mutable_header()->set_event_count(0);
    bool open = writer->Write(header);
    for (std::size_t k = 0; open && k < messages.size(); ++k) open = writer->Write(messages[k]);
    writer->WritesDone();
    return writer->Finish();
  };
  const auto child_part = [&](std::size_t k) {
    fleet::v1::UploadRunRequest message;
    *message.mutable_child_snapshot() = pieces[k];
    return message;
  };
  const auto refused_with = [](const grpc::Status& status, const std::string& reason) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find(reason), std::string::npos) << status.error_message();
  };

  // A part of the parent snapshot after the child's.
  fleet::v1::UploadRunRequest parent_part;
  *parent_part.mutable_parent_snapshot() = pieces.front();
  refused_with(stream(server, "parent-after-child", {child_part(0), child_part(1), parent_part}),
               "nothing but further parts of child_snapshot may follow it");
  // A later part carrying bytes that are no field: every part is checked, not only the first.
  fleet::v1::UploadRunRequest trailing = child_part(1);
  trailing.mutable_child_snapshot()
      ->GetReflection()
      ->MutableUnknownFields(trailing.mutable_child_snapshot())
      ->AddVarint(99, 1);
  refused_with(stream(server, "unknown-bytes-in-a-part", {child_part(0), trailing, child_part(2)}),
               "carries bytes that are no field of fleet.v1");
  EXPECT_EQ(server.Stop(), 0);

  // The parts count against max_run_bytes together: each fits in a message, all of them not in a run.
  FleetdProcess small_runs({"--max-message-bytes", "32768", "--max-run-bytes", "65536", "--workers", "1"});
  ASSERT_THAT(small_runs, IsOk());
  std::vector<fleet::v1::UploadRunRequest> every_part;
  for (std::size_t k = 0; k < pieces.size(); ++k) every_part.push_back(child_part(k));
  refused_with(stream(small_runs, "parts-over-max-run-bytes", every_part), "exceeds max_run_bytes (65536)");
  auto queries = fleet::v1::Queries::NewStub(small_runs.Channel());
  EXPECT_EQ(CountRuns(*queries, FleetdProcess::AdminToken()), 0) << "nothing stored";
  EXPECT_EQ(small_runs.Stop(), 0);
}

/// An events message of about `bytes` made of the simulated run's events, repeated.
fleet::v1::UploadRunRequest EventsOfSize(std::size_t bytes) {
  fleet::v1::UploadRunRequest message;
  const fleet::v1::RunFile& run = SimulatedRuns().front();
  for (std::size_t size = 0, i = 0; size < bytes; i = (i + 1) % static_cast<std::size_t>(run.events_size())) {
    const auto& event = run.events(static_cast<int>(i));
    *message.mutable_events()->add_events() = event;
    size += event.ByteSizeLong() + 4;  // and its tag and length
  }
  return message;
}

/// An open upload stream that has sent its header and `messages` copies of `chunk`.
struct OpenUpload {
  std::unique_ptr<grpc::ClientContext> context;
  fleet::v1::UploadRunResponse response;
  std::unique_ptr<grpc::ClientWriter<fleet::v1::UploadRunRequest>> writer;
  bool open = true;

  OpenUpload(fleet::v1::Ingest::Stub& ingest, const std::string& token, const std::string& robot,
             const fleet::v1::UploadRunRequest& chunk, int messages) {
    context = Context(token, 60);
    writer = ingest.UploadRun(context.get(), &response);
    fleet::v1::UploadRunRequest header;
    *header.mutable_header() = SimulatedRuns().front().header();
    header.mutable_header()->set_robot_id(robot);
    header.mutable_header()->set_run_id(robot + "-big");
    header.mutable_header()->set_event_count(
        static_cast<std::uint64_t>(chunk.events().events_size() * messages));
    open = writer->Write(header);
    for (int k = 0; open && k < messages; ++k) open = writer->Write(chunk);
  }
  grpc::Status Cancel() {
    context->TryCancel();
    return writer->Finish();
  }
};

std::string PeakRss(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return line.substr(6);
  }
  return "";
}

// Hostile: four robots upload ~20 MiB each at once into a fleetd that may buffer 48 MiB: the first two are
// taken, the others refused naming the limit, a small upload and a listing are answered meanwhile, and
// fleetd's peak RSS stays bounded. One robot's third stream is refused; a run that can never fit is
// INVALID_ARGUMENT and not retried.
TEST(OperationsTest, UploadsInFlightAreBoundedPerPrincipalAndInAll) {
  FleetdProcess server({"--max-message-bytes", "4194304", "--max-run-bytes", "25165824",
                        "--max-upload-bytes-per-principal", "25165824", "--max-upload-bytes-in-flight",
                        "50331648", "--max-upload-streams-per-principal", "2", "--rate-limit", "0",
                        "--workers", "1"});
  ASSERT_THAT(server, IsOk());
  auto channel = server.Channel();
  auto ingest = fleet::v1::Ingest::NewStub(channel);
  auto admin = AdminOf(server);
  const fleet::v1::UploadRunRequest chunk = EventsOfSize(3500 * 1024);
  std::vector<std::unique_ptr<OpenUpload>> uploads;
  for (int k = 0; k < 2; ++k) {
    const std::string robot = "big-" + std::to_string(k);
    uploads.push_back(std::make_unique<OpenUpload>(*ingest, RobotToken(*admin, robot), robot, chunk, 6));
    ASSERT_TRUE(uploads.back()->open) << "upload " << k << " was taken";
  }
  // Wait until fleetd has read what they sent (polled, so a loaded machine only makes it slower).
  auto metric = [&](const std::string& name) {
    std::string text;
    if (HttpGet(server.http_address(), "/metrics", &text, FleetdProcess::AdminToken()) != 200) return -1.0;
    const auto at = text.find("\n" + name + " ");
    return at == std::string::npos ? -1.0 : std::stod(text.substr(at + name.size() + 2));
  };
  ASSERT_GE(SecondsUntil(
                [&] { return metric("fleetd_upload_bytes_in_flight") >= 2.0 * 6 * 3500 * 1024 * 0.9; }, 30.0),
            0.0);
  for (int k = 2; k < 4; ++k) {
    const std::string robot = "big-" + std::to_string(k);
    OpenUpload refused(*ingest, RobotToken(*admin, robot), robot, chunk, 6);
    const grpc::Status status = refused.writer->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    EXPECT_NE(status.error_message().find("max_upload_bytes_in_flight (50331648)"), std::string::npos)
        << status.error_message();
  }
  // Meanwhile a small upload and a listing are answered.
  fleet::v1::UploadRunResponse small;
  const grpc::Status stored = Upload(*ingest, FleetdProcess::AdminToken(), SimulatedRuns().front(), &small);
  EXPECT_THAT(stored, IsOk());
  EXPECT_EQ(ListRunsCode(channel, FleetdProcess::AdminToken()), grpc::StatusCode::OK);
  std::string metrics;
  ASSERT_EQ(HttpGet(server.http_address(), "/metrics", &metrics, FleetdProcess::AdminToken()), 200);
  EXPECT_NE(metrics.find("fleetd_upload_streams_in_flight 2"), std::string::npos) << "the two held uploads";
  const std::string peak = PeakRss(server.pid());
  std::printf("fleetd peak RSS with 2 x 21 MiB uploads held and 2 refused: %s\n", peak.c_str());
  RecordProperty("fleetd_peak_rss", peak);
  EXPECT_LT(std::stol(peak), 600L * 1024) << "kB";

  // A third concurrent stream of one robot is refused while its two others are open.
  const std::string robot = "big-0";
  auto second = std::make_unique<OpenUpload>(*ingest, RobotToken(*admin, robot), robot, chunk, 0);
  // Only once fleetd holds the second stream is a third one over the limit (a loaded machine may deliver
  // them in either order).
  ASSERT_GE(SecondsUntil([&] { return metric("fleetd_upload_streams_in_flight") >= 3.0; }, 30.0), 0.0);
  OpenUpload third(*ingest, RobotToken(*admin, robot), robot, chunk, 0);
  const grpc::Status streams = third.writer->Finish();
  EXPECT_EQ(streams.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(streams.error_message().find("max_upload_streams_per_principal 2"), std::string::npos)
      << streams.error_message();
  second->Cancel();
  for (auto& upload : uploads) upload->Cancel();
  // Their handlers return and give the bytes back.
  ASSERT_GE(SecondsUntil([&] { return metric("fleetd_upload_streams_in_flight") == 0.0; }, 30.0), 0.0);

  // A run over --max-run-bytes can never fit: INVALID_ARGUMENT, tried once.
  fleet::v1::RunFile huge = SimulatedRuns().front();
  huge.mutable_header()->set_run_id("too-big");
  while (huge.ByteSizeLong() < 26u << 20) huge.mutable_events()->MergeFrom(chunk.events().events());
  huge.mutable_header()->set_event_count(static_cast<std::uint64_t>(huge.events_size()));
  fleet_client::UploaderOptions options;
  options.server = server.grpc_address();
  options.token = FleetdProcess::AdminToken();
  const fleet_client::UploadOutcome outcome = fleet_client::Uploader(options).Upload(huge);
  EXPECT_EQ(outcome.code, static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT)) << outcome.message;
  EXPECT_NE(outcome.message.find("max_run_bytes"), std::string::npos) << outcome.message;
  EXPECT_EQ(outcome.attempts, 1);
  EXPECT_EQ(server.Stop(), 0);
}

}  // namespace
}  // namespace fleetd_test
