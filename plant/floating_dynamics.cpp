#include "plant/floating_dynamics.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <utility>

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
using spatial::Mul;
using spatial::MulT;
using spatial::Xform;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// A⁻¹ b for a symmetric positive definite 6 x 6 A, by Cholesky written out
// (Eigen's LLT costs this file's compile time several seconds).
Vector6d SolveSpd(Matrix6d A, Vector6d b) {
  for (int k = 0; k < 6; ++k) {
    A(k, k) = std::sqrt(A(k, k) - A.row(k).head(k).squaredNorm());
    for (int r = k + 1; r < 6; ++r) A(r, k) = (A(r, k) - A.row(r).head(k).dot(A.row(k).head(k))) / A(k, k);
  }
  for (int r = 0; r < 6; ++r) b[r] = (b[r] - A.row(r).head(r).dot(b.head(r))) / A(r, r);  // L y = b
  for (int r = 5; r >= 0; --r) b[r] = (b[r] - A.col(r).tail(5 - r).dot(b.tail(5 - r))) / A(r, r);  // Lᵀ x = y
  return b;
}

}  // namespace

// Index 0 is the base, index i + 1 joint i's body.
struct FloatingData::Scratch {
  std::vector<double> qj, cq, sq;  // joint angles (or displacements) through the mimic maps, cos, sin
  std::vector<Xform> X;            // parent (the world for the base) → body coordinates
  std::vector<Matrix3d> R;         // folded body axes in the world
  std::vector<Vector3d> o;         // body origin in the world, m
  // Body coordinates (RNEA, kinematics) or world axes at the base origin (ABA):
  std::vector<Motion> v, a, c;  // velocity, acceleration, v × S qd
  std::vector<Motion> J;        // ABA: joint motion axes
  std::vector<Force> f;
  std::vector<Inertia> Ic;                     // composite inertias
  std::vector<ArticulatedInertia> IA;          // articulated inertias
  std::vector<Force> pA, U;                    // articulated bias forces, IA J
  std::vector<double> D, u;                    // D: 1 / Jᵀ IA J
  Eigen::Matrix<double, 6, Eigen::Dynamic> A;  // (6 x nv) A_G, for the centre of mass's Jacobian
  VectorXd zero_v, tau_v;                      // (nv) a = 0 and the drift's generalized force, for Ȧ_G v
  MatrixXd M;                                  // (nv x nv) forward dynamics with mimic joints
};

FloatingData::FloatingData(const FloatingDynamics& model) : model_(&model), s(std::make_unique<Scratch>()) {
  const auto N = static_cast<std::size_t>(model.num_joints() + 1);
  Scratch& d = *s;
  d.qj.assign(N, 0.0);
  d.cq.assign(N, 1.0);
  d.sq.assign(N, 0.0);
  d.X.resize(N);
  d.R.resize(N);
  d.o.resize(N);
  d.v.resize(N);
  d.a.resize(N);
  d.c.resize(N);
  d.J.resize(N);
  d.f.resize(N);
  d.Ic.resize(N);
  d.IA.resize(N);
  d.pA.resize(N);
  d.U.resize(N);
  d.D.resize(N);
  d.u.resize(N);
  d.A.resize(6, model.num_v());
  d.zero_v = VectorXd::Zero(model.num_v());
  d.tau_v.resize(model.num_v());
  if (model.tree().has_mimics()) d.M.resize(model.num_v(), model.num_v());
  frame_R.resize(model.tree().frames.size());
  frame_p.resize(model.tree().frames.size());
}

FloatingData::~FloatingData() = default;

