// slamtool: offline operations of the shared SLAM core on files.
//
//   slamtool optimize FILE [--out FILE.g2o] [--json] [--init linear|warm] [--robust-loss none|huber|cauchy]
//
// Exit status: 0 on success, 1 when the input is refused (the message names file, line and reason),
// 2 on a usage error.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <string>

#include "slamcore/graph_io.h"
#include "slamcore/optimizer.h"

namespace {

int Fail(const slamcore::Status& status) {
  std::cerr << "slamtool: " << status.ToString() << "\n";
  return 1;
}

struct OptimizeArguments {
  std::string input;
  std::string output;
  bool json = false;
  int max_iterations = 100;
  std::string robust_loss = "none";
  std::string initialization = "linear";
};

int RunOptimize(const OptimizeArguments& arguments) {
  auto graph = slamcore::ReadPoseGraph(arguments.input);
  if (!graph.ok()) return Fail(graph.status());
  slamcore::OptimizerOptions options;
  options.max_iterations = arguments.max_iterations;
  options.linear_initialization = arguments.initialization == "linear";
  if (arguments.robust_loss == "huber") options.robust_loss = slamcore::RobustLoss::kHuber;
  if (arguments.robust_loss == "cauchy") options.robust_loss = slamcore::RobustLoss::kCauchy;
  const auto summary = slamcore::Optimize(*graph, options);
  if (!summary.ok()) return Fail(summary.status());
  if (!arguments.output.empty()) {
    if (const auto status = slamcore::WritePoseGraph(*graph, arguments.output, slamcore::GraphFormat::kG2o);
        !status.ok()) {
      return Fail(status);
    }
  }
  if (arguments.json) {
    const nlohmann::json report = {
        {"file", arguments.input},          {"nodes", graph->num_nodes()},
        {"edges", graph->num_edges()},      {"components", graph->NumComponents()},
        {"initial_chi2", summary->initial_chi2}, {"final_chi2", summary->final_chi2},
        {"iterations", summary->iterations}, {"seconds", summary->seconds},
        {"converged", summary->converged},  {"termination", summary->message},
    };
    std::cout << report.dump() << "\n";
  } else {
    std::printf("%s: %zu nodes, %zu edges, %zu components\n", arguments.input.c_str(), graph->num_nodes(),
                graph->num_edges(), graph->NumComponents());
    std::printf("chi2 %.6g -> %.6g in %d iterations, %.3f s (%s)\n", summary->initial_chi2, summary->final_chi2,
                summary->iterations, summary->seconds, summary->converged ? "converged" : "not converged");
    if (!arguments.output.empty()) std::printf("written to %s\n", arguments.output.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"slamtool: offline operations of the shared SLAM core on files"};
  app.require_subcommand(1);

  OptimizeArguments optimize;
  CLI::App* optimize_command = app.add_subcommand("optimize", "optimise a g2o or TORO pose graph");
  optimize_command->add_option("FILE", optimize.input, "g2o or TORO file")->required()->check(CLI::ExistingFile);
  optimize_command->add_option("--out", optimize.output, "write the optimised graph as g2o");
  optimize_command->add_flag("--json", optimize.json, "print one JSON object on stdout");
  optimize_command->add_option("--max-iterations", optimize.max_iterations, "iteration limit")
      ->check(CLI::PositiveNumber);
  optimize_command->add_option("--robust-loss", optimize.robust_loss, "none, huber or cauchy")
      ->check(CLI::IsMember({"none", "huber", "cauchy"}));
  optimize_command
      ->add_option("--init", optimize.initialization,
                   "linear: start from the linear (LAGO) estimate; warm: from the poses in the file")
      ->check(CLI::IsMember({"linear", "warm"}));

  CLI11_PARSE(app, argc, argv);
  if (optimize_command->parsed()) return RunOptimize(optimize);
  return 2;
}
