// slamtool protrusion subcommands (see protrusion_commands.h): detection on a parent/child pair, the
// seeded data generator, training with ANOVA feature selection and a cross-validated choice of
// classifier, and held-out evaluation.
#include "protrusion_commands.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>

#include "sim/world.h"
#include "slamcore/protrusion_classifier.h"
#include "slamcore/protrusion_data.h"
#include "slamcore/protrusion_detector.h"

namespace {

using nlohmann::json;

/// Ends the command with an exit code (CLI11 turns RuntimeError(code) into the process's status).
[[noreturn]] void Exit(int code) { throw CLI::RuntimeError(code); }

[[noreturn]] void Fail(const slamcore::Status& status) {
  std::cerr << "slamtool: " << status.ToString() << "\n";
  Exit(1);
}

template <typename T>
T Check(slamcore::Result<T> result) {
  if (!result.ok()) Fail(result.status());
  return std::move(result).value();
}

std::set<std::string> SplitList(const std::string& list) {
  std::set<std::string> items;
  std::stringstream stream(list);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.insert(item);
  }
  return items;
}

// ---- protrusions -------------------------------------------------------------------------------------

struct DetectArguments {
  std::string parent, child, model, png, repair = "none", repaired;
  bool json = false;
};

/// `--model rule`: the geometric rule the paper's tree reduces to — a region nowhere wider than a robot
/// (max distance transform < 0.25 m) and elongated (> 3) is a protrusion. A named fallback only: it
/// knows nothing of stuck robots' bands (docs/protrusion-data.md).
double RuleProbability(const std::vector<double>& features) {
  const auto& names = slamcore::ProtrusionFeatureNames();
  auto value = [&](const char* name) {
    return features[static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin())];
  };
  return value("max_distance_m") < 0.25 && value("elongation") > 3.0 ? 1.0 : 0.0;
}

void RunDetect(const DetectArguments& arguments) {
  const auto parent = Check(slamcore::ReadMapServerYaml(arguments.parent));
  const auto child = Check(slamcore::ReadMapServerYaml(arguments.child));
  const auto aligned = Check(slamcore::AlignParentToChild(parent, child));
  const auto regions = Check(slamcore::ExtractRegions(parent, child));
  std::shared_ptr<const slamcore::ProtrusionClassifier> classifier;
  if (arguments.model.empty()) {
    classifier = Check(slamcore::DefaultProtrusionClassifier());
  } else if (arguments.model != "rule") {
    classifier = Check(slamcore::ProtrusionClassifier::Load(arguments.model));
  }
  std::vector<bool> is_protrusion;
  std::vector<double> probabilities;
  std::vector<const slamcore::ProtrusionRegion*> protrusions;
  for (const auto& region : regions) {
    const double probability =
        classifier ? Check(classifier->Probability(region.features)) : RuleProbability(region.features);
    const bool protrusion = classifier ? classifier->IsProtrusion(probability) : probability >= 0.5;
    probabilities.push_back(probability);
    is_protrusion.push_back(protrusion);
    if (protrusion) protrusions.push_back(&region);
  }
  if (!arguments.png.empty()) {
    const std::string png = Check(slamcore::RenderDetectionFigure(aligned, child, regions, is_protrusion));
    if (auto status = slamcore::WriteFileBytes(arguments.png, png); !status.ok()) Fail(status);
  }
  if (arguments.repair != "none") {
    if (arguments.repaired.empty()) Fail(slamcore::InvalidArgument("--repair needs --repaired OUT.yaml"));
    // The repaired map goes beside the inputs, never over them (the parent and child stay as they were).
    const auto same = [](const std::filesystem::path& a, const std::filesystem::path& b) {
      return std::filesystem::weakly_canonical(a) == std::filesystem::weakly_canonical(b);
    };
    const std::filesystem::path out = arguments.repaired;
    for (const std::string& input : {arguments.parent, arguments.child}) {
      for (const char* extension : {".yaml", ".pgm", ".png"}) {
        if (same(std::filesystem::path(out).replace_extension(extension),
                 std::filesystem::path(input).replace_extension(extension))) {
          Fail(slamcore::InvalidArgument("--repaired " + arguments.repaired + " would overwrite the input " +
                                         input + " (or its image); name another file"));
        }
      }
    }
    const auto mode =
        arguments.repair == "cut" ? slamcore::RepairMode::kCutOut : slamcore::RepairMode::kFallBackToParent;
    const auto repaired = slamcore::RepairChild(aligned, child, protrusions, mode);
    if (auto status = slamcore::WriteMapServerYaml(repaired, arguments.repaired); !status.ok()) Fail(status);
  }
  const auto& names = slamcore::ProtrusionFeatureNames();
  const std::string classifier_name =
      !classifier               ? std::string("rule")
      : arguments.model.empty() ? std::string("default ") + slamcore::ClassifierKindName(classifier->kind())
                                : std::string(slamcore::ClassifierKindName(classifier->kind()));
  if (arguments.json) {
    json items = json::array();
    for (std::size_t i = 0; i < regions.size(); ++i) {
      json features = json::object();
      for (std::size_t f = 0; f < names.size(); ++f) features[names[f]] = regions[i].features[f];
      const auto& box = regions[i].bbox;
      items.push_back({{"id", regions[i].id},
                       {"class", is_protrusion[i] ? "protrusion" : "new_space"},
                       {"probability", probabilities[i]},
                       {"bbox", {box.x, box.y, box.width, box.height}},
                       {"area_cells", regions[i].clean_area_cells},
                       {"features", features}});
    }
    const json report = {{"parent", arguments.parent},
                         {"child", arguments.child},
                         {"classifier", classifier_name},
                         {"width", child.width},
                         {"height", child.height},
                         {"resolution", child.resolution},
                         {"protrusions", protrusions.size()},
                         {"regions", items}};
    std::cout << report.dump() << "\n";
  } else {
    std::printf("%zu regions (%zu protrusions), classifier %s\n", regions.size(), protrusions.size(),
                classifier_name.c_str());
    for (std::size_t i = 0; i < regions.size(); ++i) {
      const auto& box = regions[i].bbox;
      std::printf("region %d: %-10s p=%.3f bbox [%d, %d, %d, %d]", regions[i].id,
                  is_protrusion[i] ? "protrusion" : "new_space", probabilities[i], box.x, box.y, box.width,
                  box.height);
      for (std::size_t f = 0; f < names.size(); ++f)
        std::printf(" %s=%.3g", names[f].c_str(), regions[i].features[f]);
      std::printf("\n");
    }
  }
  Exit(0);
}

