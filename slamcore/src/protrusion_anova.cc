// One-way ANOVA F-values and p-values for feature selection (paper IV-C: "features with p-values less
// than 0.05 are selected"), with the F distribution's tail from Boost.Math.
#include <boost/math/distributions/fisher_f.hpp>

#include <cmath>
#include <limits>

#include "slamcore/protrusion_detector.h"

namespace slamcore {

Result<std::vector<FeatureAnova>> AnovaFValues(const std::vector<std::vector<double>>& features,
                                               const std::vector<int>& labels) {
  if (features.size() != labels.size()) return InvalidArgument("ANOVA: one label per sample is needed");
  if (features.empty()) return InvalidArgument("ANOVA: no samples");
  const std::size_t dimension = features.front().size();
  int classes = 0;
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (features[i].size() != dimension)
      return InvalidArgument("ANOVA: samples have different feature counts");
    if (labels[i] < 0 || labels[i] > 1000) return InvalidArgument("ANOVA: labels must be 0..1000");
    classes = std::max(classes, labels[i] + 1);
  }
  std::vector<int> class_size(static_cast<std::size_t>(classes), 0);
  for (const int label : labels) ++class_size[static_cast<std::size_t>(label)];
  int present = 0;
  for (const int size : class_size) present += size > 0;
  const double n = static_cast<double>(features.size());
  if (present < 2 || n <= present)
    return InvalidArgument("ANOVA: needs two classes and more samples than classes");

  const std::vector<std::string>& names = ProtrusionFeatureNames();
  std::vector<FeatureAnova> result;
  for (std::size_t f = 0; f < dimension; ++f) {
    std::vector<double> class_sum(static_cast<std::size_t>(classes), 0.0);
    double total = 0.0;
    for (std::size_t i = 0; i < features.size(); ++i) {
      class_sum[static_cast<std::size_t>(labels[i])] += features[i][f];
      total += features[i][f];
    }
    const double grand_mean = total / n;
    double between = 0.0, within = 0.0;
    for (int c = 0; c < classes; ++c) {
      if (class_size[static_cast<std::size_t>(c)] == 0) continue;
      const double mean = class_sum[static_cast<std::size_t>(c)] / class_size[static_cast<std::size_t>(c)];
      between += class_size[static_cast<std::size_t>(c)] * (mean - grand_mean) * (mean - grand_mean);
    }
    for (std::size_t i = 0; i < features.size(); ++i) {
      const auto c = static_cast<std::size_t>(labels[i]);
      const double deviation = features[i][f] - class_sum[c] / class_size[c];
      within += deviation * deviation;
    }
    const double df_between = present - 1, df_within = n - present;
    FeatureAnova anova;
    anova.name = f < names.size() ? names[f] : "feature_" + std::to_string(f);
    if (!std::isfinite(between) || !std::isfinite(within)) {
      return InvalidArgument("ANOVA: feature " + anova.name + " has non-finite values");
    }
    if (within <= 0.0) {
      // No spread inside the classes: perfectly separating if the means differ, useless otherwise.
      anova.f_value = between > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
      anova.p_value = between > 0.0 ? 0.0 : 1.0;
    } else {
      anova.f_value = (between / df_between) / (within / df_within);
      const boost::math::fisher_f_distribution<double> distribution(df_between, df_within);
      anova.p_value = boost::math::cdf(boost::math::complement(distribution, anova.f_value));
    }
    result.push_back(anova);
  }
  return result;
}

}  // namespace slamcore
