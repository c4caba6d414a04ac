#include "plant/spatial_dynamics.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "plant/eigenvalues.hpp"
#include "plant/spatial_algebra.hpp"
#include "plant/spatial_sincos.hpp"

namespace lagrange {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using spatial::ArticulatedInertia;
using spatial::Cross;
using spatial::CrossStar;
using spatial::Dot;
using spatial::Force;
using spatial::Inertia;
using spatial::Motion;
using spatial::NetForce;
using spatial::RotationTakingZTo;
using spatial::WorldInertia;
using spatial::Xform;

}  // namespace

// The folded model (constant after construction). Frames are the folded body
// frames: body i's axes turned so that its joint axis is z.
struct SpatialModel {
  int n = 0;
  bool chain = true;  // parent[i] = i − 1 for all i: every entry of M and C is on a path
  bool deep = false;  // more than kDeepTreeMeanAncestors ancestors per joint on average
  std::vector<int> parent;
  std::vector<char> revolute;
  // Joint i's fixed placement in its parent's frame: the joint frame's
  // coordinates are E0 (x − r); the joint moves the body frame by Rz(q) or q z.
  std::vector<Matrix3d> E0;
  std::vector<Vector3d> r;
  // Exact zeros of E0, for the world-frame mass matrix's placements
  // (skipping them changes no bit): the identity (kIdentity), a turn about x
  // (0: its row x and column x are e_x, as a URDF origin's roll alone gives),
  // or any (kAny).
  static constexpr int kIdentity = 3, kAny = 4;
  std::vector<int> E0_axis;
  std::vector<Inertia> inertia;       // body inertia about the body origin, body axes
  std::vector<Vector3d> com;          // centre of mass, body frame, m
  std::vector<Matrix3d> inertia_com;  // rotational inertia about the centre of mass, body axes, kg·m²
  std::vector<double> subtree_mass;   // kg
  Vector3d gravity = Vector3d::Zero();
  // Per body, for the world-frame mass matrix, one column per number (n x
  // kBodyColumns, BodyColumn): mass, centre of mass (body axes) and the
  // rotational inertia about it as λ0 1 + a aᵀ + b bᵀ (SymmetricRankTwoOf).
  Eigen::MatrixXd body;
};

// Columns of SpatialModel::body.
enum BodyColumn : int { kMass, kCom = 1, kLambda0 = 4, kFactorA = 5, kFactorB = 8, kBodyColumns = 11 };

// Columns of SpatialScratch::world (n rows each): body i's world axes R_i
// (column-major: R(r, c) in kAxes + 3c + r) and origin o_i, its joint's motion
// axis J_i = (w, v), the composite inertia of its subtree about the world
// origin (first moment h; rotational inertia xx, yy, zz, xy, xz, yz) and
// F_i = Ic_i J_i = (n, f).
enum WorldColumn : int {
  kAxes = 0,
  kOrigin = 9,
  kAxisW = 12,
  kAxisV = 15,
  kMoment = 18,
  kRotational = 21,
  kForceN = 27,
  kForceF = 30,
  kWorldColumns = 33
};

// What the sweeps write, n entries each (H n x n), sized once.
struct SpatialScratch {
  // Local frames: X[i] takes parent coordinates to body i's.
  std::vector<double> cq, sq;  // cos q, sin q
  std::vector<Xform> X;
  std::vector<Motion> v, a, c;
  std::vector<Force> f;
  std::vector<Vector3d> g, h;  // gravity and subtree first moments in body frames
  std::vector<Inertia> Ic;     // composite inertias
  // World frame (C matrix, ABA): body axes R, origin o, joint motion axis J, J̇ = v × J.
  std::vector<Matrix3d> R;
  std::vector<Vector3d> o;
  std::vector<Motion> J, dJ;
  std::vector<Inertia> Idot;  // İ (mass part zero)
  std::vector<Force> hc;      // subtree momenta
  std::vector<ArticulatedInertia> IA;
  std::vector<Force> pA, U;
  std::vector<double> D, u;  // D: 1/D in the ABA
  std::vector<double> H;     // M's lower triangle, row-major n x n, then its Lᵀ D L factors
  Eigen::MatrixXd world;     // the world-frame mass matrix's columns (n x kWorldColumns, WorldColumn)
  // Derivatives (world frame): ∂a_i/∂q_i's column, zeros (qdd = 0, qd = 0).
  std::vector<Motion> dAdq;
  std::vector<double> zeros;
};

struct SpatialDynamics::Data final : DynamicsData {
  explicit Data(const SpatialDynamics& model) : DynamicsData(model) {}
  SpatialScratch s;
};