// ---- make-protrusion-data ------------------------------------------------------------------------------

struct MakeDataArguments {
  std::vector<std::string> homes;
  std::string out, family = "physical";
  int variants = 40;
  std::uint64_t seed = 1;
};

/// A home as an occupancy grid: a map_server map as it is, a floor plan as fleetsim builds it (walls,
/// doors, fixtures and furniture; every room known).
slamcore::Result<slamcore::OccupancyGrid> LoadHome(const std::filesystem::path& path) {
  if (path.extension() == ".yaml") return slamcore::ReadMapServerYaml(path.string());
  ASSIGN_OR_RETURN(auto world, sim::LoadWorld(path, 1));
  const sim::Grid& grid = world.grid;
  ASSIGN_OR_RETURN(auto home, slamcore::OccupancyGrid::Create(grid.width(), grid.height(), grid.resolution(),
                                                              grid.origin().x(), grid.origin().y()));
  for (int row = 0; row < grid.height(); ++row) {
    for (int col = 0; col < grid.width(); ++col) {
      const sim::Cell cell = grid.at(col, row);
      home.at(col, row) =
          static_cast<std::int8_t>(cell == sim::Cell::kFree       ? slamcore::CellState::kFree
                                   : cell == sim::Cell::kOccupied ? slamcore::CellState::kOccupied
                                                                  : slamcore::CellState::kUnknown);
    }
  }
  return home;
}

