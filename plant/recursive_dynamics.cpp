#include "plant/recursive_dynamics.hpp"

#include <cmath>
#include <utility>

namespace lagrange {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Xform = RecursiveDynamics::Xform;

// X m: motion vector from parent to child coordinates.
Vector3d ApplyX(const Xform& X, const Vector3d& m) {
  const double ux = m[1] - m[0] * X.r.y();
  const double uy = m[2] + m[0] * X.r.x();
  return {m[0], X.c * ux + X.s * uy, -X.s * ux + X.c * uy};
}

// Xᵀ f: force vector from child to parent coordinates.
Vector3d ApplyXT(const Xform& X, const Vector3d& f) {
  const double fx = X.c * f[1] - X.s * f[2];
  const double fy = X.s * f[1] + X.c * f[2];
  return {f[0] + X.r.x() * fy - X.r.y() * fx, fx, fy};
}

Matrix3d XMatrix(const Xform& X) {
  Matrix3d m;
  m << 1.0, 0.0, 0.0, -X.c * X.r.y() + X.s * X.r.x(), X.c, X.s, X.s * X.r.y() + X.c * X.r.x(), -X.s, X.c;
  return m;
}

// v ×m m (motion cross motion).
Vector3d CrossMotion(const Vector3d& v, const Vector3d& m) {
  return {0.0, -v[0] * m[2] + m[0] * v[2], v[0] * m[1] - m[0] * v[1]};
}

// v ×* f (motion cross force).
Vector3d CrossForce(const Vector3d& v, const Vector3d& f) {
  return {v[1] * f[2] - v[2] * f[1], -v[0] * f[2], v[0] * f[1]};
}

// S for the joint type, and Sᵀ f.
int SubspaceIndex(JointType type) { return type == JointType::kRevolute ? 0 : 1; }

Matrix3d SpatialInertia(const PlanarBody& b) {
  const double m = b.mass, cx = b.com.x(), cy = b.com.y();
  Matrix3d I;
  I << b.inertia + m * (cx * cx + cy * cy), -m * cy, m * cx, -m * cy, m, 0.0, m * cx, 0.0, m;
  return I;
}

}  // namespace

std::vector<JointType> PlanarChain::joint_types() const {
  std::vector<JointType> types;
  types.reserve(joints.size());
  for (const PlanarJoint& j : joints) types.push_back(j.type);
  return types;
}

RecursiveDynamics::RecursiveDynamics(PlanarChain chain) : Dynamics(chain.joint_types()), chain_(std::move(chain)) {
  const auto n = static_cast<std::size_t>(num_dofs());
  for (const PlanarBody& b : chain_.bodies) inertia_.push_back(SpatialInertia(b));
  X_.resize(n);
  v_.resize(n);
  a_.resize(n);
  f_.resize(n);
  c_.resize(n);
  pA_.resize(n);
  U_.resize(n);
  ov_.resize(n);
  com_.resize(n);
  axes_.resize(n, 3);
  P_.resize(n, 3);
  Q_.resize(n, 3);
  IA_.resize(n);
  D_.resize(n);
  u_.resize(n);
  zeros_ = VectorXd::Zero(num_dofs());
}

void RecursiveDynamics::ComputeTransforms(ConstVecRef q) const {
  for (int i = 0; i < num_dofs(); ++i) {
    const PlanarJoint& j = chain_.joints[i];
    Xform& X = X_[i];
    if (j.type == JointType::kRevolute) {
      X.c = std::cos(j.angle + q[i]);
      X.s = std::sin(j.angle + q[i]);
      X.r = j.position;
    } else {
      X.c = std::cos(j.angle);
      X.s = std::sin(j.angle);
      X.r = j.position + q[i] * Eigen::Vector2d(X.c, X.s);
    }
  }
}

void RecursiveDynamics::ComputeVelocities(ConstVecRef qd) const {
  Vector3d v_parent = Vector3d::Zero();
  for (int i = 0; i < num_dofs(); ++i) {
    v_[i] = ApplyX(X_[i], v_parent);
    v_[i][SubspaceIndex(chain_.joints[i].type)] += qd[i];
    v_parent = v_[i];
  }
}

