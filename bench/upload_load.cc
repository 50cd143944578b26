// upload_load: many simulated robots uploading runs to fleetd at once for a bounded time (issue #9). A load
// test run by hand, not a timed unit test; like every benchmark here it reports against a baseline measured
// in the same run.
//
//   upload_load --server HOST:PORT[,HOST:PORT...] [--token T] [--robots 500] [--seconds 60]
//               [--run-minutes 1] [--pool 16] [--seed 1] [--max-attempts 1] [--world DIR] [--json]
//
// 1. Generates a pool of simulated runs (sim::RobotSimulator: each the first run of a robot in a real floor
//    plan) before anything is timed.
// 2. Baseline: one robot at a time uploads back to back for --baseline-seconds (default min(10 s,
//    seconds / 4)), split evenly over the servers in turn (a robot stays with one server, as in the load). A
//    server that acknowledges none of its uploads is named and the program exits 1.
// 3. Load: --robots robots, one thread and one fleet_client::Uploader (own connection) each, round-robin over
//    the servers, upload back to back until --seconds have passed; uploads in flight at the deadline finish and
//    count.
//
// Every upload is a distinct run: robot i replays pool run i mod pool (the same home every time) with its own
// robot id, a new run id, and all clocks (header, events, map nodes) an hour after the previous upload.
// Moving the clock makes each child snapshot new content: fleetd stores snapshots by content, and repeats
// would store nothing. The pooled runs are first runs, without a parent map, so relabelling keeps them valid
// for ingest and analysis alike. (Chaining them, parent = the robot's previous child map, would make the
// analysis refuse them: the run creates views its parent map already holds.) So fleetd keeps every upload
// after a robot's first as a "stale" map version (built on no map while the robot has one); ingest does the
// same work for it, but the parent-by-id path of later real runs is not exercised.
//
// --max-attempts defaults to 1 so that every refused attempt (rate limit, overload, timeout) is an error in
// the table rather than absorbed by the uploader's retries.
//
// Output: per phase robots, uploads acknowledged, errors by status code, runs/s, events/s, MB/s and p50/p99/max
// acknowledgement latency (UploadOutcome::seconds of acknowledged uploads), then the load / baseline ratios;
// with --json, also one JSON object on the last line. Progress goes to stderr. Exit status: 0 when both
// phases ran (errors during the load are reported, not fatal), 1 when the baseline failed, 2 on bad arguments.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <latch>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include "fleet/status_codes.h"
#include "fleet_client/uploader.h"
#include "sim/run_simulator.h"
#include "sim/sim_params.h"
#include "sim/world.h"
#include "test_data.h"