FloatingDynamics::FloatingDynamics(RigidTree tree) : tree_(std::move(tree)) {
  if (auto error = ValidateFloatingTree(tree_)) throw std::invalid_argument("FloatingDynamics: " + *error);
  n_ = tree_.num_joints();
  // fold[b]: body b's frame → its folded frame, x_body = fold[b] x_folded (the base's: the identity).
  std::vector<Matrix3d> fold;
  auto add_body = [&](const RigidBody& body, const Matrix3d& F) {
    fold.push_back(F);
    com_.push_back(F.transpose() * body.com);
    const Matrix3d I = F.transpose() * body.inertia * F;
    inertia_com_.push_back(0.5 * (I + I.transpose()));  // the part the kinetic energy sees
    inertia_.push_back(spatial::InertiaFromCom(body.mass, com_.back(), inertia_com_.back()));
  };
  parent_.push_back(-1);
  revolute_.push_back(0);
  E0_.push_back(Matrix3d::Identity());
  r_.push_back(Vector3d::Zero());
  dof_.push_back(-1);
  scale_.push_back(0.0);
  offset_.push_back(0.0);
  add_body(tree_.base, Matrix3d::Identity());
  for (int i = 0; i < n_; ++i) {
    const RigidTree::JointMap map = tree_.MapOf(i);
    dof_.push_back(map.dof);
    scale_.push_back(map.scale);
    offset_.push_back(map.offset);
    const TreeJoint& j = tree_.joints[i];
    const int p = j.parent + 1;
    const Matrix3d Fp = fold[static_cast<std::size_t>(p)];  // a copy: add_body grows fold
    const Matrix3d F = spatial::RotationTakingZTo(j.axis);
    parent_.push_back(p);
    revolute_.push_back(j.type == JointType::kRevolute ? 1 : 0);
    // The joint frame's axes in the folded parent frame: Fpᵀ rotation F.
    E0_.push_back((Fp.transpose() * j.rotation * F).transpose());
    r_.push_back(Fp.transpose() * j.position);
    add_body(tree_.bodies[i], F);
  }
  for (const TreeFrame& f : tree_.frames) {
    const Matrix3d& F = fold[static_cast<std::size_t>(f.body + 1)];
    frame_rotation_.push_back(F.transpose() * f.rotation);
    frame_position_.push_back(F.transpose() * f.position);
  }
}

std::unique_ptr<FloatingData> FloatingDynamics::MakeData() const { return std::make_unique<FloatingData>(*this); }

void FloatingDynamics::CheckSizes([[maybe_unused]] const FloatingData& data, [[maybe_unused]] ConstVecRef q) const {
  eigen_assert(&data.model() == this && "FloatingData made by another model");
  eigen_assert(q.size() == num_q() && "q: expected num_q() = num_v() + 1 entries (p, quaternion x y z w, joints)");
}

#define LAGRANGE_CHECK_NV(x) eigen_assert((x).size() == num_v() && #x ": expected num_v() entries (v_b, ω_b, joints)")

// q => X of every body (X_b = (Rz(q_b)ᵀ E0_b, r_b) revolute, (E0_b, r_b + q_b E0_bᵀ z)
// prismatic), and the base's R and o.
void FloatingDynamics::Transforms(FloatingData& d, ConstVecRef q) const {
  FloatingData::Scratch& s = *d.s;
  const Eigen::Quaterniond quat = Eigen::Quaterniond(q[6], q[3], q[4], q[5]).normalized();
  s.R[0] = quat.toRotationMatrix();
  s.o[0] = q.head<3>();
  s.X[0] = {s.R[0].transpose(), s.o[0]};
  for (int b = 1; b <= n_; ++b) s.qj[b] = JointQ(q, b);
  spatial::SinCos(s.qj.data() + 1, s.cq.data() + 1, s.sq.data() + 1, n_);
  for (int b = 1; b <= n_; ++b) {
    const Matrix3d& E0 = E0_[b];
    Xform& X = s.X[b];
    if (revolute_[b]) {
      const double cq = s.cq[b], sq = s.sq[b];
      for (int k = 0; k < 3; ++k) {
        X.E(0, k) = cq * E0(0, k) + sq * E0(1, k);
        X.E(1, k) = cq * E0(1, k) - sq * E0(0, k);
        X.E(2, k) = E0(2, k);
      }
      X.p = r_[b];
    } else {
      X.E = E0;
      X.p = r_[b] + s.qj[b] * Vector3d(E0(2, 0), E0(2, 1), E0(2, 2));
    }
  }
}