namespace {

SpatialModel Fold(const RigidTree& tree) {
  SpatialModel m;
  m.n = tree.num_dofs();
  m.gravity = tree.gravity;
  std::vector<Matrix3d> fold(m.n);  // body frame → folded body frame: x_body = fold · x_folded
  for (int i = 0; i < m.n; ++i) {
    const TreeJoint& j = tree.joints[i];
    const RigidBody& b = tree.bodies[i];
    const Matrix3d Fp = j.parent < 0 ? Matrix3d::Identity() : fold[j.parent];
    fold[i] = RotationTakingZTo(j.axis);
    m.parent.push_back(j.parent);
    m.chain = m.chain && j.parent == i - 1;
    m.revolute.push_back(j.type == JointType::kRevolute ? 1 : 0);
    // Joint frame axes in the folded parent frame: Fpᵀ rotation fold.
    m.E0.push_back((Fp.transpose() * j.rotation * fold[i]).transpose());
    m.r.push_back(Fp.transpose() * j.position);
    const Matrix3d& F = fold[i];
    m.com.push_back(F.transpose() * b.com);
    const Matrix3d I = F.transpose() * b.inertia * F;
    m.inertia_com.push_back(0.5 * (I + I.transpose()));  // the part the kinetic energy sees
    m.inertia.push_back(spatial::InertiaFromCom(b.mass, m.com.back(), m.inertia_com.back()));
  }
  for (int i = 0; i < m.n; ++i) {
    const Matrix3d& E = m.E0[i];
    const bool about_x = E(0, 0) == 1.0 && E(0, 1) == 0.0 && E(0, 2) == 0.0 && E(1, 0) == 0.0 && E(2, 0) == 0.0;
    m.E0_axis.push_back(E == Matrix3d::Identity() ? SpatialModel::kIdentity : about_x ? 0 : SpatialModel::kAny);
  }
  int ancestors = 0;
  for (int i = 0; i < m.n; ++i) {
    for (int j = m.parent[i]; j >= 0; j = m.parent[j]) ++ancestors;
  }
  m.deep = ancestors > SpatialDynamics::kDeepTreeMeanAncestors * m.n;
  m.body.resize(m.n, kBodyColumns);
  for (int i = 0; i < m.n; ++i) {
    const SymmetricRankTwo f = SymmetricRankTwoOf(m.inertia_com[i]);
    m.body(i, kMass) = m.inertia[i].m;
    m.body(i, kLambda0) = f.lambda0;
    for (int k = 0; k < 3; ++k) {
      m.body(i, kCom + k) = m.com[i][k];
      m.body(i, kFactorA + k) = f.a[k];
      m.body(i, kFactorB + k) = f.b[k];
    }
  }
  m.subtree_mass.assign(m.n, 0.0);
  for (int i = m.n - 1; i >= 0; --i) {
    m.subtree_mass[i] += m.inertia[i].m;
    if (m.parent[i] >= 0) m.subtree_mass[m.parent[i]] += m.subtree_mass[i];
  }
  return m;
}

void Size(SpatialScratch& s, int n) {
  const auto N = static_cast<std::size_t>(n);
  s.cq.resize(N);
  s.sq.resize(N);
  s.X.resize(N);
  s.v.resize(N);
  s.a.resize(N);
  s.c.resize(N);
  s.f.resize(N);
  s.g.resize(N);
  s.h.resize(N);
  s.Ic.resize(N);
  s.R.resize(N);
  s.o.resize(N);
  s.J.resize(N);
  s.dJ.resize(N);
  s.Idot.resize(N);
  s.hc.resize(N);
  s.IA.resize(N);
  s.pA.resize(N);
  s.U.resize(N);
  s.D.resize(N);
  s.u.resize(N);
  s.H.assign(N * N, 0.0);
  s.world.setZero(n, kWorldColumns);
  s.dAdq.resize(N);
  s.zeros.assign(N, 0.0);
}

// Motion subspace S = (z, 0) for a revolute joint, (0, z) for a prismatic one:
// S_iᵀ f picks one component.
double SubspaceDot(const SpatialModel& m, int i, const Force& f) { return m.revolute[i] ? f.n.z() : f.f.z(); }

// ---- kinematics ---------------------------------------------------------

// q => X_i = (Rz(q)ᵀ E0, r) for a revolute joint, (E0, r + q E0ᵀ z) for a prismatic one.
void Transforms(const SpatialModel& m, SpatialScratch& s, const double* q) {
  spatial::SinCos(q, s.cq.data(), s.sq.data(), m.n);
  for (int i = 0; i < m.n; ++i) {
    const Matrix3d& E0 = m.E0[i];
    Xform& X = s.X[i];
    if (m.revolute[i]) {
      const double cq = s.cq[i], sq = s.sq[i];
      for (int c = 0; c < 3; ++c) {
        X.E(0, c) = cq * E0(0, c) + sq * E0(1, c);
        X.E(1, c) = cq * E0(1, c) - sq * E0(0, c);
        X.E(2, c) = E0(2, c);
      }
      X.p = m.r[i];
    } else {
      X.E = E0;
      X.p = m.r[i] + q[i] * Vector3d(E0(2, 0), E0(2, 1), E0(2, 2));
    }
  }
}

// (X, qd) => v_i = X_i v_λ(i) + S_i qd_i.
void Velocities(const SpatialModel& m, SpatialScratch& s, const double* qd) {
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    Motion& v = s.v[i];
    v = p >= 0 ? s.X[i].Apply(s.v[p]) : Motion{};
    if (m.revolute[i]) {
      v.w.z() += qd[i];
    } else {
      v.v.z() += qd[i];
    }
  }
}

// (X) => world axes R_i, origins o_i and joint motion axes J_i.
void WorldPlacements(const SpatialModel& m, SpatialScratch& s) {
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    const Xform& X = s.X[i];
    if (p >= 0) {
      s.R[i] = spatial::MulABt(s.R[p], X.E);
      s.o[i] = s.o[p] + spatial::Mul(s.R[p], X.p);
    } else {
      s.R[i] = X.E.transpose();
      s.o[i] = X.p;
    }
    const Vector3d z = s.R[i].col(2);
    s.J[i] = m.revolute[i] ? Motion{z, Cross(s.o[i], z)} : Motion{Vector3d::Zero(), z};
  }
}

// İ = v ×* I − I v×, the rate of a world inertia I carried with velocity v:
// (D, ḣ) with ḣ = ω × h + m v, D = A + Aᵀ − (h vᵀ + v hᵀ) + 2 (v · h) 1,
// A = [ω]× Ib; its mass part is zero. Symmetric, like I.
LAGRANGE_SPATIAL_INLINE Inertia InertiaRate(const Inertia& I, const Motion& v) {
  Matrix3d A;
  for (int k = 0; k < 3; ++k) A.col(k) = Cross(v.w, Vector3d(I.Ib.col(k)));
  Matrix3d D;
  const double vh = 2.0 * (v.v.x() * I.h.x() + v.v.y() * I.h.y() + v.v.z() * I.h.z());
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r <= c; ++r) {
      D(r, c) = A(r, c) + A(c, r) - I.h[r] * v.v[c] - v.v[r] * I.h[c];
      D(c, r) = D(r, c);
    }
    D(c, c) += vh;
  }
  return Inertia{0.0, Cross(v.w, I.h) + I.m * v.v, D};
}

// ---- recursive Newton–Euler ---------------------------------------------

// (X, qd, qdd) => f_i = I_i a_i [+ v_i ×* I_i v_i], each body's own net force,
// with a_i = X_i a_λ(i) + [S_i qdd_i] [+ v_i × S_i qd_i] and a_root = [−gravity].
template <bool kGravity, bool kVelocity, bool kAccel>
void RneaForward(const SpatialModel& m, SpatialScratch& s, const double* qd, const double* qdd) {
  const Motion root{Vector3d::Zero(), kGravity ? Vector3d(-m.gravity) : Vector3d::Zero()};
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    const Xform& X = s.X[i];
    Motion& a = s.a[i];
    a = X.Apply(p >= 0 ? s.a[p] : root);
    if (kVelocity) {
      Motion& v = s.v[i];
      v = p >= 0 ? X.Apply(s.v[p]) : Motion{};
      // a += v × S qd (v without its own joint term gives the same product):
      // x × z qd = (x.y, −x.x, 0) qd.
      const double qdi = qd[i];
      if (m.revolute[i]) {
        a.w.x() += v.w.y() * qdi;
        a.w.y() -= v.w.x() * qdi;
        a.v.x() += v.v.y() * qdi;
        a.v.y() -= v.v.x() * qdi;
        v.w.z() += qdi;
      } else {
        a.v.x() += v.w.y() * qdi;
        a.v.y() -= v.w.x() * qdi;
        v.v.z() += qdi;
      }
    }
    if (kAccel) {
      if (m.revolute[i]) {
        a.w.z() += qdd[i];
      } else {
        a.v.z() += qdd[i];
      }
    }
    s.f[i] = NetForce<kVelocity>(m.inertia[i].m, m.com[i], m.inertia_com[i], s.v[i], a);
  }
}

