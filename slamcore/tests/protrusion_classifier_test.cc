// The protrusion classifier and its data (paper IV-C): the seeded generator, the data set on disk, model
// files that refuse mismatches, and the held-out accuracy on real maps the model never saw.
#include "slamcore/protrusion_classifier.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "slamcore/protrusion_data.h"
#include "test_data.h"
#include "status_matchers.h"

namespace slamcore {
namespace {

const std::filesystem::path kMaps = test_data::Sample() / "maps";

struct RealMap {
  std::string id;
  OccupancyGrid grid;
};

/// Every map of `folder`, sorted by name.
std::vector<RealMap> ReadRealMaps(const std::filesystem::path& folder) {
  std::vector<RealMap> maps;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() != ".yaml") continue;
    auto grid = ReadMapServerYaml(entry.path().string());
    EXPECT_THAT(grid, IsOk());
    if (grid.ok()) maps.push_back({entry.path().stem().string(), std::move(*grid)});
  }
  std::sort(maps.begin(), maps.end(), [](const RealMap& a, const RealMap& b) { return a.id < b.id; });
  return maps;
}

std::filesystem::path TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("slamcore_protrusion_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(ProtrusionData, GeneratorIsSeededAndLabelsBothClasses) {
  auto map = ReadMapServerYaml((kMaps / "aws_small_house.yaml").string());
  ASSERT_THAT(map, IsOk());
  GeneratorOptions options;
  options.min_protrusions = 1;
  auto first = GeneratePair(*map, 42, options);
  auto again = GeneratePair(*map, 42, options);
  auto other = GeneratePair(*map, 43, options);
  ASSERT_THAT(first, IsOk());
  ASSERT_THAT(again, IsOk());
  ASSERT_THAT(other, IsOk());
  EXPECT_EQ(first->child.cells, again->child.cells);
  EXPECT_EQ(first->parent.cells, again->parent.cells);
  EXPECT_NE(first->child.cells, other->child.cells);
  EXPECT_GE(first->protrusions, 1);
  EXPECT_GE(first->new_spaces, 1);
  EXPECT_TRUE(std::count(first->truth.begin(), first->truth.end(), 1) > 0);
  EXPECT_TRUE(std::count(first->truth.begin(), first->truth.end(), 2) > 0);
  // The parent is cropped to its known cells: another size and origin than the child, on the same grid.
  EXPECT_NE(first->parent.width, first->child.width);
  auto labelled = ExtractAndLabel(*first);
  ASSERT_THAT(labelled, IsOk());
  EXPECT_EQ(std::count(labelled->labels.begin(), labelled->labels.end(), 1), first->protrusions);
  EXPECT_EQ(labelled->missed_protrusions, 0);
  EXPECT_FALSE(GeneratePair(OccupancyGrid{}, 1).ok());
  // A resolution in the wrong unit made the stuck robot's reach billions of cells (and the padding wrap).
  OccupancyGrid micro = *map;
  micro.resolution = 1e-9;
  auto refused = GeneratePair(micro, 1, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("finer than"), std::string::npos) << refused.status().ToString();
  micro.resolution = 0.001;  // accepted by the detector, but a 20 m reach is 20,000 cells beyond each edge
  refused = GeneratePair(micro, 1, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("larger than a map may be"), std::string::npos)
      << refused.status().ToString();
}

TEST(ProtrusionData, DatasetRoundTripsAndRefusesBrokenIndexes) {
  auto map = ReadMapServerYaml((kMaps / "valetudo_roborock_S5_FW2008_with_segments.yaml").string());
  ASSERT_THAT(map, IsOk());
  auto pair = GeneratePair(*map, 7);
  ASSERT_THAT(pair, IsOk());
  const auto dir = TempDir("dataset");
  const DatasetEntry entry{"s5_v7", "valetudo_roborock_S5_FW2008_with_segments",
                           "valetudo_roborock_S5_FW2008", "generator"};
  ASSERT_THAT(WriteDatasetPair(dir.string(), entry, *pair), IsOk());
  auto entries = ReadDatasetIndex(dir.string());
  ASSERT_THAT(entries, IsOk());
  ASSERT_EQ(entries->size(), 1u);
  EXPECT_EQ((*entries)[0].home_id, entry.home_id);
  auto back = ReadDatasetPair(dir.string(), (*entries)[0]);
  ASSERT_THAT(back, IsOk());
  EXPECT_EQ(back->child.cells, pair->child.cells);
  EXPECT_EQ(back->parent.cells, pair->parent.cells);
  EXPECT_EQ(back->truth, pair->truth);
  EXPECT_FALSE(WriteDatasetPair(dir.string(), {"../evil", "m", "h", "g"}, *pair).ok());
  std::ofstream(dir / "index.csv") << "wrong,header\n";
  EXPECT_FALSE(ReadDatasetIndex(dir.string()).ok());
  std::filesystem::remove_all(dir);
}

