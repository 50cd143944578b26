#include "slamcore/trajectory_error.h"

#include <cmath>

namespace slamcore {

Result<SE2> AlignRigidly(const std::vector<Vector2>& estimate, const std::vector<Vector2>& reference) {
  if (estimate.size() != reference.size()) {
    return InvalidArgument("alignment needs equally many points: " + std::to_string(estimate.size()) +
                           " vs " + std::to_string(reference.size()));
  }
  if (estimate.size() < 2) return InvalidArgument("alignment needs at least 2 points");
  Vector2 mean_estimate = Vector2::Zero(), mean_reference = Vector2::Zero();
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    mean_estimate += estimate[k];
    mean_reference += reference[k];
  }
  mean_estimate /= static_cast<double>(estimate.size());
  mean_reference /= static_cast<double>(reference.size());
  // The optimal rotation angle maximises Σ (R·a_k)·b_k over the centred points: atan2(Σ a×b, Σ a·b).
  double dot = 0.0, cross = 0.0;
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    const Vector2 a = estimate[k] - mean_estimate, b = reference[k] - mean_reference;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  const double angle = std::atan2(cross, dot);
  const SE2 rotation(0.0, 0.0, angle);
  return SE2(mean_reference - rotation.rotation() * mean_estimate, angle);
}

Result<double> AlignedRmse(const std::vector<Vector2>& estimate, const std::vector<Vector2>& reference) {
  ASSIGN_OR_RETURN(const auto alignment, AlignRigidly(estimate, reference));
  double sum = 0.0;
  for (std::size_t k = 0; k < estimate.size(); ++k)
    sum += ((alignment)*estimate[k] - reference[k]).squaredNorm();
  return std::sqrt(sum / static_cast<double>(estimate.size()));
}

}  // namespace slamcore
