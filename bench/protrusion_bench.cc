// Occupancy maps and protrusion detection (paper IV-C), each against a floor measured in the same run:
//  * Detect1000: the whole detector (alignment, difference, clean-up, regions, 14 features per region) on a
//    1000×1000 parent/child pair made from the largest real map, against the bare OpenCV difference +
//    connected-component labelling of the same, already aligned pair (the least any detector must do).
//  * Render: the global grid after one node moved (incremental Update) against rendering it from scratch.
// Prints Google Benchmark's table, then ratios (baseline time / candidate time).
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <filesystem>

#include "bench_data.h"
#include "bench_report.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_data.h"
#include "slamcore/protrusion_detector.h"

namespace {

using slamcore::OccupancyGrid;

struct Pair {
  OccupancyGrid parent;          // cropped to its known area, as saved by a robot
  OccupancyGrid aligned_parent;  // the same on the child's cells (for the floor)
  OccupancyGrid child;
};

OccupancyGrid Crop(const OccupancyGrid& grid, int col0, int row0, int size) {
  OccupancyGrid out =
      *OccupancyGrid::Create(size, size, grid.resolution, grid.origin_x + col0 * grid.resolution,
                             grid.origin_y + row0 * grid.resolution);
  for (int row = 0; row < size; ++row) {
    for (int col = 0; col < size; ++col) {
      if (grid.InBounds(col + col0, row + row0)) out.at(col, row) = grid.at(col + col0, row + row0);
    }
  }
  return out;
}

const Pair& BenchPair() {
  static const Pair pair = [] {
    const auto path = bench::FindData("protrusion_bench", "maps/valetudo_dreame_l10su_3031_giant.yaml");
    if (!path) std::exit(1);
    const auto map = slamcore::ReadMapServerYaml(path->string());
    if (!map.ok()) {
      std::fprintf(stderr, "%s\n", map.status().ToString().c_str());
      std::exit(1);
    }
    slamcore::GeneratorOptions options;
    options.min_protrusions = 2;
    options.max_protrusions = 2;
    const auto generated = slamcore::GeneratePair(*map, 11, options);
    Pair result;
    const OccupancyGrid aligned = *slamcore::AlignParentToChild(generated->parent, generated->child);
    const int col0 = (generated->child.width - 1000) / 2, row0 = (generated->child.height - 1000) / 2;
    result.child = Crop(generated->child, col0, row0, 1000);
    result.aligned_parent = Crop(aligned, col0, row0, 1000);
    result.parent = generated->parent;
    return result;
  }();
  return pair;
}

void Detect1000Baseline(benchmark::State& state) {
  const Pair& pair = BenchPair();
  const cv::Mat parent(1000, 1000, CV_8S, const_cast<std::int8_t*>(pair.aligned_parent.cells.data()));
  const cv::Mat child(1000, 1000, CV_8S, const_cast<std::int8_t*>(pair.child.cells.data()));
  for (auto _ : state) {
    // New = known now and unknown before: the image difference and labelling of Fig. 5(c).
    cv::Mat unknown_before, known_now, difference, labels, stats, centroids;
    cv::compare(parent, -1, unknown_before, cv::CMP_EQ);
    cv::compare(child, -1, known_now, cv::CMP_NE);
    cv::bitwise_and(unknown_before, known_now, difference);
    const int count = cv::connectedComponentsWithStats(difference, labels, stats, centroids, 8, CV_32S);
    benchmark::DoNotOptimize(count);
  }
}

void Detect1000Candidate(benchmark::State& state) {
  const Pair& pair = BenchPair();
  std::size_t regions = 0;
  for (auto _ : state) {
    const auto result = slamcore::ExtractRegions(pair.parent, pair.child);
    regions = result.ok() ? result->size() : 0;
    benchmark::DoNotOptimize(regions);
  }
  state.counters["regions"] = static_cast<double>(regions);
}

BENCHMARK(Detect1000Baseline)->Name("Detect1000x1000/baseline")->Unit(benchmark::kMillisecond);
BENCHMARK(Detect1000Candidate)->Name("Detect1000x1000/candidate")->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  bench::RatioReporter reporter("baseline", "candidate");
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios("baseline: bare OpenCV difference + labelling; ratio < 1 = slower");
  benchmark::Shutdown();
  return 0;
}
