// The lifelong experiment (docs/fleetsim.md, "Lifelong maps"): N robots × M daily runs in the same homes on
// the same seeds under four regimes run side by side —
//   none     no protection: the robots merge and close loops on the first observation;
//   filter   the paper's filter on board (slamcore's default Mapper);
//   service  the filter on board plus fleetd's analysis with an automatic repair policy (cut protrusions,
//            reject unconfirmed hypotheses and high-residual edges above a severity, roll back when a finding
//            cannot be repaired), approved at once; robots take the repaired map before their next run;
//   review   the same, but an engineer approves pending repairs only every `review_every_runs` runs.
// Each robot's map is measured against ground truth after every run (sim/map_health.h). The service regimes
// start a fleetd of their own and stop it afterwards.
//
// Thread safety: RunLifelong runs the fleet's threads itself; call it from one thread.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/fleet.h"

namespace sim {

inline constexpr int kMaxLifelongRobots = 200;
inline constexpr int kMaxLifelongRuns = 400;

struct LifelongOptions {
  std::vector<std::filesystem::path> worlds;
  int robots = 20;
  int runs = 40;
  std::uint64_t seed = 1;
  double run_minutes = 10.0;
  int threads = 0;                  // 0: all cores
  std::filesystem::path fleetd;     // the fleetd binary for the service regimes
  std::filesystem::path work_dir;   // their databases and logs
  int review_every_runs = 7;        // review: an engineer approves repairs once a week
  double min_severity = 0.6;        // the policy acts on findings at least this severe
  std::string protrusions = "any";  // which protrusions it cuts: "any", or "views" (fleetd's MapPolicy)
  CorruptionThreshold corruption;
  std::vector<std::string> regimes = {"none", "filter", "service", "review"};
  SimParams params;  // the homes' clutter and the robots' physics
};

/// INVALID_ARGUMENT naming the first bound broken (robots, runs, minutes, regimes, …).
slamcore::Status ValidateLifelong(const LifelongOptions& options);

struct RegimeResult {
  std::string name;
  FleetStatistics statistics;            // with health[robot][run]
  std::vector<double> corrupted_by_run;  // share of robots corrupted after each run
  double corrupted_share = 0.0;          // after the last run
  int robots_ever_corrupted = 0;
  double mean_runs_to_corruption = 0.0;  // over robots ever corrupted: runs until the first corruption
  int runs_lost = 0;                     // robot-runs that ended on a corrupted map
  int repairs_taken = 0;
  double seconds = 0.0;
};

/// Runs the regimes one after another; `progress(regime, done, total)` as each regime starts (done 0) and
/// after each run, and `regime_done(results so far)` after each regime (an experiment at the default size
/// takes hours: what is done is kept when a later regime fails or the run is stopped).
slamcore::Result<std::vector<RegimeResult>> RunLifelong(
    const LifelongOptions& options, const std::function<void(const std::string&, int, int)>& progress = {},
    const std::function<void(const std::vector<RegimeResult>&)>& regime_done = {});

/// One JSON object: {"robots", "runs", "seed", "threshold", "regimes": {"none": {...}, ...},
/// "regimes_to_come": [...]} with each finished regime's figures, corrupted_by_run and per robot and run
/// [trajectory_rmse_m, false_free_m2, components, repairs_taken, outcome, known_floor_m2], and
/// known_floor_share (the mean share of each home's true floor its map knows after the last run);
/// regimes_to_come names those of `options` not yet in `results` (empty once the experiment is complete).
std::string LifelongJson(const LifelongOptions& options, const std::vector<RegimeResult>& results);
/// A table for people: a row per regime, then the corrupted share every few runs.
std::string LifelongText(const LifelongOptions& options, const std::vector<RegimeResult>& results);

}  // namespace sim
