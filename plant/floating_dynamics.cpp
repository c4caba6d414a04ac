#include "plant/floating_dynamics.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace lagrange {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using spatial::Force;
using spatial::Inertia;
using spatial::Motion;
using spatial::Xform;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

Matrix3d Skew(const Vector3d& x) {
  Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}

// Spatial vectors as 6-vectors in (w, v) and (n, f) order, for the ABA's 6 x 6 algebra.
Vector6d Vec(const Motion& m) { return (Vector6d() << m.w, m.v).finished(); }
Vector6d Vec(const Force& f) { return (Vector6d() << f.n, f.f).finished(); }
Motion ToMotion(const Vector6d& x) { return {x.head<3>(), x.tail<3>()}; }

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

// I (w, v) = (Ib w + h × v, m v − h × w).
Matrix6d ToMatrix(const Inertia& I) {
  Matrix6d A;
  A << I.Ib, Skew(I.h), Skew(I.h).transpose(), I.m * Matrix3d::Identity();
  return A;
}

// X (w, v) = (E w, E (v − p × w)).
Matrix6d ToMatrix(const Xform& X) {
  Matrix6d A;
  A << X.E, Matrix3d::Zero(), -X.E * Skew(X.p), X.E;
  return A;
}

}  // namespace

FloatingData::FloatingData(const FloatingDynamics& model) : model_(&model) {
  const auto N = static_cast<std::size_t>(model.num_joints() + 1);
  X.resize(N);
  R.resize(N);
  o.resize(N);
  v.resize(N);
  a.resize(N);
  c.resize(N);
  g.resize(N);
  f.resize(N);
  Ic.resize(N);
  IA.resize(N);
  pA.resize(N);
  U.resize(N);
  D.resize(N);
  u.resize(N);
  frame_R.resize(model.tree().frames.size());
  frame_p.resize(model.tree().frames.size());
  A.resize(6, model.num_v());
  zero_v = VectorXd::Zero(model.num_v());
  tau_v.resize(model.num_v());
  if (model.tree().has_mimics()) M.resize(model.num_v(), model.num_v());
}

FloatingDynamics::FloatingDynamics(RigidTree tree) : tree_(std::move(tree)) {
  if (auto error = ValidateFloatingTree(tree_)) throw std::invalid_argument("FloatingDynamics: " + *error);
  n_ = tree_.num_joints();
  const RigidBody& base = tree_.base;
  parent_.push_back(-1);
  revolute_.push_back(0);
  axis_.push_back(Vector3d::Zero());
  X0_.emplace_back();
  inertia_.push_back(spatial::InertiaFromCom(base.mass, base.com, 0.5 * (base.inertia + base.inertia.transpose())));
  dof_.push_back(-1);
  scale_.push_back(0.0);
  offset_.push_back(0.0);
  for (int i = 0; i < n_; ++i) {
    const RigidTree::JointMap map = tree_.MapOf(i);
    dof_.push_back(map.dof);
    scale_.push_back(map.scale);
    offset_.push_back(map.offset);
    const TreeJoint& j = tree_.joints[i];
    const RigidBody& b = tree_.bodies[i];
    parent_.push_back(j.parent + 1);
    revolute_.push_back(j.type == JointType::kRevolute ? 1 : 0);
    axis_.push_back(j.axis);
    X0_.push_back({j.rotation.transpose(), j.position});
    inertia_.push_back(spatial::InertiaFromCom(b.mass, b.com, 0.5 * (b.inertia + b.inertia.transpose())));
  }
}

std::unique_ptr<FloatingData> FloatingDynamics::MakeData() const { return std::make_unique<FloatingData>(*this); }

void FloatingDynamics::CheckSizes([[maybe_unused]] const FloatingData& data, [[maybe_unused]] ConstVecRef q) const {
  eigen_assert(&data.model() == this && "FloatingData made by another model");
  eigen_assert(q.size() == num_q() && "q: expected num_q() = num_v() + 1 entries (p, quaternion x y z w, joints)");
}

