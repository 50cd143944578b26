// A simulated fleet: N robots × M runs over a set of homes, deterministic for one seed, robots simulated in
// parallel on all cores, with progress and fleet statistics (the paper's Fig. 6–8 figures).
//
// Thread safety: SimulateFleet runs its own worker threads; the progress callback is called from them,
// serialised by an internal mutex.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/map_health.h"
#include "sim/run_simulator.h"
#include "sim/sim_params.h"

namespace sim {

struct FleetOptions {
  std::vector<std::filesystem::path> worlds;  // robot k lives in worlds[k % size]
  int robots = 4;
  int runs = 3;
  std::uint64_t seed = 1;
  int threads = 0;                        // 0: all cores
  std::filesystem::path out;              // empty: keep nothing on disk
  std::filesystem::path protrusion_data;  // set: write each run's labelled parent/child pair here
  double first_start = 1767225600.0;      // 2026-01-01T00:00:00Z, runs one day apart
  SimParams params;
  /// Measure each robot's map against ground truth after every run (sim/map_health.h).
  bool measure_map_health = false;
  CorruptionThreshold corruption;
  /// Called on the robot's thread before each run (e.g. take the service's newest approved map) and after
  /// it (e.g. upload it, then take a repaired map); an error stops the fleet. The after-run hook may note in
  /// the outcome what it did (RunOutcome::repairs_taken).
  std::function<slamcore::Status(RobotSimulator&, int run)> before_run;
  std::function<slamcore::Status(RobotSimulator&, RunOutcome&)> after_run;
};

/// One robot's map after one run (and after the after-run hook), with what the service did to it.
struct RunHealth {
  MapHealth map;
  int repairs_taken = 0;         // repaired versions the robot took since its previous run
  std::int64_t map_version = 0;  // the version the run started from (0: none)
};

/// Figures over all runs, as the paper reports them.
struct FleetStatistics {
  int runs = 0;
  int runs_with_parent = 0;        // runs on top of an existing map: need relocalization
  int runs_started_localized = 0;  // of those, joined the parent map at once (analyzer/run_analysis.h)
  int runs_with_recovery = 0;      // ≥ 1 recovery hypothesis
  long recovery_created = 0, recovery_accepted = 0, recovery_retracted = 0;
  long merge_created = 0, merge_conditionally_accepted = 0, merge_conditional_then_rejected = 0,
       merge_accepted = 0;
  int maps_with_views = 0, maps_with_ambiguous_views = 0;
  double ambiguous_view_share_sum = 0.0;  // Σ over maps with ambiguous views of their ambiguous share
  long observations = 0, wrong_observations = 0;
  int kidnaps = 0, reboots = 0;
  int stuck_at_wall = 0, stuck_under_furniture = 0, stuck_on_rug = 0;
  long stuck_nodes = 0;
  int lidar_runs = 0;  // runs by robots with a lidar (the rest: a front ToF)
  // Ground truth of the detector's regions (RunOutcome): maps = runs' child maps
  int maps_with_truth_protrusion = 0;
  long truth_protrusion_regions = 0, truth_new_space_regions = 0;
  RegionConfusion analysis_confusion, classifier_confusion, views_confusion;  // RunOutcome's, summed
  RegionConfusion erroneous_confusion;
  long false_floor_new_space_regions = 0;
  int pairs_written = 0;  // --protrusion-data
  double simulated_hours = 0.0;
  double wall_seconds = 0.0;
  // With measure_map_health: [robot][run], and the robots by their map after the last run: corrupted; else
  // repaired (took a repaired map from the service at least once); else healthy.
  std::vector<std::vector<RunHealth>> health;
  int robots_healthy = 0, robots_repaired = 0, robots_corrupted = 0;

  void Add(const RunOutcome& outcome);
  std::string ToText() const;
  std::string ToJson() const;  // one line
  /// "map health (ground truth) … H healthy, R repaired, C corrupted robots" (with measure_map_health).
  std::string MapHealthLine() const;
};

/// Runs the fleet; `progress(done, total)` after each run. Files: OUT/<robot>/<run_id>.runpb (RunFile);
/// with `protrusion_data`, every run on a parent map whose detector finds a region is written there in the
/// protrusion data-set layout (docs/protrusion-data.md; pair id = run id, home id = home, source =
/// "fleetsim.<robot model>"), index lines in the order the runs finish.
slamcore::Result<FleetStatistics> SimulateFleet(const FleetOptions& options,
                                                const std::function<void(int, int)>& progress = {});

}  // namespace sim