// (X, f) => tau_i = S_iᵀ Σ_{subtree} f, accumulating each f into its parent's.
void RneaBackward(const SpatialModel& m, SpatialScratch& s, double* tau) {
  for (int i = m.n - 1; i >= 0; --i) {
    tau[i] = SubspaceDot(m, i, s.f[i]);
    if (m.parent[i] >= 0) s.f[m.parent[i]] += s.X[i].ApplyTransposed(s.f[i]);
  }
}

// Forward pass of tau = M qdd [+ C qd] [+ G], the terms by `terms`.
void RneaForwardGated(const SpatialModel& m, SpatialScratch& s, const double* qd, const double* qdd,
                      DynamicsTerms terms) {
  if (terms.gravity && terms.coriolis) {
    RneaForward<true, true, true>(m, s, qd, qdd);
  } else if (terms.gravity) {
    RneaForward<true, false, true>(m, s, qd, qdd);
  } else if (terms.coriolis) {
    RneaForward<false, true, true>(m, s, qd, qdd);
  } else {
    RneaForward<false, false, true>(m, s, qd, qdd);
  }
}

// ---- mass matrix ----------------------------------------------------------

// Composite inertias Ic_i of every subtree, in body i's frame (needs X).
void CompositeInertias(const SpatialModel& m, SpatialScratch& s) {
  for (int i = 0; i < m.n; ++i) s.Ic[i] = m.inertia[i];
  for (int i = m.n - 1; i >= 0; --i) {
    if (m.parent[i] >= 0) s.Ic[m.parent[i]] += s.X[i].ApplyTransposed(s.Ic[i]);
  }
}

// Row i of M on its path: M_ij for j = i and each ancestor j, handed to
// add(j, M_ij). F = Ic_i S_i is carried to each ancestor as a force (Xᵀ F) and
// M_ij = S_jᵀ F. Scalars, not vectors: the chain is serial, and vector
// spills and reloads stall it.
template <class Add>
LAGRANGE_SPATIAL_INLINE void MassMatrixRow(const SpatialModel& m, const SpatialScratch& s, int i, Add&& add) {
  const Inertia& Ic = s.Ic[i];
  double nx, ny, nz, fx, fy, fz;
  if (m.revolute[i]) {  // Ic (z, 0) = (Ib z, −h × z)
    nx = Ic.Ib(0, 2), ny = Ic.Ib(1, 2), nz = Ic.Ib(2, 2);
    fx = -Ic.h.y(), fy = Ic.h.x(), fz = 0.0;
    add(i, nz);
  } else {  // Ic (0, z) = (h × z, m z)
    nx = Ic.h.y(), ny = -Ic.h.x(), nz = 0.0;
    fx = 0.0, fy = 0.0, fz = Ic.m;
    add(i, fz);
  }
  for (int j = i; m.parent[j] >= 0;) {
    const Matrix3d& E = s.X[j].E;
    const Vector3d& p = s.X[j].p;
    const double gx = E(0, 0) * fx + E(1, 0) * fy + E(2, 0) * fz;
    const double gy = E(0, 1) * fx + E(1, 1) * fy + E(2, 1) * fz;
    const double gz = E(0, 2) * fx + E(1, 2) * fy + E(2, 2) * fz;
    const double mx = E(0, 0) * nx + E(1, 0) * ny + E(2, 0) * nz + p.y() * gz - p.z() * gy;
    const double my = E(0, 1) * nx + E(1, 1) * ny + E(2, 1) * nz + p.z() * gx - p.x() * gz;
    const double mz = E(0, 2) * nx + E(1, 2) * ny + E(2, 2) * nz + p.x() * gy - p.y() * gx;
    nx = mx, ny = my, nz = mz, fx = gx, fy = gy, fz = gz;
    j = m.parent[j];
    add(j, m.revolute[j] ? nz : fz);
  }
}

// Row i of M by world coordinates: F = Ic_i S_i taken to the world once,
// then M_ij = J_j · F for each ancestor j, independent products instead of a
// serial chain of transforms (needs WorldPlacements).
template <class Add>
LAGRANGE_SPATIAL_INLINE void MassMatrixRowWorld(const SpatialModel& m, const SpatialScratch& s, int i, Add&& add) {
  const Inertia& Ic = s.Ic[i];
  Force F;
  if (m.revolute[i]) {
    F = Force{Ic.Ib.col(2), Vector3d(-Ic.h.y(), Ic.h.x(), 0.0)};
  } else {
    F = Force{Vector3d(Ic.h.y(), -Ic.h.x(), 0.0), Vector3d(0.0, 0.0, Ic.m)};
  }
  add(i, SubspaceDot(m, i, F));
  const Matrix3d& R = s.R[i];
  const Vector3d f = spatial::Mul(R, F.f);
  const Force Fw{spatial::Mul(R, F.n) + Cross(s.o[i], f), f};
  for (int j = m.parent[i]; j >= 0; j = m.parent[j]) add(j, Dot(s.J[j], Fw));
}

// F_j = Ic_j J_j, the force of joint j's world motion J_j = (w, v) on its
// composite inertia Ic_j (mass ms; first moment s = ms c; rotational inertia
// S about the world origin): (S w + s × v, ms v − s × w). Dot(J_i) is M_ij = J_i · F_j.
struct ColumnForce {
  ColumnForce(double sx, double sy, double sz, double sxx, double syy, double szz, double sxy, double sxz, double syz,
              double ms, double w0, double w1, double w2, double v0, double v1, double v2)
      : f0(sxx * w0 + sxy * w1 + sxz * w2 + sy * v2 - sz * v1),
        f1(sxy * w0 + syy * w1 + syz * w2 + sz * v0 - sx * v2),
        f2(sxz * w0 + syz * w1 + szz * w2 + sx * v1 - sy * v0),
        f3(ms * v0 - sy * w2 + sz * w1),
        f4(ms * v1 - sz * w0 + sx * w2),
        f5(ms * v2 - sx * w1 + sy * w0) {}
  double Dot(double wx, double wy, double wz, double vx, double vy, double vz) const {
    return wx * f0 + wy * f1 + wz * f2 + vx * f3 + vy * f4 + vz * f5;
  }
  double f0, f1, f2, f3, f4, f5;
};