#define LAGRANGE_CHECK_NV(x) eigen_assert((x).size() == num_v() && #x ": expected num_v() entries (v_b, ω_b, joints)")

// q => X, R, o and the gravity acceleration g of every body.
void FloatingDynamics::Placements(FloatingData& d, ConstVecRef q) const {
  const Eigen::Quaterniond quat = Eigen::Quaterniond(q[6], q[3], q[4], q[5]).normalized();
  d.R[0] = quat.toRotationMatrix();
  d.o[0] = q.head<3>();
  d.X[0] = {d.R[0].transpose(), d.o[0]};
  for (int b = 1; b <= n_; ++b) {
    const Xform& X0 = X0_[b];
    const double qi = JointQ(q, b);
    Xform& X = d.X[b];
    if (revolute_[b]) {
      // Joint frame → body frame: turned by qi about the axis.
      X.E = Eigen::AngleAxisd(qi, axis_[b]).toRotationMatrix().transpose() * X0.E;
      X.p = X0.p;
    } else {
      X.E = X0.E;
      X.p = X0.p + X0.E.transpose() * (qi * axis_[b]);
    }
    const int p = parent(b);
    d.R[b] = d.R[p] * X.E.transpose();
    d.o[b] = d.o[p] + d.R[p] * X.p;
  }
  for (int b = 0; b <= n_; ++b) d.g[b] = {Vector3d::Zero(), d.R[b].transpose() * tree_.gravity};
}

// v => body velocities; c = v × S qd when `products`, else zero.
void FloatingDynamics::Velocities(FloatingData& d, ConstVecRef v, bool products) const {
  d.v[0] = {v.segment<3>(3), v.head<3>()};
  d.c[0] = {};
  for (int b = 1; b <= n_; ++b) {
    const double qd = JointRate(v, b);
    const Motion Sqd = qd * Subspace(b);
    d.v[b] = d.X[b].Apply(d.v[parent(b)]) + Sqd;
    d.c[b] = products ? spatial::Cross(d.v[b], Sqd) : Motion{};
  }
}

void FloatingDynamics::ComputeInverseDynamics(FloatingData& d, ConstVecRef q, ConstVecRef v, ConstVecRef a,
                                              DynamicsTerms terms, VecRef tau) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  LAGRANGE_CHECK_NV(a);
  LAGRANGE_CHECK_NV(tau);
  Placements(d, q);
  Velocities(d, v, terms.coriolis);
  d.a[0] = {a.segment<3>(3), a.head<3>()};
  for (int b = 0; b <= n_; ++b) {
    if (b > 0) {
      const double qdd = JointRate(a, b);
      d.a[b] = d.X[b].Apply(d.a[parent(b)]) + d.c[b];
      (revolute_[b] ? d.a[b].w : d.a[b].v) += qdd * axis_[b];
    }
    const Inertia& I = inertia_[b];
    d.f[b] = I * d.a[b];
    if (terms.coriolis) d.f[b] += spatial::CrossStar(d.v[b], I * d.v[b]);
    if (terms.gravity) d.f[b] = d.f[b] - I * d.g[b];
  }
  tau.tail(num_dofs()).setZero();
  for (int b = n_; b >= 1; --b) {
    const Force& f = d.f[b];
    tau[Vi(b)] += scale_[b] * axis_[b].dot(revolute_[b] ? f.n : f.f);
    d.f[parent(b)] += d.X[b].ApplyTransposed(f);
  }
  tau.head<3>() = d.f[0].f;
  tau.segment<3>(3) = d.f[0].n;
}

