// Labelled data for the protrusion classifier (paper IV-C): a seeded generator that turns a real map into
// a parent/child pair with slip protrusions and genuinely new space, the on-disk data set format, and
// the labelling of detected regions against the ground truth. docs/protrusion-data.md is the reference.
//
// Generator physics (GeneratePair):
//  * Slip protrusion. A robot whose wheels slip (or that is stuck, "stasis") keeps integrating odometry
//    while not moving, so its scans are inserted along a false, straight or gently curved path. Where that
//    path leaves known space it paints a corridor one robot wide (0.28–0.36 m, slowly wobbling), free inside
//    and edged by smeared wall hits, 0.5–5 m long outside known space, attached to the known map where the
//    robot got stuck, often through the wall it was pushing against.
//  * New space. (a) A room explored for the first time: a geodesic ball of the real map's free space around
//    a seed with ≥ 0.4 m clearance is removed from the parent (with its walls), so the child reveals it;
//    (b) an opened door: the same, with the parent holding the closed door (the cut between the ball and
//    the rest) as a wall; (c) moved furniture: a rectangle in open floor, half small (0.3–0.6 × 0.3–0.8 m, a chair or box),
//    half large (0.6–1.6 × 1.2–2.4 m, a sofa or bed), that the
//    parent shows as an outlined obstacle with unknown inside and the child as free floor.
//  * Stuck robot (the physical model, paper I and IV-C). The robot pushes an obstacle (or is lifted on a
//    rug) and its wheels keep turning: odometry advances along the push, bent by unequal slip, while the
//    robot stays where it is. Each node's scan is what the sensor sees at the TRUE place, drawn at the
//    BELIEVED pose (range_scan.h), so the child gains a band repeating the real surroundings along the
//    push, as wide as the sensor's view, usually through the obstacle into space beyond it.
//  * Realism. Edge cells of every change drop out at random (the sensor misses some), the child gains
//    speckle (1–4-cell blobs) and 1-cell fringes along known edges that the detector's clean-up must remove,
//    and the parent is cropped to its known area, so parent and child differ in size and origin.
//  * Registration error (the misregistered family). Two maps of one home are never drawn on exactly the
//    same grid: the child is a later mapping session, aligned to the parent only as well as a dock pose and
//    image registration allow. The child (and its truth) is moved by a small rigid transform, resampled
//    cell by cell, so that walls land a cell or two off, as they do in real pairs.
//
// Data set layout (version 1): DIR/index.csv with header `pair_id,map_id,home_id,source` and, per pair,
// DIR/pairs/<pair_id>/{parent.yaml,parent.png,child.yaml,child.png,truth.png} (map_server YAML naming a PGM or PNG); truth.png is in the child's
// image (row 0 at the top), 0 = unchanged, 1 = protrusion, 2 = new space. Splits are by home_id, so a home
// (and every map of it) is never in both training and test. fleetsim writes the same layout.
//
// Thread safety: free functions on values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_detector.h"

