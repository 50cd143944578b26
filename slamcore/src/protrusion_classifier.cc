// The protrusion classifier over OpenCV's ml module (see protrusion_classifier.h).
#include "slamcore/protrusion_classifier.h"

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "slamcore/occupancy_grid.h"  // ReadFileBytes, WriteFileBytes
#include "slamcore/protrusion_detector.h"

namespace slamcore {

constexpr const char* kModelFormat = "slamcore-protrusion-model";

class ProtrusionClassifier::Model {
 public:
  cv::Ptr<cv::ml::StatModel> model;
};

const char* ClassifierKindName(ClassifierKind kind) {
  switch (kind) {
    case ClassifierKind::kDecisionTree: return "decision_tree";
    case ClassifierKind::kRandomForest: return "random_forest";
    case ClassifierKind::kSvm: return "svm";
  }
  return "unknown";
}

Result<ClassifierKind> ParseClassifierKind(const std::string& name) {
  for (const ClassifierKind kind :
       {ClassifierKind::kDecisionTree, ClassifierKind::kRandomForest, ClassifierKind::kSvm}) {
    if (name == ClassifierKindName(kind)) return kind;
  }
  return InvalidArgument("unknown classifier '" + name + "' (decision_tree, random_forest or svm)");
}

void ConfusionMatrix::Add(bool truth_protrusion, bool predicted_protrusion) {
  if (truth_protrusion) {
    ++(predicted_protrusion ? true_positives : false_negatives);
  } else {
    ++(predicted_protrusion ? false_positives : true_negatives);
  }
}

void ConfusionMatrix::Add(const ConfusionMatrix& other) {
  true_positives += other.true_positives;
  false_positives += other.false_positives;
  true_negatives += other.true_negatives;
  false_negatives += other.false_negatives;
}

namespace {
double Ratio(long numerator, long denominator) {
  return denominator == 0 ? 0.0 : static_cast<double>(numerator) / static_cast<double>(denominator);
}
}  // namespace

double ConfusionMatrix::Precision() const { return Ratio(true_positives, true_positives + false_positives); }
double ConfusionMatrix::Recall() const { return Ratio(true_positives, true_positives + false_negatives); }
double ConfusionMatrix::FalsePositiveRate() const {
  return Ratio(false_positives, false_positives + true_negatives);
}
double ConfusionMatrix::Accuracy() const { return Ratio(true_positives + true_negatives, Total()); }

ProtrusionClassifier::ProtrusionClassifier() : model_(std::make_unique<Model>()) {}
ProtrusionClassifier::~ProtrusionClassifier() = default;

Result<std::unique_ptr<ProtrusionClassifier>> ProtrusionClassifier::Train(
    const std::vector<LabelledRegion>& data, const ClassifierOptions& options) {
  const std::size_t dimension = ProtrusionFeatureNames().size();
  if (data.empty()) return InvalidArgument("train: no labelled regions");
  int positives = 0;
  for (const LabelledRegion& region : data) {
    if (region.features.size() != dimension) {
      return InvalidArgument("train: a region has " + std::to_string(region.features.size()) +
                             " features, expected " + std::to_string(dimension));
    }
    for (const double value : region.features) {
      if (!std::isfinite(value)) return InvalidArgument("train: a feature value is not finite");
    }
    if (region.label != 0 && region.label != 1) return InvalidArgument("train: labels must be 0 or 1");
    positives += region.label;
  }
  if (positives == 0 || positives == static_cast<int>(data.size())) {
    return InvalidArgument("train: both classes (protrusion and new space) are needed");
  }
  if (!(options.threshold > 0.0 && options.threshold < 1.0) || options.trees < 1 || options.max_depth < 1) {
    return InvalidArgument("train: threshold must be in (0, 1), trees and max_depth positive");
  }
  std::unique_ptr<ProtrusionClassifier> classifier(new ProtrusionClassifier());
  classifier->kind_ = options.kind;
  classifier->threshold_ = options.threshold;
  classifier->selected_ = options.selected_features;
  if (classifier->selected_.empty()) {
    for (std::size_t i = 0; i < dimension; ++i) classifier->selected_.push_back(static_cast<int>(i));
  }
  std::set<int> unique;
  for (const int index : classifier->selected_) {
    if (index < 0 || index >= static_cast<int>(dimension) || !unique.insert(index).second) {
      return InvalidArgument("train: selected feature index " + std::to_string(index) +
                             " invalid or repeated");
    }
  }
  const std::size_t selected = classifier->selected_.size();
  classifier->mean_.assign(selected, 0.0);
  classifier->scale_.assign(selected, 0.0);
  for (std::size_t j = 0; j < selected; ++j) {
    double sum = 0.0, squares = 0.0;
    for (const LabelledRegion& region : data) {
      const double value = region.features[static_cast<std::size_t>(classifier->selected_[j])];
      sum += value;
      squares += value * value;
    }
    const double n = static_cast<double>(data.size());
    classifier->mean_[j] = sum / n;
    const double variance = std::max(0.0, squares / n - classifier->mean_[j] * classifier->mean_[j]);
    classifier->scale_[j] = variance > 1e-24 ? 1.0 / std::sqrt(variance) : 1.0;
  }
  cv::Mat samples(static_cast<int>(data.size()), static_cast<int>(selected), CV_32F);
  cv::Mat responses(static_cast<int>(data.size()), 1, CV_32S);
  for (std::size_t i = 0; i < data.size(); ++i) {
    for (std::size_t j = 0; j < selected; ++j) {
      const double value = data[i].features[static_cast<std::size_t>(classifier->selected_[j])];
      samples.at<float>(static_cast<int>(i), static_cast<int>(j)) =
          static_cast<float>((value - classifier->mean_[j]) * classifier->scale_[j]);
    }
    responses.at<int>(static_cast<int>(i)) = data[i].label;
  }
  try {
    const cv::Ptr<cv::ml::TrainData> train_data =
        cv::ml::TrainData::create(samples, cv::ml::ROW_SAMPLE, responses);
    cv::Ptr<cv::ml::StatModel> model;
    if (options.kind == ClassifierKind::kDecisionTree) {
      auto tree = cv::ml::DTrees::create();
      tree->setMaxDepth(options.max_depth);
      tree->setMinSampleCount(5);
      tree->setCVFolds(0);  // OpenCV's built-in pruning CV is off: we cross-validate by home instead
      tree->setUseSurrogates(false);
      model = tree;
    } else if (options.kind == ClassifierKind::kRandomForest) {
      auto forest = cv::ml::RTrees::create();
      forest->setMaxDepth(options.max_depth);
      forest->setMinSampleCount(2);
      forest->setActiveVarCount(0);  // sqrt(features) per split
      forest->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, options.trees, 0.0));
      model = forest;
    } else {
      auto svm = cv::ml::SVM::create();
      svm->setType(cv::ml::SVM::C_SVC);
      svm->setKernel(cv::ml::SVM::RBF);
      svm->setC(10.0);
      svm->setGamma(1.0 / static_cast<double>(selected));
      svm->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER | cv::TermCriteria::EPS, 10000, 1e-6));
      model = svm;
    }
    if (!model->train(train_data)) return Internal("train: OpenCV training failed");
    classifier->model_->model = model;
  } catch (const cv::Exception& e) {
    return Internal(std::string("train: OpenCV: ") + e.what());
  }
  return classifier;
}