void FloatingDynamics::ComputeMassMatrix(FloatingData& d, ConstVecRef q, MatRef M) const {
  CheckSizes(d, q);
  eigen_assert(M.rows() == num_v() && M.cols() == num_v() && "M: expected num_v() x num_v()");
  Placements(d, q);
  CompositeInertias(d);
  M.setZero();  // joints on different branches
  // The base's block: the whole tree's composite inertia, rows and columns (v_b, ω_b).
  for (int k = 0; k < 3; ++k) {
    Motion lin, ang;
    lin.v[k] = 1.0;
    ang.w[k] = 1.0;
    const Force Fl = d.Ic[0] * lin, Fa = d.Ic[0] * ang;
    M.col(k).head<3>() = Fl.f;
    M.col(k).segment<3>(3) = Fl.n;
    M.col(3 + k).head<3>() = Fa.f;
    M.col(3 + k).segment<3>(3) = Fa.n;
  }
  // Joint rows: each body's composite force carried up its ancestors to the
  // base, each entry added on the degrees of freedom (Sᵀ M_j S; s = 1 without mimics).
  for (int b = 1; b <= n_; ++b) {
    const int i = Vi(b);
    const Motion S = Subspace(b);
    Force F = d.Ic[b] * S;
    M(i, i) += scale_[b] * scale_[b] * spatial::Dot(S, F);
    int j = b;
    while (parent(j) > 0) {
      F = d.X[j].ApplyTransposed(F);
      j = parent(j);
      const int k = Vi(j);
      const double m = scale_[b] * scale_[j] * axis_[j].dot(revolute_[j] ? F.n : F.f);
      M(i, k) += m;
      M(k, i) += m;
    }
    F = d.X[j].ApplyTransposed(F);
    M.col(i).head<3>() += scale_[b] * F.f;
    M.col(i).segment<3>(3) += scale_[b] * F.n;
  }
  M.bottomLeftCorner(num_dofs(), kFreeFlyerNv) = M.topRightCorner(kFreeFlyerNv, num_dofs()).transpose();
}

void FloatingDynamics::ComputeForwardDynamics(FloatingData& d, ConstVecRef q, ConstVecRef v, ConstVecRef tau,
                                              DynamicsTerms terms, VecRef a) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  LAGRANGE_CHECK_NV(tau);
  LAGRANGE_CHECK_NV(a);
  if (tree_.has_mimics()) {
    ComputeMassMatrix(d, q, d.M);
    ComputeInverseDynamics(d, q, v, d.zero_v, terms, d.tau_v);
    a = tau - d.tau_v;
    CholeskySolveInPlace(d.M, a);
    return;
  }
  Placements(d, q);
  Velocities(d, v, terms.coriolis);
  for (int b = 0; b <= n_; ++b) {
    const Inertia& I = inertia_[b];
    d.IA[b] = ToMatrix(I);
    Force p;
    if (terms.coriolis) p = spatial::CrossStar(d.v[b], I * d.v[b]);
    if (terms.gravity) p = p - I * d.g[b];
    d.pA[b] = Vec(p);
  }
  for (int b = n_; b >= 1; --b) {
    Vector6d s = Vector6d::Zero();
    s.segment<3>(revolute_[b] ? 0 : 3) = axis_[b];
    d.U[b] = d.IA[b] * s;
    d.D[b] = s.dot(d.U[b]);
    d.u[b] = tau[kFreeFlyerNv + b - 1] - s.dot(d.pA[b]);
    const Matrix6d Ia = d.IA[b] - d.U[b] * d.U[b].transpose() / d.D[b];
    const Vector6d pa = d.pA[b] + Ia * Vec(d.c[b]) + d.U[b] * (d.u[b] / d.D[b]);
    const Matrix6d X = ToMatrix(d.X[b]);
    d.IA[parent(b)] += X.transpose() * Ia * X;
    d.pA[parent(b)] += X.transpose() * pa;
  }
  // The root: the base wrench (n, f) less the bias, through the tree's articulated inertia.
  Vector6d wrench;
  wrench << tau.segment<3>(3), tau.head<3>();
  d.a[0] = ToMotion(SolveSpd(d.IA[0], wrench - d.pA[0]));
  for (int b = 1; b <= n_; ++b) {
    d.a[b] = d.X[b].Apply(d.a[parent(b)]) + d.c[b];
    const double qdd = (d.u[b] - d.U[b].dot(Vec(d.a[b]))) / d.D[b];
    a[kFreeFlyerNv + b - 1] = qdd;
    (revolute_[b] ? d.a[b].w : d.a[b].v) += qdd * axis_[b];
  }
  a.head<3>() = d.a[0].v;
  a.segment<3>(3) = d.a[0].w;
}