namespace slamcore {

enum class TruthLabel : std::uint8_t { kUnchanged = 0, kProtrusion = 1, kNewSpace = 2 };

/// A closed interval to draw from uniformly.
struct Interval {
  double low = 0.0, high = 0.0;
};

/// The physics of a robot stuck with its wheels turning (see "Stuck robot" above). Each pair draws one
/// robot model (a sensor band, then a range and field of view within it) for all its changes.
struct StuckRobotPhysics {
  struct SensorBand {
    Interval range_m;        // sensor range
    Interval field_of_view;  // radians centred ahead; ≥ 2π: a rotating lidar
  };
  std::vector<SensorBand> sensors = {{{0.8, 1.6}, {1.2, 2.2}}, {{4.0, 6.0}, {6.3, 6.3}}};
  Interval push_deviation = {0.0, 0.52};  // |angle| between the push and the obstacle's normal, radians
  Interval stuck_travel_m = {0.5, 4.0};   // what odometry integrates while the robot does not move
  double max_heading_drift_per_m = 0.10;  // unequal wheel slip bends the believed path (rad per metre)
  double contact_share = 0.8;             // pushing an obstacle; the rest lifted on a rug in open floor
  double robot_radius_m = 0.17;
  double keyframe_m = 0.3;  // a node (and a scan) every 0.3 m of odometry
};

struct GeneratorOptions {
  int min_protrusions = 0, max_protrusions = 2;
  int min_new_spaces = 1, max_new_spaces = 3;
  double min_robot_width_m = 0.28, max_robot_width_m = 0.36;
  double min_protrusion_length_m = 0.5, max_protrusion_length_m = 5.0;
  int max_speckles = 30;
  /// Share of protrusions made by the stuck robot (the rest are corridors); 0 = the corridor model only.
  double stuck_robot_share = 0.0;
  /// New rooms and opened doors revealed by scans of the pair's sensor from where the robot was (some
  /// seen through a doorway from outside: a lidar's fan), instead of copied from the real map.
  bool scan_rendering = false;
  StuckRobotPhysics stuck;
  /// The child's registration error against the parent: a shift of this length (metres, in a uniform
  /// direction) and a rotation of this magnitude (radians, either sign) about the map's centre. Zero: the
  /// child is drawn on the parent's grid exactly (the corridor family, data set version 1).
  Interval registration_shift_m = {0.0, 0.0};
  Interval registration_rotation = {0.0, 0.0};
};

/// The named generator families (docs/protrusion-data.md): "corridor" (version 1: corridors, copied new
/// space), "physical" (what the default model trains on: stuck robots and scanned new space),
/// "heldout" (stuck robots only, with sensor ranges, fields of view, push angles, travel and drift that
/// "physical" never uses: kept out of all training and tuning) and "misregistered" (the heldout pairs with
/// the child drawn 0.05–0.10 m off the parent: testing only).
Result<GeneratorOptions> GeneratorFamily(const std::string& name);

struct GeneratedPair {
  OccupancyGrid parent;
  OccupancyGrid child;
  std::vector<std::uint8_t> truth;  // per child grid cell (grid rows: row 0 = lowest y), TruthLabel values
  int protrusions = 0;
  int new_spaces = 0;
};

/// A parent/child pair from one real map; the same (map, seed, options) always gives the same pair.
Result<GeneratedPair> GeneratePair(const OccupancyGrid& real_map, std::uint64_t seed,
                                   const GeneratorOptions& options = {});

struct DatasetEntry {
  std::string pair_id, map_id, home_id, source;
};

/// Writes one pair under `root` and appends its line to root/index.csv (created with its header).
Status WriteDatasetPair(const std::string& root, const DatasetEntry& entry, const GeneratedPair& pair);
Result<std::vector<DatasetEntry>> ReadDatasetIndex(const std::string& root);
/// Reads a pair back (parent, child, truth) and checks that the truth image matches the child's size.
Result<GeneratedPair> ReadDatasetPair(const std::string& root, const DatasetEntry& entry);

/// Regions of one pair with their true class. A region counts as a protrusion when most of its changed
/// cells are protrusion truth; regions that are mostly unchanged-truth (noise that survived clean-up) are
/// negatives. `missed_protrusions` counts protrusion pieces of at least kMinMissedProtrusionAreaM2 (a
/// robot's footprint; smaller slivers are noise-sized) that no protrusion region covers: they
/// are false negatives of the segmentation, before any classifier.
inline constexpr double kMinMissedProtrusionAreaM2 = 0.2;
struct LabelledPair {
  std::vector<ProtrusionRegion> regions;
  std::vector<int> labels;  // 1 protrusion, 0 not
  int missed_protrusions = 0;
  int spurious_regions = 0;
};
Result<LabelledPair> ExtractAndLabel(const GeneratedPair& pair, const DetectorOptions& options = {});

/// Adds one labelled pair's outcome under `classifier` to `confusion`: every region is one prediction,
/// and every protrusion the segmentation missed is one false negative.
Status AccumulateConfusion(const ProtrusionClassifier& classifier, const LabelledPair& pair,
                           ConfusionMatrix* confusion);

/// The home a real map belongs to, for splits: the first four '_'-separated parts of its file stem
/// ("valetudo_dreame_d9_1058_no_segments" and "..._with_segments" are one home at two times).
std::string HomeOfRealMap(const std::string& map_id);

}  // namespace slamcore
