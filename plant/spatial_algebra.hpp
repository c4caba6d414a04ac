#pragma once
// Spatial (Plücker) algebra in 3-D for plant/spatial_dynamics, Featherstone's
// vocabulary (Rigid Body Dynamics Algorithms, ch. 2) on fixed-size 3-vectors:
//
//   Motion  m = (w, v)  angular velocity (rad/s) and the velocity of the point
//                       at the frame origin (m/s); or the matching accelerations
//   Force   f = (n, f)  moment about the frame origin (N·m) and force (N)
//   Inertia I = (m, h, Ib)  mass (kg), first moment h = m c (kg·m, c the centre
//                       of mass), rotational inertia about the frame origin
//                       Ib = I_c − m [c]×² (kg·m²); I (w, v) = (Ib w + h × v, m v − h × w)
//   Xform   X = (E, p)  from a parent frame to a child frame whose origin is p
//                       (parent coordinates) and whose coordinates are E (x − p)
//
//   X m     = (E w, E (v − p × w))               motion, parent → child
//   Xᵀ f    = (Eᵀ n + p × Eᵀ f, Eᵀ f)            force, child → parent
//   m1 × m2 = (w1 × w2, w1 × v2 + v1 × w2)       motion cross motion
//   m ×* f  = (w × n + v × f, w × f)             motion cross force
//   m · f   = w · n + v · f                      power
//
// Shared by the fixed-base (plant/spatial_dynamics) and floating-base
// (plant/floating_dynamics) sweeps: RotationTakingZTo (a joint's folding),
// WorldInertia (a body's inertia in world axes) and NetForce (Newton–Euler at
// the centre of mass).
//
// Everything is inline and allocation-free.

#include <Eigen/Core>

// The sweeps call these per body; inlining them is most of their speed.
#if defined(__GNUC__)
#define LAGRANGE_SPATIAL_INLINE inline __attribute__((always_inline))
#else
#define LAGRANGE_SPATIAL_INLINE inline
#endif

namespace lagrange::spatial {

using Eigen::Matrix3d;
using Eigen::Vector3d;

struct Motion {
  Vector3d w = Vector3d::Zero();
  Vector3d v = Vector3d::Zero();
};

struct Force {
  Vector3d n = Vector3d::Zero();
  Vector3d f = Vector3d::Zero();
};

// ---- 3-vectors and 3x3 matrices, written out so that they always inline ----

LAGRANGE_SPATIAL_INLINE Vector3d Cross(const Vector3d& a, const Vector3d& b) {
  return {a.y() * b.z() - a.z() * b.y(), a.z() * b.x() - a.x() * b.z(), a.x() * b.y() - a.y() * b.x()};
}
// E x.
LAGRANGE_SPATIAL_INLINE Vector3d Mul(const Matrix3d& E, const Vector3d& x) {
  return {E(0, 0) * x.x() + E(0, 1) * x.y() + E(0, 2) * x.z(), E(1, 0) * x.x() + E(1, 1) * x.y() + E(1, 2) * x.z(),
          E(2, 0) * x.x() + E(2, 1) * x.y() + E(2, 2) * x.z()};
}
// Eᵀ x.
LAGRANGE_SPATIAL_INLINE Vector3d MulT(const Matrix3d& E, const Vector3d& x) {
  return {E(0, 0) * x.x() + E(1, 0) * x.y() + E(2, 0) * x.z(), E(0, 1) * x.x() + E(1, 1) * x.y() + E(2, 1) * x.z(),
          E(0, 2) * x.x() + E(1, 2) * x.y() + E(2, 2) * x.z()};
}
// A B.
LAGRANGE_SPATIAL_INLINE Matrix3d MulAB(const Matrix3d& A, const Matrix3d& B) {
  Matrix3d C;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) C(r, c) = A(r, 0) * B(0, c) + A(r, 1) * B(1, c) + A(r, 2) * B(2, c);
  }
  return C;
}
// A Bᵀ.
LAGRANGE_SPATIAL_INLINE Matrix3d MulABt(const Matrix3d& A, const Matrix3d& B) {
  Matrix3d C;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) C(r, c) = A(r, 0) * B(c, 0) + A(r, 1) * B(c, 1) + A(r, 2) * B(c, 2);
  }
  return C;
}
// Eᵀ S E for a symmetric S: T = S E, then the upper triangle of Eᵀ T, mirrored.
LAGRANGE_SPATIAL_INLINE Matrix3d Congruence(const Matrix3d& E, const Matrix3d& S) {
  const Matrix3d T = MulAB(S, E);
  Matrix3d C;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r <= c; ++r) {
      C(r, c) = E(0, r) * T(0, c) + E(1, r) * T(1, c) + E(2, r) * T(2, c);
      C(c, r) = C(r, c);
    }
  }
  return C;
}