Result<double> ProtrusionClassifier::Probability(const std::vector<double>& features) const {
  const std::size_t dimension = ProtrusionFeatureNames().size();
  if (features.size() != dimension) {
    return InvalidArgument("classifier: expected " + std::to_string(dimension) + " features, got " +
                           std::to_string(features.size()));
  }
  cv::Mat sample(1, static_cast<int>(selected_.size()), CV_32F);
  for (std::size_t j = 0; j < selected_.size(); ++j) {
    const double value = features[static_cast<std::size_t>(selected_[j])];
    if (!std::isfinite(value))
      return InvalidArgument("classifier: feature " + std::to_string(selected_[j]) + " not finite");
    sample.at<float>(0, static_cast<int>(j)) = static_cast<float>((value - mean_[j]) * scale_[j]);
  }
  try {
    if (kind_ == ClassifierKind::kRandomForest) {
      cv::Mat votes;
      model_->model.dynamicCast<cv::ml::RTrees>()->getVotes(sample, votes, 0);
      double protrusion = 0.0, total = 0.0;
      for (int c = 0; c < votes.cols; ++c) {
        const double count = votes.at<int>(1, c);
        total += count;
        if (votes.at<int>(0, c) == 1) protrusion = count;
      }
      return total > 0.0 ? protrusion / total : 0.0;
    }
    const float predicted = model_->model->predict(sample);
    if (kind_ == ClassifierKind::kDecisionTree) return predicted > 0.5f ? 1.0 : 0.0;
    cv::Mat raw;
    model_->model->predict(sample, raw, cv::ml::StatModel::RAW_OUTPUT);
    const double confidence = 1.0 / (1.0 + std::exp(-2.0 * std::abs(static_cast<double>(raw.at<float>(0)))));
    return predicted > 0.5f ? confidence : 1.0 - confidence;
  } catch (const cv::Exception& e) {
    return Internal(std::string("classifier: OpenCV: ") + e.what());
  }
}