// X => R, o of every body but the base (Transforms sets the base's).
void FloatingDynamics::WorldPlacements(FloatingData& d) const {
  FloatingData::Scratch& s = *d.s;
  for (int b = 1; b <= n_; ++b) {
    const int p = parent(b);
    s.R[b] = spatial::MulABt(s.R[p], s.X[b].E);
    s.o[b] = s.o[p] + Mul(s.R[p], s.X[b].p);
  }
}

// v => body velocities; c = v × S qd when `products`, else zero.
void FloatingDynamics::Velocities(FloatingData& d, ConstVecRef v, bool products) const {
  FloatingData::Scratch& s = *d.s;
  s.v[0] = {v.segment<3>(3), v.head<3>()};
  s.c[0] = {};
  for (int b = 1; b <= n_; ++b) {
    const double qd = JointRate(v, b);
    const Motion Sqd = qd * Subspace(b);
    s.v[b] = s.X[b].Apply(s.v[parent(b)]) + Sqd;
    s.c[b] = products ? spatial::Cross(s.v[b], Sqd) : Motion{};
  }
}

// (X, v, a) => f_b = I_b a_b [+ v_b ×* I_b v_b], each body's own net force,
// with a_b = X_b a_λ(b) + S_b qdd_b [+ v_b × S_b qd_b] from the base's a_0
// (which carries gravity: ComputeInverseDynamics).
template <bool kVelocity>
void FloatingDynamics::RneaForward(FloatingData& d, ConstVecRef v, ConstVecRef a) const {
  FloatingData::Scratch& s = *d.s;
  const Inertia& I0 = inertia_[0];
  s.f[0] = spatial::NetForce<kVelocity>(I0.m, com_[0], inertia_com_[0], s.v[0], s.a[0]);
  for (int b = 1; b <= n_; ++b) {
    const int p = parent(b);
    const Xform& X = s.X[b];
    Motion& ab = s.a[b];
    ab = X.Apply(s.a[p]);
    if (kVelocity) {
      Motion& vb = s.v[b];
      vb = X.Apply(s.v[p]);
      // a += v × S qd (v without its own joint term gives the same product):
      // x × z qd = (x.y, −x.x, 0) qd.
      const double qd = JointRate(v, b);
      if (revolute_[b]) {
        ab.w.x() += vb.w.y() * qd;
        ab.w.y() -= vb.w.x() * qd;
        ab.v.x() += vb.v.y() * qd;
        ab.v.y() -= vb.v.x() * qd;
        vb.w.z() += qd;
      } else {
        ab.v.x() += vb.w.y() * qd;
        ab.v.y() -= vb.w.x() * qd;
        vb.v.z() += qd;
      }
    }
    (revolute_[b] ? ab.w.z() : ab.v.z()) += JointRate(a, b);
    const Inertia& I = inertia_[b];
    s.f[b] = spatial::NetForce<kVelocity>(I.m, com_[b], inertia_com_[b], s.v[b], ab);
  }
}

void FloatingDynamics::ComputeInverseDynamics(FloatingData& d, ConstVecRef q, ConstVecRef v, ConstVecRef a,
                                              DynamicsTerms terms, VecRef tau) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  LAGRANGE_CHECK_NV(a);
  LAGRANGE_CHECK_NV(tau);
  CountTerms(d, terms);
  Transforms(d, q);
  // Gravity as the base's acceleration: a_b − (0, g_b) for every body, g_b gravity in its axes.
  s.a[0] = {a.segment<3>(3), a.head<3>()};
  if (terms.gravity) s.a[0].v -= MulT(s.R[0], tree_.gravity);
  if (terms.coriolis) {
    s.v[0] = {v.segment<3>(3), v.head<3>()};
    RneaForward<true>(d, v, a);
  } else {
    RneaForward<false>(d, v, a);
  }
  tau.tail(num_dofs()).setZero();
  for (int b = n_; b >= 1; --b) {
    const Force& f = s.f[b];
    tau[Vi(b)] += scale_[b] * SubspaceDot(b, f);
    s.f[parent(b)] += s.X[b].ApplyTransposed(f);
  }
  tau.head<3>() = s.f[0].f;
  tau.segment<3>(3) = s.f[0].n;
}

