// Manhattan-world pose graphs of any size, for scale measurements: the classic construction of Olson's
// Manhattan set (Olson, Leonard, Teller, "Fast iterative optimization of pose graphs with poor initial
// estimates", ICRA 2006): a robot walks a city grid one metre per pose, turning only at intersections, with
// noisy odometry, and a loop closure is added when it comes back near a place it has been before.
//
// Construction (all from one seed):
//  * True poses on the integer lattice: streets every `block_length` metres in a square world of
//    `world_blocks` × `world_blocks` blocks (by default grown with √poses, so the density of revisits, and
//    with it the closures per pose, stays the same at every size). At an intersection the robot goes
//    straight, left, right or back with probabilities 0.5, 0.2, 0.2, 0.1 among the moves that stay inside.
//  * Odometry k → k+1: the true relative pose plus independent N(0, σ²) noise on x, y and θ; information
//    diag(1/σ²). The initial estimate of every node is the composed odometry (what a robot would have).
//  * Loop closures at pose k: the earlier poses i ≤ k − min_closure_gap whose *true* position lies within
//    `closure_radius`; with probability `closure_probability` up to `max_closures_per_pose` of them (drawn at
//    random) get an edge i → k with the true relative pose plus the same kind of noise. No closure is ever
//    made between places that are not truly close.
//
// Thread safety: a free function without shared state.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "slamcore/pose_graph.h"

namespace slamcore {

struct ManhattanOptions {
  int poses = 3500;
  std::uint64_t seed = 1;
  int block_length = 5;         // metres (= poses) between intersections
  int world_blocks = 0;         // side of the square world in blocks; 0: max(2, ⌈√poses / 3⌉)
  double sigma_xy = 0.03;       // metres, odometry and closures
  double sigma_theta = 0.01;    // radians, odometry and closures
  double closure_radius = 1.5;  // metres between the true positions of a closure's ends
  double closure_probability = 0.5;
  int max_closures_per_pose = 2;
  int min_closure_gap = 10;  // poses: nearer ones are the odometry's business
};

/// Largest accepted `poses` (keeps a generated graph within a few hundred MB).
inline constexpr int kMaxManhattanPoses = 2'000'000;

struct ManhattanWorld {
  PoseGraph
      graph;  // initial estimate = composed odometry; edges in pose order (odometry into k, then k's closures)
  std::vector<SE2> truth;  // true pose of node k at index k
};

/// Fails with a message naming the bad option (poses < 2 or above the cap, non-positive noise, …).
Result<ManhattanWorld> GenerateManhattanWorld(const ManhattanOptions& options);

/// Writes true poses as text, one "id x y θ" line per node in id order (full double precision), the
/// ground-truth layout bench/filter_evaluation.h reads. Fails only on I/O errors, naming the file.
Status WriteGroundTruth(const std::vector<SE2>& truth, const std::filesystem::path& path);

}  // namespace slamcore