// (q, sin q, cos q) => M by the world-frame CRBA (MassMatrixKernel::kWorldFrame),
// in three passes over columns of all bodies (SpatialScratch::world): the
// placements root first (each body's axes from its parent's), each body's
// inertia about the world origin (no dependency between bodies: a loop the
// compiler vectorises), then tip to base the composites as plain sums,
// F_j = Ic_j J_j and M_ij = J_i · F_j for i = j and each joint above j.
void MassMatrixWorldFrame(const SpatialModel& m, SpatialScratch& s, const double* q, MatRef M) {
  const int n = m.n;
  double* W = s.world.data();
  const auto col = [W, n](int k) { return W + static_cast<std::ptrdiff_t>(k) * n; };
  double* R[9];
  for (int k = 0; k < 9; ++k) R[k] = col(kAxes + k);
  double *ox = col(kOrigin), *oy = col(kOrigin + 1), *oz = col(kOrigin + 2);
  double *wx = col(kAxisW), *wy = col(kAxisW + 1), *wz = col(kAxisW + 2);
  double *vx = col(kAxisV), *vy = col(kAxisV + 1), *vz = col(kAxisV + 2);
  // Placements: with P = R_λ E0ᵀ, R_i = P Rz(q) (revolute) or P (prismatic),
  // o_i = o_λ + R_λ r (+ q P e_z, prismatic); J_i = (z, o × z) or (0, z), z = R_i e_z.
  // E0's exact zeros skipped when it is the identity or a turn about x
  // (SpatialModel::E0_axis; a URDF origin's roll alone, as Denavit–Hartenberg
  // robots' joints have).
  for (int i = 0; i < n; ++i) {
    const int p = m.parent[i];
    const Matrix3d& E = m.E0[i];
    const Vector3d& r = m.r[i];
    double p00, p10, p20, p01, p11, p21, p02, p12, p22, o0, o1, o2;  // P column-major, o_i
    if (p < 0) {
      p00 = E(0, 0), p10 = E(0, 1), p20 = E(0, 2), p01 = E(1, 0), p11 = E(1, 1), p21 = E(1, 2);
      p02 = E(2, 0), p12 = E(2, 1), p22 = E(2, 2);
      o0 = r.x(), o1 = r.y(), o2 = r.z();
    } else {
      const double a00 = R[0][p], a10 = R[1][p], a20 = R[2][p], a01 = R[3][p], a11 = R[4][p], a21 = R[5][p];
      const double a02 = R[6][p], a12 = R[7][p], a22 = R[8][p];
      o0 = ox[p] + a00 * r.x() + a01 * r.y() + a02 * r.z();
      o1 = oy[p] + a10 * r.x() + a11 * r.y() + a12 * r.z();
      o2 = oz[p] + a20 * r.x() + a21 * r.y() + a22 * r.z();
      switch (m.E0_axis[i]) {
        case SpatialModel::kIdentity:
          p00 = a00, p10 = a10, p20 = a20, p01 = a01, p11 = a11, p21 = a21, p02 = a02, p12 = a12, p22 = a22;
          break;
        case 0:  // column x kept, y and z mixed
          p00 = a00, p10 = a10, p20 = a20;
          p01 = a01 * E(1, 1) + a02 * E(1, 2), p11 = a11 * E(1, 1) + a12 * E(1, 2), p21 = a21 * E(1, 1) + a22 * E(1, 2);
          p02 = a01 * E(2, 1) + a02 * E(2, 2), p12 = a11 * E(2, 1) + a12 * E(2, 2), p22 = a21 * E(2, 1) + a22 * E(2, 2);
          break;
        default:
          p00 = a00 * E(0, 0) + a01 * E(0, 1) + a02 * E(0, 2);
          p10 = a10 * E(0, 0) + a11 * E(0, 1) + a12 * E(0, 2);
          p20 = a20 * E(0, 0) + a21 * E(0, 1) + a22 * E(0, 2);
          p01 = a00 * E(1, 0) + a01 * E(1, 1) + a02 * E(1, 2);
          p11 = a10 * E(1, 0) + a11 * E(1, 1) + a12 * E(1, 2);
          p21 = a20 * E(1, 0) + a21 * E(1, 1) + a22 * E(1, 2);
          p02 = a00 * E(2, 0) + a01 * E(2, 1) + a02 * E(2, 2);
          p12 = a10 * E(2, 0) + a11 * E(2, 1) + a12 * E(2, 2);
          p22 = a20 * E(2, 0) + a21 * E(2, 1) + a22 * E(2, 2);
          break;
      }
    }
    if (m.revolute[i]) {  // R_i = P Rz(q): columns x and y mixed
      const double c = s.cq[i], sn = s.sq[i];
      const double q00 = c * p00 + sn * p01, q10 = c * p10 + sn * p11, q20 = c * p20 + sn * p21;
      p01 = c * p01 - sn * p00, p11 = c * p11 - sn * p10, p21 = c * p21 - sn * p20;
      p00 = q00, p10 = q10, p20 = q20;
      wx[i] = p02, wy[i] = p12, wz[i] = p22;
      vx[i] = o1 * p22 - o2 * p12, vy[i] = o2 * p02 - o0 * p22, vz[i] = o0 * p12 - o1 * p02;
    } else {
      o0 += q[i] * p02, o1 += q[i] * p12, o2 += q[i] * p22;
      wx[i] = 0.0, wy[i] = 0.0, wz[i] = 0.0;
      vx[i] = p02, vy[i] = p12, vz[i] = p22;
    }
    R[0][i] = p00, R[1][i] = p10, R[2][i] = p20, R[3][i] = p01, R[4][i] = p11, R[5][i] = p21;
    R[6][i] = p02, R[7][i] = p12, R[8][i] = p22;
    ox[i] = o0, oy[i] = o1, oz[i] = o2;
  }
  // Each body's inertia about the world origin: centre of mass c = o + R c_b,
  // h = m c, Ib = R I_c Rᵀ + m (|c|² 1 − c cᵀ) with R I_c Rᵀ = λ0 1 + (R a)(R a)ᵀ + (R b)(R b)ᵀ.
  const double* mass = m.body.col(kMass).data();
  const double *cbx = m.body.col(kCom).data(), *cby = m.body.col(kCom + 1).data(), *cbz = m.body.col(kCom + 2).data();
  const double* l0 = m.body.col(kLambda0).data();
  const double *ax = m.body.col(kFactorA).data(), *ay = m.body.col(kFactorA + 1).data(),
               *az = m.body.col(kFactorA + 2).data();
  const double *bx = m.body.col(kFactorB).data(), *by = m.body.col(kFactorB + 1).data(),
               *bz = m.body.col(kFactorB + 2).data();
  double *hx = col(kMoment), *hy = col(kMoment + 1), *hz = col(kMoment + 2);
  double *Ixx = col(kRotational), *Iyy = col(kRotational + 1), *Izz = col(kRotational + 2);
  double *Ixy = col(kRotational + 3), *Ixz = col(kRotational + 4), *Iyz = col(kRotational + 5);
  const double *R00 = R[0], *R10 = R[1], *R20 = R[2], *R01 = R[3], *R11 = R[4], *R21 = R[5];
  const double *R02 = R[6], *R12 = R[7], *R22 = R[8];
#pragma GCC ivdep
  for (int i = 0; i < n; ++i) {
    const double r00 = R00[i], r10 = R10[i], r20 = R20[i], r01 = R01[i], r11 = R11[i], r21 = R21[i];
    const double r02 = R02[i], r12 = R12[i], r22 = R22[i];
    const double cx = ox[i] + r00 * cbx[i] + r01 * cby[i] + r02 * cbz[i];
    const double cy = oy[i] + r10 * cbx[i] + r11 * cby[i] + r12 * cbz[i];
    const double cz = oz[i] + r20 * cbx[i] + r21 * cby[i] + r22 * cbz[i];
    const double pax = r00 * ax[i] + r01 * ay[i] + r02 * az[i];
    const double pay = r10 * ax[i] + r11 * ay[i] + r12 * az[i];
    const double paz = r20 * ax[i] + r21 * ay[i] + r22 * az[i];
    const double pbx = r00 * bx[i] + r01 * by[i] + r02 * bz[i];
    const double pby = r10 * bx[i] + r11 * by[i] + r12 * bz[i];
    const double pbz = r20 * bx[i] + r21 * by[i] + r22 * bz[i];
    const double mi = mass[i];
    const double gx = mi * cx, gy = mi * cy, gz = mi * cz;
    const double d = l0[i] + gx * cx + gy * cy + gz * cz;
    hx[i] = gx, hy[i] = gy, hz[i] = gz;
    Ixx[i] = d + pax * pax + pbx * pbx - gx * cx;
    Iyy[i] = d + pay * pay + pby * pby - gy * cy;
    Izz[i] = d + paz * paz + pbz * pbz - gz * cz;
    Ixy[i] = pax * pay + pbx * pby - gx * cy;
    Ixz[i] = pax * paz + pbx * pbz - gx * cz;
    Iyz[i] = pay * paz + pby * pbz - gy * cz;
  }
  const double* Ms = m.subtree_mass.data();  // the composites' masses
  if (m.chain) {
    // One sweep tip to base: the composite Ic_j as running sums, F_j = Ic_j J_j
    // = (Ib w + h × v, M v − h × w), then row and column j of M over the joints
    // above: M_ij = J_i · F_j, independent dot products.
    double sx = 0.0, sy = 0.0, sz = 0.0, sxx = 0.0, syy = 0.0, szz = 0.0, sxy = 0.0, sxz = 0.0, syz = 0.0;
    for (int j = n - 1; j >= 0; --j) {
      sx += hx[j], sy += hy[j], sz += hz[j];
      sxx += Ixx[j], syy += Iyy[j], szz += Izz[j], sxy += Ixy[j], sxz += Ixz[j], syz += Iyz[j];
      const ColumnForce f(sx, sy, sz, sxx, syy, szz, sxy, sxz, syz, Ms[j], wx[j], wy[j], wz[j], vx[j], vy[j], vz[j]);
      double* Mj = &M(0, j);
      for (int i = 0; i <= j; ++i) {
        const double Mij = f.Dot(wx[i], wy[i], wz[i], vx[i], vy[i], vz[i]);
        Mj[i] = Mij;
        M(j, i) = Mij;
      }
    }
    return;
  }
  // A tree: the same sweep, each composite complete when it is reached (its
  // descendants come after it) and then added into its parent's.
  for (int j = n - 1; j >= 0; --j) {
    const double sx = hx[j], sy = hy[j], sz = hz[j], sxx = Ixx[j], syy = Iyy[j], szz = Izz[j];
    const double sxy = Ixy[j], sxz = Ixz[j], syz = Iyz[j];
    const ColumnForce f(sx, sy, sz, sxx, syy, szz, sxy, sxz, syz, Ms[j], wx[j], wy[j], wz[j], vx[j], vy[j], vz[j]);
    for (int i = j; i >= 0; i = m.parent[i]) {
      const double Mij = f.Dot(wx[i], wy[i], wz[i], vx[i], vy[i], vz[i]);
      M(i, j) = Mij;
      M(j, i) = Mij;
    }
    const int p = m.parent[j];
    if (p >= 0) {
      hx[p] += sx, hy[p] += sy, hz[p] += sz;
      Ixx[p] += sxx, Iyy[p] += syy, Izz[p] += szz, Ixy[p] += sxy, Ixz[p] += sxz, Iyz[p] += syz;
    }
  }
}