// ---- spatial vectors ----

LAGRANGE_SPATIAL_INLINE Motion operator+(const Motion& a, const Motion& b) { return {a.w + b.w, a.v + b.v}; }
LAGRANGE_SPATIAL_INLINE Motion operator-(const Motion& a, const Motion& b) { return {a.w - b.w, a.v - b.v}; }
LAGRANGE_SPATIAL_INLINE Motion operator*(double s, const Motion& a) { return {s * a.w, s * a.v}; }
LAGRANGE_SPATIAL_INLINE Motion& operator+=(Motion& a, const Motion& b) {
  a.w += b.w;
  a.v += b.v;
  return a;
}
LAGRANGE_SPATIAL_INLINE Force operator+(const Force& a, const Force& b) { return {a.n + b.n, a.f + b.f}; }
LAGRANGE_SPATIAL_INLINE Force operator-(const Force& a, const Force& b) { return {a.n - b.n, a.f - b.f}; }
LAGRANGE_SPATIAL_INLINE Force operator*(double s, const Force& a) { return {s * a.n, s * a.f}; }
LAGRANGE_SPATIAL_INLINE Force& operator+=(Force& a, const Force& b) {
  a.n += b.n;
  a.f += b.f;
  return a;
}

LAGRANGE_SPATIAL_INLINE Motion Cross(const Motion& a, const Motion& b) {
  return {Cross(a.w, b.w), Cross(a.w, b.v) + Cross(a.v, b.w)};
}
LAGRANGE_SPATIAL_INLINE Force CrossStar(const Motion& a, const Force& f) {
  return {Cross(a.w, f.n) + Cross(a.v, f.f), Cross(a.w, f.f)};
}
LAGRANGE_SPATIAL_INLINE double Dot(const Motion& m, const Force& f) {
  return m.w.x() * f.n.x() + m.w.y() * f.n.y() + m.w.z() * f.n.z() + m.v.x() * f.f.x() + m.v.y() * f.f.y() +
         m.v.z() * f.f.z();
}

// a × (0, 0, 1) = (a.y, −a.x, 0).
LAGRANGE_SPATIAL_INLINE Vector3d CrossZ(const Vector3d& a) { return {a.y(), -a.x(), 0.0}; }

struct Inertia {
  double m = 0.0;
  Vector3d h = Vector3d::Zero();
  Matrix3d Ib = Matrix3d::Zero();  // symmetric

  LAGRANGE_SPATIAL_INLINE Force operator*(const Motion& a) const {
    return {Mul(Ib, a.w) + Cross(h, a.v), m * a.v - Cross(h, a.w)};
  }
  LAGRANGE_SPATIAL_INLINE Inertia& operator+=(const Inertia& o) {
    m += o.m;
    h += o.h;
    Ib += o.Ib;
    return *this;
  }
};

// (m, c, I_c about the centre of mass) => the inertia about the frame origin.
LAGRANGE_SPATIAL_INLINE Inertia InertiaFromCom(double m, const Vector3d& c, const Matrix3d& Ic) {
  // −m [c]×² = m (|c|² 1 − c cᵀ)
  Matrix3d Ib = Ic - m * c * c.transpose();
  Ib.diagonal().array() += m * c.squaredNorm();
  return {m, m * c, Ib};
}