void RunMakeData(const MakeDataArguments& arguments) {
  const auto options = Check(slamcore::GeneratorFamily(arguments.family));
  std::vector<std::filesystem::path> yamls;
  for (const auto& directory : arguments.homes) {
    for (const auto& entry : std::filesystem::directory_iterator(directory)) {
      if (entry.path().extension() == ".yaml" || entry.path().extension() == ".txt")
        yamls.push_back(entry.path());
    }
  }
  std::sort(yamls.begin(), yamls.end());
  if (yamls.empty())
    Fail(slamcore::NotFound("no map_server .yaml maps or floor-plan .txt files in the given directories"));
  if (std::filesystem::exists(std::filesystem::path(arguments.out) / "index.csv")) {
    Fail(slamcore::FailedPrecondition(arguments.out +
                                      "/index.csv exists; write a new data set to a new directory"));
  }
  int pairs = 0, protrusions = 0, new_spaces = 0;
  for (std::size_t m = 0; m < yamls.size(); ++m) {
    const auto map = Check(LoadHome(yamls[m]));
    const std::string map_id = yamls[m].stem().string();
    for (int variant = 0; variant < arguments.variants; ++variant) {
      // One seed per (data set seed, map, variant): any pair can be regenerated alone.
      const std::uint64_t seed =
          arguments.seed * 1000003ULL + m * 10007ULL + static_cast<std::uint64_t>(variant);
      const auto pair = Check(slamcore::GeneratePair(map, seed, options));
      const slamcore::DatasetEntry entry{map_id + "_v" + std::to_string(variant), map_id,
                                         slamcore::HomeOfRealMap(map_id), arguments.family};
      if (auto status = slamcore::WriteDatasetPair(arguments.out, entry, pair); !status.ok()) Fail(status);
      ++pairs;
      protrusions += pair.protrusions;
      new_spaces += pair.new_spaces;
    }
  }
  std::printf("%d pairs from %zu maps: %d protrusions, %d new spaces -> %s\n", pairs, yamls.size(),
              protrusions, new_spaces, arguments.out.c_str());
  Exit(0);
}

// ---- shared by train and eval ---------------------------------------------------------------------------

struct LoadedPair {
  slamcore::DatasetEntry entry;
  slamcore::LabelledPair labelled;
};

std::vector<LoadedPair> LoadData(const std::vector<std::string>& roots) {
  std::vector<LoadedPair> pairs;
  for (const std::string& root : roots) {
    for (const auto& entry : Check(slamcore::ReadDatasetIndex(root))) {
      const auto pair = Check(slamcore::ReadDatasetPair(root, entry));
      pairs.push_back({entry, Check(slamcore::ExtractAndLabel(pair))});
    }
  }
  return pairs;
}

std::vector<slamcore::LabelledRegion> Regions(const std::vector<LoadedPair>& pairs) {
  std::vector<slamcore::LabelledRegion> regions;
  for (const auto& pair : pairs) {
    for (std::size_t i = 0; i < pair.labelled.regions.size(); ++i) {
      regions.push_back({pair.entry.home_id, pair.labelled.regions[i].features, pair.labelled.labels[i]});
    }
  }
  return regions;
}

std::vector<slamcore::FeatureAnova> Anova(const std::vector<slamcore::LabelledRegion>& regions) {
  std::vector<std::vector<double>> features;
  std::vector<int> labels;
  for (const auto& region : regions) {
    features.push_back(region.features);
    labels.push_back(region.label);
  }
  return Check(slamcore::AnovaFValues(features, labels));
}

/// Paper IV-C: keep the features whose ANOVA p-value is below 0.05, among `allowed` (names; empty: all).
std::vector<int> SelectFeatures(const std::vector<slamcore::FeatureAnova>& anova,
                                const std::set<std::string>& allowed = {}) {
  for (const std::string& name : allowed) {
    const auto& names = slamcore::ProtrusionFeatureNames();
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      Fail(slamcore::InvalidArgument("--features: unknown feature \"" + name + "\""));
    }
  }
  std::vector<int> selected;
  for (std::size_t i = 0; i < anova.size(); ++i) {
    if (anova[i].p_value < 0.05 && (allowed.empty() || allowed.contains(anova[i].name)))
      selected.push_back(static_cast<int>(i));
  }
  return selected;
}

json ConfusionJson(const slamcore::ConfusionMatrix& confusion) {
  return {{"true_positives", confusion.true_positives},
          {"false_positives", confusion.false_positives},
          {"true_negatives", confusion.true_negatives},
          {"false_negatives", confusion.false_negatives},
          {"precision", confusion.Precision()},
          {"recall", confusion.Recall()},
          {"false_positive_rate", confusion.FalsePositiveRate()},
          {"accuracy", confusion.Accuracy()}};
}

