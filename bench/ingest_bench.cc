// Ingest and analysis throughput of fleetd against baselines measured in the same run.
//
//   ingest_bench [--benchmark_...]
//
// Pairs (RatioReporter: ratio = baseline time / candidate time, so < 1 means the candidate is slower):
//   Ingest/baseline   the same runs stored straight into a Repository (PutRobot, PutSnapshot×2, InsertRun) —
//                     no gRPC, no validation
//   Ingest/candidate  the runs uploaded to a real fleetd over loopback gRPC (4 parallel streams, analysis
//                     workers off so only ingest is measured)
//   Analysis/baseline analyzer::AnalyzeRun on in-memory runs (no storage)
//   Analysis/candidate the stored-run analysis a worker does (load from storage, analyse, PutReport)
// Counters: runs/s and events/s; after the table, p50/p99 upload latency of the candidate.
#include <benchmark/benchmark.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "analyzer/run_analysis.h"
#include "bench_report.h"
#include "fleet_client/local_fleetd.h"
#include "fleet_client/uploader.h"
#include "server/analysis.h"
#include "server/fleet_server.h"
#include "sim/run_simulator.h"
#include "sim/world.h"
#include "storage/repository.h"
#include "test_data.h"

namespace {

const std::string kAdmin = "admin:bench.9c4e1f7a2b6d3e8f0a5c7b1d9e2f4a6c8b0d3e5f7a9c1b2d4e6f8a0c2e4b6d8f";

std::vector<fleet::v1::RunFile>& Runs() {
  static std::vector<fleet::v1::RunFile> runs = [] {
    std::vector<fleet::v1::RunFile> out;
    auto worlds = sim::ListWorlds(test_data::WidestDir("floorplans"));
    if (!worlds.ok() || worlds->empty()) return out;
    sim::SimParams params;
    params.run_minutes = 2.0;
    for (int robot = 0; robot < 8; ++robot) {
      auto world = sim::LoadWorld((*worlds)[static_cast<std::size_t>(robot) % worlds->size()],
                                  3 + static_cast<std::uint64_t>(robot));
      if (!world.ok()) continue;
      sim::RobotSimulator simulator(*world, params, "bench-" + std::to_string(robot), "1.0", 5 + robot);
      for (int run = 0; run < 3; ++run) {
        auto outcome = simulator.SimulateRun("bench-" + std::to_string(robot) + "-" + std::to_string(run),
                                             1767225600.0 + 86400.0 * run);
        if (outcome.ok()) out.push_back(outcome->run);
      }
    }
    return out;
  }();
  return runs;
}

std::int64_t EventCount() {
  std::int64_t events = 0;
  for (const auto& run : Runs()) events += run.events_size();
  return events;
}

std::filesystem::path TempDirectory() {
  char pattern[] = "/tmp/ingest-bench-XXXXXX";
  return mkdtemp(pattern);
}

// A fleetd process with analysis workers off (role=server), without HTTP; its log in `directory`.
std::unique_ptr<fleet_client::LocalFleetd> StartFleetd(const std::filesystem::path& directory) {
  fleet_client::LocalFleetdOptions options;
  options.binary = FLEETD_BINARY;
  options.directory = directory;
  options.flags = {"--http", "", "--role", "server", "--rate-limit", "0"};
  options.admin_token = kAdmin;
  auto fleetd = std::make_unique<fleet_client::LocalFleetd>();
  if (const slamcore::Status started = fleetd->Start(options); !started.ok()) {
    std::fprintf(stderr, "%s\n", started.ToString().c_str());
  }
  return fleetd;
}

std::mutex g_latency_mutex;
std::vector<double> g_latencies;
// CPU seconds spent during the timed uploads, by fleetd and by this process (the uploader's threads).
double g_fleetd_cpu = 0.0, g_uploader_cpu = 0.0;
std::int64_t g_uploads_timed = 0;

/// User plus system CPU seconds of a process so far (/proc/<pid>/stat); 0 when it cannot be read.
double CpuSeconds(const std::string& pid) {
  std::ifstream file("/proc/" + pid + "/stat");
  std::string stat;
  std::getline(file, stat);                      // one line
  const std::size_t name_end = stat.rfind(')');  // the command name may hold spaces
  if (name_end == std::string::npos) return 0.0;
  std::istringstream fields(stat.substr(name_end + 2));
  std::string field;
  long long user = 0, system = 0;
  for (int index = 3; fields >> field && index <= 15; ++index) {  // field numbers as in proc(5)
    if (index == 14) user = std::stoll(field);
    if (index == 15) system = std::stoll(field);
  }
  return static_cast<double>(user + system) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

void SetCounters(benchmark::State& state, std::int64_t runs, std::int64_t events) {
  state.counters["runs/s"] = benchmark::Counter(static_cast<double>(runs), benchmark::Counter::kIsRate);
  state.counters["events/s"] = benchmark::Counter(static_cast<double>(events), benchmark::Counter::kIsRate);
}

void Ingest_baseline(benchmark::State& state) {
  std::int64_t runs = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const auto directory = TempDirectory();
    auto repository = storage::OpenRepository("sqlite:" + (directory / "fleet.db").string());
    state.ResumeTiming();
    for (const auto& run : Runs()) {
      storage::RobotRecord robot{run.header().robot_id(), run.header().robot_model(), run.header().firmware(),
                                 0};
      (void)(*repository)->PutRobot(robot);
      storage::RunRecord record;
      record.run_id = run.header().run_id();
      record.robot_id = run.header().robot_id();
      if (run.parent_snapshot().nodes_size() > 0) {
        auto id = (*repository)->PutSnapshot(run.parent_snapshot().SerializeAsString());
        if (id.ok()) record.parent_snapshot_id = *id;
      }
      auto child = (*repository)->PutSnapshot(run.child_snapshot().SerializeAsString());
      if (child.ok()) record.child_snapshot_id = *child;
      fleet::v1::RunFile telemetry;
      *telemetry.mutable_header() = run.header();
      *telemetry.mutable_events() = run.events();
      record.telemetry = telemetry.SerializeAsString();
      if (!(*repository)->InsertRun(record).ok()) state.SkipWithError("InsertRun failed");
      ++runs;
    }
    state.PauseTiming();
    repository = storage::Result<std::unique_ptr<storage::Repository>>(storage::Internal("closed"));
    std::filesystem::remove_all(directory);
    state.ResumeTiming();
  }
  SetCounters(state, runs, runs / static_cast<std::int64_t>(Runs().size()) * EventCount());
}

void Ingest_candidate(benchmark::State& state) {
  std::int64_t runs = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const auto directory = TempDirectory();
    auto server = StartFleetd(directory);
    if (!server->running()) {
      state.SkipWithError("fleetd did not start");
      return;
    }
    fleet_client::UploaderOptions options;
    options.server = server->grpc_address();
    options.token = kAdmin;
    fleet_client::Uploader uploader(options);
    const std::string fleetd_pid = std::to_string(server->pid());
    const double fleetd_cpu_before = CpuSeconds(fleetd_pid), uploader_cpu_before = CpuSeconds("self");
    state.ResumeTiming();
    std::atomic<std::size_t> next{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) {
      threads.emplace_back([&] {
        // One robot's runs in order (parents first), robots in parallel.
        for (std::size_t robot = next++; robot < 8; robot = next++) {
          for (const auto& run : Runs()) {
            if (run.header().robot_id() != "bench-" + std::to_string(robot)) continue;
            const auto outcome = uploader.Upload(run);
            std::lock_guard lock(g_latency_mutex);
            if (outcome.ok) g_latencies.push_back(outcome.seconds);
          }
        }
      });
    }
    for (auto& thread : threads) thread.join();
    runs += static_cast<std::int64_t>(Runs().size());
    state.PauseTiming();
    g_fleetd_cpu += CpuSeconds(fleetd_pid) - fleetd_cpu_before;
    g_uploader_cpu += CpuSeconds("self") - uploader_cpu_before;
    g_uploads_timed += static_cast<std::int64_t>(Runs().size());
    server.reset();
    std::filesystem::remove_all(directory);
    state.ResumeTiming();
  }
  SetCounters(state, runs, runs / static_cast<std::int64_t>(Runs().size()) * EventCount());
}

