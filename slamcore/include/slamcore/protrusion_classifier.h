// The protrusion classifier (paper IV-C): labels each region of ExtractRegions() as an erroneous
// protrusion or genuinely new space. Backed by OpenCV's ml module (decision tree, random forest, SVM);
// OpenCV stays out of this header.
//
// Model files (format "slamcore-protrusion-model", version kProtrusionModelVersion; OpenCV FileStorage
// YAML) record the classifier kind, the full feature list the detector produced at training time, the
// selected feature indices, the standardisation and the decision threshold. Load() refuses a file whose
// format, version or feature list differs from this build's, so a model never silently reads the wrong
// columns. docs/protrusion-data.md describes the file.
//
// Thread safety: a loaded classifier is immutable; concurrent Predict() calls are safe.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "slamcore/status.h"

namespace slamcore {

inline constexpr int kProtrusionModelVersion = 1;
/// Bounds on a model file, checked before OpenCV parses it: its size (the default model is about 1 MB) and
/// how deeply its YAML nests (a few levels; OpenCV's parser recurses once per level).
inline constexpr std::size_t kMaxModelBytes = 64u << 20;
inline constexpr int kMaxModelNesting = 256;

enum class ClassifierKind { kDecisionTree, kRandomForest, kSvm };
const char* ClassifierKindName(ClassifierKind kind);  // "decision_tree", "random_forest", "svm"
Result<ClassifierKind> ParseClassifierKind(const std::string& name);

/// One region with its class: label 1 = protrusion, 0 = new space (or any other non-protrusion change).
/// group names what must never be split between training and test (a home, a map).
struct LabelledRegion {
  std::string group;
  std::vector<double> features;
  int label = 0;
};

struct ClassifierOptions {
  ClassifierKind kind = ClassifierKind::kRandomForest;
  std::vector<int> selected_features;  // indices into ProtrusionFeatureNames(); empty = all
  double threshold = 0.5;              // probability above which a region is a protrusion
  int trees = 100;                     // random forest
  int max_depth = 10;                  // trees
};

struct ConfusionMatrix {
  long true_positives = 0, false_positives = 0, true_negatives = 0, false_negatives = 0;
  void Add(bool truth_protrusion, bool predicted_protrusion);
  void Add(const ConfusionMatrix& other);
  double Precision() const;
  double Recall() const;
  double FalsePositiveRate() const;
  double Accuracy() const;
  long Total() const { return true_positives + false_positives + true_negatives + false_negatives; }
};

class ProtrusionClassifier {
 public:
  static Result<std::unique_ptr<ProtrusionClassifier>> Train(const std::vector<LabelledRegion>& data,
                                                             const ClassifierOptions& options);
  static Result<std::unique_ptr<ProtrusionClassifier>> Load(const std::string& path);
  /// The same from a model file's bytes (a model stored in a database, or the built-in default).
  static Result<std::unique_ptr<ProtrusionClassifier>> LoadFromBytes(const std::string& bytes);
  ~ProtrusionClassifier();

  Status Save(const std::string& path) const;
  /// The model file's bytes, as Save writes them.
  Result<std::string> ToBytes() const;
  /// P(protrusion) for a full feature vector (ProtrusionFeatureNames() order): random forest = the
  /// fraction of trees voting protrusion, SVM = a logistic of the margin, decision tree = 0 or 1.
  Result<double> Probability(const std::vector<double>& features) const;
  bool IsProtrusion(double probability) const { return probability >= threshold_; }

  ClassifierKind kind() const { return kind_; }
  double threshold() const { return threshold_; }
  const std::vector<int>& selected_features() const { return selected_; }

 private:
  class Model;
  ProtrusionClassifier();
  /// `bytes` of a model file, named by `path` in every message (the file, or "model" for bytes).
  static Result<std::unique_ptr<ProtrusionClassifier>> Read(const std::string& bytes,
                                                            const std::string& path);
  ClassifierKind kind_ = ClassifierKind::kRandomForest;
  double threshold_ = 0.5;
  std::vector<int> selected_;
  std::vector<double> mean_, scale_;  // standardisation of the selected features
  std::unique_ptr<Model> model_;
};

/// The model shipped with slamcore (slamcore/models/, built into the library; how it was trained and how
/// it scores: docs/protrusion-data.md "Default model"), loaded once. Used whenever no other model is
/// chosen: by `slamtool protrusions`, the analysis and fleetd. Fails only if the built-in bytes are corrupt.
Result<std::shared_ptr<const ProtrusionClassifier>> DefaultProtrusionClassifier();
/// The built-in model file's bytes (for tools that export or compare it).
std::string DefaultProtrusionModelBytes();

/// k-fold cross-validation with whole groups per fold (no group in both training and test of a fold).
struct CrossValidationResult {
  ConfusionMatrix confusion;
  int folds = 0;
};
Result<CrossValidationResult> CrossValidate(const std::vector<LabelledRegion>& data,
                                            const ClassifierOptions& options, int folds);

}  // namespace slamcore