// An articulated-body inertia: a symmetric 6x6 in blocks, (w, v) ↦ (A w + B v, Bᵀ w + C v).
struct ArticulatedInertia {
  Matrix3d A, B, C;  // A, C symmetric
};

struct Xform {
  Matrix3d E = Matrix3d::Identity();
  Vector3d p = Vector3d::Zero();

  LAGRANGE_SPATIAL_INLINE Motion Apply(const Motion& a) const { return {Mul(E, a.w), Mul(E, a.v + Cross(a.w, p))}; }
  LAGRANGE_SPATIAL_INLINE Force ApplyTransposed(const Force& a) const {
    const Vector3d f = MulT(E, a.f);
    return {MulT(E, a.n) + Cross(p, f), f};
  }
  // Xᵀ I X: a child-frame inertia in the parent frame. With ho = Eᵀ h and
  // k = ho + ½ m p: Ib' = Eᵀ Ib E − (k pᵀ + p kᵀ) + 2 (p · k) 1, h' = ho + m p.
  LAGRANGE_SPATIAL_INLINE Inertia ApplyTransposed(const Inertia& I) const {
    const Vector3d ho = MulT(E, I.h);
    const Vector3d k = ho + 0.5 * I.m * p;
    Matrix3d Ib = Congruence(E, I.Ib);
    const double d = 2.0 * (p.x() * k.x() + p.y() * k.y() + p.z() * k.z());
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r <= c; ++r) {
        Ib(r, c) -= k[r] * p[c] + p[r] * k[c];
        Ib(c, r) = Ib(r, c);
      }
      Ib(c, c) += d;
    }
    return {I.m, ho + I.m * p, Ib};
  }
};

// A rotation whose third column is the unit vector a: a joint's folding.
inline Matrix3d RotationTakingZTo(const Vector3d& a) {
  // Start from the coordinate axis least aligned with a.
  Vector3d h = Vector3d::Zero();
  int k = 0;
  a.cwiseAbs().minCoeff(&k);
  h[k] = 1.0;
  const Vector3d x = (h - h.dot(a) * a).normalized();
  Matrix3d R;
  R.col(0) = x;
  R.col(1) = Cross(a, x);
  R.col(2) = a;
  return R;
}

// Body i's inertia in world coordinates, about the world origin: rotate by R,
// shift by o (as Xform::ApplyTransposed with E = Rᵀ, p = o).
LAGRANGE_SPATIAL_INLINE Inertia WorldInertia(const Inertia& I, const Matrix3d& R, const Vector3d& o) {
  const Vector3d ho = Mul(R, I.h);
  const Vector3d k = ho + 0.5 * I.m * o;
  const Matrix3d T = MulAB(R, I.Ib);
  const double d = 2.0 * (o.x() * k.x() + o.y() * k.y() + o.z() * k.z());
  Matrix3d Ib;
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r <= c; ++r) {
      Ib(r, c) = T(r, 0) * R(c, 0) + T(r, 1) * R(c, 1) + T(r, 2) * R(c, 2) - (k[r] * o[c] + o[r] * k[c]);
      Ib(c, r) = Ib(r, c);
    }
    Ib(c, c) += d;
  }
  return {I.m, ho + I.m * o, Ib};
}

// The net force on a body, f = I a + v ×* I v, by Newton and Euler at its
// centre of mass c (fewer products than the spatial form): with the spatial
// acceleration a = (ω̇, a_o), the centre of mass accelerates at
// a_c = a_o + ω̇ × c + ω × (v_o + ω × c), F = m a_c, and n = I_c ω̇ + ω × I_c ω + c × F.
template <bool kVelocity>
LAGRANGE_SPATIAL_INLINE Force NetForce(double mass, const Vector3d& c, const Matrix3d& Ic, const Motion& v,
                                       const Motion& a) {
  Vector3d ac = a.v + Cross(a.w, c);
  Vector3d n = Mul(Ic, a.w);
  if (kVelocity) {
    ac += Cross(v.w, v.v + Cross(v.w, c));
    n += Cross(v.w, Mul(Ic, v.w));
  }
  const Vector3d F = mass * ac;
  return {n + Cross(c, F), F};
}

}  // namespace lagrange::spatial
