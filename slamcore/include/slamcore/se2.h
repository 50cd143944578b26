// SE(2): rigid motions of the plane, the one place where the project's Lie-group conventions live.
//
// Conventions (fixed; every other file relies on them):
//  * A pose T = (x, y, θ) maps a point p of its own frame into the parent frame: T·p = R(θ)·p + t.
//    `a_T_b` is the pose of frame b expressed in frame a, so a_T_c = a_T_b · b_T_c.
//  * θ is always wrapped to (-π, π].
//  * Tangent vectors ξ = (ρx, ρy, φ): translation part first, rotation last.
//  * Perturbations are on the LEFT: T ⊕ ξ = exp(ξ) · T. This matches the paper's equation (6),
//    G ← exp(K · ln R) · G, and makes covariances of T live in the parent frame.
//  * Adjoint: T · exp(ξ) · T⁻¹ = exp(Adj_T · ξ), with Adj_T = [R, (y, −x)ᵀ; 0, 1].
//  * Jacobians are with respect to left perturbations of every pose argument, and plain derivatives for
//    points and tangent vectors.
//
// Thread safety: value types, no shared state.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

namespace slamcore {

using Vector2 = Eigen::Vector2d;
using Vector3 = Eigen::Vector3d;
using Matrix2 = Eigen::Matrix2d;
using Matrix3 = Eigen::Matrix3d;

/// Wraps an angle to (-π, π].
inline double WrapAngle(double angle) {
  // Already in (−π, π]: std::remainder would return it unchanged (it is exact), so skip its cost — most
  // angles the solvers wrap are small differences.
  if (angle > -std::numbers::pi && angle <= std::numbers::pi) return angle;
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  double wrapped = std::remainder(angle, kTwoPi);  // in [-π, π]
  if (wrapped <= -std::numbers::pi) wrapped += kTwoPi;
  return wrapped;
}

/// The 2×2 generator of rotations, J = [0 −1; 1 0]; J·p is p turned by +90°.
inline Vector2 Perp(const Vector2& p) { return {-p.y(), p.x()}; }

class SE2 {
 public:
  SE2() = default;
  SE2(double x, double y, double theta) : x_(x), y_(y), theta_(WrapAngle(theta)) {}
  SE2(const Vector2& translation, double theta) : SE2(translation.x(), translation.y(), theta) {}

  static SE2 Identity() { return {}; }

  double x() const { return x_; }
  double y() const { return y_; }
  double theta() const { return theta_; }
  Vector2 translation() const { return {x_, y_}; }
  Matrix2 rotation() const {
    const double c = std::cos(theta_), s = std::sin(theta_);
    return (Matrix2() << c, -s, s, c).finished();
  }
  /// (x, y, θ) as stored; not the Lie-algebra coordinates (use Log for those).
  Vector3 vector() const { return {x_, y_, theta_}; }

  SE2 operator*(const SE2& other) const {
    return SE2(translation() + rotation() * other.translation(), theta_ + other.theta_);
  }
  Vector2 operator*(const Vector2& point) const { return rotation() * point + translation(); }

  SE2 inverse() const {
    const Vector2 t = -(rotation().transpose() * translation());
    return SE2(t, -theta_);
  }

  /// Adj_T, so that T · exp(ξ) · T⁻¹ = exp(Adj_T ξ).
  Matrix3 Adjoint() const {
    Matrix3 adjoint = Matrix3::Identity();
    adjoint.topLeftCorner<2, 2>() = rotation();
    adjoint(0, 2) = y_;
    adjoint(1, 2) = -x_;
    return adjoint;
  }

  /// T·p with Jacobians: d/dξ of exp(ξ)·T·p (2×3) and d/dp (2×2).
  Vector2 Act(const Vector2& point, Eigen::Matrix<double, 2, 3>* d_pose = nullptr,
              Matrix2* d_point = nullptr) const {
    const Vector2 result = (*this) * point;
    if (d_pose) {
      d_pose->leftCols<2>() = Matrix2::Identity();
      d_pose->col(2) = Perp(result);
    }
    if (d_point) *d_point = rotation();
    return result;
  }