Result<std::string> ProtrusionClassifier::ToBytes() const {
  try {
    cv::FileStorage file("model.yml",
                         cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    file << "format" << kModelFormat << "version" << kProtrusionModelVersion << "kind"
         << ClassifierKindName(kind_);
    std::vector<cv::String> names(ProtrusionFeatureNames().begin(), ProtrusionFeatureNames().end());
    file << "features" << names << "selected" << selected_ << "mean" << mean_ << "scale" << scale_;
    file << "threshold" << threshold_;
    file << "model"
         << "{";
    model_->model->write(file);
    file << "}";
    return std::string(file.releaseAndGetString());
  } catch (const cv::Exception& e) {
    return Internal(std::string("cannot write model: ") + e.what());
  }
}

Status ProtrusionClassifier::Save(const std::string& path) const {
  auto bytes = ToBytes();
  if (!bytes.ok()) return Status(bytes.status().code(), path + ": " + bytes.status().message());
  return WriteFileBytes(path, *bytes);
}

namespace {

/// How deeply a YAML text nests, bounded from above: flow brackets open at once, plus the indentation and
/// block-sequence dashes that start the line ("- - - x" nests three deep in six characters). OpenCV's
/// parser recurses once per level, so a file nesting tens of thousands deep overflows the stack.
int YamlNestingBound(const std::string& text) {
  int flow = 0, deepest = 0;
  bool line_start = true;
  int leading = 0;
  char quote = 0;
  for (const char c : text) {
    if (c == '\n') {
      line_start = true;
      leading = 0;
      continue;
    }
    if (line_start && (c == ' ' || c == '-' || c == '\t')) {
      deepest = std::max(deepest, flow + ++leading);
      continue;
    }
    line_start = false;
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++flow + leading);
    } else if ((c == ']' || c == '}') && flow > 0) {
      --flow;
    }
  }
  return deepest;
}