void PrintConfusion(const slamcore::ConfusionMatrix& confusion) {
  std::printf("                     predicted protrusion  predicted new space\n");
  std::printf("  true protrusion    %20ld  %19ld\n", confusion.true_positives, confusion.false_negatives);
  std::printf("  true new space     %20ld  %19ld\n", confusion.false_positives, confusion.true_negatives);
  std::printf("  precision %.4f%%  recall %.4f%%  false-positive rate %.4f%%\n", 100 * confusion.Precision(),
              100 * confusion.Recall(), 100 * confusion.FalsePositiveRate());
}

json AnovaJson(const std::vector<slamcore::FeatureAnova>& anova, const std::vector<int>& selected) {
  json features = json::array();
  for (std::size_t i = 0; i < anova.size(); ++i) {
    const bool used = std::find(selected.begin(), selected.end(), static_cast<int>(i)) != selected.end();
    features.push_back({{"name", anova[i].name},
                        {"f_value", anova[i].f_value},
                        {"p_value", anova[i].p_value},
                        {"selected", used}});
  }
  return features;
}

void PrintAnova(const std::vector<slamcore::FeatureAnova>& anova, const std::vector<int>& selected) {
  std::printf("%-22s %14s %12s %s\n", "feature", "F", "p", "selected");
  for (std::size_t i = 0; i < anova.size(); ++i) {
    const bool used = std::find(selected.begin(), selected.end(), static_cast<int>(i)) != selected.end();
    std::printf("%-22s %14.2f %12.3g %s\n", anova[i].name.c_str(), anova[i].f_value, anova[i].p_value,
                used ? "yes" : "");
  }
}

// ---- train-protrusions ---------------------------------------------------------------------------------

struct TrainArguments {
  std::vector<std::string> data;
  std::string out, classifier = "auto", holdout_homes, features;
  int folds = 5;
  int trees = 100, max_depth = 10;
  double threshold = 0.5;
  bool json = false;
};

/// Precision first (a false protrusion cuts real space out of a home's map), then recall.
double Score(const slamcore::ConfusionMatrix& confusion) {
  const bool meets = confusion.Precision() >= 0.996 && confusion.Recall() >= 0.95;
  return (meets ? 10.0 : 0.0) + 2.0 * confusion.Precision() + confusion.Recall();
}

void RunTrain(const TrainArguments& arguments) {
  const std::set<std::string> holdout = SplitList(arguments.holdout_homes);
  std::vector<LoadedPair> pairs;
  for (auto& pair : LoadData(arguments.data)) {
    if (!holdout.contains(pair.entry.home_id)) pairs.push_back(std::move(pair));
  }
  const auto regions = Regions(pairs);
  std::set<std::string> homes;
  for (const auto& region : regions) homes.insert(region.group);
  const auto anova = Anova(regions);
  slamcore::ClassifierOptions options;
  options.selected_features = SelectFeatures(anova, SplitList(arguments.features));
  options.trees = arguments.trees;
  options.max_depth = arguments.max_depth;
  options.threshold = arguments.threshold;
  const int folds = std::min<int>(arguments.folds, static_cast<int>(homes.size()));
  json comparison = json::array();
  std::vector<slamcore::ClassifierKind> kinds;
  if (arguments.classifier == "auto") {
    kinds = {slamcore::ClassifierKind::kDecisionTree, slamcore::ClassifierKind::kRandomForest,
             slamcore::ClassifierKind::kSvm};
  } else {
    kinds = {Check(slamcore::ParseClassifierKind(arguments.classifier))};
  }
  double best_score = -1.0;
  slamcore::ClassifierKind best_kind = kinds.front();
  for (const auto kind : kinds) {
    if (kinds.size() == 1) break;
    options.kind = kind;
    const auto result = Check(slamcore::CrossValidate(regions, options, folds));
    comparison.push_back({{"classifier", slamcore::ClassifierKindName(kind)},
                          {"folds", folds},
                          {"confusion", ConfusionJson(result.confusion)}});
    if (!arguments.json) {
      std::printf("%d-fold cross-validation by home, %s:\n", folds, slamcore::ClassifierKindName(kind));
      PrintConfusion(result.confusion);
    }
    if (Score(result.confusion) > best_score) {
      best_score = Score(result.confusion);
      best_kind = kind;
    }
  }
  options.kind = best_kind;
  const auto classifier = Check(slamcore::ProtrusionClassifier::Train(regions, options));
  if (auto status = classifier->Save(arguments.out); !status.ok()) Fail(status);
  if (arguments.json) {
    std::cout << json{{"model", arguments.out},
                      {"classifier", slamcore::ClassifierKindName(options.kind)},
                      {"pairs", pairs.size()},
                      {"regions", regions.size()},
                      {"homes", homes},
                      {"features", AnovaJson(anova, options.selected_features)},
                      {"cross_validation", comparison}}
                     .dump()
              << "\n";
  } else {
    PrintAnova(anova, options.selected_features);
    std::printf("trained %s on %zu regions from %zu pairs of %zu homes -> %s\n",
                slamcore::ClassifierKindName(options.kind), regions.size(), pairs.size(), homes.size(),
                arguments.out.c_str());
  }
  Exit(0);
}