/// Regions of `variants` generated pairs per real map, grouped by home.
std::vector<LabelledRegion> Regions(const std::vector<RealMap>& maps, int variants,
                                    std::map<std::string, int>* missed) {
  std::vector<LabelledRegion> regions;
  for (std::size_t m = 0; m < maps.size(); ++m) {
    for (int variant = 0; variant < variants; ++variant) {
      auto pair =
          GeneratePair(maps[m].grid, 1000003ULL * 7 + m * 10007ULL + static_cast<std::uint64_t>(variant));
      EXPECT_THAT(pair, IsOk());
      if (!pair.ok()) continue;
      auto labelled = ExtractAndLabel(*pair);
      EXPECT_THAT(labelled, IsOk());
      if (!labelled.ok()) continue;
      const std::string home = HomeOfRealMap(maps[m].id);
      for (std::size_t i = 0; i < labelled->regions.size(); ++i) {
        regions.push_back({home, labelled->regions[i].features, labelled->labels[i]});
      }
      if (missed) (*missed)[home] += labelled->missed_protrusions;
    }
  }
  return regions;
}

TEST(ProtrusionClassifier, SavesLoadsAndRefusesMismatchedModels) {
  const std::vector<RealMap> maps = ReadRealMaps(kMaps);
  const std::vector<RealMap> two(maps.begin(), maps.begin() + 2);
  const auto regions = Regions(two, 6, nullptr);
  const auto dir = TempDir("model");
  for (const ClassifierKind kind :
       {ClassifierKind::kDecisionTree, ClassifierKind::kRandomForest, ClassifierKind::kSvm}) {
    SCOPED_TRACE(ClassifierKindName(kind));
    ClassifierOptions options;
    options.kind = kind;
    options.selected_features = {5, 6, 7, 12};
    auto trained = ProtrusionClassifier::Train(regions, options);
    ASSERT_THAT(trained, IsOk());
    const std::string path = (dir / "model.yml").string();
    ASSERT_THAT((*trained)->Save(path), IsOk());
    auto loaded = ProtrusionClassifier::Load(path);
    ASSERT_THAT(loaded, IsOk());
    EXPECT_EQ((*loaded)->selected_features(), options.selected_features);
    for (const LabelledRegion& region : regions) {
      EXPECT_DOUBLE_EQ(*(*loaded)->Probability(region.features), *(*trained)->Probability(region.features));
    }
    EXPECT_FALSE((*loaded)->Probability({1.0, 2.0}).ok());
  }
  // A model from a build with another feature list, or another version, is refused by name.
  auto saved = ReadFileBytes((dir / "model.yml").string());
  ASSERT_THAT(saved, IsOk());
  const std::string text = *saved;
  auto write_and_load = [&](const std::string& contents) {
    std::ofstream(dir / "bad.yml") << contents;
    return ProtrusionClassifier::Load((dir / "bad.yml").string());
  };
  std::string renamed = text;
  renamed.replace(renamed.find("wall_fraction"), 13, "wall_fractiom");
  auto refused = write_and_load(renamed);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("different feature list"), std::string::npos)
      << refused.status().ToString();
  std::string versioned = text;
  versioned.replace(versioned.find("version: 1"), 10, "version: 9");
  refused = write_and_load(versioned);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("version 9"), std::string::npos) << refused.status().ToString();
  EXPECT_FALSE(write_and_load("%YAML:1.0\n---\nformat: something-else\n").ok());
  EXPECT_FALSE(write_and_load("\x01\x02 not yaml [[[").ok());
  EXPECT_FALSE(write_and_load(text.substr(0, text.size() / 2)).ok());
  EXPECT_EQ(ProtrusionClassifier::Load((dir / "missing.yml").string()).status().code(),
            StatusCode::kNotFound);
  std::filesystem::remove_all(dir);
}