// ---- forward dynamics by composite rigid bodies -----------------------------

// (X, f, tau) => qdd = M⁻¹ (tau − bias), in one backward and one forward sweep.
// Backward, at each k (all of k's descendants done): the bias RNEA step
// (x_k += tau_k − S_kᵀ f_k, f into the parent), k's composite inertia into its
// parent's, row k of M added to H (which holds the updates of the rows below),
// then step k of Featherstone's LTDL factorisation H = Lᵀ D L (no fill-in on a
// tree) and of the solve Lᵀ y = x. Each step's division overlaps the next
// row's arithmetic. Forward: x = L⁻¹ D⁻¹ y. kBias: f holds the bias forces.
template <bool kBias>
void CompositeForwardDynamics(const SpatialModel& m, SpatialScratch& s, const double* tau, double* x) {
  const int n = m.n;
  double* H = s.H.data();
  double* Dinv = s.D.data();
  for (int i = 0; i < n; ++i) {
    x[i] = 0.0;
    s.Ic[i] = m.inertia[i];
    for (int j = 0; j <= i; ++j) H[i * n + j] = 0.0;
  }
  for (int k = n - 1; k >= 0; --k) {
    const int p = m.parent[k];
    const Xform& X = s.X[k];
    x[k] += tau[k];
    if (kBias) {
      x[k] -= SubspaceDot(m, k, s.f[k]);
      if (p >= 0) s.f[p] += X.ApplyTransposed(s.f[k]);
    }
    if (p >= 0) s.Ic[p] += X.ApplyTransposed(s.Ic[k]);
    double* Hk = H + k * n;
    MassMatrixRow(m, s, k, [Hk](int j, double Mkj) { Hk[j] += Mkj; });
    const double inv = 1.0 / Hk[k];
    Dinv[k] = inv;
    if (m.chain) {
      for (int i = k - 1; i >= 0; --i) {
        const double a = Hk[i] * inv;
        double* Hi = H + i * n;
        for (int j = 0; j <= i; ++j) Hi[j] -= a * Hk[j];
        Hk[i] = a;
        x[i] -= a * x[k];
      }
    } else {
      for (int i = p; i >= 0; i = m.parent[i]) {
        const double a = Hk[i] * inv;
        double* Hi = H + i * n;
        for (int j = i; j >= 0; j = m.parent[j]) Hi[j] -= a * Hk[j];
        Hk[i] = a;
        x[i] -= a * x[k];
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    const double* Hi = H + i * n;
    double xi = x[i] * Dinv[i];
    if (m.chain) {
      for (int j = 0; j < i; ++j) xi -= Hi[j] * x[j];
    } else {
      for (int j = m.parent[i]; j >= 0; j = m.parent[j]) xi -= Hi[j] * x[j];
    }
    x[i] = xi;
  }
}

// ---- forward dynamics by articulated bodies -----------------------------------

// (X, qd, tau) => qdd by the articulated-body algorithm in world coordinates,
// where no inertia needs transforming between bodies: a subtree's
// articulated inertia is a plain sum. Forward: world velocities, the bias
// acceleration c = v × J qd and force pA = v ×* I v. Backward: U = IA J,
// D = Jᵀ U, u = tau − Jᵀ pA, then IA − U Uᵀ/D and pA + Ia c + U u/D into the
// parent. Forward: qdd = (u − Uᵀ (a_λ + c))/D, a = a_λ + c + J qdd.
void Aba(const SpatialModel& m, SpatialScratch& s, const double* qd, const double* tau, DynamicsTerms terms,
         double* qdd) {
  using spatial::Mul;
  using spatial::MulT;
  WorldPlacements(m, s);
  ArticulatedInertia* IA = s.IA.data();
  for (int i = 0; i < m.n; ++i) {
    const Inertia I = WorldInertia(m.inertia[i], s.R[i], s.o[i]);
    const Vector3d& h = I.h;
    IA[i].A = I.Ib;
    IA[i].B << 0.0, -h.z(), h.y(), h.z(), 0.0, -h.x(), -h.y(), h.x(), 0.0;
    IA[i].C = I.m * Matrix3d::Identity();
    if (terms.coriolis) {
      const int p = m.parent[i];
      s.v[i] = (p >= 0 ? s.v[p] : Motion{}) + qd[i] * s.J[i];
      s.c[i] = qd[i] * Cross(s.v[i], s.J[i]);
      s.pA[i] = CrossStar(s.v[i], I * s.v[i]);
    } else {
      s.c[i] = Motion{};
      s.pA[i] = Force{};
    }
  }
  for (int i = m.n - 1; i >= 0; --i) {
    const Motion& J = s.J[i];
    const ArticulatedInertia& Ii = IA[i];
    const Force U{Mul(Ii.A, J.w) + Mul(Ii.B, J.v), MulT(Ii.B, J.w) + Mul(Ii.C, J.v)};
    const double Dinv = 1.0 / Dot(J, U);
    s.U[i] = U;
    s.D[i] = Dinv;
    s.u[i] = tau[i] - Dot(J, s.pA[i]);
    const int p = m.parent[i];
    if (p < 0) continue;
    // Ia = IA − U Uᵀ/D into the parent's, block by block.
    const Vector3d un = Dinv * U.n, uf = Dinv * U.f;
    ArticulatedInertia& Ip = IA[p];
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r <= c; ++r) {
        const double a = Ii.A(r, c) - un[r] * U.n[c];
        const double cc = Ii.C(r, c) - uf[r] * U.f[c];
        Ip.A(r, c) += a;
        Ip.C(r, c) += cc;
        if (r != c) {
          Ip.A(c, r) += a;
          Ip.C(c, r) += cc;
        }
      }
      for (int r = 0; r < 3; ++r) Ip.B(r, c) += Ii.B(r, c) - un[r] * U.f[c];
    }
    // pa = pA + Ia c + U u/D, with Ia c = IA c − U (Uᵀ c)/D.
    const Motion& c = s.c[i];
    const double k = s.u[i] * Dinv - (Dinv * Dot(c, U));
    s.pA[p] += s.pA[i] + Force{Mul(Ii.A, c.w) + Mul(Ii.B, c.v) + k * U.n, MulT(Ii.B, c.w) + Mul(Ii.C, c.v) + k * U.f};
  }
  const Motion root{Vector3d::Zero(), terms.gravity ? Vector3d(-m.gravity) : Vector3d::Zero()};
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    const Motion a = (p >= 0 ? s.a[p] : root) + s.c[i];
    qdd[i] = (s.u[i] - Dot(a, s.U[i])) * s.D[i];
    s.a[i] = a + qdd[i] * s.J[i];
  }
}

