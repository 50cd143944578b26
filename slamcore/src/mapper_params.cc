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

// Every field also has a documented maximum (MapperParamsLimits): a parameter set is untrusted input, and a
// window of 2^31 nodes or an expiry of 1e300 s turns one run's replay into unbounded work.
Status CheckPositiveFinite(const char* field, double value, double max) {
  if (std::isfinite(value) && value > 0.0 && value <= max) return Status::Ok();
  std::ostringstream requirement;
  requirement << "must be positive, finite and at most " << max;
  return InvalidArgument(Describe(field, value, requirement.str().c_str()));
}

Status CheckPositiveCount(const char* field, int value, int max = MapperParamsLimits::kMaxCount) {
  if (value > 0 && value <= max) return Status::Ok();
  return InvalidArgument(Describe(field, value, ("must be in [1, " + std::to_string(max) + "]").c_str()));
}

/// A set of acceptance criteria needs at least one observation of one view, and can never ask for more
/// distinct views than observations (each view needs at least one observation of its own).
Status CheckCriteria(const std::string& name, const AcceptanceCriteria& criteria) {
  const std::string observations = name + ".min_observations", views = name + ".min_views";
  RETURN_IF_ERROR(CheckPositiveCount(observations.c_str(), criteria.min_observations));
  RETURN_IF_ERROR(CheckPositiveCount(views.c_str(), criteria.min_views));
  if (criteria.min_views > criteria.min_observations) {
    return InvalidArgument(Describe(
        views.c_str(), criteria.min_views,
        ("must not exceed " + observations + " = " + std::to_string(criteria.min_observations)).c_str()));
  }
  return Status::Ok();
}

/// A value within [low, high] (finite); the message names the field and the range.
template <typename T>
Status CheckRange(const char* field, T value, T low, T high) {
  if (std::isfinite(static_cast<double>(value)) && value >= low && value <= high) return Status::Ok();
  std::ostringstream requirement;
  requirement << "must lie in [" << low << ", " << high << "]";
  return InvalidArgument(Describe(field, static_cast<double>(value), requirement.str().c_str()));
}

/// The bounds keep every check's cost bounded too: caps on open hypotheses, judged hypotheses and
/// continuation edges are what the per-observation work is proportional to.
Status ValidateConsistency(const ConsistencyParams& c) {
  RETURN_IF_ERROR(CheckRange("consistency.pass_gap_seconds", c.pass_gap_seconds, 1e-3, 3600.0));
  RETURN_IF_ERROR(CheckRange("consistency.pass_gap_distance", c.pass_gap_distance, 1e-3, 1000.0));
  RETURN_IF_ERROR(CheckRange("consistency.map_gate_chi2", c.map_gate_chi2, 1e-3, 1e6));
  RETURN_IF_ERROR(
      CheckRange("consistency.min_redundancy_for_scaling", c.min_redundancy_for_scaling, 0, 1 << 30));
  RETURN_IF_ERROR(CheckRange("consistency.min_variance_factor", c.min_variance_factor, 1e-6, 1.0));
  RETURN_IF_ERROR(CheckRange("consistency.aliasing_offset", c.aliasing_offset, 1e-3, 1000.0));
  RETURN_IF_ERROR(CheckRange("consistency.min_passes_uninformative", c.min_passes_uninformative, 1, 100));
  RETURN_IF_ERROR(CheckRange("consistency.min_passes_against_map", c.min_passes_against_map, 1, 100));
  RETURN_IF_ERROR(CheckRange("consistency.retraction_confidence", c.retraction_confidence, 0.5, 0.999999));
  RETURN_IF_ERROR(CheckRange("consistency.max_open_hypotheses", c.max_open_hypotheses, 1, 10000));
  RETURN_IF_ERROR(CheckRange("consistency.max_continuation_edges", c.max_continuation_edges, 0, 1000));
  RETURN_IF_ERROR(CheckRange("consistency.max_judged_per_check", c.max_judged_per_check, 1, 100));
  RETURN_IF_ERROR(CheckRange("consistency.max_retractions_per_check", c.max_retractions_per_check, 0, 100));
  RETURN_IF_ERROR(CheckRange("consistency.max_contest_trials", c.max_contest_trials, 0, 100));
  RETURN_IF_ERROR(CheckRange("consistency.max_edges_judged", c.max_edges_judged, 1, 1000));
  // The update's dense solve is cubic in the nodes: 256 nodes is a 768 × 768 factorisation.
  RETURN_IF_ERROR(CheckRange("consistency.max_marginal_update_nodes", c.max_marginal_update_nodes, 0, 256));
  RETURN_IF_ERROR(
      CheckRange("consistency.consistent_set_confidence", c.consistent_set_confidence, 0.5, 0.999999));
  RETURN_IF_ERROR(CheckRange("consistency.consistent_set_growth", c.consistent_set_growth, 1.01, 100.0));
  RETURN_IF_ERROR(CheckRange("consistency.max_kept_refused", c.max_kept_refused, 0, 10000));
  RETURN_IF_ERROR(CheckRange("consistency.gnc_max_iterations", c.gnc_max_iterations, 1, 1000));
  return Status::Ok();
}

}  // namespace