// ---- eval-protrusions ----------------------------------------------------------------------------------

struct EvalArguments {
  std::vector<std::string> data, test_data;
  std::string model, homes, classifier = "random_forest", features;
  int trees = 100, max_depth = 10;
  double threshold = 0.5;
  bool leave_one_home_out = false;
  bool list_errors = false;
  bool list_regions = false;
  bool json = false;
};

/// Which regions Accumulate names on stderr, with their truth, probability and features.
enum class RegionListing : std::uint8_t { kNone, kErrors, kAll };

/// Like slamcore::AccumulateConfusion, and names the misclassified regions (or all) on stderr when asked.
void Accumulate(const slamcore::ProtrusionClassifier& classifier, const LoadedPair& pair,
                RegionListing listing, slamcore::ConfusionMatrix* confusion) {
  if (auto status = slamcore::AccumulateConfusion(classifier, pair.labelled, confusion); !status.ok())
    Fail(status);
  if (listing == RegionListing::kNone) return;
  const auto& names = slamcore::ProtrusionFeatureNames();
  for (std::size_t i = 0; i < pair.labelled.regions.size(); ++i) {
    const auto& region = pair.labelled.regions[i];
    const double probability = Check(classifier.Probability(region.features));
    if (listing == RegionListing::kErrors &&
        classifier.IsProtrusion(probability) == (pair.labelled.labels[i] == 1))
      continue;
    std::fprintf(stderr, "%s region %d truth %s p=%.3f bbox [%d, %d, %d, %d]", pair.entry.pair_id.c_str(),
                 region.id, pair.labelled.labels[i] == 1 ? "protrusion" : "new_space", probability,
                 region.bbox.x, region.bbox.y, region.bbox.width, region.bbox.height);
    for (std::size_t f = 0; f < names.size(); ++f)
      std::fprintf(stderr, " %s=%.3g", names[f].c_str(), region.features[f]);
    std::fprintf(stderr, "\n");
  }
  if (pair.labelled.missed_protrusions > 0) {
    std::fprintf(stderr, "%s: %d protrusions missed by segmentation\n", pair.entry.pair_id.c_str(),
                 pair.labelled.missed_protrusions);
  }
}