void FloatingDynamics::ComputeMassMatrix(FloatingData& d, ConstVecRef q, MatRef M) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  eigen_assert(M.rows() == num_v() && M.cols() == num_v() && "M: expected num_v() x num_v()");
  Transforms(d, q);
  CompositeInertias(d);
  M.setZero();  // joints on different branches
  // The base's block: the whole tree's composite inertia, rows and columns (v_b, ω_b).
  for (int k = 0; k < 3; ++k) {
    Motion lin, ang;
    lin.v[k] = 1.0;
    ang.w[k] = 1.0;
    const Force Fl = s.Ic[0] * lin, Fa = s.Ic[0] * ang;
    M.col(k).head<3>() = Fl.f;
    M.col(k).segment<3>(3) = Fl.n;
    M.col(3 + k).head<3>() = Fa.f;
    M.col(3 + k).segment<3>(3) = Fa.n;
  }
  // Joint rows: each body's composite force carried up its ancestors to the
  // base, each entry added on the degrees of freedom (Sᵀ M_j S; s = 1 without mimics).
  for (int b = 1; b <= n_; ++b) {
    const int i = Vi(b);
    // F = Ic S: (Ib z, −h × z) revolute, (h × z, m z) prismatic.
    const Inertia& Ic = s.Ic[b];
    Force F = revolute_[b] ? Force{Ic.Ib.col(2), Vector3d(-Ic.h.y(), Ic.h.x(), 0.0)}
                           : Force{Vector3d(Ic.h.y(), -Ic.h.x(), 0.0), Vector3d(0.0, 0.0, Ic.m)};
    M(i, i) += scale_[b] * scale_[b] * SubspaceDot(b, F);
    int j = b;
    while (parent(j) > 0) {
      F = s.X[j].ApplyTransposed(F);
      j = parent(j);
      const int k = Vi(j);
      const double m = scale_[b] * scale_[j] * SubspaceDot(j, F);
      M(i, k) += m;
      M(k, i) += m;
    }
    F = s.X[j].ApplyTransposed(F);
    M.col(i).head<3>() += scale_[b] * F.f;
    M.col(i).segment<3>(3) += scale_[b] * F.n;
  }
  M.bottomLeftCorner(num_dofs(), kFreeFlyerNv) = M.topRightCorner(kFreeFlyerNv, num_dofs()).transpose();
}

void FloatingDynamics::ComputeForwardDynamics(FloatingData& d, ConstVecRef q, ConstVecRef v, ConstVecRef tau,
                                              DynamicsTerms terms, VecRef a) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  LAGRANGE_CHECK_NV(tau);
  LAGRANGE_CHECK_NV(a);
  if (tree_.has_mimics()) {
    ComputeMassMatrix(d, q, s.M);
    ComputeInverseDynamics(d, q, v, s.zero_v, terms, s.tau_v);
    a = tau - s.tau_v;
    CholeskySolveInPlace(s.M, a);
    return;
  }
  CountTerms(d, terms);
  Placements(d, q);
  Aba(d, v, tau, terms, a);
}

