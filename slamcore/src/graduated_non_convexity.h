// Graduated non-convexity for truncated least squares (Yang, Antonante, Tzoumas, Carlone, "Graduated
// Non-Convexity for Robust Spatial Perception: From Non-Minimal Solvers to Global Outlier Rejection",
// RA-L 2020). The TLS cost min(r², c̄²) is approached through surrogates controlled by μ: convex for small
// μ, TLS as μ → ∞. Each round solves the weighted least squares, then sets each measurement's weight from
// its residual with this rule and grows μ.
//
// Thread safety: pure function.
#pragma once

#include <cmath>

namespace slamcore::internal {

/// The GNC-TLS weight (eq. 14 of the paper) of a measurement whose residual is s = r²/c̄² times its
/// threshold: 1 for s ≤ μ/(μ+1), 0 for s ≥ (μ+1)/μ, and √(μ(μ+1)/s) − μ between.
inline double TruncatedLeastSquaresWeight(double s, double mu) {
  if (s <= mu / (mu + 1.0)) return 1.0;
  if (s >= (mu + 1.0) / mu) return 0.0;
  return std::sqrt(mu * (mu + 1.0) / s) - mu;
}

/// μ of the first round: every measurement's weight is then 1 (the surrogate is convex), s_max the largest.
inline double InitialControlParameter(double largest_s) { return 1.0 / (2.0 * largest_s - 1.0); }

/// μ grows by this factor per round (the paper's choice).
inline constexpr double kControlParameterGrowth = 1.4;

}  // namespace slamcore::internal
