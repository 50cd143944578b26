#include "sim/fleet.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "sim/sensor.h"

namespace sim {

void FleetStatistics::Add(const RunOutcome& outcome) {
  const slamcore::MapperStatistics& stats = outcome.statistics;
  ++runs;
  if (outcome.had_parent) ++runs_with_parent;
  if (outcome.started_localized) ++runs_started_localized;
  if (stats.recovery_created > 0) ++runs_with_recovery;
  recovery_created += stats.recovery_created;
  recovery_accepted += stats.recovery_accepted;
  recovery_retracted += stats.recovery_retracted;
  merge_created += stats.merge_created;
  merge_conditionally_accepted += stats.merge_conditionally_accepted;
  merge_conditional_then_rejected += stats.merge_conditional_then_rejected;
  merge_accepted += stats.merge_accepted;
  if (outcome.views_total > 0) {
    ++maps_with_views;
    if (outcome.views_ambiguous > 0) {
      ++maps_with_ambiguous_views;
      ambiguous_view_share_sum +=
          static_cast<double>(outcome.views_ambiguous) / static_cast<double>(outcome.views_total);
    }
  }
  observations += outcome.observations;
  wrong_observations += outcome.wrong_observations;
  kidnaps += outcome.kidnaps;
  reboots += outcome.reboots;
  stuck_at_wall += outcome.stuck_at_wall;
  stuck_under_furniture += outcome.stuck_under_furniture;
  stuck_on_rug += outcome.stuck_on_rug;
  stuck_nodes += outcome.stuck_nodes;
  if (outcome.run.header().robot_model() == kLidarModel) ++lidar_runs;
  if (outcome.truth_protrusion_regions > 0) ++maps_with_truth_protrusion;
  truth_protrusion_regions += outcome.truth_protrusion_regions;
  truth_new_space_regions += outcome.truth_new_space_regions;
  analysis_confusion += outcome.analysis_confusion;
  classifier_confusion += outcome.classifier_confusion;
  views_confusion += outcome.views_confusion;
  erroneous_confusion += outcome.erroneous_confusion;
  false_floor_new_space_regions += outcome.false_floor_new_space_regions;
  simulated_hours += outcome.simulated_seconds / 3600.0;
}

namespace {

double Share(double part, double whole) { return whole > 0 ? part / whole : 0.0; }

}  // namespace

std::string FleetStatistics::ToText() const {
  char text[2048];
  std::snprintf(
      text, sizeof text,
      "runs                                   %d (%.1f simulated hours, %.1f s wall)\n"
      "runs on an existing map                %d, started localized %.1f %%   (paper: 43.2 %%)\n"
      "runs with a recovery hypothesis        %.1f %%   (paper: most runs)\n"
      "recovery hypotheses per run            %.2f, accepted %.1f %%   (paper: 1.1 %%), later retracted %ld\n"
      "merge hypotheses                       %ld, conditionally accepted then rejected %.1f %%   (paper: "
      "18.6 %%)\n"
      "maps with ambiguous views              %.1f %%   (paper: 90.7 %%)\n"
      "ambiguous share of views in those maps %.1f %%   (paper: 15-18 %%)\n"
      "wrong observations from the front-end  %.1f %% of %ld\n"
      "kidnaps %d, reboots %d\n"
      "stuck episodes                         %d (wall %d, under furniture %d, rug %d; %ld stuck nodes)\n"
      "maps with a protrusion (ground truth)  %.2f %% (%d of %d; %ld protrusion and %ld new-space regions)   "
      "(paper: 0.92 %%)\n"
      "robots' sensors                        %d runs lidar, %d runs ToF\n",
      runs, simulated_hours, wall_seconds, runs_with_parent,
      100 * Share(runs_started_localized, runs_with_parent), 100 * Share(runs_with_recovery, runs),
      Share(static_cast<double>(recovery_created), runs),
      100 * Share(static_cast<double>(recovery_accepted), static_cast<double>(recovery_created)),
      recovery_retracted, merge_created,
      100 * Share(static_cast<double>(merge_conditional_then_rejected), static_cast<double>(merge_created)),
      100 * Share(maps_with_ambiguous_views, maps_with_views),
      100 * Share(ambiguous_view_share_sum, maps_with_ambiguous_views),
      100 * Share(static_cast<double>(wrong_observations), static_cast<double>(observations)), observations,
      kidnaps, reboots, stuck_at_wall + stuck_under_furniture + stuck_on_rug, stuck_at_wall,
      stuck_under_furniture, stuck_on_rug, stuck_nodes, 100 * Share(maps_with_truth_protrusion, runs),
      maps_with_truth_protrusion, runs, truth_protrusion_regions, truth_new_space_regions, lidar_runs,
      runs - lidar_runs);
  std::string out = text;
  out += "regions classed as the analysis does   " + analysis_confusion.ToText() + "   (views, then model)\n";
  out += "regions classed by the built-in model  " + classifier_confusion.ToText() + "\n";
  out += "regions classed by the views alone     " + views_confusion.ToText() + "\n";
  out += "new-space regions that are false floor " + std::to_string(false_floor_new_space_regions) + " of " +
         std::to_string(truth_new_space_regions) + " (by the home's truth)\n";
  out += "analysis vs protrusion or false floor  " + erroneous_confusion.ToText() + "\n";
  if (!health.empty()) out += MapHealthLine() + "\n";
  return out;
}

std::string FleetStatistics::MapHealthLine() const {
  char line[256];
  std::snprintf(line, sizeof line,
                "map health (ground truth)              %d healthy, %d repaired, %d corrupted robots",
                robots_healthy, robots_repaired, robots_corrupted);
  return line;
}

std::string FleetStatistics::ToJson() const {
  char text[2048];
  std::snprintf(
      text, sizeof text,
      "{\"runs\":%d,\"simulated_hours\":%.3f,\"wall_seconds\":%.3f,\"runs_with_parent\":%d,"
      "\"started_localized_share\":%.4f,\"runs_with_recovery_share\":%.4f,\"recovery_per_run\":%.4f,"
      "\"recovery_accepted_share\":%.4f,\"recovery_retracted\":%ld,\"merge_created\":%ld,\"merge_"
      "conditionally_accepted\":%ld,"
      "\"merge_conditional_then_rejected_share\":%.4f,\"merge_accepted\":%ld,"
      "\"maps_with_ambiguous_views_share\":%.4f,\"ambiguous_view_share\":%.4f,\"observations\":%ld,"
      "\"wrong_observation_share\":%.4f,\"kidnaps\":%d,\"reboots\":%d,\"stuck_at_wall\":%d,"
      "\"stuck_under_furniture\":%d,\"stuck_on_rug\":%d,\"stuck_nodes\":%ld,\"maps_with_truth_protrusion\":%"
      "d,"
      "\"maps_with_truth_protrusion_share\":%.5f,\"truth_protrusion_regions\":%ld,\"truth_new_space_"
      "regions\":%ld,"
      "\"lidar_runs\":%d,\"pairs_written\":%d}",
      runs, simulated_hours, wall_seconds, runs_with_parent, Share(runs_started_localized, runs_with_parent),
      Share(runs_with_recovery, runs), Share(static_cast<double>(recovery_created), runs),
      Share(static_cast<double>(recovery_accepted), static_cast<double>(recovery_created)),
      recovery_retracted, merge_created, merge_conditionally_accepted,
      Share(static_cast<double>(merge_conditional_then_rejected), static_cast<double>(merge_created)),
      merge_accepted, Share(maps_with_ambiguous_views, maps_with_views),
      Share(ambiguous_view_share_sum, maps_with_ambiguous_views), observations,
      Share(static_cast<double>(wrong_observations), static_cast<double>(observations)), kidnaps, reboots,
      stuck_at_wall, stuck_under_furniture, stuck_on_rug, stuck_nodes, maps_with_truth_protrusion,
      Share(maps_with_truth_protrusion, runs), truth_protrusion_regions, truth_new_space_regions, lidar_runs,
      pairs_written);
  std::string out = text;
  out.pop_back();  // the closing brace
  auto confusion = [](const RegionConfusion& c) {
    return "{\"tp\":" + std::to_string(c.true_protrusion) + ",\"fn\":" + std::to_string(c.missed_protrusion) +
           ",\"fp\":" + std::to_string(c.false_protrusion) + ",\"tn\":" + std::to_string(c.true_new_space) +
           "}";
  };
  out += ",\"analysis_confusion\":" + confusion(analysis_confusion) +
         ",\"classifier_confusion\":" + confusion(classifier_confusion) +
         ",\"views_confusion\":" + confusion(views_confusion) +
         ",\"erroneous_confusion\":" + confusion(erroneous_confusion) +
         ",\"false_floor_new_space_regions\":" + std::to_string(false_floor_new_space_regions) + "}";
  if (!health.empty()) {
    out.pop_back();
    out += ",\"robots_healthy\":" + std::to_string(robots_healthy) +
           ",\"robots_repaired\":" + std::to_string(robots_repaired) +
           ",\"robots_corrupted\":" + std::to_string(robots_corrupted) + "}";
  }
  return out;
}

slamcore::Result<FleetStatistics> SimulateFleet(const FleetOptions& options,
                                                const std::function<void(int, int)>& progress) {
  if (options.worlds.empty()) return slamcore::InvalidArgument("no worlds to simulate");
  if (options.robots < 1 || options.runs < 1)
    return slamcore::InvalidArgument("robots and runs must be at least 1");
  RETURN_IF_ERROR(options.params.Validate());
  SimParams params = options.params;
  if (!options.protrusion_data.empty()) {
    params.keep_truth_pairs = params.label_regions = true;
    std::error_code error;
    if (std::filesystem::exists(options.protrusion_data / "index.csv", error)) {
      return slamcore::InvalidArgument(options.protrusion_data.string() +
                                       ": already holds a data set (index.csv); choose an empty directory");
    }
  }
  std::atomic<int> pairs_written{0};
  const auto start = std::chrono::steady_clock::now();

  // Load each home once; robots share it read-only.
  std::map<std::size_t, World> worlds;
  for (int robot = 0; robot < options.robots; ++robot) {
    const std::size_t index = static_cast<std::size_t>(robot) % options.worlds.size();
    if (worlds.contains(index)) continue;
    ASSIGN_OR_RETURN(
        auto world, LoadWorld(options.worlds[index], options.seed * 1000003ULL + index, params.home_clutter));
    worlds.emplace(index, std::move(world));
  }

  const int total = options.robots * options.runs;
  std::vector<std::vector<RunOutcome>> outcomes(static_cast<std::size_t>(options.robots));
  std::vector<std::vector<RunHealth>> health_by_robot(static_cast<std::size_t>(options.robots));
  std::atomic<int> next_robot{0}, done{0};
  std::mutex mutex;  // guards first_error and progress calls
  slamcore::Status first_error;
  auto work = [&] {
    for (int robot = next_robot++; robot < options.robots; robot = next_robot++) {
      const World& world = worlds.at(static_cast<std::size_t>(robot) % options.worlds.size());
      char robot_id[32];
      std::snprintf(robot_id, sizeof robot_id, "robot-%04d", robot);
      const std::string firmware = robot % 2 == 0 ? "1.4.2" : "1.5.0";
      RobotSimulator simulator(world, params, robot_id, firmware,
                               options.seed * 0x9E3779B97F4A7C15ULL + static_cast<std::uint64_t>(robot));
      std::optional<MapHealthMeter> meter;
      if (options.measure_map_health) meter.emplace(world, options.corruption);
      auto fail = [&](const slamcore::Status& status) {
        std::lock_guard lock(mutex);
        if (first_error.ok()) first_error = status;
      };
      for (int run = 0; run < options.runs; ++run) {
        if (options.before_run) {
          if (const slamcore::Status status = options.before_run(simulator, run); !status.ok())
            return fail(status);
        }
        char run_id[64];
        std::snprintf(run_id, sizeof run_id, "%s-s%llu-run%04d", robot_id,
                      static_cast<unsigned long long>(options.seed), run);
        auto outcome = simulator.SimulateRun(run_id, options.first_start + 86400.0 * run + 60.0 * robot);
        if (!outcome.ok()) return fail(outcome.status());
        if (!options.out.empty()) {
          const std::filesystem::path directory = options.out / robot_id;
          std::filesystem::create_directories(directory);
          const std::filesystem::path file = directory / (std::string(run_id) + ".runpb");
          std::ofstream output(file.string() + ".tmp", std::ios::binary | std::ios::trunc);
          if (!outcome->run.SerializeToOstream(&output)) {
            std::lock_guard lock(mutex);
            if (first_error.ok()) first_error = slamcore::DataLoss(file.string() + ": write failed");
            return;
          }
          output.close();
          std::filesystem::rename(file.string() + ".tmp", file);
        }
        if (outcome->truth_pair && (outcome->truth_pair->protrusions + outcome->truth_pair->new_spaces) > 0) {
          const slamcore::DatasetEntry entry{run_id, run_id, world.name,
                                             "fleetsim." + outcome->run.header().robot_model()};
          std::lock_guard lock(mutex);  // one writer of index.csv at a time
          if (const slamcore::Status status =
                  slamcore::WriteDatasetPair(options.protrusion_data.string(), entry, *outcome->truth_pair);
              !status.ok()) {
            if (first_error.ok()) first_error = status;
            return;
          }
          ++pairs_written;
        }
        outcome->truth_pair.reset();
        if (options.after_run) {
          if (const slamcore::Status status = options.after_run(simulator, *outcome); !status.ok())
            return fail(status);
        }
        if (meter) {
          auto health = meter->Measure(simulator.map(), simulator.node_truth());
          if (!health.ok()) return fail(health.status());
          health_by_robot[static_cast<std::size_t>(robot)].push_back(
              {*health, outcome->repairs_taken, outcome->map_version});
        }
        // The statistics need no telemetry, only the robot model.
        const std::string model = outcome->run.header().robot_model();
        outcome->run.Clear();
        outcome->run.mutable_header()->set_robot_model(model);
        outcomes[static_cast<std::size_t>(robot)].push_back(std::move(outcome).value());
        const int finished = ++done;
        if (progress) {
          std::lock_guard lock(mutex);
          progress(finished, total);
        }
      }
    }
  };
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (int t = 0; t < std::min(threads, options.robots); ++t) pool.emplace_back(work);
  for (std::thread& thread : pool) thread.join();
  RETURN_IF_ERROR(first_error);

  // Aggregate in robot order, so the figures do not depend on thread timing.
  FleetStatistics statistics;
  for (const auto& robot_outcomes : outcomes) {
    for (const RunOutcome& outcome : robot_outcomes) statistics.Add(outcome);
  }
  statistics.pairs_written = pairs_written;
  if (options.measure_map_health) {
    for (const auto& runs : health_by_robot) {
      if (runs.empty()) continue;
      bool repaired = false;
      for (const RunHealth& run : runs) repaired = repaired || run.repairs_taken > 0;
      ++(runs.back().map.corrupted ? statistics.robots_corrupted
         : repaired                ? statistics.robots_repaired
                                   : statistics.robots_healthy);
    }
    statistics.health = std::move(health_by_robot);
  }
  statistics.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return statistics;
}

}  // namespace sim