// (R, o, v, tau) => a by the articulated-body algorithm in world axes at the
// base's origin o_0 (every position o_b − o_0). Gravity as the fixed-base
// ABA's: the accelerations â = a − (0, g) obey the sweeps' equations with no
// gravity force, and a_0 = â_0 + (0, g) at the end. Forward: joint axes J_b,
// velocities, the bias acceleration c = v × J qd and force pA = v ×* I v.
// Backward: U = IA J, D = Jᵀ U, u = tau − Jᵀ pA, then IA − U Uᵀ/D and
// pA + Ia c + U u/D into the parent. Root: IA_0 â_0 = F_0 − pA_0 (F_0 the base
// wrench). Forward: qdd = (u − Uᵀ (â_λ + c))/D, â = â_λ + c + J qdd.
void FloatingDynamics::Aba(FloatingData& d, ConstVecRef v, ConstVecRef tau, DynamicsTerms terms, VecRef a) const {
  FloatingData::Scratch& s = *d.s;
  const Matrix3d& R0 = s.R[0];
  ArticulatedInertia* IA = s.IA.data();
  if (terms.coriolis) s.v[0] = {Mul(R0, v.segment<3>(3)), Mul(R0, v.head<3>())};
  for (int b = 0; b <= n_; ++b) {
    const Vector3d o = s.o[b] - s.o[0];
    const Inertia I = spatial::WorldInertia(inertia_[b], s.R[b], o);
    const Vector3d& h = I.h;
    IA[b].A = I.Ib;
    IA[b].B << 0.0, -h.z(), h.y(), h.z(), 0.0, -h.x(), -h.y(), h.x(), 0.0;
    IA[b].C = I.m * Matrix3d::Identity();
    if (b > 0) {
      const Vector3d z = s.R[b].col(2);
      s.J[b] = revolute_[b] ? Motion{z, Cross(o, z)} : Motion{Vector3d::Zero(), z};
      if (terms.coriolis) {
        const double qd = v[Vi(b)];
        s.v[b] = s.v[parent(b)] + qd * s.J[b];
        s.c[b] = qd * Cross(s.v[b], s.J[b]);
      } else {
        s.c[b] = Motion{};
      }
    }
    s.pA[b] = terms.coriolis ? CrossStar(s.v[b], I * s.v[b]) : Force{};
  }
  for (int b = n_; b >= 1; --b) {
    const Motion& J = s.J[b];
    const ArticulatedInertia& Ib = IA[b];
    const Force U{Mul(Ib.A, J.w) + Mul(Ib.B, J.v), MulT(Ib.B, J.w) + Mul(Ib.C, J.v)};
    const double Dinv = 1.0 / Dot(J, U);
    s.U[b] = U;
    s.D[b] = Dinv;
    s.u[b] = tau[Vi(b)] - Dot(J, s.pA[b]);
    // Ia = IA − U Uᵀ/D into the parent's, block by block.
    const Vector3d un = Dinv * U.n, uf = Dinv * U.f;
    ArticulatedInertia& Ip = IA[parent(b)];
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r <= c; ++r) {
        const double x = Ib.A(r, c) - un[r] * U.n[c];
        const double y = Ib.C(r, c) - uf[r] * U.f[c];
        Ip.A(r, c) += x;
        Ip.C(r, c) += y;
        if (r != c) {
          Ip.A(c, r) += x;
          Ip.C(c, r) += y;
        }
      }
      for (int r = 0; r < 3; ++r) Ip.B(r, c) += Ib.B(r, c) - un[r] * U.f[c];
    }
    // pa = pA + Ia c + U u/D, with Ia c = IA c − U (Uᵀ c)/D.
    const Motion& c = s.c[b];
    const double k = s.u[b] * Dinv - Dinv * Dot(c, U);
    s.pA[parent(b)] +=
        s.pA[b] + Force{Mul(Ib.A, c.w) + Mul(Ib.B, c.v) + k * U.n, MulT(Ib.B, c.w) + Mul(Ib.C, c.v) + k * U.f};
  }
  // The root: the base wrench (n, f), turned to the world, less the bias, through IA_0.
  const ArticulatedInertia& I0 = IA[0];
  Matrix6d K;
  K << I0.A, I0.B, I0.B.transpose(), I0.C;
  Vector6d rhs;
  rhs << Mul(R0, tau.segment<3>(3)) - s.pA[0].n, Mul(R0, tau.head<3>()) - s.pA[0].f;
  const Vector6d x = SolveSpd(K, rhs);
  s.a[0] = {x.head<3>(), x.tail<3>()};
  for (int b = 1; b <= n_; ++b) {
    const Motion ab = s.a[parent(b)] + s.c[b];
    const double qdd = (s.u[b] - Dot(ab, s.U[b])) * s.D[b];
    a[Vi(b)] = qdd;
    s.a[b] = ab + qdd * s.J[b];
  }
  Motion a0 = s.a[0];
  if (terms.gravity) a0.v += tree_.gravity;
  a.head<3>() = MulT(R0, a0.v);
  a.segment<3>(3) = MulT(R0, a0.w);
}

