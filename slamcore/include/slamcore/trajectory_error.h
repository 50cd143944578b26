// Trajectory error against a reference: the root-mean-square position difference after the rigid
// motion that best aligns the estimate onto the reference (closed-form least squares in 2-D, Umeyama's
// method without scale). Used to score the Mapper against ground truth and against outlier-free solutions.
//
// Thread safety: free functions.
#pragma once

#include <vector>

#include "slamcore/se2.h"
#include "slamcore/status.h"

namespace slamcore {

/// The rigid motion T minimising Σ |T·estimate_k − reference_k|²; needs two or more points.
Result<SE2> AlignRigidly(const std::vector<Vector2>& estimate, const std::vector<Vector2>& reference);

/// RMS of |T·estimate_k − reference_k| with T from AlignRigidly.
Result<double> AlignedRmse(const std::vector<Vector2>& estimate, const std::vector<Vector2>& reference);

}  // namespace slamcore