double FloatingDynamics::ComputeKineticEnergy(FloatingData& d, ConstVecRef q, ConstVecRef v) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  Placements(d, q);
  Velocities(d, v, false);
  double T = 0.0;
  for (int b = 0; b <= n_; ++b) T += 0.5 * spatial::Dot(d.v[b], inertia_[b] * d.v[b]);
  return T;
}

double FloatingDynamics::ComputePotentialEnergy(FloatingData& d, ConstVecRef q) const {
  CheckSizes(d, q);
  Placements(d, q);
  double V = 0.0;
  for (int b = 0; b <= n_; ++b) {
    const Inertia& I = inertia_[b];
    V -= tree_.gravity.dot(I.m * d.o[b] + d.R[b] * I.h);
  }
  return V;
}

Force FloatingDynamics::ComputeMomentum(FloatingData& d, ConstVecRef q, ConstVecRef v) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  Placements(d, q);
  Velocities(d, v, false);
  Force h;
  for (int b = 0; b <= n_; ++b) {
    const Force hb = inertia_[b] * d.v[b];
    const Vector3d f = d.R[b] * hb.f;
    h.n += d.R[b] * hb.n + d.o[b].cross(f);
    h.f += f;
  }
  return h;
}

// X => Ic: each body's subtree inertia, body coordinates.
void FloatingDynamics::CompositeInertias(FloatingData& d) const {
  for (int b = 0; b <= n_; ++b) d.Ic[b] = inertia_[b];
  for (int b = n_; b >= 1; --b) d.Ic[parent(b)] += d.X[b].ApplyTransposed(d.Ic[b]);
}

void FloatingDynamics::ComputeFramePlacements(FloatingData& d, ConstVecRef q) const {
  CheckSizes(d, q);
  Placements(d, q);
  for (std::size_t k = 0; k < tree_.frames.size(); ++k) {
    const TreeFrame& f = tree_.frames[k];
    const int b = f.body + 1;
    d.frame_R[k] = d.R[b] * f.rotation;
    d.frame_p[k] = d.o[b] + d.R[b] * f.position;
  }
}

void FloatingDynamics::ComputeFrameJacobian(FloatingData& d, ConstVecRef q, int frame, MatRef J) const {
  eigen_assert(frame >= 0 && frame < static_cast<int>(tree_.frames.size()) && "frame: an index into tree().frames");
  eigen_assert(J.rows() == 6 && J.cols() == num_v() && "J: expected 6 x num_v()");
  ComputeFramePlacements(d, q);
  const Vector3d& p = d.frame_p[static_cast<std::size_t>(frame)];
  J.setZero();
  for (int j = 0; j < 3; ++j) {
    const Vector3d e = d.R[0].col(j);
    J.col(j).head<3>() = e;
    J.col(3 + j).head<3>() = e.cross(p - d.o[0]);
    J.col(3 + j).tail<3>() = e;
  }
  for (int b = tree_.frames[static_cast<std::size_t>(frame)].body + 1; b > 0; b = parent(b)) {
    const Vector3d z = d.R[b] * axis_[b];  // the joint's world axis, through o_b
    auto col = J.col(Vi(b));
    if (revolute_[b]) {
      col.head<3>() += scale_[b] * z.cross(p - d.o[b]);
      col.tail<3>() += scale_[b] * z;
    } else {
      col.head<3>() += scale_[b] * z;
    }
  }
}

