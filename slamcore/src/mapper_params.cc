#include "slamcore/mapper_params.h"

#include <cmath>
#include <sstream>
#include <string>

namespace slamcore {
namespace {

std::string Describe(const char* field, double value, const char* requirement) {
  std::ostringstream message;
  message << "MapperParams." << field << " = " << value << ": " << requirement;
  return message.str();
}

Status CheckPositiveFinite(const char* field, double value) {
  if (std::isfinite(value) && value > 0.0) return Status::Ok();
  return InvalidArgument(Describe(field, value, "must be positive and finite"));
}

Status CheckPositiveCount(const char* field, int value) {
  if (value > 0) return Status::Ok();
  return InvalidArgument(Describe(field, value, "must be at least 1"));
}

/// A set of acceptance criteria needs at least one observation of one view, and can never ask for more
/// distinct views than observations (each view needs at least one observation of its own).
Status CheckCriteria(const std::string& name, const AcceptanceCriteria& criteria) {
  const std::string observations = name + ".min_observations", views = name + ".min_views";
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount(observations.c_str(), criteria.min_observations));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount(views.c_str(), criteria.min_views));
  if (criteria.min_views > criteria.min_observations) {
    return InvalidArgument(Describe(views.c_str(), criteria.min_views,
                                    ("must not exceed " + observations + " = " +
                                     std::to_string(criteria.min_observations))
                                        .c_str()));
  }
  return Status::Ok();
}

}  // namespace

Status MapperParams::Validate() const {
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("gate_chi2", gate_chi2));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("direct_max_position_sigma", direct_max_position_sigma));
  SLAMCORE_RETURN_IF_ERROR(CheckCriteria("recovery", recovery));
  SLAMCORE_RETURN_IF_ERROR(CheckCriteria("merge_conditional", merge_conditional));
  SLAMCORE_RETURN_IF_ERROR(CheckCriteria("merge_full", merge_full));
  // IV-B: the full merge cannot be undone, so it must ask for at least as much evidence as the
  // conditional one; otherwise the "permissive" set would be the strict one.
  if (merge_full.min_observations < merge_conditional.min_observations) {
    return InvalidArgument(Describe("merge_full.min_observations", merge_full.min_observations,
                                    ("must be at least merge_conditional.min_observations = " +
                                     std::to_string(merge_conditional.min_observations))
                                        .c_str()));
  }
  if (merge_full.min_views < merge_conditional.min_views) {
    return InvalidArgument(Describe("merge_full.min_views", merge_full.min_views,
                                    ("must be at least merge_conditional.min_views = " +
                                     std::to_string(merge_conditional.min_views))
                                        .c_str()));
  }
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("local_window_nodes", local_window_nodes));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("full_optimization_every", full_optimization_every));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("hypothesis_expiry_seconds", hypothesis_expiry_seconds));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("hypothesis_expiry_distance", hypothesis_expiry_distance));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("ambiguity_window_distance", ambiguity_window_distance));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("ambiguity_min_rejections", ambiguity_min_rejections));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("consistency.pass_gap_seconds", consistency.pass_gap_seconds));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("consistency.pass_gap_distance", consistency.pass_gap_distance));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("consistency.map_gate_chi2", consistency.map_gate_chi2));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveFinite("consistency.aliasing_offset", consistency.aliasing_offset));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("consistency.min_passes_uninformative", consistency.min_passes_uninformative));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("consistency.min_passes_against_map", consistency.min_passes_against_map));
  if (!(consistency.retraction_confidence > 0.5 && consistency.retraction_confidence < 1.0)) {
    return InvalidArgument(Describe("consistency.retraction_confidence", consistency.retraction_confidence,
                                    "must lie in (0.5, 1)"));
  }
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("consistency.max_judged_per_trial", consistency.max_judged_per_trial));
  if (consistency.max_continuation_edges < 0) {
    return InvalidArgument(Describe("consistency.max_continuation_edges", consistency.max_continuation_edges,
                                    "must not be negative"));
  }
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("consistency.max_open_hypotheses", consistency.max_open_hypotheses));
  SLAMCORE_RETURN_IF_ERROR(CheckPositiveCount("consistency.max_retractions_per_check", consistency.max_retractions_per_check));
  if (const Status status = slamcore::Validate(optimizer); !status.ok()) {
    return InvalidArgument("MapperParams.optimizer: " + status.message());
  }
  return Status::Ok();
}

}  // namespace slamcore