void Analysis_baseline(benchmark::State& state) {
  std::int64_t runs = 0, events = 0;
  analyzer::AnalysisOptions options;
  for (auto _ : state) {
    for (const auto& run : Runs()) {
      auto report = analyzer::AnalyzeRun(run, options);
      if (!report.ok()) state.SkipWithError(report.status().ToString().c_str());
      ++runs;
      events += run.events_size();
    }
  }
  SetCounters(state, runs, events);
}

void Analysis_candidate(benchmark::State& state) {
  const auto directory = TempDirectory();
  auto repository = storage::OpenRepository("sqlite:" + (directory / "fleet.db").string());
  if (!repository.ok() || !server::EnsureDefaultParameterSet(**repository, "default").ok()) {
    state.SkipWithError("storage");
    return;
  }
  for (const auto& run : Runs()) {
    (void)(*repository)
        ->PutRobot({run.header().robot_id(), run.header().robot_model(), run.header().firmware(), 0});
    storage::RunRecord record;
    record.run_id = run.header().run_id();
    record.robot_id = run.header().robot_id();
    if (run.parent_snapshot().nodes_size() > 0)
      record.parent_snapshot_id = *(*repository)->PutSnapshot(run.parent_snapshot().SerializeAsString());
    record.child_snapshot_id = *(*repository)->PutSnapshot(run.child_snapshot().SerializeAsString());
    fleet::v1::RunFile telemetry;
    *telemetry.mutable_header() = run.header();
    *telemetry.mutable_events() = run.events();
    record.telemetry = telemetry.SerializeAsString();
    (void)(*repository)->InsertRun(record);
  }
  std::int64_t runs = 0, events = 0;
  for (auto _ : state) {
    for (const auto& run : Runs()) {
      auto analysed = server::AnalyzeStoredRun(**repository, {run.header().robot_id(), run.header().run_id()},
                                               "default", nullptr);
      if (!analysed.ok()) state.SkipWithError(analysed.status().ToString().c_str());
      ++runs;
      events += run.events_size();
    }
  }
  SetCounters(state, runs, events);
  repository = storage::Result<std::unique_ptr<storage::Repository>>(storage::Internal("closed"));
  std::filesystem::remove_all(directory);
}

