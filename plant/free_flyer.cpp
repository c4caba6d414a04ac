#include "plant/free_flyer.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "plant/spatial_algebra.hpp"

namespace lagrange {
namespace {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

// Below this angle the coefficients are their Taylor series (the closed forms cancel).
constexpr double kSmallAngle = 1e-2;

Matrix3d Skew(const Vector3d& x) {
  Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}

// V(φ) = 1 + B [φ]× + C [φ]×², B = (1 − cos θ)/θ², C = (θ − sin θ)/θ³.
Matrix3d LeftJacobian(const Vector3d& phi) {
  const double t2 = phi.squaredNorm(), t = std::sqrt(t2);
  const double B = t < kSmallAngle ? 0.5 - t2 / 24.0 + t2 * t2 / 720.0 : (1.0 - std::cos(t)) / t2;
  const double C = t < kSmallAngle ? 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 : (t - std::sin(t)) / (t2 * t);
  const Matrix3d K = Skew(phi);
  return Matrix3d::Identity() + B * K + C * K * K;
}

// V(φ)⁻¹ = 1 − ½ [φ]× + D [φ]×², D = (1 − θ sin θ / (2 (1 − cos θ))) / θ².
Matrix3d InverseLeftJacobian(const Vector3d& phi) {
  const double t2 = phi.squaredNorm(), t = std::sqrt(t2);
  const double D = t < kSmallAngle ? 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
                                   : (1.0 - t * std::sin(t) / (2.0 * (1.0 - std::cos(t)))) / t2;
  const Matrix3d K = Skew(phi);
  return Matrix3d::Identity() - 0.5 * K + D * K * K;
}

Quaterniond QuaternionOf(ConstVecRef q) { return {q[6], q[3], q[4], q[5]}; }

}  // namespace

void Integrate(ConstVecRef q, ConstVecRef v, double h, VecRef out) {
  eigen_assert(q.size() == v.size() + 1 && out.size() == q.size() && "q, out: nq = nv + 1 entries; v: nv");
  const Vector3d phi = h * v.segment<3>(3);
  const double t2 = phi.squaredNorm(), t = std::sqrt(t2);
  // exp([φ]×) as a quaternion: (sin(θ/2) φ/θ, cos(θ/2)).
  const double s = t < kSmallAngle ? 0.5 - t2 / 48.0 + t2 * t2 / 3840.0 : std::sin(0.5 * t) / t;
  const Quaterniond step(std::cos(0.5 * t), s * phi.x(), s * phi.y(), s * phi.z());
  const Quaterniond quat = QuaternionOf(q);
  const Vector3d dp = quat.toRotationMatrix() * (LeftJacobian(phi) * (h * v.head<3>()));
  const Quaterniond next = (quat * step).normalized();
  out.head<3>() = q.head<3>() + dp;
  out.segment<4>(3) = next.coeffs();  // x y z w
  const Eigen::Index n = v.size() - 6;
  out.tail(n) = q.tail(n) + h * v.tail(n);
}

void Difference(ConstVecRef q0, ConstVecRef q1, VecRef v) {
  eigen_assert(q0.size() == q1.size() && v.size() + 1 == q0.size() && "q0, q1: nq = nv + 1 entries; v: nv");
  const Quaterniond quat0 = QuaternionOf(q0);
  Quaterniond rel = quat0.conjugate() * QuaternionOf(q1);
  if (rel.w() < 0.0) rel.coeffs() = -rel.coeffs();  // the shorter way round
  const double s = rel.vec().norm();
  // θ = 2 atan2(s, w); below kSmallAngle² in s, θ / s = 2 / w to round-off.
  const double scale = s < kSmallAngle * kSmallAngle ? 2.0 / rel.w() : 2.0 * std::atan2(s, rel.w()) / s;
  const Vector3d phi = scale * rel.vec();
  const Vector3d dp = quat0.toRotationMatrix().transpose() * (q1.head<3>() - q0.head<3>());
  v.head<3>() = InverseLeftJacobian(phi) * dp;
  v.segment<3>(3) = phi;
  const Eigen::Index n = v.size() - 6;
  v.tail(n) = q1.tail(n) - q0.tail(n);
}

void TwistRate(ConstVecRef xi, ConstVecRef v, VecRef rate) {
  eigen_assert(xi.size() == v.size() && rate.size() == v.size() && "xi, v, rate: nv entries each");
  const spatial::Motion x{xi.segment<3>(3), xi.head<3>()}, w{v.segment<3>(3), v.head<3>()};
  const spatial::Motion xw = spatial::Cross(x, w);
  const spatial::Motion r = w + 0.5 * xw + (1.0 / 12.0) * spatial::Cross(x, xw);
  rate.head<3>() = r.v;
  rate.segment<3>(3) = r.w;
  const Eigen::Index n = v.size() - 6;
  rate.tail(n) = v.tail(n);
}

// cay([φ]×) as a unit quaternion, ∝ (φ/2, 1).
Quaterniond CayleyRotation(const Vector3d& phi) {
  return Quaterniond(1.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
}

// The base's displacement in its own axes: (1 − [φ]×/2)⁻¹ ρ = 4 / (4 + ‖φ‖²) (ρ + ½ φ × ρ + ¼ φ (φ · ρ)).
Vector3d CayleyTranslation(const Vector3d& rho, const Vector3d& phi) {
  return (4.0 / (4.0 + phi.squaredNorm())) * (rho + 0.5 * phi.cross(rho) + 0.25 * phi.dot(rho) * phi);
}

void IntegrateCayley(ConstVecRef q, ConstVecRef xi, VecRef out) {
  eigen_assert(q.size() == xi.size() + 1 && out.size() == q.size() && "q, out: nq = nv + 1 entries; xi: nv");
  const Vector3d rho = xi.head<3>(), phi = xi.segment<3>(3);
  const Quaterniond quat = QuaternionOf(q);
  const Quaterniond step = CayleyRotation(phi);
  const Vector3d dp = quat.toRotationMatrix() * CayleyTranslation(rho, phi);
  const Quaterniond next = (quat * step).normalized();
  out.head<3>() = q.head<3>() + dp;
  out.segment<4>(3) = next.coeffs();  // x y z w
  const Eigen::Index n = xi.size() - 6;
  out.tail(n) = q.tail(n) + xi.tail(n);
}

Eigen::Matrix<double, 6, 1> CayleyMomentum(const Eigen::Matrix<double, 6, 1>& xi,
                                           const Eigen::Matrix<double, 6, 1>& mu) {
  // dcay⁻¹_ξ = [[P, −½ P [ρ]×], [0, P + ¼ φ φᵀ]], P = 1 − ½ [φ]×, rows (linear, angular); its transpose on (f, n).
  const Vector3d rho = xi.head<3>(), phi = xi.tail<3>(), f = mu.head<3>(), n = mu.tail<3>();
  const Vector3d a = f + 0.5 * phi.cross(f);
  Eigen::Matrix<double, 6, 1> out;
  out.head<3>() = a;
  out.tail<3>() = n + 0.5 * phi.cross(n) + 0.25 * phi.dot(n) * phi + 0.5 * rho.cross(a);
  return out;
}

Eigen::Matrix<double, 6, 1> CayleyTransport(const Eigen::Matrix<double, 6, 1>& xi,
                                            const Eigen::Matrix<double, 6, 1>& mu) {
  const Vector3d rho = xi.head<3>(), phi = xi.tail<3>(), f = mu.head<3>(), n = mu.tail<3>();
  // cay([φ]×)ᵀ = 1 + 4 / (4 + ‖φ‖²) (−[φ]× + ½ [φ]×²).
  const Matrix3d K = Skew(phi);
  const Matrix3d Ct = Matrix3d::Identity() + (4.0 / (4.0 + phi.squaredNorm())) * (0.5 * K * K - K);
  Eigen::Matrix<double, 6, 1> out;
  out.head<3>() = Ct * f;
  out.tail<3>() = Ct * (n - CayleyTranslation(rho, phi).cross(f));
  return out;
}

}  // namespace lagrange