namespace {

using Clock = std::chrono::steady_clock;

double SecondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

struct LoadOptions {
  std::vector<std::string> servers;
  std::string token;
  int robots = 500;
  double seconds = 60.0;
  double baseline_seconds = 0.0;  // 0: min(10, seconds / 4)
  double run_minutes = 1.0;
  int pool_size = 16;
  std::uint64_t seed = 1;
  int max_attempts = 1;
  double upload_timeout_seconds = 120.0;
  double progress_seconds = 5.0;
  std::string world_dir = test_data::WidestDir("floorplans").string();
  bool json = false;
};

// ---- The runs ------------------------------------------------------------------------------------------

constexpr double kPoolEpoch = 1767225600.0;  // 2026-01-01, when the pooled runs start
constexpr double kUploadSpacingSeconds = 3600.0;

/// The first run of `pool_size` simulated robots in the homes of `world_dir` (taken in turn).
slamcore::Result<std::vector<fleet::v1::RunFile>> GenerateRunPool(const LoadOptions& options) {
  ASSIGN_OR_RETURN(auto worlds, sim::ListWorlds(options.world_dir));
  sim::SimParams params;
  params.run_minutes = options.run_minutes;
  std::vector<fleet::v1::RunFile> pool;
  for (int i = 0; i < options.pool_size; ++i) {
    const auto& path = (worlds)[static_cast<std::size_t>(i) % worlds.size()];
    auto world = sim::LoadWorld(path, options.seed + static_cast<std::uint64_t>(i));
    if (!world.ok())
      return slamcore::Status(world.status().code(), path.string() + ": " + world.status().message());
    const std::string robot_id = "pool-" + std::to_string(i);
    sim::RobotSimulator simulator(*world, params, robot_id, "1.0",
                                  options.seed * 1000 + static_cast<std::uint64_t>(i));
    auto outcome = simulator.SimulateRun(robot_id + "-run-0", kPoolEpoch);
    if (!outcome.ok()) {
      return slamcore::Status(outcome.status().code(), path.string() + ": " + outcome.status().message());
    }
    if (outcome->run.parent_snapshot().nodes_size() != 0) {
      return slamcore::Internal(
          "a robot's first simulated run came with a parent map; it cannot be relabelled");
    }
    pool.push_back(std::move(outcome->run));
  }
  return pool;
}

/// `pooled` as upload number `sequence` of robot `robot_id`: new ids, and every clock moved by
/// sequence × kUploadSpacingSeconds so the child snapshot differs from every other upload's.
fleet::v1::RunFile RelabelRun(const fleet::v1::RunFile& pooled, const std::string& robot_id,
                              const std::string& run_id, std::int64_t sequence) {
  fleet::v1::RunFile run = pooled;
  const double shift = static_cast<double>(sequence) * kUploadSpacingSeconds;
  fleet::v1::RunHeader& header = *run.mutable_header();
  header.set_robot_id(robot_id);
  header.set_run_id(run_id);
  header.set_started_at(header.started_at() + shift);
  header.set_ended_at(header.ended_at() + shift);
  for (auto& event : *run.mutable_events()) event.set_time(event.time() + shift);
  for (auto& node : *run.mutable_child_snapshot()->mutable_nodes()) node.set_time(node.time() + shift);
  return run;
}

// ---- Measurements --------------------------------------------------------------------------------------

/// What one robot (or a whole phase, after Merge) saw. Not thread-safe: one per robot thread.
struct UploadStats {
  std::vector<double> latencies;  // seconds, acknowledged uploads only
  std::int64_t acknowledged = 0, already_present = 0, retried = 0, events = 0, bytes = 0;
  std::map<std::string, std::int64_t> errors_by_code;
  std::map<std::string, std::string> first_error_by_code;
  std::map<std::string, std::int64_t> acknowledged_by_server, errors_by_server;
  std::map<std::string, std::string> first_error_by_server;

  void Add(const std::string& server, const fleet_client::UploadOutcome& outcome, std::int64_t upload_bytes) {
    if (outcome.attempts > 1) ++retried;
    if (outcome.ok) {
      latencies.push_back(outcome.seconds);
      ++acknowledged;
      ++acknowledged_by_server[server];
      if (outcome.already_present) ++already_present;
      events += static_cast<std::int64_t>(outcome.events);
      bytes += upload_bytes;
      return;
    }
    const std::string code = fleet::GrpcCodeName(outcome.code);
    ++errors_by_code[code];
    first_error_by_code.try_emplace(code, outcome.message);
    ++errors_by_server[server];
    first_error_by_server.try_emplace(server, outcome.message);
  }

  void Merge(const UploadStats& other) {
    latencies.insert(latencies.end(), other.latencies.begin(), other.latencies.end());
    acknowledged += other.acknowledged;
    already_present += other.already_present;
    retried += other.retried;
    events += other.events;
    bytes += other.bytes;
    for (const auto& [code, count] : other.errors_by_code) errors_by_code[code] += count;
    for (const auto& [code, message] : other.first_error_by_code)
      first_error_by_code.try_emplace(code, message);
    for (const auto& [server, count] : other.acknowledged_by_server) acknowledged_by_server[server] += count;
    for (const auto& [server, count] : other.errors_by_server) errors_by_server[server] += count;
    for (const auto& [server, message] : other.first_error_by_server) {
      first_error_by_server.try_emplace(server, message);
    }
  }