// ---- derivatives of inverse dynamics ---------------------------------------

// (X, qd, qdd) => ∂tau/∂q, ∂tau/∂qd, M = ∂tau/∂qdd in world coordinates, one
// forward and one backward sweep (the structure of Carpentier and Mansard,
// RSS 2018, derived here for this algebra). Turning q_j moves the subtree of
// j rigidly with the screw J_j, so every world quantity of a body k at or
// below j changes as it would moving with velocity J_j, except where it
// depends on the ancestors of j (their velocity and acceleration):
//   ∂J_k/∂q_j = J_j × J_k,  ∂I_k/∂q_j = J_j ×* I_k − I_k J_j×,
//   ∂v_k/∂q_j = J_j × v_k + J̇_j,
//   ∂a_k/∂q_j = J_j × a_k + ψ_j + J̇_j × v_k,
// with J̇_j = v_λ(j) × J_j and ψ_j = a_λ(j) × J_j + v_λ(j) × J̇_j; and
// ∂v_k/∂qd_j = J_j, ∂a_k/∂qd_j = 2 J̇_j + J_j × v_k. With f_k = I_k a_k +
// v_k ×* I_k v_k, the subtree sums F, Ic, İc = Σ (v ×* I − I v×), momentum hc,
// and Ω x = İc x + x ×* hc (Ωᵀ x = İc x − x ×* hc), the J_j ×* terms of
// ∂F_i cancel against ∂J_i in tau_i = J_i · F_i, leaving, for j at or above i,
//   ∂tau_i/∂q_j  = (Ic_i J_i) · ψ_j + (Ωᵀ_i J_i) · J̇_j
//   ∂tau_j/∂q_i  = J_j · (J_i ×* F_i + Ic_i ψ_i + Ω_i J̇_i)
//   ∂tau_i/∂qd_j = (Ic_i J_i) · 2 J̇_j + (Ωᵀ_i J_i) · J_j
//   ∂tau_j/∂qd_i = J_j · (2 Ic_i J̇_i + Ω_i J_i)
//   M_ij         = J_j · (Ic_i J_i)
// and zero where i and j are on different branches (left untouched: the
// caller zeroes them). The backward sweep fills row and column i against
// each ancestor: a handful of 6-D dot products per pair. kVelocity false: qd
// = 0 (no velocity terms, ∂tau/∂qd untouched), as for G or without Coriolis.
template <bool kVelocity>
void RneaDerivatives(const SpatialModel& m, SpatialScratch& s, const double* qd, const double* qdd, bool gravity,
                     MatRef dq, MatRef dqd, MatRef M) {
  WorldPlacements(m, s);
  const Motion root{Vector3d::Zero(), gravity ? Vector3d(-m.gravity) : Vector3d::Zero()};
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    const Motion& J = s.J[i];
    const Motion& ap = p >= 0 ? s.a[p] : root;
    const Inertia I = WorldInertia(m.inertia[i], s.R[i], s.o[i]);
    s.Ic[i] = I;
    if (kVelocity) {
      const Motion vp = p >= 0 ? s.v[p] : Motion{};
      const Motion dJ = Cross(vp, J);
      s.dJ[i] = dJ;
      s.v[i] = vp + qd[i] * J;
      s.a[i] = ap + qdd[i] * J + qd[i] * dJ;
      s.dAdq[i] = Cross(ap, J) + Cross(vp, dJ);
      const Force h = I * s.v[i];
      s.hc[i] = h;
      s.Idot[i] = InertiaRate(I, s.v[i]);
      s.f[i] = I * s.a[i] + CrossStar(s.v[i], h);
    } else {
      s.a[i] = ap + qdd[i] * J;
      s.dAdq[i] = Cross(ap, J);
      s.f[i] = I * s.a[i];
    }
  }
  for (int i = m.n - 1; i >= 0; --i) {
    const Motion& J = s.J[i];
    const Inertia& Ic = s.Ic[i];
    const Force U = Ic * J;
    Force Q = CrossStar(J, s.f[i]) + Ic * s.dAdq[i];
    Force W, R;  // Ωᵀ J and 2 Ic J̇ + Ω J
    if (kVelocity) {
      const Motion& dJ = s.dJ[i];
      const Force IdJ = s.Idot[i] * J;
      const Force Jh = CrossStar(J, s.hc[i]);
      W = IdJ - Jh;
      R = 2.0 * (Ic * dJ) + IdJ + Jh;
      Q += s.Idot[i] * dJ + CrossStar(dJ, s.hc[i]);
    }
    M(i, i) = Dot(J, U);
    dq(i, i) = Dot(J, Q);
    if (kVelocity) dqd(i, i) = Dot(J, R);
    for (int j = m.parent[i]; j >= 0; j = m.parent[j]) {
      const Motion& Jj = s.J[j];
      const double Mij = Dot(Jj, U);
      M(i, j) = Mij;
      M(j, i) = Mij;
      dq(j, i) = Dot(Jj, Q);
      if (kVelocity) {
        dq(i, j) = Dot(s.dAdq[j], U) + Dot(s.dJ[j], W);
        dqd(j, i) = Dot(Jj, R);
        dqd(i, j) = 2.0 * Dot(s.dJ[j], U) + Dot(Jj, W);
      } else {
        dq(i, j) = Dot(s.dAdq[j], U);
      }
    }
    const int p = m.parent[i];
    if (p >= 0) {
      s.Ic[p] += Ic;
      s.f[p] += s.f[i];
      if (kVelocity) {
        s.Idot[p] += s.Idot[i];
        s.hc[p] += s.hc[i];
      }
    }
  }
}

}  // namespace