/// A tree model's structure, checked before it predicts anything: OpenCV's predict follows the class and
/// variable indices as the file gives them, so a file whose indices point outside its arrays would crash it.
Status CheckTrees(const cv::ml::DTrees& trees, const cv::FileNode& node, int variables,
                  const std::string& name) {
  std::vector<int> class_labels, variable_types;
  node["class_labels"] >> class_labels;
  if (class_labels != std::vector<int>{0, 1}) {
    return InvalidArgument(name + ": the model's class labels must be [0, 1] (new space, protrusion)");
  }
  // Every feature is a number (ordered) and the response a class: a split on a categorical variable would
  // index the model's category subsets, which these models never have.
  node["var_type"] >> variable_types;
  std::vector<int> expected_types(static_cast<std::size_t>(variables), 0);
  expected_types.push_back(1);
  if (variable_types != expected_types) {
    return InvalidArgument(name + ": the model's variable types must be " + std::to_string(variables) +
                           " ordered features and a categorical response");
  }
  // OpenCV links the nodes and splits as it reads them; the variable each split tests and the class each
  // leaf names come from the file.
  for (const cv::ml::DTrees::Node& tree_node : trees.getNodes()) {
    if (tree_node.left < 0 && (tree_node.classIdx < 0 || tree_node.classIdx > 1)) {
      return InvalidArgument(name + ": a leaf names class " + std::to_string(tree_node.classIdx) + " of 2");
    }
  }
  for (const cv::ml::DTrees::Split& split : trees.getSplits()) {
    if (split.varIdx < 0 || split.varIdx >= variables) {
      return InvalidArgument(name + ": a split tests variable " + std::to_string(split.varIdx) + " of " +
                             std::to_string(variables));
    }
  }
  return Status::Ok();
}

}  // namespace

Result<std::unique_ptr<ProtrusionClassifier>> ProtrusionClassifier::Read(const std::string& bytes,
                                                                         const std::string& path) {
  if (bytes.size() > kMaxModelBytes) {
    return InvalidArgument(path + ": " + std::to_string(bytes.size()) +
                           " bytes, more than a model file may be (" + std::to_string(kMaxModelBytes) + ")");
  }
  if (const int nesting = YamlNestingBound(bytes); nesting > kMaxModelNesting) {
    return InvalidArgument(path + ": nests " + std::to_string(nesting) +
                           " levels deep, more than a model file's " + std::to_string(kMaxModelNesting));
  }
  std::unique_ptr<ProtrusionClassifier> classifier(new ProtrusionClassifier());
  try {
    cv::FileStorage file(bytes, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!file.isOpened()) return InvalidArgument(path + ": not a model file");
    std::string format, kind_name;
    int version = 0;
    file["format"] >> format;
    if (format != kModelFormat)
      return InvalidArgument(path + ": not a protrusion model (format '" + format + "')");
    file["version"] >> version;
    if (version != kProtrusionModelVersion) {
      return InvalidArgument(path + ": model version " + std::to_string(version) +
                             " is not supported (this build reads " +
                             std::to_string(kProtrusionModelVersion) + ")");
    }
    std::vector<cv::String> names;
    file["features"] >> names;
    const std::vector<std::string> expected = ProtrusionFeatureNames();
    if (std::vector<std::string>(names.begin(), names.end()) != expected) {
      return InvalidArgument(path + ": model expects a different feature list than this detector computes (" +
                             std::to_string(names.size()) + " features vs " +
                             std::to_string(expected.size()) + "); retrain it");
    }
    file["kind"] >> kind_name;
    auto kind = ParseClassifierKind(kind_name);
    if (!kind.ok()) return InvalidArgument(path + ": " + kind.status().message());
    classifier->kind_ = *kind;
    file["selected"] >> classifier->selected_;
    file["mean"] >> classifier->mean_;
    file["scale"] >> classifier->scale_;
    file["threshold"] >> classifier->threshold_;
    const std::size_t selected = classifier->selected_.size();
    if (selected == 0 || classifier->mean_.size() != selected || classifier->scale_.size() != selected) {
      return InvalidArgument(path +
                             ": selected features, mean and scale are missing or of different lengths");
    }
    for (std::size_t j = 0; j < selected; ++j) {
      if (!std::isfinite(classifier->mean_[j]) || !std::isfinite(classifier->scale_[j])) {
        return InvalidArgument(path + ": the standardisation (mean, scale) has a value that is not finite");
      }
    }
    for (const int index : classifier->selected_) {
      if (index < 0 || index >= static_cast<int>(expected.size())) {
        return InvalidArgument(path + ": selected feature index " + std::to_string(index) + " out of range");
      }
    }
    if (!(classifier->threshold_ > 0.0 && classifier->threshold_ < 1.0)) {
      return InvalidArgument(path + ": threshold must be in (0, 1)");
    }
    cv::Ptr<cv::ml::StatModel> model;
    if (*kind == ClassifierKind::kDecisionTree) model = cv::ml::DTrees::create();
    if (*kind == ClassifierKind::kRandomForest) model = cv::ml::RTrees::create();
    if (*kind == ClassifierKind::kSvm) model = cv::ml::SVM::create();
    const cv::FileNode node = file["model"];
    if (node.empty()) return InvalidArgument(path + ": no 'model' section");
    model->read(node);
    if (!model->isTrained() || model->getVarCount() != static_cast<int>(selected)) {
      return InvalidArgument(path + ": the model section is not a trained " + kind_name + " over " +
                             std::to_string(selected) + " features");
    }
    if (const auto trees = model.dynamicCast<cv::ml::DTrees>()) {
      RETURN_IF_ERROR(CheckTrees(*trees, node, static_cast<int>(selected), path));
    }
    classifier->model_->model = model;
  } catch (const cv::Exception& e) {
    return DataLoss(path + ": corrupt model file: " + e.what());
  }
  return classifier;
}

