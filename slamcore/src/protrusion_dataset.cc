// The protrusion data set on disk (layout in protrusion_data.h and docs/protrusion-data.md), and the
// labelling of extracted regions against the ground truth.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "slamcore/protrusion_data.h"

namespace slamcore {
namespace {

constexpr const char* kIndexHeader = "pair_id,map_id,home_id,source";

bool ValidId(const std::string& id) {
  if (id.empty() || id.size() > 200) return false;
  for (const char c : id) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  }
  return id != "." && id != "..";
}

}  // namespace

Status WriteDatasetPair(const std::string& root, const DatasetEntry& entry, const GeneratedPair& pair) {
  for (const std::string* id : {&entry.pair_id, &entry.map_id, &entry.home_id, &entry.source}) {
    if (!ValidId(*id)) return InvalidArgument("data set: id '" + *id + "' must be [A-Za-z0-9_.-]+");
  }
  if (pair.truth.size() != pair.child.cells.size())
    return InvalidArgument("data set: truth does not match the child");
  const std::filesystem::path dir = std::filesystem::path(root) / "pairs" / entry.pair_id;
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) return NotFound(dir.string() + ": cannot create (" + error.message() + ")");
  // PNG images (map_server reads them too): the padded maps compress ~50× better than PGM.
  RETURN_IF_ERROR(WriteMapServerYaml(pair.parent, (dir / "parent.yaml").string(), /*png=*/true));
  RETURN_IF_ERROR(WriteMapServerYaml(pair.child, (dir / "child.yaml").string(), /*png=*/true));
  cv::Mat truth(pair.child.height, pair.child.width, CV_8U);
  for (int row = 0; row < pair.child.height; ++row) {
    const std::uint8_t* source = &pair.truth[static_cast<std::size_t>(row) * pair.child.width];
    std::copy(source, source + pair.child.width, truth.ptr<std::uint8_t>(pair.child.ImageRowOf(row)));
  }
  try {
    if (!cv::imwrite((dir / "truth.png").string(), truth))
      return Internal(dir.string() + "/truth.png: write failed");
  } catch (const cv::Exception& e) {
    return Internal(dir.string() + "/truth.png: " + e.what());
  }
  const std::filesystem::path index = std::filesystem::path(root) / "index.csv";
  const bool fresh = !std::filesystem::exists(index);
  std::ofstream out(index, std::ios::app);
  if (!out) return NotFound(index.string() + ": cannot open for appending");
  if (fresh) out << kIndexHeader << "\n";
  out << entry.pair_id << "," << entry.map_id << "," << entry.home_id << "," << entry.source << "\n";
  return out ? Status::Ok() : Internal(index.string() + ": write failed");
}

Result<std::vector<DatasetEntry>> ReadDatasetIndex(const std::string& root) {
  const std::string path = (std::filesystem::path(root) / "index.csv").string();
  ASSIGN_OR_RETURN(auto text, ReadFileBytes(path));
  std::istringstream lines(text);
  std::string line;
  if (!std::getline(lines, line) || line != kIndexHeader) {
    return DataLoss(path + ": first line must be '" + std::string(kIndexHeader) + "'");
  }
  std::vector<DatasetEntry> entries;
  int number = 1;
  while (std::getline(lines, line)) {
    ++number;
    if (line.empty()) continue;
    std::vector<std::string> fields;
    std::istringstream parts(line);
    std::string field;
    while (std::getline(parts, field, ',')) fields.push_back(field);
    if (fields.size() != 4 || !ValidId(fields[0]) || !ValidId(fields[1]) || !ValidId(fields[2])) {
      return DataLoss(path + ":" + std::to_string(number) + ": expected pair_id,map_id,home_id,source");
    }
    entries.push_back({fields[0], fields[1], fields[2], fields[3]});
  }
  if (entries.empty()) return InvalidArgument(path + ": no pairs");
  return entries;
}

