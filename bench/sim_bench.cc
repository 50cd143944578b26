// fleetsim speed, and the analysis of what it simulates:
//  * one simulated hour of cleaning, Mapper on board included, on one core (target < 1 s), against the same
//    hour with the Mapper's optimisation switched off (physics, sensors and bookkeeping: the floor), in the
//    same run;
//  * the server's analysis of that hour (analyzer::AnalyzeRun, what a fleetd worker does with an upload:
//    the Mapper's replay, the maps rendered and compared, protrusions classed, the report), on one core
//    (issue 18's goal: 150 ms), with the incremental back-end against the batch one (Ceres), the baseline.
// The homes are loaded, and the analysed hours simulated, once, outside the timing.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>

#include "analyzer/run_analysis.h"
#include "bench_data.h"
#include "bench_report.h"
#include "sim/run_simulator.h"

namespace {

// Benchmark names: a prefix and the home's name, cut to keep the tables' columns.
std::string HourName(const sim::World& world) { return "one_hour_" + world.name.substr(0, 20); }
std::string AnalysisName(const sim::World& world) { return "analysis_" + world.name.substr(0, 20); }

void RegisterHour(const std::string& name, const sim::World& world) {
  for (const bool optimise : {false, true}) {
    benchmark::RegisterBenchmark((name + (optimise ? "/mapper" : "/no_optimisation")).c_str(),
                                 [&world, optimise](benchmark::State& state) {
                                   sim::SimParams params;
                                   params.run_minutes = 60.0;
                                   params.mapper.optimize_after_accept = optimise;
                                   std::uint64_t seed = 1;
                                   for (auto _ : state) {
                                     sim::RobotSimulator robot(world, params, "robot", "fw", seed++);
                                     const auto outcome = robot.SimulateRun("run", 0.0);
                                     if (!outcome.ok())
                                       state.SkipWithError(outcome.status().ToString().c_str());
                                   }
                                 })
        ->Unit(benchmark::kMillisecond)
        ->MinTime(3.0)
        ->UseRealTime();
  }
}

void RegisterAnalysis(const std::string& name, const fleet::v1::RunFile& run) {
  for (const slamcore::MapperBackend backend :
       {slamcore::MapperBackend::kBatch, slamcore::MapperBackend::kIncremental}) {
    const bool batch = backend == slamcore::MapperBackend::kBatch;
    benchmark::RegisterBenchmark((name + (batch ? "/batch" : "/incremental")).c_str(),
                                 [&run, backend](benchmark::State& state) {
                                   analyzer::AnalysisOptions options;
                                   options.mapper.backend = backend;
                                   for (auto _ : state) {
                                     const auto report = analyzer::AnalyzeRun(run, options);
                                     if (!report.ok())
                                       state.SkipWithError(report.status().ToString().c_str());
                                     benchmark::DoNotOptimize(report);
                                   }
                                 })
        ->Unit(benchmark::kMillisecond)
        ->MinTime(3.0)
        ->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  static std::vector<sim::World> worlds;
  for (const char* relative : {"floorplans/00_02_09a30b61b563f93faf6a6466ffab_0001.txt",
                               "maps/valetudo_dreame_d9_1058_with_segments.yaml"}) {
    const auto file = bench::FindData("sim_bench", relative);
    if (!file) return 1;
    auto world = sim::LoadWorld(*file, 1);
    if (!world.ok()) {
      std::fprintf(stderr, "%s\n", world.status().ToString().c_str());
      return 1;
    }
    worlds.push_back(std::move(world).value());
  }
  // The analysed hour: a robot's first hour in the home (seed 1), as it uploads it.
  static std::vector<fleet::v1::RunFile> hours;
  for (const sim::World& world : worlds) {
    sim::SimParams params;
    params.run_minutes = 60.0;
    sim::RobotSimulator robot(world, params, "robot", "fw", 1);
    constexpr double kStartedAt = 1.7e9;  // 2023-11-14 UTC: uploads carry a real start time
    auto outcome = robot.SimulateRun("run", kStartedAt);
    if (!outcome.ok()) {
      std::fprintf(stderr, "%s\n", outcome.status().ToString().c_str());
      return 1;
    }
    hours.push_back(std::move(outcome->run));
  }
  for (std::size_t k = 0; k < worlds.size(); ++k) {
    RegisterHour(HourName(worlds[k]), worlds[k]);
    RegisterAnalysis(AnalysisName(worlds[k]), hours[k]);
  }
  bench::RatioReporter reporter("no_optimisation", "mapper");
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios(
      "time without optimisation / with (the Mapper's optimisation share); target: mapper < 1000 ms");
  std::printf("\n%-36s %12s %12s %10s\n", "analysis of the hour", "batch", "incremental", "ratio");
  for (const sim::World& world : worlds) {
    const std::string name = AnalysisName(world);
    const auto batch = reporter.Times().find(name + "/batch");
    const auto incremental = reporter.Times().find(name + "/incremental");
    if (batch == reporter.Times().end() || incremental == reporter.Times().end() || incremental->second <= 0)
      continue;
    std::printf("%-36s %12.3f %12.3f %10.2f\n", name.c_str(), batch->second, incremental->second,
                batch->second / incremental->second);
  }
  std::printf(
      "(analyzer::AnalyzeRun of the first hour, batch / incremental back-end; goal: incremental < 150 ms)\n");
  benchmark::Shutdown();
  return 0;
}
