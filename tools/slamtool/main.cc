// slamtool: offline operations of the shared SLAM core on files.
//
//   slamtool optimize FILE [--out FILE.g2o] [--json] [--init linear|warm] [--robust-loss none|huber|cauchy]
//   slamtool replay-g2o FILE [--params FILE] [--backend incremental|batch] [--json] [--decisions FILE.jsonl]
//   slamtool corrupt-g2o FILE --out FILE [--count N | --fraction F] [--mode random|local|first|shifted]
//            [--group G] [--max-group G] [--single-fraction F] [--seed S]
//   slamtool generate-manhattan --poses N [--seed S] [--truth FILE] OUT.g2o
//   slamtool protrusions | make-protrusion-data | train-protrusions | eval-protrusions (protrusion_commands.h)
//   slamtool valetudo-to-map FILE.json --out OUT.yaml [--png] [--json] (valetudo_command.h)
//
// Exit status: 0 on success, 1 when the input is refused (the message names file, line and reason),
// 2 on a usage error.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>

#include "analyzer/parameters.h"
#include "protrusion_commands.h"
#include "valetudo_command.h"
#include "slamcore/g2o_replay.h"
#include "slamcore/graph_io.h"
#include "slamcore/loop_closure_outliers.h"
#include "slamcore/manhattan_world.h"
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
        {"file", arguments.input},
        {"nodes", graph->num_nodes()},
        {"edges", graph->num_edges()},
        {"components", graph->NumComponents()},
        {"initial_chi2", summary->initial_chi2},
        {"final_chi2", summary->final_chi2},
        {"iterations", summary->iterations},
        {"seconds", summary->seconds},
        {"converged", summary->converged},
        {"termination", summary->message},
    };
    std::cout << report.dump() << "\n";
  } else {
    std::printf("%s: %zu nodes, %zu edges, %zu components\n", arguments.input.c_str(), graph->num_nodes(),
                graph->num_edges(), graph->NumComponents());
    std::printf("chi2 %.6g -> %.6g in %d iterations, %.3f s (%s)\n", summary->initial_chi2,
                summary->final_chi2, summary->iterations, summary->seconds,
                summary->converged ? "converged" : "not converged");
    if (!arguments.output.empty()) std::printf("written to %s\n", arguments.output.c_str());
  }
  return 0;
}

struct ReplayArguments {
  std::string input;
  std::string params_file;
  std::string backend = "incremental";
  bool json = false;
  std::string decisions_file;
};

// One JSON object per line and decision, in the order the Mapper made them.
slamcore::Status WriteDecisions(const std::vector<slamcore::Decision>& decisions, const std::string& path) {
  return slamcore::WriteFileReplacing(path, [&](std::ostream& output) {
    for (const slamcore::Decision& decision : decisions) {
      nlohmann::json line = {{"time", decision.time},
                             {"kind", slamcore::DecisionKindName(decision.kind)},
                             {"node", decision.node},
                             {"view", decision.view},
                             {"reason", decision.reason}};
      if (decision.hypothesis >= 0) line["hypothesis"] = decision.hypothesis;
      if (decision.hypothesis_kind)
        line["hypothesis_kind"] = slamcore::HypothesisKindName(*decision.hypothesis_kind);
      output << line.dump() << "\n";
    }
  });
}

nlohmann::json PairsToJson(const std::vector<slamcore::VertexPair>& pairs) {
  nlohmann::json array = nlohmann::json::array();
  for (const auto& [from, to] : pairs) array.push_back({from, to});
  return array;
}