// (X, qd, qdd) => tau = M qdd + [C qd] + [G].
void RecursiveDynamics::Rnea(ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms, VecRef tau) const {
  const int n = num_dofs();
  if (terms.coriolis) ComputeVelocities(qd);
  Vector3d a_parent(0.0, 0.0, terms.gravity ? chain_.g : 0.0);  // −a_gravity, world frame
  for (int i = 0; i < n; ++i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    a_[i] = ApplyX(X_[i], a_parent);
    a_[i][k] += qdd[i];
    if (terms.coriolis) {
      Vector3d vj = Vector3d::Zero();
      vj[k] = qd[i];
      a_[i] += CrossMotion(v_[i], vj);
    }
    f_[i] = inertia_[i] * a_[i];
    if (terms.coriolis) f_[i] += CrossForce(v_[i], inertia_[i] * v_[i]);
    a_parent = a_[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    tau[i] = f_[i][SubspaceIndex(chain_.joints[i].type)];
    if (i > 0) f_[i - 1] += ApplyXT(X_[i], f_[i]);
  }
}

void RecursiveDynamics::ComputeInverseDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms,
                                               VecRef tau) const {
  AssertSizes(q, qd, qdd, tau);
  if (terms.gravity) CountGravity();
  if (terms.coriolis) CountCoriolis();
  ComputeTransforms(q);
  Rnea(qd, qdd, terms, tau);
}

void RecursiveDynamics::ComputeForwardDynamics(ConstVecRef q, ConstVecRef qd, ConstVecRef tau, DynamicsTerms terms,
                                               VecRef qdd) const {
  AssertSizes(q, qd, tau, qdd);
  const int n = num_dofs();
  ComputeTransforms(q);
  // Pass 1: velocity-product terms c_i = v_i × S qd_i and bias forces p_i = v_i ×* I v_i.
  if (terms.coriolis) {
    CountCoriolis();
    ComputeVelocities(qd);
    for (int i = 0; i < n; ++i) {
      Vector3d vj = Vector3d::Zero();
      vj[SubspaceIndex(chain_.joints[i].type)] = qd[i];
      c_[i] = CrossMotion(v_[i], vj);
      pA_[i] = CrossForce(v_[i], inertia_[i] * v_[i]);
    }
  } else {
    for (int i = 0; i < n; ++i) {
      c_[i].setZero();
      pA_[i].setZero();
    }
  }
  for (int i = 0; i < n; ++i) IA_[i] = inertia_[i];
  // Pass 2: articulated-body inertias and bias forces, tip to base.
  for (int i = n - 1; i >= 0; --i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    U_[i] = IA_[i].col(k);
    D_[i] = U_[i][k];
    u_[i] = tau[i] - pA_[i][k];
    if (i > 0) {
      const Matrix3d Ia = IA_[i] - U_[i] * U_[i].transpose() / D_[i];
      const Vector3d pa = pA_[i] + Ia * c_[i] + U_[i] * (u_[i] / D_[i]);
      const Matrix3d X = XMatrix(X_[i]);
      IA_[i - 1].noalias() += X.transpose() * Ia * X;
      pA_[i - 1] += ApplyXT(X_[i], pa);
    }
  }
  // Pass 3: accelerations, base to tip.
  Vector3d a_parent(0.0, 0.0, 0.0);
  if (terms.gravity) {
    CountGravity();
    a_parent[2] = chain_.g;
  }
  for (int i = 0; i < n; ++i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    const Vector3d a = ApplyX(X_[i], a_parent) + c_[i];
    qdd[i] = (u_[i] - U_[i].dot(a)) / D_[i];
    a_parent = a;
    a_parent[k] += qdd[i];
  }
}