BENCHMARK(Ingest_baseline)
    ->Name("Ingest/baseline")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();
BENCHMARK(Ingest_candidate)
    ->Name("Ingest/candidate")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();
BENCHMARK(Analysis_baseline)
    ->Name("Analysis/baseline")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();
BENCHMARK(Analysis_candidate)
    ->Name("Analysis/candidate")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (Runs().empty()) {
    std::fprintf(stderr, "ingest_bench: no floor plans to simulate in %s\n",
                 test_data::WidestDir("floorplans").string().c_str());
    return 1;
  }
  std::printf("%zu runs, %lld events (8 robots x 3 runs of 2 simulated minutes)\n", Runs().size(),
              static_cast<long long>(EventCount()));
  bench::RatioReporter reporter("baseline", "candidate");
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios("ingest: repository vs fleetd over gRPC; analysis: in memory vs from storage");
  std::sort(g_latencies.begin(), g_latencies.end());
  if (!g_latencies.empty()) {
    auto percentile = [](double p) {
      return g_latencies[std::min(
          g_latencies.size() - 1,
          static_cast<std::size_t>(p / 100.0 * static_cast<double>(g_latencies.size())))];
    };
    std::printf("upload latency over %zu uploads (4 parallel streams): p50 %.1f ms, p99 %.1f ms\n",
                g_latencies.size(), 1000 * percentile(50), 1000 * percentile(99));
  }
  if (g_uploads_timed > 0) {
    // Where ingest's time goes on a machine whose cores the server and the uploader share.
    std::printf("CPU per upload: fleetd %.1f ms, uploader %.1f ms\n",
                1000 * g_fleetd_cpu / static_cast<double>(g_uploads_timed),
                1000 * g_uploader_cpu / static_cast<double>(g_uploads_timed));
  }
  return 0;
}
