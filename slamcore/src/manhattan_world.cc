#include "slamcore/manhattan_world.h"

#include "slamcore/graph_io.h"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <unordered_map>

namespace slamcore {
namespace {

Status Validate(const ManhattanOptions& options) {
  if (options.poses < 2 || options.poses > kMaxManhattanPoses) {
    return InvalidArgument("poses must be in [2, " + std::to_string(kMaxManhattanPoses) + "], got " +
                           std::to_string(options.poses));
  }
  if (options.block_length < 1 || options.block_length > 1000)
    return InvalidArgument("block_length must be in [1, 1000]");
  if (options.world_blocks < 0 || options.world_blocks > 100000)
    return InvalidArgument("world_blocks must be in [0, 100000]");
  if (!(options.sigma_xy > 0.0 && options.sigma_xy <= 10.0))
    return InvalidArgument("sigma_xy must be in (0, 10]");
  if (!(options.sigma_theta > 0.0 && options.sigma_theta <= 1.0))
    return InvalidArgument("sigma_theta must be in (0, 1]");
  if (!(options.closure_radius >= 0.0 && options.closure_radius <= 100.0)) {
    return InvalidArgument("closure_radius must be in [0, 100]");
  }
  if (!(options.closure_probability >= 0.0 && options.closure_probability <= 1.0)) {
    return InvalidArgument("closure_probability must be in [0, 1]");
  }
  if (options.max_closures_per_pose < 0 || options.max_closures_per_pose > 100) {
    return InvalidArgument("max_closures_per_pose must be in [0, 100]");
  }
  if (options.min_closure_gap < 2) return InvalidArgument("min_closure_gap must be at least 2");
  return Status::Ok();
}

/// Lattice cell of a position, for finding earlier poses near a true position.
std::int64_t CellKey(double x, double y, double cell) {
  const auto cx = static_cast<std::int64_t>(std::floor(x / cell)),
             cy = static_cast<std::int64_t>(std::floor(y / cell));
  return cx * 4'000'003 + cy;
}

}  // namespace

Result<ManhattanWorld> GenerateManhattanWorld(const ManhattanOptions& options) {
  RETURN_IF_ERROR(Validate(options));
  std::mt19937_64 random(options.seed);
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const int blocks =
      options.world_blocks > 0
          ? options.world_blocks
          : std::max(2, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(options.poses)) / 3.0)));
  const int side = blocks * options.block_length;  // the world is [0, side]² on the lattice

  Matrix3 information = Matrix3::Zero();
  information.diagonal() << 1.0 / (options.sigma_xy * options.sigma_xy),
      1.0 / (options.sigma_xy * options.sigma_xy), 1.0 / (options.sigma_theta * options.sigma_theta);
  const auto noisy = [&](const SE2& truth) {
    return SE2(truth.x() + options.sigma_xy * unit_normal(random),
               truth.y() + options.sigma_xy * unit_normal(random),
               truth.theta() + options.sigma_theta * unit_normal(random));
  };

  ManhattanWorld world;
  world.truth.reserve(static_cast<std::size_t>(options.poses));
  // Integer lattice state: position and heading in quarter turns (0 = +x).
  int x = 0, y = 0, heading = 0;
  const double cell = std::max(options.closure_radius, 1.0);
  std::unordered_map<std::int64_t, std::vector<int>> poses_in_cell;
  const auto truth_pose = [&] { return SE2(x, y, WrapAngle(heading * std::numbers::pi / 2)); };

  for (int k = 0; k < options.poses; ++k) {
    if (k > 0) {
      // At an intersection choose a turn among those that stay inside; elsewhere keep going.
      int turn = 0;
      if (x % options.block_length == 0 && y % options.block_length == 0) {
        static constexpr int kTurns[] = {0, 1, -1, 2};
        static constexpr double kWeights[] = {0.5, 0.2, 0.2, 0.1};
        std::vector<int> allowed;
        std::vector<double> weights;
        for (int t = 0; t < 4; ++t) {
          const int h = ((heading + kTurns[t]) % 4 + 4) % 4;
          const int nx = x + (h == 0) - (h == 2), ny = y + (h == 1) - (h == 3);
          if (nx >= 0 && nx <= side && ny >= 0 && ny <= side)
            allowed.push_back(kTurns[t]), weights.push_back(kWeights[t]);
        }
        turn = allowed[std::discrete_distribution<std::size_t>(weights.begin(), weights.end())(random)];
      }
      const SE2 before = truth_pose();
      heading = ((heading + turn) % 4 + 4) % 4;
      x += (heading == 0) - (heading == 2);
      y += (heading == 1) - (heading == 3);
      const SE2 relative = before.inverse() * truth_pose();
      const SE2 measured = noisy(relative);
      Node node{.id = k, .pose = world.graph.node(k - 1).pose * measured};
      (void)world.graph.AddNode(node);  // fresh id
      (void)world.graph.AddEdge(Edge{.from = k - 1,
                                     .to = k,
                                     .measurement = measured,
                                     .information = information,
                                     .kind = EdgeKind::kMotion});
    } else {
      (void)world.graph.AddNode(Node{.id = 0, .pose = SE2::Identity()});
    }
    world.truth.push_back(truth_pose());

    // Loop closures to earlier poses that are truly near.
    std::vector<int> candidates;
    const SE2 here = world.truth.back();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const auto it = poses_in_cell.find(CellKey(x + dx * cell, y + dy * cell, cell));
        if (it == poses_in_cell.end()) continue;
        for (const int i : it->second) {
          if (i <= k - options.min_closure_gap &&
              (world.truth[static_cast<std::size_t>(i)].translation() - here.translation()).norm() <=
                  options.closure_radius) {
            candidates.push_back(i);
          }
        }
      }
    }
    if (!candidates.empty() && uniform(random) < options.closure_probability) {
      std::sort(candidates.begin(), candidates.end());  // the cells' order must not decide the draw
      std::shuffle(candidates.begin(), candidates.end(), random);
      const std::size_t count =
          std::min(candidates.size(), static_cast<std::size_t>(options.max_closures_per_pose));
      for (std::size_t c = 0; c < count; ++c) {
        const int i = candidates[c];
        const SE2 relative = world.truth[static_cast<std::size_t>(i)].inverse() * here;
        (void)world.graph.AddEdge(Edge{.from = i,
                                       .to = k,
                                       .measurement = noisy(relative),
                                       .information = information,
                                       .kind = EdgeKind::kObservation});
      }
    }
    poses_in_cell[CellKey(x, y, cell)].push_back(k);
  }
  return world;
}

Status WriteGroundTruth(const std::vector<SE2>& truth, const std::filesystem::path& path) {
  return WriteFileReplacing(path, [&](std::ostream& output) {
    output.precision(std::numeric_limits<double>::max_digits10);
    for (std::size_t k = 0; k < truth.size(); ++k) {
      output << k << ' ' << truth[k].x() << ' ' << truth[k].y() << ' ' << truth[k].theta() << '\n';
    }
  });
}

}  // namespace slamcore