int RunReplay(const ReplayArguments& arguments) {
  const auto graph = slamcore::ReadPoseGraph(arguments.input);
  if (!graph.ok()) return Fail(graph.status());
  slamcore::MapperParams params;
  if (!arguments.params_file.empty()) {
    const auto loaded = analyzer::ReadMapperParamsFile(arguments.params_file);
    if (!loaded.ok()) return Fail(loaded.status());
    params = *loaded;
  }
  params.backend =
      arguments.backend == "batch" ? slamcore::MapperBackend::kBatch : slamcore::MapperBackend::kIncremental;
  const auto result = slamcore::ReplayPoseGraph(*graph, params);
  if (!result.ok()) return Fail(result.status());
  if (!arguments.decisions_file.empty()) {
    if (const slamcore::Status status = WriteDecisions(result->decisions, arguments.decisions_file);
        !status.ok())
      return Fail(status);
  }
  const slamcore::MapperStatistics& stats = result->statistics;
  if (arguments.json) {
    const nlohmann::json report = {
        {"file", arguments.input},
        {"accepted", PairsToJson(result->accepted)},
        {"rejected", PairsToJson(result->rejected)},
        {"final_chi2", result->final_chi2},
        {"mapper_chi2", result->mapper_chi2},
        {"backend", arguments.backend},
        {"seconds", result->seconds},
        {"direct_edges", stats.direct_edges},
        {"recovery_hypotheses", stats.recovery_created},
        {"recovery_accepted", stats.recovery_accepted},
        {"views_marked_ambiguous", stats.views_marked_ambiguous},
        {"recovery_retracted", stats.recovery_retracted},
        {"consistent_set_checks",
         {{"judged", result->consistent_set_checks.judged},
          {"settled_by_status_quo", result->consistent_set_checks.settled_by_status_quo},
          {"status_quo_below_gnc", result->consistent_set_checks.status_quo_below_gnc}}},
    };
    std::cout << report.dump() << "\n";
  } else {
    std::printf("%s: %zu loop closures accepted, %zu rejected\n", arguments.input.c_str(),
                result->accepted.size(), result->rejected.size());
    std::printf(
        "direct edges %d, recovery hypotheses %d (accepted %d, expired %d, rejected %d), ambiguous views "
        "%d\n",
        stats.direct_edges, stats.recovery_created, stats.recovery_accepted, stats.recovery_expired,
        stats.recovery_rejected, stats.views_marked_ambiguous);
    std::printf("final chi2 %.6g, %.3f s\n", result->final_chi2, result->seconds);
  }
  return 0;
}

struct CorruptArguments {
  std::string input;
  std::string output;
  std::string mode = "random";
  int count = 100;
  double fraction = 0.0;
  int group = 1;
  int max_group = 0;
  double single_fraction = 0.0;
  std::uint64_t seed = 1;
};

int RunCorrupt(const CorruptArguments& arguments) {
  const auto graph = slamcore::ReadPoseGraph(arguments.input);
  if (!graph.ok()) return Fail(graph.status());
  slamcore::OutlierOptions options;
  const auto mode = slamcore::ParseOutlierMode(arguments.mode);
  if (!mode.ok()) return Fail(mode.status());
  options.mode = *mode;
  options.count = arguments.count;
  if (arguments.fraction > 0) {
    options.total_edges =
        std::max(1, static_cast<int>(std::lround(arguments.fraction * slamcore::CountLoopClosures(*graph))));
  }
  options.group_size = arguments.group;
  options.max_group_size = arguments.max_group;
  options.single_fraction = arguments.single_fraction;
  options.seed = arguments.seed;
  const auto corrupted = slamcore::AddLoopClosureOutliers(*graph, options);
  if (!corrupted.ok()) return Fail(corrupted.status());
  if (const auto status =
          slamcore::WritePoseGraph(corrupted->graph, arguments.output, slamcore::GraphFormat::kG2o);
      !status.ok()) {
    return Fail(status);
  }
  const auto agreeing =
      std::count(corrupted->agrees_with_optimum.begin(), corrupted->agrees_with_optimum.end(), true);
  std::printf(
      "%zu wrong loop closures appended (%td of them agree with the input's optimum, chi2 <= %.2f: not "
      "wrong after all); written to %s\n",
      corrupted->outliers.size(), agreeing, slamcore::kAgreesWithOptimumChi2, arguments.output.c_str());
  return 0;
}

struct GenerateArguments {
  std::string output;
  std::string truth;  // default: OUT's stem + "_groundtruth.txt" beside it
  slamcore::ManhattanOptions options;
};