  /// A·B with Jacobians of left perturbations of A and of B.
  static SE2 Compose(const SE2& a, const SE2& b, Matrix3* d_a = nullptr, Matrix3* d_b = nullptr) {
    if (d_a) *d_a = Matrix3::Identity();
    if (d_b) *d_b = a.Adjoint();
    return a * b;
  }

  /// T⁻¹ with the Jacobian of a left perturbation of T.
  static SE2 Inverse(const SE2& pose, Matrix3* d_pose = nullptr) {
    const SE2 inverse = pose.inverse();
    if (d_pose) *d_pose = -inverse.Adjoint();
    return inverse;
  }

  /// exp: tangent (ρ, φ) → pose. Optional left Jacobian J_l(ξ), exp(ξ + δ) ≈ exp(J_l δ) · exp(ξ).
  static SE2 Exp(const Vector3& xi, Matrix3* left_jacobian = nullptr) {
    const double phi = xi.z();
    double a, b;  // sin φ / φ and (1 − cos φ) / φ, with their small-angle series
    SinCosRatios(phi, &a, &b);
    const Vector2 t(a * xi.x() - b * xi.y(), b * xi.x() + a * xi.y());
    if (left_jacobian) *left_jacobian = LeftJacobian(xi);
    return SE2(t, phi);
  }

  /// log: pose → tangent (ρ, φ), φ in (−π, π]. Inverse of Exp on that range.
  static Vector3 Log(const SE2& pose) {
    const double phi = pose.theta_;
    const double half = 0.5 * phi;
    // (φ/2)·cot(φ/2), with its series near 0; at ±π it is 0, which is well defined.
    const double half_cot =
        std::abs(phi) < 1e-4 ? 1.0 - phi * phi / 12.0 : half * std::cos(half) / std::sin(half);
    const double x = half_cot * pose.x_ + half * pose.y_;
    const double y = -half * pose.x_ + half_cot * pose.y_;
    return {x, y, phi};
  }

  /// Left Jacobian of SE(2) at ξ.
  static Matrix3 LeftJacobian(const Vector3& xi) {
    const double phi = xi.z();
    double a, b;
    SinCosRatios(phi, &a, &b);
    // d a/dφ and d b/dφ, again with series near 0.
    double da, db;
    if (std::abs(phi) < 1e-4) {
      da = -phi / 3.0;
      db = 0.5 - phi * phi / 8.0;
    } else {
      da = (phi * std::cos(phi) - std::sin(phi)) / (phi * phi);
      db = (phi * std::sin(phi) - (1.0 - std::cos(phi))) / (phi * phi);
    }
    Matrix3 jacobian = Matrix3::Identity();
    jacobian.topLeftCorner<2, 2>() << a, -b, b, a;
    // Column for φ: derivative of V(φ)ρ, corrected by the rotation of the translation already present.
    const Vector2 dv(da * xi.x() - db * xi.y(), db * xi.x() + da * xi.y());
    const Vector2 t(a * xi.x() - b * xi.y(), b * xi.x() + a * xi.y());
    jacobian.block<2, 1>(0, 2) = dv - Perp(t);
    return jacobian;
  }

  bool IsApprox(const SE2& other, double tolerance = 1e-9) const {
    return std::abs(x_ - other.x_) <= tolerance && std::abs(y_ - other.y_) <= tolerance &&
           std::abs(WrapAngle(theta_ - other.theta_)) <= tolerance;
  }

 private:
  static void SinCosRatios(double phi, double* sin_ratio, double* cos_ratio) {
    if (std::abs(phi) < 1e-4) {
      const double phi2 = phi * phi;
      *sin_ratio = 1.0 - phi2 / 6.0;
      *cos_ratio = 0.5 * phi * (1.0 - phi2 / 12.0);
    } else {
      *sin_ratio = std::sin(phi) / phi;
      *cos_ratio = (1.0 - std::cos(phi)) / phi;
    }
  }

  double x_ = 0.0;
  double y_ = 0.0;
  double theta_ = 0.0;
};

}  // namespace slamcore
