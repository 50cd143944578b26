// Statistics over a decision log (paper Fig. 6–8 are aggregates of these).
#include <unordered_set>

#include "slamcore/mapper.h"

namespace slamcore {

MapperStatistics ComputeStatistics(const std::vector<Decision>& decisions) {
  MapperStatistics statistics;
  std::unordered_set<std::int64_t> conditionally_accepted;
  for (const Decision& decision : decisions) {
    const bool recovery = decision.hypothesis_kind == HypothesisKind::kRecovery;
    const bool merge = decision.hypothesis_kind == HypothesisKind::kMerge;
    switch (decision.kind) {
      case DecisionKind::kDirectEdge: ++statistics.direct_edges; break;
      case DecisionKind::kHypothesisCreated:
        statistics.recovery_created += recovery;
        statistics.merge_created += merge;
        break;
      case DecisionKind::kHypothesisUpdated: break;
      case DecisionKind::kConditionallyAccepted:
        statistics.merge_conditionally_accepted += merge;
        conditionally_accepted.insert(decision.hypothesis);
        break;
      case DecisionKind::kAccepted:
        statistics.recovery_accepted += recovery;
        statistics.merge_accepted += merge;
        break;
      case DecisionKind::kRejected:
        statistics.recovery_rejected += recovery;
        statistics.merge_rejected += merge;
        statistics.merge_conditional_then_rejected +=
            merge && conditionally_accepted.contains(decision.hypothesis);
        break;
      case DecisionKind::kExpired:
        statistics.recovery_expired += recovery;
        statistics.merge_expired += merge;
        break;
      case DecisionKind::kViewMarkedAmbiguous: ++statistics.views_marked_ambiguous; break;
      case DecisionKind::kComponentCreated: ++statistics.components_created; break;
      case DecisionKind::kComponentsMerged: break;
      case DecisionKind::kRetracted: statistics.recovery_retracted += recovery; break;
      case DecisionKind::kSlipCorrected: ++statistics.slip_corrections; break;
    }
  }
  return statistics;
}

}  // namespace slamcore