SpatialDynamics::SpatialDynamics(RigidTree tree) : Dynamics(tree.joint_types()), tree_(std::move(tree)) {
  if (auto error = ValidateRigidTree(tree_)) throw std::invalid_argument("SpatialDynamics: " + *error);
  if (tree_.has_mimics()) {
    throw std::invalid_argument(
        "SpatialDynamics: a tree with mimic joints (run it as WithEveryJointFree() under MimicDynamics)");
  }
  model_ = std::make_unique<const SpatialModel>(Fold(tree_));
  forward_ = model_->deep ? ForwardAlgorithm::kArticulatedBody : ForwardAlgorithm::kCompositeRigidBody;
  mass_kernel_ = model_->chain || model_->deep ? MassMatrixKernel::kWorldFrame : MassMatrixKernel::kBodyFrame;
}

SpatialDynamics::~SpatialDynamics() = default;

std::unique_ptr<DynamicsData> SpatialDynamics::MakeData() const {
  auto data = std::make_unique<Data>(*this);
  Size(data->s, num_dofs());
  return data;
}

void SpatialDynamics::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  ComputeMassMatrix(data, mass_kernel_, q, M);
}

void SpatialDynamics::ComputeMassMatrix(DynamicsData& data, MassMatrixKernel kernel, ConstVecRef q, MatRef M) const {
  SpatialScratch& s = Checked<Data>(data, q, M).s;
  const SpatialModel& m = *model_;
  if (!m.chain) M.setZero();
  if (kernel == MassMatrixKernel::kWorldFrame) {
    spatial::SinCos(q.data(), s.cq.data(), s.sq.data(), m.n);
    MassMatrixWorldFrame(m, s, q.data(), M);
    return;
  }
  Transforms(m, s, q.data());
  if (m.deep) {
    CompositeInertias(m, s);
    WorldPlacements(m, s);
    for (int i = 0; i < m.n; ++i) {
      MassMatrixRowWorld(m, s, i, [&M, i](int j, double Mij) {
        M(i, j) = Mij;
        M(j, i) = Mij;
      });
    }
    return;
  }
  CompositeInertias(m, s);
  for (int i = 0; i < m.n; ++i) {
    MassMatrixRow(m, s, i, [&M, i](int j, double Mij) {
      M(i, j) = Mij;
      M(j, i) = Mij;
    });
  }
}

// World coordinates. With, for each body b, İ_b = v_b ×* I_b − I_b v_b× and
// the Christoffel operator B_b = ½ (İ_b + (I_b v_b)×̄*), where (h×̄*) u = u ×* h,
// C = Σ_b J_bᵀ (I_b J̇_b + B_b J_b) (Echeandia & Wensing 2021; Pinocchio's
// computeCoriolisMatrix). Summed over subtrees, entry by entry:
//   C_ki = J_k · (Ic_i J̇_i + Bc_i J_i)            k = i or an ancestor of i
//   C_ik = J̇_k · (Ic_i J_i) + J_k · (Bc_iᵀ J_i)     k an ancestor of i
// with Bc J = ½ İc J + ½ J ×* hc and Bcᵀ J = ½ İc J − ½ J ×* hc (İc symmetric,
// hc the subtree's momentum): one forward sweep (I, İ, I v per body), one
// backward sweep accumulating Ic, İc, hc and filling row and column i.
void SpatialDynamics::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, C).s;
  const SpatialModel& m = *model_;
  if (!m.chain) C.setZero();
  Transforms(m, s, q.data());
  WorldPlacements(m, s);
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    const Motion& J = s.J[i];
    s.v[i] = (p >= 0 ? s.v[p] : Motion{}) + qd[i] * J;
    const Motion& v = s.v[i];
    s.dJ[i] = Cross(v, J);
    const Inertia I = WorldInertia(m.inertia[i], s.R[i], s.o[i]);
    s.Ic[i] = I;
    s.hc[i] = I * v;
    s.Idot[i] = InertiaRate(I, v);
  }
  for (int i = m.n - 1; i >= 0; --i) {
    const Motion& J = s.J[i];
    const Force P = s.Ic[i] * J;
    const Force Y = 0.5 * (s.Idot[i] * J);
    const Force Z = 0.5 * CrossStar(J, s.hc[i]);
    const Force F = s.Ic[i] * s.dJ[i] + Y + Z;
    const Force Q = Y - Z;
    C(i, i) = Dot(J, F);
    for (int k = m.parent[i]; k >= 0; k = m.parent[k]) {
      C(k, i) = Dot(s.J[k], F);
      C(i, k) = Dot(s.dJ[k], P) + Dot(s.J[k], Q);
    }
    const int p = m.parent[i];
    if (p >= 0) {
      s.Ic[p] += s.Ic[i];
      s.Idot[p] += s.Idot[i];
      s.hc[p] += s.hc[i];
    }
  }
}