double FloatingDynamics::ComputeKineticEnergy(FloatingData& d, ConstVecRef q, ConstVecRef v) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  Transforms(d, q);
  Velocities(d, v, false);
  double T = 0.0;
  for (int b = 0; b <= n_; ++b) T += 0.5 * spatial::Dot(s.v[b], inertia_[b] * s.v[b]);
  return T;
}

double FloatingDynamics::ComputePotentialEnergy(FloatingData& d, ConstVecRef q) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  Placements(d, q);
  double V = 0.0;
  for (int b = 0; b <= n_; ++b) {
    const Inertia& I = inertia_[b];
    V -= tree_.gravity.dot(I.m * s.o[b] + s.R[b] * I.h);
  }
  return V;
}

Force FloatingDynamics::ComputeMomentum(FloatingData& d, ConstVecRef q, ConstVecRef v) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  Placements(d, q);
  Velocities(d, v, false);
  Force h;
  for (int b = 0; b <= n_; ++b) {
    const Force hb = inertia_[b] * s.v[b];
    const Vector3d f = s.R[b] * hb.f;
    h.n += s.R[b] * hb.n + s.o[b].cross(f);
    h.f += f;
  }
  return h;
}

// X => Ic: each body's subtree inertia, body coordinates.
void FloatingDynamics::CompositeInertias(FloatingData& d) const {
  FloatingData::Scratch& s = *d.s;
  for (int b = 0; b <= n_; ++b) s.Ic[b] = inertia_[b];
  for (int b = n_; b >= 1; --b) s.Ic[parent(b)] += s.X[b].ApplyTransposed(s.Ic[b]);
}

void FloatingDynamics::ComputeFramePlacements(FloatingData& d, ConstVecRef q) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  Placements(d, q);
  for (std::size_t k = 0; k < tree_.frames.size(); ++k) {
    const int b = tree_.frames[k].body + 1;
    d.frame_R[k] = s.R[b] * frame_rotation_[k];
    d.frame_p[k] = s.o[b] + s.R[b] * frame_position_[k];
  }
}

void FloatingDynamics::ComputeFrameJacobian(FloatingData& d, ConstVecRef q, int frame, MatRef J) const {
  FloatingData::Scratch& s = *d.s;
  eigen_assert(frame >= 0 && frame < static_cast<int>(tree_.frames.size()) && "frame: an index into tree().frames");
  eigen_assert(J.rows() == 6 && J.cols() == num_v() && "J: expected 6 x num_v()");
  ComputeFramePlacements(d, q);
  const Vector3d& p = d.frame_p[static_cast<std::size_t>(frame)];
  J.setZero();
  for (int j = 0; j < 3; ++j) {
    const Vector3d e = s.R[0].col(j);
    J.col(j).head<3>() = e;
    J.col(3 + j).head<3>() = e.cross(p - s.o[0]);
    J.col(3 + j).tail<3>() = e;
  }
  for (int b = tree_.frames[static_cast<std::size_t>(frame)].body + 1; b > 0; b = parent(b)) {
    const Vector3d z = s.R[b].col(2);  // the joint's world axis, through o_b
    auto col = J.col(Vi(b));
    if (revolute_[b]) {
      col.head<3>() += scale_[b] * z.cross(p - s.o[b]);
      col.tail<3>() += scale_[b] * z;
    } else {
      col.head<3>() += scale_[b] * z;
    }
  }
}

Vector3d FloatingDynamics::ComputeCentroidalMomentumMatrix(FloatingData& d, ConstVecRef q, MatRef A) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  eigen_assert(A.rows() == 6 && A.cols() == num_v() && "A: expected 6 x num_v()");
  Placements(d, q);
  CompositeInertias(d);
  const Inertia& total = s.Ic[0];
  const Vector3d c = s.o[0] + s.R[0] * (total.h / total.m);
  // A momentum F in body b's coordinates => (linear, angular about c), world axes.
  auto to_centroid = [&](int b, const Force& F) {
    const Vector3d f = s.R[b] * F.f;
    return (Vector6d() << f, s.R[b] * F.n + (s.o[b] - c).cross(f)).finished();
  };
  for (int j = 0; j < 3; ++j) {
    Motion lin, ang;
    lin.v[j] = 1.0;
    ang.w[j] = 1.0;
    A.col(j) = to_centroid(0, total * lin);
    A.col(3 + j) = to_centroid(0, total * ang);
  }
  A.rightCols(num_dofs()).setZero();
  for (int b = 1; b <= n_; ++b) A.col(Vi(b)) += scale_[b] * to_centroid(b, s.Ic[b] * Subspace(b));
  return c;
}