void RecursiveDynamics::ComputeMassMatrix(ConstVecRef q, MatRef M) const {
  AssertSizes(q, M);
  const int n = num_dofs();
  ComputeTransforms(q);
  for (int i = 0; i < n; ++i) IA_[i] = inertia_[i];  // composite inertias
  for (int i = n - 1; i > 0; --i) {
    const Matrix3d X = XMatrix(X_[i]);
    IA_[i - 1].noalias() += X.transpose() * IA_[i] * X;
  }
  for (int i = 0; i < n; ++i) {
    Vector3d F = IA_[i].col(SubspaceIndex(chain_.joints[i].type));
    M(i, i) = F[SubspaceIndex(chain_.joints[i].type)];
    for (int j = i; j > 0; --j) {
      F = ApplyXT(X_[j], F);
      const double m = F[SubspaceIndex(chain_.joints[j - 1].type)];
      M(i, j - 1) = m;
      M(j - 1, i) = m;
    }
  }
}

void RecursiveDynamics::ComputeCoriolisForce(ConstVecRef q, ConstVecRef qd, VecRef c) const {
  AssertSizes(q, qd, c);
  ComputeTransforms(q);
  Rnea(qd, zeros_, DynamicsTerms{.gravity = false, .coriolis = true}, c);
}

void RecursiveDynamics::ComputeGravityForce(ConstVecRef q, VecRef G) const {
  AssertSizes(q, G);
  ComputeTransforms(q);
  Rnea(zeros_, zeros_, DynamicsTerms{.gravity = true, .coriolis = false}, G);
}

// (X, qd) => base-frame joint axes J_j, body velocities v_j and centres of mass.
void RecursiveDynamics::ComputeBaseFrameMotion(ConstVecRef qd) const {
  double c = 1.0, s = 0.0;  // rotation of body j's frame in the base frame
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  Vector3d v = Vector3d::Zero();
  for (int j = 0; j < num_dofs(); ++j) {
    const Xform& X = X_[j];
    p += Eigen::Vector2d(c * X.r.x() - s * X.r.y(), s * X.r.x() + c * X.r.y());
    const double cj = c * X.c - s * X.s;
    s = s * X.c + c * X.s;
    c = cj;
    const Vector3d J =
        chain_.joints[j].type == JointType::kRevolute ? Vector3d(1.0, p.y(), -p.x()) : Vector3d(0.0, c, s);
    v += qd[j] * J;
    axes_.row(j) = J;
    ov_[j] = v;
    const PlanarBody& b = chain_.bodies[j];
    com_[j] = p + Eigen::Vector2d(c * b.com.x() - s * b.com.y(), s * b.com.x() + c * b.com.y());
  }
}

