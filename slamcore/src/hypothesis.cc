#include "hypothesis.h"

#include <cmath>
#include <unordered_set>

namespace slamcore::internal {

EvidenceCount CountEvidence(const Hypothesis& hypothesis, bool discount_ambiguous,
                            const std::function<bool(ViewId)>& is_ambiguous) {
  EvidenceCount count;
  std::unordered_set<ViewId> views;
  for (const HypothesisObservation& observation : hypothesis.observations) {
    if (discount_ambiguous && is_ambiguous(observation.view)) continue;
    ++count.observations;
    views.insert(observation.view);
  }
  count.views = static_cast<int>(views.size());
  return count;
}

std::string EvidenceText(const EvidenceCount& count) {
  return std::to_string(count.observations) +
         (count.observations == 1 ? " observation of " : " observations of ") + std::to_string(count.views) +
         (count.views == 1 ? " view" : " views");
}

bool BeyondPassGap(const TraversalPoint& earlier, const TraversalPoint& later, double gap_seconds,
                   double gap_distance) {
  return later.time - earlier.time > gap_seconds ||
         std::abs(later.odometer - earlier.odometer) > gap_distance;
}

int CountPasses(std::span<const TraversalPoint> points, double gap_seconds, double gap_distance) {
  int passes = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    if ((k == 0 || BeyondPassGap(points[k - 1], points[k], gap_seconds, gap_distance)) &&
        points[k].confirms) {
      ++passes;
    }
  }
  return passes;
}

int CountPasses(const Hypothesis& hypothesis, double gap_seconds, double gap_distance) {
  std::vector<TraversalPoint> points;
  for (const HypothesisObservation& observation : hypothesis.observations) {
    points.push_back(
        {.time = observation.time, .odometer = observation.odometer, .confirms = observation.confirms});
  }
  return CountPasses(points, gap_seconds, gap_distance);
}

}  // namespace slamcore::internal
