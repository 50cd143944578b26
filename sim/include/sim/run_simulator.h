// One simulated robot run: physics (motion, collisions, slip, kidnaps), the odometry and camera front-end
// a real robot reports, local occupancy patches, and the robot's own back-end (slamcore's Mapper) running
// on board. The failure modes of the paper arise from this physics — a symmetric object seen from the
// other side, look-alike fixtures, wheels turning while stuck — and are never painted into the telemetry;
// ground truth is recorded beside it, in clearly marked fields.
//
// Thread safety: a RobotSimulator is used from one thread; different robots run on different threads.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "fleet/v1/telemetry.pb.h"
#include "sim/sensor.h"
#include "sim/sim_params.h"
#include "sim/world.h"
#include "slamcore/mapper.h"
#include "slamcore/protrusion_data.h"

namespace sim {

/// Regions by truth (protrusion or new space) and by the class predicted for them.
struct RegionConfusion {
  long true_protrusion = 0, missed_protrusion = 0, false_protrusion = 0, true_new_space = 0;
  void Add(bool truth_protrusion, bool predicted_protrusion) {
    ++(truth_protrusion ? (predicted_protrusion ? true_protrusion : missed_protrusion)
                        : (predicted_protrusion ? false_protrusion : true_new_space));
  }
  RegionConfusion& operator+=(const RegionConfusion& other);
  /// "TP a, FN b, FP c, TN d (precision p %, recall r %)".
  std::string ToText() const;
};

/// What one run produced, beside the telemetry.
struct RunOutcome {
  fleet::v1::RunFile run;                 // header, events (with ground truth), parent and child snapshots
  slamcore::MapperStatistics statistics;  // the robot's own decisions
  bool started_localized = false;         // joined the parent map within analyzer::kStartedLocalizedSeconds
  bool had_parent = false;
  int kidnaps = 0, reboots = 0;
  int stuck_at_wall = 0, stuck_under_furniture = 0, stuck_on_rug = 0;  // episodes by where they started
  int stuck_nodes = 0;                                                 // nodes made while stuck
  int wrong_observations = 0, observations = 0;
  // Recognitions of a landmark that has a look-alike with a view (the front-end could confuse them), those it
  // matched to the look-alike, and the passes those came in (SimParams::lookalike_pass_gap_seconds).
  int lookalike_candidates = 0, lookalike_observations = 0, lookalike_passes = 0;
  std::size_t views_total = 0, views_ambiguous = 0;  // in the child map
  double simulated_seconds = 0.0;
  // Ground truth of the protrusion detector's regions between this run's parent and child maps
  // (analyzer::RegionsDrawnAway by the stuck nodes, the rule fleetd's reports use); with
  // SimParams::keep_truth_pairs, the pair itself with per-cell truth (1 protrusion: drawn by a stuck node's
  // patch where the robot was not; 2 new space; 0 unchanged). The confusion matrices class the same regions
  // as the analysis does (analyzer::ClassifyRegions with the built-in model), by the built-in model alone,
  // and by the slip the run's views show alone (protrusion where they show it, new space elsewhere).
  int truth_protrusion_regions = 0, truth_new_space_regions = 0;
  RegionConfusion analysis_confusion, classifier_confusion, views_confusion;
  // The same regions against the world's truth: a region is erroneous when it is a protrusion above or
  // floor the home does not have (MapHealthMeter::FalseFloor); how many "new space" regions are that.
  RegionConfusion erroneous_confusion;
  int false_floor_new_space_regions = 0;
  std::optional<slamcore::GeneratedPair> truth_pair;
  std::int64_t map_version = 0;  // header.map_version: the service's version the run started from
  int repairs_taken = 0;         // set by a fleet's after-run hook: repaired versions taken after it
  int stuck_episodes() const { return stuck_at_wall + stuck_under_furniture + stuck_on_rug; }
};

/// A robot living in one home across runs: its map, its front-end's view database and its odometry
/// bias persist from run to run (the child map of run k is the parent map of run k+1).
class RobotSimulator {
 public:
  RobotSimulator(const World& world, const SimParams& params, std::string robot_id, std::string firmware,
                 std::uint64_t seed);
  ~RobotSimulator();

  /// Simulates the next run; `started_at` is its Unix start time.
  slamcore::Result<RunOutcome> SimulateRun(const std::string& run_id, double started_at);

  /// The ranging sensor this robot was built with.
  const RangeSensor& sensor() const;

  /// Replaces the on-board map with version `version` of the robot's map in the service (Maps.GetMap's
  /// answer), as a robot that follows the service does before a run: the next run starts from it, names it
  /// as its parent snapshot byte for byte and reports the version. Views the map no longer holds are
  /// forgotten by the front-end. INVALID_ARGUMENT when the snapshot does not decode (the map is kept).
  slamcore::Status TakeMap(const fleet::v1::MapSnapshot& snapshot, std::int64_t version);
  /// The service's version of the robot's current map (its last upload became it); 0: none.
  void SetMapVersion(std::int64_t version);
  std::int64_t map_version() const;
  const std::string& robot_id() const;
  /// The robot's current map, and the true pose of every node it ever made (kept across runs).
  const slamcore::Map& map() const;
  const std::unordered_map<slamcore::NodeId, SE2>& node_truth() const;

  /// The robot's persistent state (map, view database, odometry bias); defined in the .cc.
  struct State;

 private:
  std::unique_ptr<State> state_;
};

}  // namespace sim
