// Pose-graph optimisation: our optimiser (analytic SE(2) Jacobians, linear start) against the textbook
// Ceres setup (automatic differentiation of the same g2o error, default Solver::Options, starting from
// the file's poses, first node held constant), on the real graphs, in the same run.
// Prints Google Benchmark's table, then one line per graph: time ratio (textbook / ours) and both final χ².
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "bench_data.h"
#include "bench_report.h"
#include "slamcore/graph_io.h"
#include "slamcore/optimizer.h"

namespace {

using slamcore::PoseGraph;

/// The g2o EDGE_SE2 error written once for automatic differentiation, as the Ceres examples do.
struct AutoDiffEdgeError {
  AutoDiffEdgeError(const slamcore::SE2& z, const slamcore::Matrix3& sqrt_info)
      : measurement(z), sqrt_information(sqrt_info) {}

  template <typename T>
  bool operator()(const T* from, const T* to, T* residual) const {
    using std::cos, std::sin;
    const T dx = to[0] - from[0], dy = to[1] - from[1];
    const T c = cos(from[2]), s = sin(from[2]);
    const T local_x = c * dx + s * dy, local_y = -s * dx + c * dy;
    const double cz = std::cos(measurement.theta()), sz = std::sin(measurement.theta());
    const T ex = cz * (local_x - measurement.x()) + sz * (local_y - measurement.y());
    const T ey = -sz * (local_x - measurement.x()) + cz * (local_y - measurement.y());
    T angle = to[2] - from[2] - measurement.theta();
    // Wrap to (-π, π] as ceres::examples::NormalizeAngle does.
    const T two_pi(2.0 * M_PI);
    angle = angle - two_pi * ceres::floor((angle + T(M_PI)) / two_pi);
    const T error[3] = {ex, ey, angle};
    for (int r = 0; r < 3; ++r) {
      residual[r] = sqrt_information(r, 0) * error[0] + sqrt_information(r, 1) * error[1] +
                    sqrt_information(r, 2) * error[2];
    }
    return true;
  }

  slamcore::SE2 measurement;
  slamcore::Matrix3 sqrt_information;
};

double TextbookSolve(PoseGraph& graph) {
  std::vector<std::array<double, 3>> poses(graph.num_nodes());
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    const auto& pose = graph.nodes()[i].pose;
    poses[i] = {pose.x(), pose.y(), pose.theta()};
  }
  ceres::Problem problem;
  for (const slamcore::Edge& edge : graph.edges()) {
    const slamcore::Matrix3 sqrt_information = Eigen::LLT<slamcore::Matrix3>(edge.information).matrixU();
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AutoDiffEdgeError, 3, 3, 3>(
                                 new AutoDiffEdgeError(edge.measurement, sqrt_information)),
                             nullptr, poses[graph.IndexOf(edge.from)].data(),
                             poses[graph.IndexOf(edge.to)].data());
  }
  problem.SetParameterBlockConstant(poses[0].data());
  ceres::Solver::Options options;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    graph.mutable_nodes()[i].pose = slamcore::SE2(poses[i][0], poses[i][1], poses[i][2]);
  }
  return slamcore::Chi2(graph);
}

double OurSolve(PoseGraph& graph) {
  slamcore::OptimizerOptions options;
  options.linear_initialization = true;
  const auto summary = slamcore::Optimize(graph, options);
  return summary.ok() ? summary->final_chi2 : -1.0;
}

void Register(const std::string& name, const PoseGraph& graph) {
  for (const bool ours : {false, true}) {
    benchmark::RegisterBenchmark((name + (ours ? "/ours" : "/textbook")).c_str(),
                                 [graph, ours](benchmark::State& state) {
                                   double chi2 = 0.0;
                                   for (auto _ : state) {
                                     state.PauseTiming();
                                     PoseGraph copy = graph;
                                     state.ResumeTiming();
                                     chi2 = ours ? OurSolve(copy) : TextbookSolve(copy);
                                   }
                                   state.counters["chi2"] = chi2;
                                 })
        ->Unit(benchmark::kMillisecond)
        ->MinTime(0.5);
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  int registered = 0;
  for (const char* file :
       {"vertigo/manhattanOlson3500_olson.g2o", "vertigo/intel.g2o", "sesync/intel.g2o", "sesync/CSAIL.g2o",
        "sesync/MIT.g2o", "sesync/manhattan.g2o", "vertigo/ringCity.g2o"}) {
    // data/ carries a few of the graphs; the rest are in the larger set, and are skipped without it.
    const auto path = bench::FindData("optimizer_bench", std::string("posegraphs/") + file);
    if (!path) continue;
    ++registered;
    auto graph = slamcore::ReadPoseGraph(*path);
    if (!graph.ok()) {
      std::fprintf(stderr, "%s\n", graph.status().ToString().c_str());
      return 1;
    }
    Register(std::filesystem::path(file).stem().string() + "(" +
                 std::filesystem::path(file).parent_path().string() + ")",
             *graph);
  }
  if (registered == 0) {
    std::fprintf(stderr, "optimizer_bench: none of its graphs is in data/ or the larger set\n");
    return 1;
  }
  bench::RatioReporter reporter("textbook", "ours");
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios("time textbook/ours (target >= 2)");
  benchmark::Shutdown();
  return 0;
}