void SpatialDynamics::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, c).s;
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  RneaForward<false, true, false>(m, s, qd.data(), nullptr);
  RneaBackward(m, s, c.data());
}

// G_i = −S_iᵀ (subtree gravity wrench about joint i): −z · (h_i × g_i) for a
// revolute joint, −m_i z · g_i for a prismatic one, with h_i, m_i the
// subtree's first moment and mass and g_i gravity in body i's frame.
void SpatialDynamics::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  SpatialScratch& s = Checked<Data>(data, q, G).s;
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  for (int i = 0; i < m.n; ++i) {
    const int p = m.parent[i];
    s.g[i] = spatial::Mul(s.X[i].E, p >= 0 ? s.g[p] : m.gravity);
    s.h[i] = m.inertia[i].h;
  }
  for (int i = m.n - 1; i >= 0; --i) {
    const Vector3d& h = s.h[i];
    const Vector3d& g = s.g[i];
    G[i] = m.revolute[i] ? h.y() * g.x() - h.x() * g.y() : -m.subtree_mass[i] * g.z();
    const int p = m.parent[i];
    if (p >= 0) s.h[p] += spatial::MulT(s.X[i].E, h) + m.subtree_mass[i] * s.X[i].p;
  }
}

// ∂T/∂q_i = (v_i × S_i) · H_i with H_i the subtree's momentum in body i's frame.
void SpatialDynamics::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                   VecRef dTdq) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, dTdq).s;
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  Velocities(m, s, qd.data());
  for (int i = 0; i < m.n; ++i) s.f[i] = m.inertia[i] * s.v[i];
  for (int i = m.n - 1; i >= 0; --i) {
    const Vector3d& w = s.v[i].w;
    const Vector3d& v = s.v[i].v;
    const Force& H = s.f[i];
    // v × S: revolute ((w.y, −w.x, 0), (v.y, −v.x, 0)), prismatic (0, (w.y, −w.x, 0)).
    dTdq[i] = m.revolute[i] ? w.y() * H.n.x() - w.x() * H.n.y() + v.y() * H.f.x() - v.x() * H.f.y()
                            : w.y() * H.f.x() - w.x() * H.f.y();
    const int p = m.parent[i];
    if (p >= 0) s.f[p] += s.X[i].ApplyTransposed(H);
  }
}

double SpatialDynamics::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  SpatialScratch& s = Checked<Data>(data, q, qd).s;
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  Velocities(m, s, qd.data());
  double T = 0.0;
  for (int i = 0; i < m.n; ++i) T += Dot(s.v[i], m.inertia[i] * s.v[i]);
  return 0.5 * T;
}

// V = −gravity · Σ m c: the subtree first moments carried to the world origin.
double SpatialDynamics::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  SpatialScratch& s = Checked<Data>(data, q).s;
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  for (int i = 0; i < m.n; ++i) s.h[i] = m.inertia[i].h;
  Vector3d world = Vector3d::Zero();
  for (int i = m.n - 1; i >= 0; --i) {
    const Vector3d h = spatial::MulT(s.X[i].E, s.h[i]) + m.subtree_mass[i] * s.X[i].p;
    if (m.parent[i] >= 0) {
      s.h[m.parent[i]] += h;
    } else {
      world += h;
    }
  }
  return -m.gravity.dot(world);
}

void SpatialDynamics::ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                             DynamicsTerms terms, VecRef tau) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, qdd, tau).s;
  if (terms.gravity) CountGravity(data);
  if (terms.coriolis) CountCoriolis(data);
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  RneaForwardGated(m, s, qd.data(), qdd.data(), terms);
  RneaBackward(m, s, tau.data());
}

void SpatialDynamics::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                             DynamicsTerms terms, VecRef qdd) const {
  ComputeForwardDynamics(data, forward_, q, qd, tau, terms, qdd);
}

void SpatialDynamics::ComputeForwardDynamics(DynamicsData& data, ForwardAlgorithm algorithm, ConstVecRef q,
                                             ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms, VecRef qdd) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, tau, qdd).s;
  if (terms.gravity) CountGravity(data);
  if (terms.coriolis) CountCoriolis(data);
  const SpatialModel& m = *model_;
  Transforms(m, s, q.data());
  if (algorithm == ForwardAlgorithm::kArticulatedBody) {
    Aba(m, s, qd.data(), tau.data(), terms, qdd.data());
    return;
  }
  // Bias forces [C qd] + [G] by the RNEA forward pass with qdd = 0.
  if (terms.gravity && terms.coriolis) {
    RneaForward<true, true, false>(m, s, qd.data(), nullptr);
  } else if (terms.gravity) {
    RneaForward<true, false, false>(m, s, qd.data(), nullptr);
  } else if (terms.coriolis) {
    RneaForward<false, true, false>(m, s, qd.data(), nullptr);
  } else {
    CompositeForwardDynamics<false>(m, s, tau.data(), qdd.data());
    return;
  }
  CompositeForwardDynamics<true>(m, s, tau.data(), qdd.data());
}

}  // namespace lagrange

namespace lagrange {

void SpatialDynamics::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                        ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                        MatRef dtau_dqd, MatRef dtau_dqdd) const {
  SpatialScratch& s = Checked<Data>(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd).s;
  CountTerms(data, terms);
  const SpatialModel& m = *model_;
  if (!m.chain) {
    dtau_dq.setZero();
    dtau_dqd.setZero();
    dtau_dqdd.setZero();
  }
  Transforms(m, s, q.data());
  if (terms.coriolis) {
    RneaDerivatives<true>(m, s, qd.data(), qdd.data(), terms.gravity, dtau_dq, dtau_dqd, dtau_dqdd);
  } else {
    RneaDerivatives<false>(m, s, nullptr, qdd.data(), terms.gravity, dtau_dq, dtau_dqd, dtau_dqdd);
    dtau_dqd.setZero();
  }
}

void SpatialDynamics::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  SpatialScratch& s = Checked<Data>(data, q, dG_dq).s;
  const SpatialModel& m = *model_;
  if (!m.chain) dG_dq.setZero();
  Transforms(m, s, q.data());
  Eigen::Map<MatrixXd> unused(s.H.data(), m.n, m.n);  // M, not asked for
  RneaDerivatives<false>(m, s, nullptr, s.zeros.data(), true, dG_dq, unused, unused);
}

}  // namespace lagrange