Result<std::unique_ptr<ProtrusionClassifier>> ProtrusionClassifier::Load(const std::string& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path, kMaxModelBytes));
  if (bytes.empty()) return InvalidArgument(path + ": empty");
  return Read(bytes, path);
}

Result<std::unique_ptr<ProtrusionClassifier>> ProtrusionClassifier::LoadFromBytes(const std::string& bytes) {
  if (bytes.empty()) return InvalidArgument("model: empty");
  return Read(bytes, "model");
}

Result<CrossValidationResult> CrossValidate(const std::vector<LabelledRegion>& data,
                                            const ClassifierOptions& options, int folds) {
  std::vector<std::string> groups;
  for (const LabelledRegion& region : data) groups.push_back(region.group);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  if (folds < 2 || static_cast<int>(groups.size()) < folds) {
    return InvalidArgument("cross-validation: needs at least 2 folds and one group per fold (" +
                           std::to_string(groups.size()) + " groups)");
  }
  std::map<std::string, int> fold_of;
  for (std::size_t i = 0; i < groups.size(); ++i)
    fold_of[groups[i]] = static_cast<int>(i % static_cast<std::size_t>(folds));
  CrossValidationResult result;
  result.folds = folds;
  for (int fold = 0; fold < folds; ++fold) {
    std::vector<LabelledRegion> train, test;
    for (const LabelledRegion& region : data)
      (fold_of[region.group] == fold ? test : train).push_back(region);
    ASSIGN_OR_RETURN(auto classifier, ProtrusionClassifier::Train(train, options));
    for (const LabelledRegion& region : test) {
      ASSIGN_OR_RETURN(auto probability, (classifier)->Probability(region.features));
      result.confusion.Add(region.label == 1, (classifier)->IsProtrusion(probability));
    }
  }
  return result;
}

namespace internal {
const std::string& DefaultProtrusionModelText();  // generated from models/protrusion_default.yml
}  // namespace internal

std::string DefaultProtrusionModelBytes() { return internal::DefaultProtrusionModelText(); }

Result<std::shared_ptr<const ProtrusionClassifier>> DefaultProtrusionClassifier() {
  static const Result<std::shared_ptr<const ProtrusionClassifier>> kDefault =
      []() -> Result<std::shared_ptr<const ProtrusionClassifier>> {
    auto loaded = ProtrusionClassifier::LoadFromBytes(internal::DefaultProtrusionModelText());
    if (!loaded.ok()) return Status(loaded.status().code(), "default " + loaded.status().message());
    return std::shared_ptr<const ProtrusionClassifier>(std::move(loaded).value());
  }();
  return kDefault;
}

}  // namespace slamcore