void RunEval(const EvalArguments& arguments) {
  if (arguments.model.empty() == !arguments.leave_one_home_out) {
    Fail(slamcore::InvalidArgument("give either --model MODEL or --leave-one-home-out"));
  }
  const std::set<std::string> only = SplitList(arguments.homes);
  // Training regions (leave one home out) come from DATA; test pairs from --test-data when given (another
  // generator family: nothing of it is ever trained on), else from DATA too.
  std::vector<LoadedPair> training = LoadData(arguments.data);
  std::vector<LoadedPair> pairs;
  for (auto& pair : arguments.test_data.empty() ? training : LoadData(arguments.test_data)) {
    if (only.empty() || only.contains(pair.entry.home_id)) pairs.push_back(pair);
  }
  if (pairs.empty()) Fail(slamcore::InvalidArgument("no pairs to evaluate (check --homes)"));
  const RegionListing listing = arguments.list_regions  ? RegionListing::kAll
                                : arguments.list_errors ? RegionListing::kErrors
                                                        : RegionListing::kNone;
  slamcore::ConfusionMatrix confusion;
  int missed = 0, spurious = 0;
  for (const auto& pair : pairs) {
    missed += pair.labelled.missed_protrusions;
    spurious += pair.labelled.spurious_regions;
  }
  const auto all_regions = Regions(pairs);
  const auto anova = Anova(all_regions);
  std::vector<int> selected;
  std::string classifier_name;
  if (!arguments.model.empty()) {
    const auto classifier = arguments.model == "default"
                                ? Check(slamcore::DefaultProtrusionClassifier())
                                : std::shared_ptr<const slamcore::ProtrusionClassifier>(
                                      Check(slamcore::ProtrusionClassifier::Load(arguments.model)));
    selected = classifier->selected_features();
    classifier_name = slamcore::ClassifierKindName(classifier->kind());
    for (const auto& pair : pairs) Accumulate(*classifier, pair, listing, &confusion);
  } else {
    // Leave one home out: per home, ANOVA selection and training on every other home, test on it.
    slamcore::ClassifierOptions options;
    options.kind = Check(slamcore::ParseClassifierKind(arguments.classifier));
    options.trees = arguments.trees;
    options.max_depth = arguments.max_depth;
    options.threshold = arguments.threshold;
    classifier_name = arguments.classifier;
    std::set<std::string> homes;
    for (const auto& pair : pairs) homes.insert(pair.entry.home_id);
    const auto training_regions = Regions(training);
    for (const std::string& home : homes) {
      std::vector<slamcore::LabelledRegion> train;
      for (const auto& region : training_regions) {
        if (region.group != home) train.push_back(region);
      }
      if (train.empty()) {
        Fail(slamcore::InvalidArgument("leave one home out: no region of any home but " + home +
                                       " to train on; the training data need at least two homes"));
      }
      options.selected_features = SelectFeatures(Anova(train), SplitList(arguments.features));
      const auto classifier = Check(slamcore::ProtrusionClassifier::Train(train, options));
      for (const auto& pair : pairs) {
        if (pair.entry.home_id == home) Accumulate(*classifier, pair, listing, &confusion);
      }
    }
    selected = SelectFeatures(anova);
  }
  if (arguments.json) {
    std::cout << json{{"classifier", classifier_name},
                      {"mode", arguments.leave_one_home_out ? "leave_one_home_out" : "model"},
                      {"pairs", pairs.size()},
                      {"regions", all_regions.size()},
                      {"missed_by_segmentation", missed},
                      {"spurious_regions", spurious},
                      {"confusion", ConfusionJson(confusion)},
                      {"features", AnovaJson(anova, selected)}}
                     .dump()
              << "\n";
  } else {
    std::printf(
        "%zu pairs, %zu regions, %d protrusions missed by segmentation (counted as false negatives), "
        "%d regions of noise; classifier %s (%s)\n",
        pairs.size(), all_regions.size(), missed, spurious, classifier_name.c_str(),
        arguments.leave_one_home_out ? "leave one home out" : arguments.model.c_str());
    PrintConfusion(confusion);
    PrintAnova(anova, selected);
  }
  Exit(0);
}

}  // namespace