int RunGenerate(GenerateArguments arguments) {
  const auto world = slamcore::GenerateManhattanWorld(arguments.options);
  if (!world.ok()) return Fail(world.status());
  if (arguments.truth.empty()) {
    std::filesystem::path truth = arguments.output;
    arguments.truth = truth.replace_extension().string() + "_groundtruth.txt";
  }
  if (const auto status =
          slamcore::WritePoseGraph(world->graph, arguments.output, slamcore::GraphFormat::kG2o);
      !status.ok()) {
    return Fail(status);
  }
  if (const auto status = slamcore::WriteGroundTruth(world->truth, arguments.truth); !status.ok())
    return Fail(status);
  std::printf("%zu poses, %d loop closures; graph %s, ground truth %s\n", world->graph.num_nodes(),
              slamcore::CountLoopClosures(world->graph), arguments.output.c_str(), arguments.truth.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"slamtool: offline operations of the shared SLAM core on files"};
  app.require_subcommand(1);

  OptimizeArguments optimize;
  CLI::App* optimize_command = app.add_subcommand("optimize", "optimise a g2o or TORO pose graph");
  optimize_command->add_option("FILE", optimize.input, "g2o or TORO file")
      ->required()
      ->check(CLI::ExistingFile);
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

  ReplayArguments replay;
  CLI::App* replay_command = app.add_subcommand(
      "replay-g2o", "replay a g2o graph through the Mapper online, as a robot would see it");
  replay_command->add_option("FILE", replay.input, "g2o or TORO file")->required()->check(CLI::ExistingFile);
  replay_command
      ->add_option("--params", replay.params_file, "Mapper parameter set (JSON, fleet.v1.ParameterSet)")
      ->check(CLI::ExistingFile);
  replay_command->add_flag("--json", replay.json, "print one JSON object on stdout");
  replay_command->add_option(
      "--decisions", replay.decisions_file,
      "write the Mapper's decision log here, one JSON object per line (kind, node, view, "
      "hypothesis, reason)");
  replay_command
      ->add_option(
          "--backend", replay.backend,
          "incremental (default: only the region an edge affects is re-solved) or batch (the baseline)")
      ->check(CLI::IsMember({"incremental", "batch"}));

  CorruptArguments corrupt;
  CLI::App* corrupt_command =
      app.add_subcommand("corrupt-g2o", "append seeded wrong loop closures (Vertigo protocol)");
  corrupt_command->add_option("FILE", corrupt.input, "g2o or TORO file")
      ->required()
      ->check(CLI::ExistingFile);
  corrupt_command->add_option("--out", corrupt.output, "output g2o file")->required();
  corrupt_command->add_option("--count", corrupt.count, "outlier groups")->check(CLI::NonNegativeNumber);
  corrupt_command
      ->add_option("--fraction", corrupt.fraction,
                   "write this many wrong edges per true loop closure of the file instead of --count groups")
      ->check(CLI::Range(0.0, 10.0));
  corrupt_command
      ->add_option("--group", corrupt.group, "consecutive pairs per group (the smallest with --max-group)")
      ->check(CLI::Range(1, 1000));
  corrupt_command
      ->add_option("--max-group", corrupt.max_group, "group sizes uniform in [--group, --max-group]")
      ->check(CLI::Range(0, 1000));
  corrupt_command
      ->add_option("--single-fraction", corrupt.single_fraction, "share of groups that are single outliers")
      ->check(CLI::Range(0.0, 1.0));
  corrupt_command
      ->add_option(
          "--mode", corrupt.mode,
          "random: anywhere; local: second end within 20 vertices; first: before the region's first true "
          "loop closure; shifted: a true loop closure's measurement 3-10 vertices away")
      ->check(CLI::IsMember({"random", "local", "first", "shifted"}));
  corrupt_command->add_option("--seed", corrupt.seed, "random seed");

  GenerateArguments generate;
  CLI::App* generate_command = app.add_subcommand(
      "generate-manhattan", "write a Manhattan-world pose graph (Olson's construction) and its ground truth");
  generate_command->add_option("OUT", generate.output, "output g2o file")->required();
  generate_command->add_option("--poses", generate.options.poses, "number of poses")
      ->required()
      ->check(CLI::Range(2, slamcore::kMaxManhattanPoses));
  generate_command->add_option("--seed", generate.options.seed, "random seed");
  generate_command->add_option("--truth", generate.truth, "ground-truth poses (id x y theta per line)");

  AddProtrusionCommands(app);
  AddValetudoCommands(app);

  CLI11_PARSE(app, argc, argv);
  if (optimize_command->parsed()) return RunOptimize(optimize);
  if (replay_command->parsed()) return RunReplay(replay);
  if (corrupt_command->parsed()) return RunCorrupt(corrupt);
  if (generate_command->parsed()) return RunGenerate(generate);
  return 2;
}