// (q, qd) => C in one forward and one backward pass, in base coordinates
// (Pinocchio's computeCoriolisMatrix in 2-D). With J_j the base-frame joint
// axis, J̇_j = v_j × J_j, and over the subtree j..n−1 the composite inertia
// Ic_j, its rate İc_j and momentum h_j, Bc_j = ½ (İc_j + h_j ×̄*) (m ↦ m ×* h_j):
//   C_ij = J_iᵀ (Ic_k J̇_j + Bc_k J_j),  k = max(i, j),
// i.e. C_ij = J_i · F_j for i <= j, F_j = Ic_j J̇_j + Bc_j J_j, and
// C_ij = P_i · J̇_j + Q_i · J_j for i > j, P_i = Ic_i J_i, Q_i = Bc_iᵀ J_i.
// The Christoffel symbols ∂C_ij/∂qd_k are symmetric in (j, k), so this is the
// Christoffel C: Ṁ − 2C is skew and C qd is the RNEA's.
void RecursiveDynamics::ComputeCoriolisMatrix(ConstVecRef q, ConstVecRef qd, MatRef C) const {
  AssertSizes(q, qd, C);
  const int n = num_dofs();
  if (n == 1) {  // the one body's M = S_0ᵀ I_0 S_0 in its own frame does not depend on q
    C(0, 0) = 0.0;
    return;
  }
  ComputeTransforms(q);
  ComputeBaseFrameMotion(qd);
  double m = 0.0, hx = 0.0, hy = 0.0, I = 0.0;          // Ic = [[I, −hy, hx], [−hy, m, 0], [hx, 0, m]]
  double dI = 0.0, dhx = 0.0, dhy = 0.0;                // İc, the same shape with zero mass
  Vector3d h = Vector3d::Zero();                        // Σ I_b v_b
  const auto ic = [&](const Vector3d& x) -> Vector3d {  // Ic x
    return {I * x[0] - hy * x[1] + hx * x[2], -hy * x[0] + m * x[1], hx * x[0] + m * x[2]};
  };
  const auto bc = [&](const Vector3d& x, double sign) -> Vector3d {  // Bc x (sign 1) or Bcᵀ x (sign −1)
    return 0.5 * Vector3d(dI * x[0] + (sign * h[2] - dhy) * x[1] + (dhx - sign * h[1]) * x[2],
                          (-dhy - sign * h[2]) * x[0], (dhx + sign * h[1]) * x[0]);
  };
  const double *J0 = axes_.col(0).data(), *J1 = axes_.col(1).data(), *J2 = axes_.col(2).data();
  const double *P1 = P_.col(1).data(), *P2 = P_.col(2).data();
  const double *Q0 = Q_.col(0).data(), *Q1 = Q_.col(1).data(), *Q2 = Q_.col(2).data();
  for (int j = n - 1; j >= 0; --j) {
    // Add body j to the subtree's composites.
    const PlanarBody& b = chain_.bodies[j];
    const Vector3d& vj = ov_[j];
    const double bm = b.mass, bhx = bm * com_[j].x(), bhy = bm * com_[j].y();
    const double bI = b.inertia + bm * com_[j].squaredNorm();
    h += Vector3d(bI * vj[0] - bhy * vj[1] + bhx * vj[2], -bhy * vj[0] + bm * vj[1], bhx * vj[0] + bm * vj[2]);
    dI += 2.0 * (bhx * vj[1] + bhy * vj[2]);
    dhx += bm * vj[1] - vj[0] * bhy;
    dhy += bm * vj[2] + vj[0] * bhx;
    m += bm;
    hx += bhx;
    hy += bhy;
    I += bI;
    // Column j: rows i <= j from F_j, rows i > j from P_i, Q_i made on the way down.
    const Vector3d J = axes_.row(j).transpose();
    const Vector3d dJ = CrossMotion(vj, J);  // J̇_j; its angular part is 0
    const Vector3d F = ic(dJ) + bc(J, 1.0);
    P_.row(j) = ic(J);
    Q_.row(j) = bc(J, -1.0);
    double* col = &C(0, j);
    for (int i = 0; i <= j; ++i) col[i] = J0[i] * F[0] + J1[i] * F[1] + J2[i] * F[2];
    for (int i = j + 1; i < n; ++i) col[i] = P1[i] * dJ[1] + P2[i] * dJ[2] + Q0[i] * J[0] + Q1[i] * J[1] + Q2[i] * J[2];
  }
}

void RecursiveDynamics::ComputeKineticEnergyGradient(ConstVecRef q, ConstVecRef qd, VecRef dTdq) const {
  AssertSizes(q, qd, dTdq);
  const int n = num_dofs();
  ComputeTransforms(q);
  ComputeVelocities(qd);
  Vector3d H = Vector3d::Zero();  // Σ_{i≥j} I_i v_i in frame j
  for (int j = n - 1; j >= 0; --j) {
    const int k = SubspaceIndex(chain_.joints[j].type);
    if (j < n - 1) H = ApplyXT(X_[j + 1], H);
    H += inertia_[j] * v_[j];
    Vector3d u = v_[j];  // parent's velocity in frame j
    u[k] -= qd[j];
    dTdq[j] = -CrossForce(u, H)[k];
  }
}

double RecursiveDynamics::ComputeKineticEnergy(ConstVecRef q, ConstVecRef qd) const {
  AssertSizes(q, qd);
  ComputeTransforms(q);
  ComputeVelocities(qd);
  double T = 0.0;
  for (int i = 0; i < num_dofs(); ++i) T += 0.5 * v_[i].dot(inertia_[i] * v_[i]);
  return T;
}

double RecursiveDynamics::ComputePotentialEnergy(ConstVecRef q) const {
  AssertSizes(q);
  return chain_.PotentialEnergy<double>(std::span<const double>(q.data(), q.size()));
}

}  // namespace lagrange