// A model file is read by OpenCV, whose tree predictions follow the file's indices as they are and whose
// YAML parser recurses per level: what could crash it is refused first, by name.
TEST(ProtrusionClassifier, RefusesModelFilesThatWouldCrashThePrediction) {
  const std::vector<RealMap> maps = ReadRealMaps(kMaps);
  const auto regions = Regions({maps.begin(), maps.begin() + 2}, 6, nullptr);
  ClassifierOptions options;
  options.kind = ClassifierKind::kRandomForest;
  options.selected_features = {5, 6, 7, 12};
  auto trained = ProtrusionClassifier::Train(regions, options);
  ASSERT_THAT(trained, IsOk());
  auto bytes = (*trained)->ToBytes();
  ASSERT_THAT(bytes, IsOk());
  ASSERT_THAT(ProtrusionClassifier::LoadFromBytes(*bytes), IsOk());
  const auto refusal = [](const std::string& text) {
    const auto loaded = ProtrusionClassifier::LoadFromBytes(text);
    return loaded.ok() ? std::string("loaded") : loaded.status().message();
  };
  const auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = *bytes;
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? text : text.replace(at, from.size(), to);
  };
  EXPECT_NE(refusal(replaced("class_labels: [ 0, 1 ]", "class_labels: [ ]")).find("class labels"),
            std::string::npos);
  EXPECT_NE(refusal(replaced("var_type: [ 0,", "var_type: [ 1,")).find("variable types"), std::string::npos);
  std::string not_a_number = *bytes;
  const std::size_t first_mean = not_a_number.find("mean: [ ") + 8;
  not_a_number.replace(first_mean, not_a_number.find(',', first_mean) - first_mean, ".Nan");
  EXPECT_NE(refusal(not_a_number).find("not finite"), std::string::npos);
  // 50,000 levels of flow sequences overflowed the parser's stack; "- - - …" nests as deep in two bytes a level.
  const std::string deep =
      "%YAML:1.0\n---\nformat: " + std::string(50'000, '[') + std::string(50'000, ']') + "\n";
  EXPECT_NE(refusal(deep).find("levels deep"), std::string::npos);
  std::string dashes = "%YAML:1.0\n---\nformat:\n";
  for (int level = 0; level < 20'000; ++level) dashes += "- ";
  EXPECT_NE(refusal(dashes + "x\n").find("levels deep"), std::string::npos);
  EXPECT_NE(refusal(std::string(kMaxModelBytes + 1, ' ')).find("more than a model file may be"),
            std::string::npos);
}

// The acceptance test of IV-C "done better than the paper": every home (and so every real map) is held out
// once; the model never sees the home it is tested on. Targets: precision ≥ 99.6 %, recall ≥ 95 %
// (paper: 99.58 %, 94.05 %). Protrusions the segmentation missed count as false negatives.
TEST(ProtrusionHeldOut, MeetsThePaperTargetsOnHeldOutHomes) {
  REQUIRE_LARGER_DATA_OR_SKIP("all 11 real maps of 10 homes (maps/) for leave-one-home-out");
  const std::vector<RealMap> maps = ReadRealMaps(*test_data::Larger() / "maps");
  ASSERT_EQ(maps.size(), 11u);
  std::map<std::string, int> missed;
  const auto regions = Regions(maps, 50, &missed);
  ClassifierOptions options;
  options.kind = ClassifierKind::kRandomForest;
  std::map<std::string, int> homes;
  for (const LabelledRegion& region : regions) ++homes[region.group];
  ASSERT_EQ(homes.size(), 10u);  // the two d9_1058 maps are one home
  auto result = CrossValidate(regions, options, static_cast<int>(homes.size()));
  ASSERT_THAT(result, IsOk());
  ConfusionMatrix confusion = result->confusion;
  for (const auto& [home, count] : missed) confusion.false_negatives += count;
  std::printf("held-out homes: TP %ld FP %ld TN %ld FN %ld precision %.4f recall %.4f FPR %.4f\n",
              confusion.true_positives, confusion.false_positives, confusion.true_negatives,
              confusion.false_negatives, confusion.Precision(), confusion.Recall(),
              confusion.FalsePositiveRate());
  EXPECT_GT(confusion.true_positives, 400);
  EXPECT_GE(confusion.Precision(), 0.996);
  EXPECT_GE(confusion.Recall(), 0.95);
}

}  // namespace
}  // namespace slamcore