Status MapperParams::Validate() const {
  RETURN_IF_ERROR(CheckPositiveFinite("gate_chi2", gate_chi2, MapperParamsLimits::kMaxChi2));
  RETURN_IF_ERROR(CheckPositiveFinite("direct_max_position_sigma", direct_max_position_sigma,
                                      MapperParamsLimits::kMaxMeters));
  RETURN_IF_ERROR(CheckCriteria("recovery", recovery));
  RETURN_IF_ERROR(CheckCriteria("merge_conditional", merge_conditional));
  RETURN_IF_ERROR(CheckCriteria("merge_full", merge_full));
  // IV-B: the full merge cannot be undone, so it must ask for at least as much evidence as the
  // conditional one; otherwise the "permissive" set would be the strict one.
  if (merge_full.min_observations < merge_conditional.min_observations) {
    return InvalidArgument(Describe("merge_full.min_observations", merge_full.min_observations,
                                    ("must be at least merge_conditional.min_observations = " +
                                     std::to_string(merge_conditional.min_observations))
                                        .c_str()));
  }
  if (merge_full.min_views < merge_conditional.min_views) {
    return InvalidArgument(Describe(
        "merge_full.min_views", merge_full.min_views,
        ("must be at least merge_conditional.min_views = " + std::to_string(merge_conditional.min_views))
            .c_str()));
  }
  RETURN_IF_ERROR(
      CheckPositiveCount("local_window_nodes", local_window_nodes, MapperParamsLimits::kMaxWindowNodes));
  RETURN_IF_ERROR(CheckPositiveCount("full_optimization_every", full_optimization_every,
                                     MapperParamsLimits::kMaxOptimizationEvery));
  RETURN_IF_ERROR(CheckPositiveFinite("hypothesis_expiry_seconds", hypothesis_expiry_seconds,
                                      MapperParamsLimits::kMaxSeconds));
  RETURN_IF_ERROR(CheckPositiveFinite("hypothesis_expiry_distance", hypothesis_expiry_distance,
                                      MapperParamsLimits::kMaxMeters));
  RETURN_IF_ERROR(CheckPositiveFinite("ambiguity_window_distance", ambiguity_window_distance,
                                      MapperParamsLimits::kMaxMeters));
  RETURN_IF_ERROR(CheckPositiveCount("ambiguity_min_rejections", ambiguity_min_rejections));
  RETURN_IF_ERROR(ValidateConsistency(consistency));
  RETURN_IF_ERROR(CheckPositiveCount("optimizer.max_iterations", optimizer.max_iterations,
                                     MapperParamsLimits::kMaxIterations));
  RETURN_IF_ERROR(
      CheckPositiveCount("optimizer.num_threads", optimizer.num_threads, MapperParamsLimits::kMaxThreads));
  if (const Status status = slamcore::Validate(optimizer); !status.ok()) {
    return InvalidArgument("MapperParams.optimizer: " + status.message());
  }
  return Status::Ok();
}

}  // namespace slamcore
