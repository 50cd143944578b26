#include "hypothesis.h"

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

}  // namespace slamcore::internal
