// Issue 16: under a flood of bad tokens, fleetd still answers a valid request at once. Starts fleetd on
// loopback, measures a valid Queries.ListRuns (engineer token verified once before) unflooded, then while 16
// threads send 300 requests with wrong secrets for an existing robot, and prints both with their ratio; also
// what a token never used before gets during the flood (the per-peer failure limit applies to it).
//
//   auth_flood_bench [--fleetd PATH]     (run by hand; not a timed unit test)
#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "fleet/v1/service.grpc.pb.h"
#include "fleetd_child.h"

namespace {

const std::string kAdmin = "admin:bench.9c4e1f7a2b6d3e8f0a5c7b1d9e2f4a6c8b0d3e5f7a9c1b2d4e6f8a0c2e4b6d8f";

std::unique_ptr<grpc::ClientContext> Context(const std::string& token) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->AddMetadata("authorization", "Bearer " + token);
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  return context;
}

/// Seconds one ListRuns takes, and its status.
std::pair<double, grpc::Status> ListRuns(fleet::v1::Queries::Stub& queries, const std::string& token) {
  fleet::v1::ListRunsRequest request;
  request.set_page_size(10);
  fleet::v1::ListRunsResponse response;
  auto context = Context(token);
  const auto start = std::chrono::steady_clock::now();
  grpc::Status status = queries.ListRuns(context.get(), request, &response);
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), status};
}

std::string Mint(fleet::v1::Admin::Stub& admin, const std::string& principal) {
  fleet::v1::SetCredentialRequest request;
  request.set_principal(principal);
  fleet::v1::SetCredentialResponse response;
  auto context = Context(kAdmin);
  const grpc::Status status = admin.SetCredential(context.get(), request, &response);
  if (!status.ok()) {
    std::fprintf(stderr, "SetCredential(%s): %s\n", principal.c_str(), status.error_message().c_str());
    std::exit(1);
  }
  return response.token();
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values.empty() ? 0.0 : values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string binary = FLEETD_BINARY;
  for (int k = 1; k + 1 < argc; ++k) {
    if (std::string(argv[k]) == "--fleetd") binary = argv[k + 1];
  }
  char pattern[] = "/tmp/auth-flood-bench-XXXXXX";
  const std::filesystem::path directory = mkdtemp(pattern);
  int exit_code = 0;
  {
    bench::FleetdChild fleetd(binary, directory, kAdmin, {"--workers", "1", "--rate-limit", "0"});
    if (fleetd.grpc.empty()) {
      std::fprintf(stderr, "fleetd did not start (log in %s)\n", directory.c_str());
      return 1;
    }
    auto channel = grpc::CreateChannel(fleetd.grpc, grpc::InsecureChannelCredentials());
    auto queries = fleet::v1::Queries::NewStub(channel);
    auto admin = fleet::v1::Admin::NewStub(channel);
    const std::string engineer = Mint(*admin, "engineer:bench");
    const std::string fresh = Mint(*admin, "engineer:fresh");
    const std::string victim = Mint(*admin, "robot:victim");
    const std::string victim_principal = victim.substr(0, victim.rfind('.'));

    // Baseline: the same valid request, nothing else going on.
    ListRuns(*queries, engineer);  // verified once (a client's first call)
    std::vector<double> baseline;
    for (int k = 0; k < 50; ++k) baseline.push_back(ListRuns(*queries, engineer).first);

    // Flood: 16 threads, 300 wrong secrets for an existing principal, each on its own channel.
    constexpr int kThreads = 16, kBadTokens = 300;
    std::atomic<int> sent{0}, refused_fast{0};
    const auto flood_start = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        grpc::ChannelArguments arguments;
        arguments.SetInt("flood_thread", t);  // a channel (connection) of its own
        auto own = fleet::v1::Queries::NewStub(
            grpc::CreateCustomChannel(fleetd.grpc, grpc::InsecureChannelCredentials(), arguments));
        while (sent.fetch_add(1) < kBadTokens) {
          const auto [seconds, status] = ListRuns(*own, victim_principal + "." + std::string(64, '0'));
          if (status.error_message().find("too many failed attempts") != std::string::npos) ++refused_fast;
          (void)seconds;
        }
      });
    }
    std::vector<double> flooded;
    std::pair<double, grpc::Status> fresh_result{0.0, grpc::Status::OK};
    bool fresh_tried = false;
    while (sent.load() < kBadTokens) {
      const auto [seconds, status] = ListRuns(*queries, engineer);
      if (!status.ok())
        std::fprintf(stderr, "valid request failed during the flood: %s\n", status.error_message().c_str());
      flooded.push_back(seconds);
      if (!fresh_tried && sent.load() > kBadTokens / 2) {
        fresh_result = ListRuns(*queries, fresh);
        fresh_tried = true;
      }
    }
    for (auto& thread : threads) thread.join();
    const double flood_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - flood_start).count();
    const double worst = flooded.empty() ? 0.0 : *std::max_element(flooded.begin(), flooded.end());

    std::printf(
        "auth flood: %d wrong secrets for %s from %d threads in %.3f s (%.0f/s); %d refused by the "
        "failed-attempt limit before hashing\n",
        kBadTokens, victim_principal.c_str(), kThreads, flood_seconds, kBadTokens / flood_seconds,
        refused_fast.load());
    std::printf("valid ListRuns, unflooded baseline: median %.3f ms, max %.3f ms (%zu requests)\n",
                1e3 * Median(baseline), 1e3 * *std::max_element(baseline.begin(), baseline.end()),
                baseline.size());
    std::printf("valid ListRuns, during the flood:   median %.3f ms, max %.3f ms (%zu requests)\n",
                1e3 * Median(flooded), 1e3 * worst, flooded.size());
    std::printf("ratio flooded/baseline: median %.2f, max %.2f\n", Median(flooded) / Median(baseline),
                worst / *std::max_element(baseline.begin(), baseline.end()));
    if (fresh_tried) {
      std::printf("a token never used before, from the flooding address, mid-flood: %.3f ms, %s\n",
                  1e3 * fresh_result.first,
                  fresh_result.second.ok() ? "OK" : fresh_result.second.error_message().c_str());
    }
    const bool pass = !flooded.empty() && worst < 1.0;
    std::printf("valid request answered in < 1 s under the flood: %s\n", pass ? "yes" : "NO");
    exit_code = pass ? 0 : 1;
  }
  std::filesystem::remove_all(directory);
  return exit_code;
}