  std::int64_t Errors() const {
    std::int64_t total = 0;
    for (const auto& [code, count] : errors_by_code) total += count;
    return total;
  }
};

/// Nearest-rank percentile of sorted values; 0 when there are none.
double Percentile(const std::vector<double>& sorted, double percent) {
  if (sorted.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(percent / 100.0 * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

struct PhaseResult {
  std::string name;
  int robots = 0;
  double seconds = 0.0;  // from the start until the last upload finished
  UploadStats stats;

  double RunsPerSecond() const {
    return seconds > 0 ? static_cast<double>(stats.acknowledged) / seconds : 0.0;
  }
  double EventsPerSecond() const { return seconds > 0 ? static_cast<double>(stats.events) / seconds : 0.0; }
  double BytesPerSecond() const { return seconds > 0 ? static_cast<double>(stats.bytes) / seconds : 0.0; }
  double LatencyPercentile(double percent) const { return Percentile(stats.latencies, percent); }
  double MaxLatency() const { return stats.latencies.empty() ? 0.0 : stats.latencies.back(); }

  nlohmann::json ToJson() const {
    return {{"robots", robots},
            {"seconds", seconds},
            {"acknowledged", stats.acknowledged},
            {"already_present", stats.already_present},
            {"errors", stats.Errors()},
            {"errors_by_code", stats.errors_by_code},
            {"retried", stats.retried},
            {"acknowledged_by_server", stats.acknowledged_by_server},
            {"runs_per_second", RunsPerSecond()},
            {"events_per_second", EventsPerSecond()},
            {"bytes_per_second", BytesPerSecond()},
            {"latency_ms",
             {{"p50", 1000 * LatencyPercentile(50)},
              {"p99", 1000 * LatencyPercentile(99)},
              {"max", 1000 * MaxLatency()}}}};
  }
};

/// What every robot of a phase shares. The counters are read by the progress line while robots upload.
struct SharedUploadState {
  const std::vector<fleet::v1::RunFile>& pool;
  Clock::time_point deadline{};                // no upload starts after it
  std::atomic<std::int64_t> next_sequence{0};  // numbers every upload of the whole program
  std::atomic<std::int64_t> acknowledged{0}, errors{0};
  std::atomic<int> robots_uploading{0};
};

// ---- Uploading -----------------------------------------------------------------------------------------

struct RobotPlan {
  std::string robot_id;
  std::size_t pool_index = 0;  // the run (and home) this robot replays, every time
};

/// One robot uploading back to back to `server` until the deadline.
void UploadUntilDeadline(const RobotPlan& robot, fleet_client::Uploader& uploader, const std::string& server,
                         SharedUploadState& shared, UploadStats& stats) {
  const fleet::v1::RunFile& pooled = shared.pool[robot.pool_index % shared.pool.size()];
  for (std::size_t k = 0; Clock::now() < shared.deadline; ++k) {
    const fleet::v1::RunFile run = RelabelRun(
        pooled, robot.robot_id, robot.robot_id + "-run-" + std::to_string(k), shared.next_sequence++);
    const auto bytes = static_cast<std::int64_t>(run.ByteSizeLong());
    const fleet_client::UploadOutcome outcome = uploader.Upload(run);
    stats.Add(server, outcome, bytes);
    ++(outcome.ok ? shared.acknowledged : shared.errors);
  }
}

fleet_client::UploaderOptions MakeUploaderOptions(const LoadOptions& options, const std::string& server) {
  fleet_client::UploaderOptions uploader;
  uploader.server = server;
  uploader.token = options.token;
  uploader.max_attempts = options.max_attempts;
  uploader.deadline_seconds = options.upload_timeout_seconds;
  return uploader;
}

/// One robot at a time uploading sequentially: a robot per server, each for an equal share of the time.
PhaseResult RunBaseline(const LoadOptions& options, const std::string& run_tag, SharedUploadState& shared) {
  PhaseResult result{"baseline", 1, 0.0, {}};
  const auto start = Clock::now();
  const double share = options.baseline_seconds / static_cast<double>(options.servers.size());
  for (std::size_t s = 0; s < options.servers.size(); ++s) {
    fleet_client::Uploader uploader(MakeUploaderOptions(options, options.servers[s]));
    shared.deadline = start + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(share * static_cast<double>(s + 1)));
    UploadUntilDeadline({run_tag + "-baseline-" + std::to_string(s), s}, uploader, options.servers[s], shared,
                        result.stats);
  }
  result.seconds = SecondsBetween(start, Clock::now());
  std::sort(result.stats.latencies.begin(), result.stats.latencies.end());
  return result;
}

/// `options.robots` robots, one thread and one uploader each, servers round-robin.
PhaseResult RunLoad(const LoadOptions& options, const std::string& run_tag, SharedUploadState& shared) {
  const auto robot_count = static_cast<std::size_t>(options.robots);
  std::vector<std::unique_ptr<fleet_client::Uploader>> uploaders;
  std::vector<std::string> server_of_robot;
  for (std::size_t i = 0; i < robot_count; ++i) {
    server_of_robot.push_back(options.servers[i % options.servers.size()]);
    uploaders.push_back(
        std::make_unique<fleet_client::Uploader>(MakeUploaderOptions(options, server_of_robot.back())));
  }
  std::vector<UploadStats> stats(robot_count);
  shared.acknowledged = 0;
  shared.errors = 0;
  shared.robots_uploading = options.robots;
  // Every robot starts at the same moment: threads are created first and released together (the latch also
  // publishes the deadline to them).
  std::latch start_signal(1);
  std::vector<std::thread> threads;
  threads.reserve(robot_count);
  for (std::size_t i = 0; i < robot_count; ++i) {
    threads.emplace_back([&, i] {
      start_signal.wait();
      UploadUntilDeadline({run_tag + "-robot-" + std::to_string(i), i}, *uploaders[i], server_of_robot[i],
                          shared, stats[i]);
      --shared.robots_uploading;
    });
  }
  const auto start = Clock::now();
  shared.deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.seconds));
  start_signal.count_down();

  auto last_report = start;
  std::int64_t acknowledged_at_last_report = 0;
  while (shared.robots_uploading > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = Clock::now();
    if (SecondsBetween(last_report, now) < options.progress_seconds) continue;
    const std::int64_t acknowledged = shared.acknowledged;
    const double interval_rate =
        static_cast<double>(acknowledged - acknowledged_at_last_report) / SecondsBetween(last_report, now);
    std::fprintf(stderr, "upload_load: %5.1f s: %lld acknowledged (%.1f runs/s lately), %lld errors, %d %s\n",
                 SecondsBetween(start, now), static_cast<long long>(acknowledged), interval_rate,
                 static_cast<long long>(shared.errors.load()), shared.robots_uploading.load(),
                 now < shared.deadline ? "robots uploading" : "uploads still in flight after the deadline");
    last_report = now;
    acknowledged_at_last_report = acknowledged;
  }
  for (auto& thread : threads) thread.join();

  PhaseResult result{"load", options.robots, SecondsBetween(start, Clock::now()), {}};
  for (const auto& robot_stats : stats) result.stats.Merge(robot_stats);
  std::sort(result.stats.latencies.begin(), result.stats.latencies.end());
  return result;
}

// ---- Reporting -----------------------------------------------------------------------------------------

void PrintPhaseRow(const PhaseResult& phase) {
  std::printf("%-9s %7d %8.1f %8lld %7lld %8.2f %10.0f %7.2f %8.1f %8.1f %8.1f\n", phase.name.c_str(),
              phase.robots, phase.seconds, static_cast<long long>(phase.stats.acknowledged),
              static_cast<long long>(phase.stats.Errors()), phase.RunsPerSecond(), phase.EventsPerSecond(),
              phase.BytesPerSecond() / 1e6, 1000 * phase.LatencyPercentile(50),
              1000 * phase.LatencyPercentile(99), 1000 * phase.MaxLatency());
}

void PrintPhaseDetails(const PhaseResult& phase) {
  std::printf("%s: errors by status code:", phase.name.c_str());
  if (phase.stats.errors_by_code.empty()) std::printf(" none");
  for (const auto& [code, count] : phase.stats.errors_by_code) {
    std::printf(" %s %lld", code.c_str(), static_cast<long long>(count));
  }
  std::printf("\n");
  for (const auto& [code, message] : phase.stats.first_error_by_code) {
    std::printf("  first %s: %.300s\n", code.c_str(), message.c_str());
  }
  std::printf("%s: acknowledged by server:", phase.name.c_str());
  for (const auto& [server, count] : phase.stats.acknowledged_by_server) {
    std::printf(" %s %lld", server.c_str(), static_cast<long long>(count));
  }
  std::printf("; %lld already present, %lld needed a retry\n",
              static_cast<long long>(phase.stats.already_present),
              static_cast<long long>(phase.stats.retried));
}

/// numerator / denominator, or null when the denominator is 0.
nlohmann::json Ratio(double numerator, double denominator) {
  return denominator > 0 ? nlohmann::json(numerator / denominator) : nlohmann::json(nullptr);
}

std::string FormatRatio(const nlohmann::json& ratio) {
  if (ratio.is_null()) return "n/a";
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", ratio.get<double>());
  return text;
}

/// Splits "a:1,b:2" and checks each is host:port.
std::vector<std::string> ParseServers(const std::string& list, std::string& error) {
  std::vector<std::string> servers;
  std::size_t begin = 0;
  while (begin <= list.size()) {
    const std::size_t end = std::min(list.find(',', begin), list.size());
    const std::string server = list.substr(begin, end - begin);
    const std::size_t colon = server.rfind(':');
    const std::string port = colon == std::string::npos ? "" : server.substr(colon + 1);
    const bool port_ok = !port.empty() && port.size() <= 5 &&
                         std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
                         std::stoi(port) >= 1 && std::stoi(port) <= 65535;
    if (colon == 0 || !port_ok) {
      error = "--server: \"" + server + "\" is not host:port";
      return {};
    }
    servers.push_back(server);
    begin = end + 1;
  }
  return servers;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "upload_load: many simulated robots uploading to fleetd at once, against a one-robot baseline"};
  LoadOptions options;
  std::string server_list;
  app.add_option("--server", server_list,
                 "fleetd gRPC address(es), host:port[,host:port...]; robots round-robin")
      ->required();
  app.add_option("--token", options.token, "token every robot uploads with (default: $FLEET_TOKEN)");
  app.add_option("--robots", options.robots, "concurrent robots in the load phase")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--seconds", options.seconds, "duration of the load phase")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--baseline-seconds", options.baseline_seconds,
                 "duration of the one-robot baseline (0: min(10, seconds/4))")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--run-minutes", options.run_minutes, "simulated minutes per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--pool", options.pool_size, "distinct simulated runs to relabel")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  app.add_option("--seed", options.seed, "seed of the simulated runs")->capture_default_str();
  app.add_option("--max-attempts", options.max_attempts, "attempts per upload (1: every refusal is an error)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--upload-timeout", options.upload_timeout_seconds,
                 "deadline of one upload attempt, seconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--progress-seconds", options.progress_seconds, "interval of the progress line on stderr")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--world", options.world_dir,
                 "floor plans (.txt) and/or maps (.yaml) the runs are simulated in")
      ->capture_default_str();
  app.add_flag("--json", options.json, "also print one JSON object on the last line");
  CLI11_PARSE(app, argc, argv);

  std::string error;
  options.servers = ParseServers(server_list, error);
  if (options.servers.empty()) {
    std::cerr << "upload_load: " << error << "\n";
    return 2;
  }
  if (options.token.empty() && std::getenv("FLEET_TOKEN") != nullptr)
    options.token = std::getenv("FLEET_TOKEN");
  if (options.token.empty()) {
    std::cerr << "upload_load: no token: pass --token or set FLEET_TOKEN\n";
    return 2;
  }
  if (options.baseline_seconds <= 0) options.baseline_seconds = std::min(10.0, options.seconds / 4);

  const auto generation_start = Clock::now();
  auto pool = GenerateRunPool(options);
  if (!pool.ok()) {
    std::cerr << "upload_load: simulating the runs: " << pool.status().ToString() << "\n";
    return 1;
  }
  double pool_events = 0, pool_bytes = 0;
  for (const auto& run : *pool) {
    pool_events += run.events_size();
    pool_bytes += static_cast<double>(run.ByteSizeLong());
  }
  std::string servers_text;
  for (const auto& server : options.servers) servers_text += (servers_text.empty() ? "" : ", ") + server;
  std::printf(
      "upload_load: %zu simulated runs of %.2g simulated minutes (mean %.0f events, %.1f kB) in %.1f s;"
      " servers %s; at most %d attempt(s) per upload\n",
      pool->size(), options.run_minutes, pool_events / static_cast<double>(pool->size()),
      pool_bytes / static_cast<double>(pool->size()) / 1e3, SecondsBetween(generation_start, Clock::now()),
      servers_text.c_str(), options.max_attempts);
  std::fflush(stdout);

  // Run ids must be new to the database even when it is reused: tag them with the time and process.
  const std::string run_tag = "load-" +
                              std::to_string(std::chrono::duration_cast<std::chrono::seconds>(
                                                 std::chrono::system_clock::now().time_since_epoch())
                                                 .count()) +
                              "-" + std::to_string(getpid());
  SharedUploadState shared{.pool = *pool};

  std::fprintf(stderr, "upload_load: baseline: 1 robot for %.1f s\n", options.baseline_seconds);
  const PhaseResult baseline = RunBaseline(options, run_tag, shared);
  bool unreachable = false;
  for (const auto& server : options.servers) {
    if (baseline.stats.acknowledged_by_server.contains(server)) continue;
    const auto first_error = baseline.stats.first_error_by_server.find(server);
    std::cerr << "upload_load: server " << server << " acknowledged none of the baseline's uploads: "
              << (first_error == baseline.stats.first_error_by_server.end() ? "no upload was tried"
                                                                            : first_error->second)
              << "\n";
    unreachable = true;
  }
  if (unreachable) return 1;

  std::fprintf(stderr, "upload_load: load: %d robots for %.1f s\n", options.robots, options.seconds);
  const PhaseResult load = RunLoad(options, run_tag, shared);

  std::printf("\n%-9s %7s %8s %8s %7s %8s %10s %7s %8s %8s %8s\n", "phase", "robots", "seconds", "acked",
              "errors", "runs/s", "events/s", "MB/s", "p50 ms", "p99 ms", "max ms");
  PrintPhaseRow(baseline);
  PrintPhaseRow(load);
  PrintPhaseDetails(baseline);
  PrintPhaseDetails(load);
  const nlohmann::json ratios = {
      {"throughput", Ratio(load.RunsPerSecond(), baseline.RunsPerSecond())},
      {"p50_latency", Ratio(load.LatencyPercentile(50), baseline.LatencyPercentile(50))},
      {"p99_latency", Ratio(load.LatencyPercentile(99), baseline.LatencyPercentile(99))},
  };
  std::printf("\nratios, %d robots / 1 robot: throughput %s, p50 latency %s, p99 latency %s\n",
              options.robots, FormatRatio(ratios["throughput"]).c_str(),
              FormatRatio(ratios["p50_latency"]).c_str(), FormatRatio(ratios["p99_latency"]).c_str());
  // The storage check of upload_load.sh: runs stored = acknowledged - already present, over both phases.
  const std::int64_t acknowledged = baseline.stats.acknowledged + load.stats.acknowledged;
  const std::int64_t already_present = baseline.stats.already_present + load.stats.already_present;
  std::printf("acknowledged in total: %lld uploads (%lld already present); run ids start with %s\n",
              static_cast<long long>(acknowledged), static_cast<long long>(already_present), run_tag.c_str());
  if (options.json) {
    const nlohmann::json summary = {{"servers", options.servers},
                                    {"robots", options.robots},
                                    {"seconds", options.seconds},
                                    {"run_minutes", options.run_minutes},
                                    {"pool", options.pool_size},
                                    {"max_attempts", options.max_attempts},
                                    {"run_tag", run_tag},
                                    {"baseline", baseline.ToJson()},
                                    {"load", load.ToJson()},
                                    {"ratios", ratios},
                                    {"acknowledged_total", acknowledged},
                                    {"already_present_total", already_present}};
    std::printf("%s\n", summary.dump().c_str());
  }
  return 0;
}
