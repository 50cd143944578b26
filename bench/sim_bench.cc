// fleetsim speed: one simulated hour of cleaning, Mapper on board included, on one core (target < 1 s),
// against the same hour with the Mapper's optimisation switched off (physics, sensors and bookkeeping:
// the floor), in the same run. The home is loaded once, outside the timing.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>

#include "bench_report.h"
#include "sim/run_simulator.h"

namespace {

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

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  const std::filesystem::path data = std::filesystem::path(SHARED_DATA_DIR);
  static std::vector<sim::World> worlds;
  for (const std::filesystem::path& file : {data / "floorplans/00_02_09a30b61b563f93faf6a6466ffab_0001.txt",
                                            data / "maps/valetudo_dreame_d9_1058_with_segments.yaml"}) {
    auto world = sim::LoadWorld(file, 1);
    if (!world.ok()) {
      std::fprintf(stderr, "%s\n", world.status().ToString().c_str());
      return 1;
    }
    worlds.push_back(std::move(world).value());
  }
  for (const sim::World& world : worlds) RegisterHour("one_hour_" + world.name.substr(0, 20), world);
  bench::RatioReporter reporter("no_optimisation", "mapper");
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios(
      "time without optimisation / with (the Mapper's optimisation share); target: mapper < 1000 ms");
  benchmark::Shutdown();
  return 0;
}
