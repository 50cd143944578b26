// The Mapper's incremental back-end against the batch baseline (MapperParams::backend), both measured in
// this run on the same events: replay time of outlier-laden graphs, and events per second as the map grows.
// Rows (issue 18):
//   manhattan-random   Manhattan 3500 (Olson), 100 % random outliers                goal ≤ 1.5 s
//   manhattan-grouped  Manhattan 3500, 50 % grouped outliers (groups of 10)          goal ≤ 3× its outlier-free replay
//   city-random        generated 10,000-pose city, 100 % random outliers             goal ≤ 8 s
//   city-local         generated 10,000-pose city, 50 % local outliers               goal ≤ 15 s
//   scaling            generated cities of 1k, 3.5k, 10k, 30k poses, outlier-free: events/s and the growth
//                      exponent of the time per event (0: independent of map size)
// A replay that exceeds --deadline seconds is stopped and printed as "> deadline".
//
//   backend_bench [--row NAME]... [--deadline S] [--seed S] [--data DIR]
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/loop_closure_outliers.h"
#include "slamcore/manhattan_world.h"
#include "test_data.h"

namespace {

using slamcore::MapperBackend;

struct Timing {
  std::optional<double> seconds;  // nullopt: stopped at the deadline
  std::size_t events = 0;
};

/// The Mapper's replay of a graph (ReplayPoseGraph's event loop, without its bookkeeping), stopped at the deadline.
Timing Replay(const slamcore::PoseGraph& graph, MapperBackend backend, double deadline) {
  const auto run = slamcore::RunFromPoseGraph(graph);
  if (!run.ok()) {
    std::fprintf(stderr, "%s\n", run.status().ToString().c_str());
    std::exit(1);
  }
  slamcore::MapperParams params;
  params.backend = backend;
  const auto start = std::chrono::steady_clock::now();
  auto mapper = slamcore::Mapper::Create(params);
  Timing timing{.seconds = std::nullopt, .events = run->events.size()};
  for (std::size_t k = 0; k < run->events.size(); ++k) {
    if (!(*mapper)->Process(run->events[k]).ok()) {
      std::fprintf(stderr, "event %zu refused\n", k);
      std::exit(1);
    }
    if (k % 256 == 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > deadline) {
      return timing;
    }
  }
  (void)(*mapper)->Finish();
  timing.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return timing;
}

std::string Seconds(const Timing& timing, double deadline) {
  char text[64];
  if (timing.seconds) {
    std::snprintf(text, sizeof text, "%.2f", *timing.seconds);
  } else {
    std::snprintf(text, sizeof text, "> %.0f", deadline);
  }
  return text;
}

std::string Ratio(const Timing& baseline, const Timing& ours, double deadline) {
  char text[64];
  if (!ours.seconds) return "–";
  if (!baseline.seconds) {
    std::snprintf(text, sizeof text, "> %.1f", deadline / *ours.seconds);
  } else {
    std::snprintf(text, sizeof text, "%.1f", *baseline.seconds / *ours.seconds);
  }
  return text;
}

slamcore::PoseGraph Corrupt(const slamcore::PoseGraph& graph, const std::string& mode, double fraction,
                            int group, std::uint64_t seed) {
  slamcore::OutlierOptions options;
  options.mode = *slamcore::ParseOutlierMode(mode);
  options.group_size = group;
  options.total_edges =
      std::max(1, static_cast<int>(std::lround(fraction * slamcore::CountLoopClosures(graph))));
  options.seed = seed;
  auto corrupted = slamcore::AddLoopClosureOutliers(graph, options);
  if (!corrupted.ok()) {
    std::fprintf(stderr, "%s\n", corrupted.status().ToString().c_str());
    std::exit(1);
  }
  return std::move(corrupted->graph);
}

slamcore::PoseGraph City(int poses, std::uint64_t seed) {
  slamcore::ManhattanOptions options;
  options.poses = poses;
  options.seed = seed;
  auto world = slamcore::GenerateManhattanWorld(options);
  if (!world.ok()) {
    std::fprintf(stderr, "%s\n", world.status().ToString().c_str());
    std::exit(1);
  }
  return std::move(world->graph);
}

void PrintRow(const std::string& work, const Timing& batch, const Timing& incremental, double deadline,
              const std::string& goal) {
  std::printf("| %s | %s | %s | %s | %s |\n", work.c_str(), Seconds(batch, deadline).c_str(),
              Seconds(incremental, deadline).c_str(), Ratio(batch, incremental, deadline).c_str(),
              goal.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"backend_bench: the Mapper's incremental back-end against the batch baseline, same run"};
  std::vector<std::string> rows{"manhattan-random", "manhattan-grouped", "city-random", "city-local",
                                "scaling"};
  double deadline = 300.0;
  std::uint64_t seed = 1;
  std::string data = test_data::WidestDir("posegraphs").string();
  app.add_option("--row", rows, "manhattan-random, manhattan-grouped, city-random, city-local, scaling")
      ->check(
          CLI::IsMember({"manhattan-random", "manhattan-grouped", "city-random", "city-local", "scaling"}));
  app.add_option("--deadline", deadline, "seconds after which a replay is stopped")
      ->check(CLI::Range(1.0, 3600.0));
  app.add_option("--seed", seed, "seed of the outliers and generated cities");
  app.add_option("--data", data, "the posegraphs directory (for Manhattan 3500)");
  CLI11_PARSE(app, argc, argv);
  const auto has = [&](const char* row) { return std::find(rows.begin(), rows.end(), row) != rows.end(); };
  const auto both = [&](const slamcore::PoseGraph& graph) {
    return std::pair{Replay(graph, MapperBackend::kBatch, deadline),
                     Replay(graph, MapperBackend::kIncremental, deadline)};
  };

  std::printf("| work | batch s | incremental s | batch / incremental | goal |\n|---|---|---|---|---|\n");
  if (has("manhattan-random") || has("manhattan-grouped")) {
    const auto manhattan =
        slamcore::ReadPoseGraph(std::filesystem::path(data) / "vertigo/manhattanOlson3500_olson.g2o");
    if (!manhattan.ok()) {
      std::fprintf(stderr, "%s\n", manhattan.status().ToString().c_str());
      return 1;
    }
    if (has("manhattan-random")) {
      const auto [batch, incremental] = both(Corrupt(*manhattan, "random", 1.0, 1, seed));
      PrintRow("Manhattan 3500, 100 % random outliers", batch, incremental, deadline, "≤ 1.5 s");
    }
    if (has("manhattan-grouped")) {
      const auto [clean_batch, clean_incremental] = both(*manhattan);
      PrintRow("Manhattan 3500, outlier-free", clean_batch, clean_incremental, deadline, "");
      const auto [batch, incremental] = both(Corrupt(*manhattan, "random", 0.5, 10, seed));
      char goal[96];
      std::snprintf(goal, sizeof goal, "≤ 3× outlier-free: batch %.2f×, incremental %.2f×",
                    batch.seconds && clean_batch.seconds ? *batch.seconds / *clean_batch.seconds : NAN,
                    incremental.seconds && clean_incremental.seconds
                        ? *incremental.seconds / *clean_incremental.seconds
                        : NAN);
      PrintRow("Manhattan 3500, 50 % grouped outliers (10)", batch, incremental, deadline, goal);
    }
  }
  if (has("city-random") || has("city-local")) {
    const slamcore::PoseGraph city = City(10000, seed);
    const std::string name =
        "city 10,000 poses (" + std::to_string(slamcore::CountLoopClosures(city)) + " closures)";
    if (has("city-random")) {
      const auto [batch, incremental] = both(Corrupt(city, "random", 1.0, 1, seed));
      PrintRow(name + ", 100 % random outliers", batch, incremental, deadline, "≤ 8 s");
    }
    if (has("city-local")) {
      const auto [batch, incremental] = both(Corrupt(city, "local", 0.5, 1, seed));
      PrintRow(name + ", 50 % local outliers", batch, incremental, deadline, "≤ 15 s");
    }
  }
  if (has("scaling")) {
    std::printf(
        "\n| poses | events | batch events/s | incremental events/s | batch / incremental "
        "|\n|---|---|---|---|---|\n");
    std::vector<std::pair<double, double>> per_event;  // (poses, incremental seconds per event)
    std::vector<std::pair<double, double>> batch_per_event;
    for (const int poses : {1000, 3500, 10000, 30000}) {
      const auto [batch, incremental] = both(City(poses, seed));
      const auto rate = [&](const Timing& timing) {
        char text[32];
        if (!timing.seconds)
          return std::string("< ") + std::to_string(static_cast<long>(timing.events / deadline));
        std::snprintf(text, sizeof text, "%.0f", static_cast<double>(timing.events) / *timing.seconds);
        return std::string(text);
      };
      std::printf("| %d | %zu | %s | %s | %s |\n", poses, incremental.events, rate(batch).c_str(),
                  rate(incremental).c_str(), Ratio(batch, incremental, deadline).c_str());
      std::fflush(stdout);
      if (incremental.seconds)
        per_event.emplace_back(poses, *incremental.seconds / static_cast<double>(incremental.events));
      if (batch.seconds)
        batch_per_event.emplace_back(poses, *batch.seconds / static_cast<double>(batch.events));
    }
    const auto exponent = [](const std::vector<std::pair<double, double>>& points) {
      if (points.size() < 2) return std::nan("");
      return std::log(points.back().second / points.front().second) /
             std::log(points.back().first / points.front().first);
    };
    std::printf("\ngrowth exponent of the time per event (%g → %g poses): incremental %.2f, batch %.2f%s\n",
                per_event.empty() ? 0.0 : per_event.front().first,
                per_event.empty() ? 0.0 : per_event.back().first, exponent(per_event),
                exponent(batch_per_event),
                batch_per_event.size() < per_event.size() ? " (batch over the sizes it finished)" : "");
  }
  return 0;
}