void AddProtrusionCommands(CLI::App& app) {
  auto detect = std::make_shared<DetectArguments>();
  CLI::App* detect_command =
      app.add_subcommand("protrusions", "detect erroneous protrusions between two maps (IV-C)");
  detect_command->add_option("--parent", detect->parent, "parent map (map_server YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  detect_command->add_option("--child", detect->child, "child map (map_server YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  detect_command
      ->add_option("--model", detect->model,
                   "classifier model file (train-protrusions), or 'rule'; default: the built-in model")
      ->check(CLI::ExistingFile | CLI::IsMember({"rule"}));
  detect_command->add_flag("--json", detect->json, "print one JSON object on stdout");
  detect_command->add_option("--png", detect->png,
                             "write the Fig. 5 picture (parent, child, difference, classes)");
  detect_command
      ->add_option("--repair", detect->repair, "none, cut (cut protrusions out) or parent (fall back)")
      ->check(CLI::IsMember({"none", "cut", "parent"}));
  detect_command->add_option("--repaired", detect->repaired, "where --repair writes the map (YAML + PGM)");
  detect_command->callback([detect] { RunDetect(*detect); });

  auto make = std::make_shared<MakeDataArguments>();
  CLI::App* make_command = app.add_subcommand("make-protrusion-data",
                                              "generate labelled parent/child pairs from real maps (seeded)");
  make_command
      ->add_option("HOMES", make->homes, "directories of map_server YAML maps and/or floor plans (.txt)")
      ->required()
      ->check(CLI::ExistingDirectory);
  make_command
      ->add_option("--family", make->family,
                   "generator family: physical (default), heldout, misregistered (heldout, the child one or "
                   "two cells off the parent), corridor")
      ->check(CLI::IsMember({"physical", "heldout", "misregistered", "corridor"}));
  make_command->add_option("--out", make->out, "output data set directory")->required();
  make_command->add_option("--variants", make->variants, "pairs per map")->check(CLI::Range(1, 100000));
  make_command->add_option("--seed", make->seed, "data set seed");
  make_command->callback([make] { RunMakeData(*make); });

  auto train = std::make_shared<TrainArguments>();
  CLI::App* train_command =
      app.add_subcommand("train-protrusions", "train the protrusion classifier on a data set");
  train_command->add_option("DATA", train->data, "data set directories")
      ->required()
      ->check(CLI::ExistingDirectory);
  train_command->add_option("--out", train->out, "model file to write")->required();
  train_command
      ->add_option("--classifier", train->classifier, "auto (compare by cross-validation) or one kind")
      ->check(CLI::IsMember({"auto", "decision_tree", "random_forest", "svm"}));
  train_command->add_option("--holdout-homes", train->holdout_homes,
                            "comma-separated homes kept out of training");
  train_command->add_option("--folds", train->folds, "cross-validation folds (by home)")
      ->check(CLI::Range(2, 100));
  train_command->add_option("--features", train->features,
                            "comma-separated features the model may use (default: all)");
  train_command->add_option("--trees", train->trees, "random forest: trees")->check(CLI::Range(1, 1000));
  train_command->add_option("--max-depth", train->max_depth, "tree depth")->check(CLI::Range(1, 30));
  train_command->add_option("--threshold", train->threshold, "P(protrusion) above which a region is one")
      ->check(CLI::Range(0.01, 0.99));
  train_command->add_flag("--json", train->json, "print one JSON object on stdout");
  train_command->callback([train] { RunTrain(*train); });

  auto eval = std::make_shared<EvalArguments>();
  CLI::App* eval_command =
      app.add_subcommand("eval-protrusions", "evaluate a protrusion classifier on a data set");
  eval_command->add_option("DATA", eval->data, "data set directories")
      ->required()
      ->check(CLI::ExistingDirectory);
  eval_command->add_option("--model", eval->model, "model file, or 'default' (the built-in model)")
      ->check(CLI::ExistingFile | CLI::IsMember({"default"}));
  eval_command
      ->add_option("--test-data", eval->test_data,
                   "with --leave-one-home-out: test on this data set's pairs of the left-out home")
      ->check(CLI::ExistingDirectory);
  eval_command->add_option("--homes", eval->homes, "comma-separated homes to evaluate on (default: all)");
  eval_command->add_flag("--leave-one-home-out", eval->leave_one_home_out,
                         "train on all other homes, per home");
  eval_command->add_option("--classifier", eval->classifier, "kind for --leave-one-home-out")
      ->check(CLI::IsMember({"decision_tree", "random_forest", "svm"}));
  eval_command->add_option("--features", eval->features,
                           "with --leave-one-home-out: features the models may use");
  eval_command->add_option("--trees", eval->trees, "with --leave-one-home-out: random forest trees")
      ->check(CLI::Range(1, 1000));
  eval_command->add_option("--max-depth", eval->max_depth, "with --leave-one-home-out: tree depth")
      ->check(CLI::Range(1, 30));
  eval_command->add_option("--threshold", eval->threshold, "with --leave-one-home-out: decision threshold")
      ->check(CLI::Range(0.01, 0.99));
  eval_command->add_flag("--json", eval->json, "print one JSON object on stdout");
  auto* list_errors = eval_command->add_flag("--list-errors", eval->list_errors,
                                             "print every misclassified region to stderr");
  eval_command
      ->add_flag("--list-regions", eval->list_regions,
                 "print every region to stderr (its truth, P(protrusion), bounding box and features)")
      ->excludes(list_errors);
  eval_command->callback([eval] { RunEval(*eval); });
}
