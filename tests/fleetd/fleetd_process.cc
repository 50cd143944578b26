#include "fleetd_process.h"

#include <grpcpp/generic/generic_stub.h>

#include <map>
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "sim/run_simulator.h"
#include "sim/world.h"
#include "test_data.h"
#include "status_matchers.h"

namespace fleetd_test {

const std::string& FleetdProcess::AdminToken() {
  static const std::string token =
      "admin:root.5f0c9e2a7b13d48e6a91c07f3b2d5e84a6c1f9073e2b8d4c5a7f60e19b3d2c8a";
  return token;
}

FleetdProcess::FleetdProcess(std::vector<std::string> extra, std::function<void()> in_child) {
  char pattern[] = "/tmp/fleetd-test-XXXXXX";
  directory_ = mkdtemp(pattern);
  int out[2];
  if (pipe(out) != 0) return;
  // Flags in `extra` replace the defaults of the same name.
  std::vector<std::pair<std::string, std::string>> defaults = {
      {"--db", "sqlite:" + (directory_ / "fleet.db").string()},
      {"--listen", "127.0.0.1:0"},
      {"--http", "127.0.0.1:0"},
      {"--workers", "2"},
      {"--shutdown-grace", "10"}};
  std::vector<std::string> args = {FLEETD_BINARY};
  for (const auto& [flag, value] : defaults) {
    if (std::find(extra.begin(), extra.end(), flag) == extra.end()) {
      args.push_back(flag);
      args.push_back(value);
    }
  }
  args.insert(args.end(), extra.begin(), extra.end());
  const std::string log_path = (directory_ / "fleetd.log").string();
  pid_ = fork();
  if (pid_ == 0) {
    dup2(out[1], 1);
    const int log = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (log >= 0) dup2(log, 2);
    close(out[0]);
    close(out[1]);
    setenv("FLEETD_BOOTSTRAP_ADMIN_TOKEN", AdminToken().c_str(), 1);
    if (in_child) in_child();
    std::vector<char*> argv;
    for (auto& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(out[1]);
  std::string line;
  char c;
  while (read(out[0], &c, 1) == 1 && c != '\n') line += c;
  close(out[0]);
  try {
    const auto json = nlohmann::json::parse(line);
    grpc_ = json.at("grpc").get<std::string>();
    http_ = json.at("http").get<std::string>();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fleetd did not print its addresses (got \"%s\"): %s\n", line.c_str(), e.what());
  }
}

FleetdProcess::~FleetdProcess() {
  Stop();
  std::error_code ignored;
  if (std::getenv("FLEETD_TEST_KEEP") == nullptr) std::filesystem::remove_all(directory_, ignored);
}

int FleetdProcess::Stop() {
  if (pid_ <= 0) return -1;
  kill(pid_, SIGTERM);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::shared_ptr<grpc::Channel> FleetdProcess::Channel() const {
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(64 << 20);
  return grpc::CreateCustomChannel(grpc_, grpc::InsecureChannelCredentials(), arguments);
}

std::string HttpRaw(const std::string& address, const std::string& request) {
  const std::size_t colon = address.rfind(':');
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
  inet_pton(AF_INET, address.substr(0, colon).c_str(), &addr.sin_addr);
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      write(fd, request.data(), request.size()) < 0) {
    close(fd);
    return "";
  }
  std::string response;
  char buffer[4096];
  ssize_t n;
  while ((n = read(fd, buffer, sizeof buffer)) > 0) response.append(buffer, static_cast<std::size_t>(n));
  close(fd);
  return response;
}

int HttpGet(const std::string& address, const std::string& path, std::string* body,
            const std::string& token) {
  const std::string response =
      HttpRaw(address, "GET " + path + " HTTP/1.1\r\nHost: " + address + "\r\n" +
                           (token.empty() ? "" : "Authorization: Bearer " + token + "\r\n") +
                           "Connection: close\r\n\r\n");
  const std::size_t header_end = response.find("\r\n\r\n");
  if (body != nullptr) *body = header_end == std::string::npos ? "" : response.substr(header_end + 4);
  if (response.size() < 12) return -1;
  return std::stoi(response.substr(9, 3));
}

std::string IssueToken(fleet::v1::Admin::Stub& admin, const std::string& principal) {
  fleet::v1::SetCredentialRequest request;
  request.set_principal(principal);
  fleet::v1::SetCredentialResponse response;
  auto context = Context(FleetdProcess::AdminToken());
  const grpc::Status status = admin.SetCredential(context.get(), request, &response);
  EXPECT_THAT(status, IsOk());
  return response.token();
}

std::string RobotToken(fleet::v1::Admin::Stub& admin, const std::string& robot_id) {
  static std::map<std::string, std::string> tokens;
  auto [it, inserted] = tokens.try_emplace(robot_id);
  if (inserted) it->second = IssueToken(admin, "robot:" + robot_id);
  return it->second;
}

int CountRuns(fleet::v1::Queries::Stub& queries, const std::string& token) {
  fleet::v1::ListRunsRequest request;
  request.set_page_size(1000);
  fleet::v1::ListRunsResponse response;
  auto context = Context(token);
  EXPECT_THAT(queries.ListRuns(context.get(), request, &response), IsOk());
  return response.runs_size();
}

const std::vector<fleet::v1::RunFile>& SimulatedRuns() {
  static std::once_flag once;
  static std::vector<fleet::v1::RunFile> runs;
  std::call_once(once, [] {
    const std::filesystem::path plans = test_data::Sample() / "floorplans";
    auto worlds = sim::ListWorlds(plans);
    if (!worlds.ok()) return;
    sim::SimParams params;
    params.run_minutes = 2.0;
    for (int robot = 0; robot < 2; ++robot) {
      auto world =
          sim::LoadWorld((*worlds)[static_cast<std::size_t>(robot)], 7 + static_cast<std::uint64_t>(robot));
      if (!world.ok()) return;
      const std::string robot_id = "robot-" + std::to_string(robot);
      sim::RobotSimulator simulator(*world, params, robot_id, robot == 0 ? "1.4.2" : "1.5.0", 11 + robot);
      for (int run = 0; run < 2; ++run) {
        auto outcome = simulator.SimulateRun(robot_id + "-run" + std::to_string(run),
                                             1767225600.0 + 86400.0 * run + 60.0 * robot);
        if (!outcome.ok()) return;
        runs.push_back(outcome->run);
      }
    }
  });
  return runs;
}

int HealthStatus(const std::shared_ptr<grpc::Channel>& channel) {
  // The request is a raw protobuf of one empty string field; the reply's field 1 is the status.
  grpc::GenericStub generic(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::Slice empty("", 0);
  grpc::ByteBuffer request(&empty, 1), reply;
  grpc::Status status;
  std::mutex mutex;
  std::condition_variable done;
  bool finished = false;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &reply,
                    [&](grpc::Status s) {
                      std::lock_guard lock(mutex);
                      status = s;
                      finished = true;
                      done.notify_all();
                    });
  std::unique_lock lock(mutex);
  done.wait(lock, [&] { return finished; });
  std::vector<grpc::Slice> slices;
  if (!status.ok() || !reply.Dump(&slices).ok()) return -1;
  std::string bytes;
  for (const auto& slice : slices) bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  return bytes.size() == 2 && bytes[0] == '\x08' ? bytes[1] : -1;
}

std::unique_ptr<grpc::ClientContext> Context(const std::string& token, int deadline_seconds) {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(deadline_seconds));
  return context;
}

grpc::Status Upload(fleet::v1::Ingest::Stub& stub, const std::string& token, const fleet::v1::RunFile& run,
                    fleet::v1::UploadRunResponse* response, const UploadOptions& options) {
  auto context = Context(token);
  auto writer = stub.UploadRun(context.get(), response);
  int sent = 0;
  auto send = [&](const fleet::v1::UploadRunRequest& message) {
    if (options.cancel_after_messages >= 0 && sent >= options.cancel_after_messages) return false;
    ++sent;
    return writer->Write(message);
  };
  bool cut = false;
  fleet::v1::UploadRunRequest message;
  *message.mutable_header() = run.header();
  if (!options.parent_id.empty()) message.mutable_header()->set_parent_snapshot_id(options.parent_id);
  if (!send(message)) cut = true;
  for (int i = 0; !cut && i < run.events_size(); i += options.events_per_chunk) {
    message.Clear();
    for (int j = i; j < std::min(run.events_size(), i + options.events_per_chunk); ++j) {
      *message.mutable_events()->add_events() = run.events(j);
    }
    if (!send(message)) cut = true;
  }
  if (!cut && options.send_parent && run.has_parent_snapshot() && run.parent_snapshot().nodes_size() > 0) {
    message.Clear();
    *message.mutable_parent_snapshot() = run.parent_snapshot();
    if (!send(message)) cut = true;
  }
  if (!cut && options.send_child) {
    message.Clear();
    *message.mutable_child_snapshot() = run.child_snapshot();
    if (!send(message)) cut = true;
  }
  if (cut && options.cancel_after_messages >= 0) {
    context->TryCancel();
    return writer->Finish();
  }
  writer->WritesDone();
  return writer->Finish();
}

}  // namespace fleetd_test