Vector3d FloatingDynamics::ComputeCenterOfMass(FloatingData& d, ConstVecRef q, MatRef Jc) const {
  FloatingData::Scratch& s = *d.s;
  eigen_assert(Jc.rows() == 3 && Jc.cols() == num_v() && "Jc: expected 3 x num_v()");
  // ċ = (linear momentum) / m: A_G's linear rows over the mass.
  const Vector3d c = ComputeCentroidalMomentumMatrix(d, q, s.A);
  Jc = s.A.topRows<3>() / s.Ic[0].m;
  return c;
}

void FloatingDynamics::ComputeFrameAccelerationBias(FloatingData& d, ConstVecRef q, ConstVecRef v, int frame,
                                                    Eigen::Ref<Vector6d> Jdv) const {
  FloatingData::Scratch& s = *d.s;
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  eigen_assert(frame >= 0 && frame < static_cast<int>(tree_.frames.size()) && "frame: an index into tree().frames");
  Placements(d, q);
  Velocities(d, v, true);
  s.a[0] = {};
  for (int b = 1; b <= n_; ++b) s.a[b] = s.X[b].Apply(s.a[parent(b)]) + s.c[b];
  const int b = tree_.frames[static_cast<std::size_t>(frame)].body + 1;
  const Motion& vb = s.v[b];
  const Motion& ab = s.a[b];
  const Vector3d& r = frame_position_[static_cast<std::size_t>(frame)];
  Jdv.head<3>() = s.R[b] * (ab.v + ab.w.cross(r) + vb.w.cross(vb.v + vb.w.cross(r)));
  Jdv.tail<3>() = s.R[b] * ab.w;
}

Vector3d FloatingDynamics::ComputeCentroidalMomentumBias(FloatingData& d, ConstVecRef q, ConstVecRef v,
                                                         Eigen::Ref<Vector6d> Adv) const {
  FloatingData::Scratch& s = *d.s;
  ComputeInverseDynamics(d, q, v, s.zero_v, {.gravity = false, .coriolis = true}, s.tau_v);
  WorldPlacements(d);
  double m = 0.0;
  Vector3d mc = Vector3d::Zero();
  for (int b = 0; b <= n_; ++b) {
    m += inertia_[b].m;
    mc += inertia_[b].m * s.o[b] + s.R[b] * inertia_[b].h;
  }
  const Vector3d c = mc / m;
  const Vector3d f = s.R[0] * s.f[0].f;  // the base wrench, about the base origin, in the world
  Adv.head<3>() = f;
  Adv.tail<3>() = s.R[0] * s.f[0].n + (s.o[0] - c).cross(f);
  return c;
}

#undef LAGRANGE_CHECK_NV

void CholeskySolveInPlace(MatrixXd& A, VecRef x) {
  const Eigen::Index n = A.rows();
  for (Eigen::Index k = 0; k < n; ++k) {
    A(k, k) = std::sqrt(A(k, k) - A.row(k).head(k).squaredNorm());
    for (Eigen::Index r = k + 1; r < n; ++r) A(r, k) = (A(r, k) - A.row(r).head(k).dot(A.row(k).head(k))) / A(k, k);
  }
  for (Eigen::Index r = 0; r < n; ++r) x[r] = (x[r] - A.row(r).head(r).dot(x.head(r))) / A(r, r);
  for (Eigen::Index r = n - 1; r >= 0; --r) x[r] = (x[r] - A.col(r).tail(n - 1 - r).dot(x.tail(n - 1 - r))) / A(r, r);
}

}  // namespace lagrange
