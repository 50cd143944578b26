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

int CountPasses(const Hypothesis& hypothesis, double gap_seconds, double gap_distance) {
  int passes = 0;
  const HypothesisObservation* previous = nullptr;
  for (const HypothesisObservation& observation : hypothesis.observations) {
    if (!previous || observation.time - previous->time > gap_seconds ||
        std::abs(observation.odometer - previous->odometer) > gap_distance) {
      ++passes;
    }
    previous = &observation;
  }
  return passes;
}

}  // namespace slamcore::internal