Vector3d FloatingDynamics::ComputeCentroidalMomentumMatrix(FloatingData& d, ConstVecRef q, MatRef A) const {
  CheckSizes(d, q);
  eigen_assert(A.rows() == 6 && A.cols() == num_v() && "A: expected 6 x num_v()");
  Placements(d, q);
  CompositeInertias(d);
  const Inertia& total = d.Ic[0];
  const Vector3d c = d.o[0] + d.R[0] * (total.h / total.m);
  // A momentum F in body b's coordinates => (linear, angular about c), world axes.
  auto to_centroid = [&](int b, const Force& F) {
    const Vector3d f = d.R[b] * F.f;
    return (Vector6d() << f, d.R[b] * F.n + (d.o[b] - c).cross(f)).finished();
  };
  for (int j = 0; j < 3; ++j) {
    Motion lin, ang;
    lin.v[j] = 1.0;
    ang.w[j] = 1.0;
    A.col(j) = to_centroid(0, total * lin);
    A.col(3 + j) = to_centroid(0, total * ang);
  }
  A.rightCols(num_dofs()).setZero();
  for (int b = 1; b <= n_; ++b) A.col(Vi(b)) += scale_[b] * to_centroid(b, d.Ic[b] * Subspace(b));
  return c;
}

Vector3d FloatingDynamics::ComputeCenterOfMass(FloatingData& d, ConstVecRef q, MatRef Jc) const {
  eigen_assert(Jc.rows() == 3 && Jc.cols() == num_v() && "Jc: expected 3 x num_v()");
  // ċ = (linear momentum) / m: A_G's linear rows over the mass.
  const Vector3d c = ComputeCentroidalMomentumMatrix(d, q, d.A);
  Jc = d.A.topRows<3>() / d.Ic[0].m;
  return c;
}

void FloatingDynamics::ComputeFrameAccelerationBias(FloatingData& d, ConstVecRef q, ConstVecRef v, int frame,
                                                    Eigen::Ref<Vector6d> Jdv) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  eigen_assert(frame >= 0 && frame < static_cast<int>(tree_.frames.size()) && "frame: an index into tree().frames");
  Placements(d, q);
  Velocities(d, v, true);
  d.a[0] = {};
  for (int b = 1; b <= n_; ++b) d.a[b] = d.X[b].Apply(d.a[parent(b)]) + d.c[b];
  const TreeFrame& f = tree_.frames[static_cast<std::size_t>(frame)];
  const int b = f.body + 1;
  const Motion& vb = d.v[b];
  const Motion& ab = d.a[b];
  const Vector3d& r = f.position;
  Jdv.head<3>() = d.R[b] * (ab.v + ab.w.cross(r) + vb.w.cross(vb.v + vb.w.cross(r)));
  Jdv.tail<3>() = d.R[b] * ab.w;
}

Vector3d FloatingDynamics::ComputeCentroidalMomentumBias(FloatingData& d, ConstVecRef q, ConstVecRef v,
                                                         Eigen::Ref<Vector6d> Adv) const {
  ComputeInverseDynamics(d, q, v, d.zero_v, {.gravity = false, .coriolis = true}, d.tau_v);
  double m = 0.0;
  Vector3d mc = Vector3d::Zero();
  for (int b = 0; b <= n_; ++b) {
    m += inertia_[b].m;
    mc += inertia_[b].m * d.o[b] + d.R[b] * inertia_[b].h;
  }
  const Vector3d c = mc / m;
  const Vector3d f = d.R[0] * d.f[0].f;  // the base wrench, about the base origin, in the world
  Adv.head<3>() = f;
  Adv.tail<3>() = d.R[0] * d.f[0].n + (d.o[0] - c).cross(f);
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