Result<GeneratedPair> ReadDatasetPair(const std::string& root, const DatasetEntry& entry) {
  const std::filesystem::path dir = std::filesystem::path(root) / "pairs" / entry.pair_id;
  ASSIGN_OR_RETURN(auto parent, ReadMapServerYaml((dir / "parent.yaml").string()));
  ASSIGN_OR_RETURN(auto child, ReadMapServerYaml((dir / "child.yaml").string()));
  const std::string truth_path = (dir / "truth.png").string();
  cv::Mat truth;
  try {
    truth = cv::imread(truth_path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    return DataLoss(truth_path + ": " + e.what());
  }
  if (truth.empty() || truth.cols != child.width || truth.rows != child.height) {
    return DataLoss(truth_path + ": missing, corrupt, or not the child's size");
  }
  GeneratedPair pair;
  pair.truth.resize(child.cells.size());
  for (int row = 0; row < child.height; ++row) {
    const std::uint8_t* source = truth.ptr<std::uint8_t>(child.ImageRowOf(row));
    for (int col = 0; col < child.width; ++col) {
      if (source[col] > 2) return DataLoss(truth_path + ": labels must be 0, 1 or 2");
      pair.truth[static_cast<std::size_t>(row) * child.width + col] = source[col];
    }
  }
  pair.parent = std::move(parent);
  pair.child = std::move(child);
  return pair;
}

Result<LabelledPair> ExtractAndLabel(const GeneratedPair& pair, const DetectorOptions& options) {
  if (pair.truth.size() != pair.child.cells.size())
    return InvalidArgument("label: truth does not match the child");
  ASSIGN_OR_RETURN(auto regions, ExtractRegions(pair.parent, pair.child, options));
  LabelledPair result;
  std::vector<std::uint8_t> covered(pair.truth.size(), 0);
  for (ProtrusionRegion& region : regions) {
    long counts[3] = {0, 0, 0};
    for (const std::int32_t cell : region.cells) ++counts[pair.truth[static_cast<std::size_t>(cell)]];
    const bool protrusion = counts[1] > counts[2] && 2 * counts[1] >= counts[0];
    if (counts[1] + counts[2] < counts[0]) ++result.spurious_regions;
    if (protrusion) {
      for (const std::int32_t cell : region.cells) covered[static_cast<std::size_t>(cell)] = 1;
    }
    result.labels.push_back(protrusion ? 1 : 0);
    result.regions.push_back(std::move(region));
  }
  // Protrusions the segmentation lost: truth components (≥ the minimum region area) mostly not covered.
  cv::Mat truth_protrusion(pair.child.height, pair.child.width, CV_8U);
  for (std::size_t i = 0; i < pair.truth.size(); ++i) truth_protrusion.data[i] = pair.truth[i] == 1;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(truth_protrusion, labels, stats, centroids, 8, CV_32S);
  const double min_cells = kMinMissedProtrusionAreaM2 / (pair.child.resolution * pair.child.resolution);
  std::vector<long> covered_cells(static_cast<std::size_t>(count), 0);
  for (std::size_t i = 0; i < pair.truth.size(); ++i) {
    if (covered[i]) ++covered_cells[static_cast<std::size_t>(labels.ptr<int>(0)[i])];
  }
  for (int label = 1; label < count; ++label) {
    const int area = stats.at<int>(label, cv::CC_STAT_AREA);
    if (area >= min_cells && 2 * covered_cells[static_cast<std::size_t>(label)] < area)
      ++result.missed_protrusions;
  }
  return result;
}

Status AccumulateConfusion(const ProtrusionClassifier& classifier, const LabelledPair& pair,
                           ConfusionMatrix* confusion) {
  for (std::size_t i = 0; i < pair.regions.size(); ++i) {
    ASSIGN_OR_RETURN(auto probability, classifier.Probability(pair.regions[i].features));
    confusion->Add(pair.labels[i] == 1, classifier.IsProtrusion(probability));
  }
  confusion->false_negatives += pair.missed_protrusions;
  return Status::Ok();
}

std::string HomeOfRealMap(const std::string& map_id) {
  std::size_t end = 0;
  for (int part = 0; part < 4 && end != std::string::npos; ++part)
    end = map_id.find('_', end == 0 ? 0 : end + 1);
  return end == std::string::npos ? map_id : map_id.substr(0, end);
}

}  // namespace slamcore
