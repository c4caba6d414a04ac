#include "plant/recursive_dynamics.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "plant/spatial_dynamics.hpp"
#include "plant/spatial_sincos.hpp"

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

std::optional<PlanarChain> PlanarChainOf(const RigidTree& tree) {
  // Exact comparisons: the built-in plants build their trees from these
  // very numbers (PlanarTreeJoint, PlanarGravity), and anything else is
  // evaluated in 3-D, correctly, by the spatial algorithms.
  if (tree.gravity.x() != 0.0 || tree.gravity.z() != 0.0 || tree.has_mimics()) return std::nullopt;
  PlanarChain chain;
  chain.g = -tree.gravity.y();
  for (int i = 0; i < tree.num_joints(); ++i) {
    const TreeJoint& j = tree.joints[static_cast<std::size_t>(i)];
    const Matrix3d& R = j.rotation;
    const bool about_z = R(2, 2) == 1.0 && R(0, 2) == 0.0 && R(1, 2) == 0.0 && R(2, 0) == 0.0 && R(2, 1) == 0.0;
    const Vector3d axis = j.type == JointType::kRevolute ? Vector3d::UnitZ() : Vector3d::UnitX();
    if (j.parent != i - 1 || !about_z || j.position.z() != 0.0 || j.axis != axis) return std::nullopt;
    chain.joints.push_back({j.type, j.position.head<2>(), std::atan2(R(1, 0), R(0, 0))});
    const RigidBody& b = tree.bodies[static_cast<std::size_t>(i)];
    chain.bodies.push_back({b.mass, b.com.head<2>(), b.inertia(2, 2)});
  }
  return chain;
}

std::vector<JointType> PlanarChain::joint_types() const {
  std::vector<JointType> types;
  types.reserve(joints.size());
  for (const PlanarJoint& j : joints) types.push_back(j.type);
  return types;
}

// Workspace of one user (n entries each): frames, velocities, the passes'
// vectors and, for the Coriolis matrix, base-frame motion and one row per
// joint of the joint axes J_j and the factors P_j, Q_j.
struct RecursiveDynamics::Data final : DynamicsData {
  explicit Data(const RecursiveDynamics& model) : DynamicsData(model) {
    const int n = model.num_dofs();
    const auto N = static_cast<std::size_t>(n);
    X.resize(N);
    v.resize(N);
    a.resize(N);
    f.resize(N);
    c.resize(N);
    pA.resize(N);
    U.resize(N);
    ov.resize(N);
    com.resize(N);
    axes.resize(n, 3);
    P.resize(n, 3);
    Q.resize(n, 3);
    IA.resize(N);
    D.resize(N);
    u.resize(N);
    zeros = VectorXd::Zero(n);
    angle.resize(n);
    cosine.resize(n);
    sine.resize(n);
    spatial = model.spatial_->MakeData();
  }
  std::vector<Xform> X;
  std::vector<Eigen::Vector3d> v, a, f, c, pA, U;
  std::vector<Eigen::Vector3d> ov;
  std::vector<Eigen::Vector2d> com;
  Eigen::Matrix<double, Eigen::Dynamic, 3> axes, P, Q;
  std::vector<Eigen::Matrix3d> IA;
  std::vector<double> D, u;
  VectorXd zeros;  // qd or qdd = 0 for the gravity and Coriolis passes
  VectorXd angle, cosine, sine;  // (n) each joint's angle to its parent, its cosine and sine (ComputeTransforms)
  std::unique_ptr<DynamicsData> spatial;  // the derivatives' (spatial_)
};

RigidTree PlanarChainTree(const PlanarChain& chain) {
  RigidTree tree;
  tree.gravity = PlanarGravity(chain.g);
  for (int i = 0; i < chain.num_dofs(); ++i) {
    const PlanarJoint& j = chain.joints[static_cast<std::size_t>(i)];
    const PlanarBody& b = chain.bodies[static_cast<std::size_t>(i)];
    std::string name = std::to_string(i + 1);
    name.insert(0, 1, 'q');  // (not "q" + ...: GCC 12 warns falsely of overlap there, -Wrestrict)
    tree.joints.push_back(PlanarTreeJoint(name, j.type, i - 1, j.position.x(), j.position.y(), j.angle));
    tree.bodies.push_back(PlanarTreeBody(b.mass, b.com.x(), b.com.y(), b.inertia));
  }
  return tree;
}

RecursiveDynamics::RecursiveDynamics(PlanarChain chain)
    : Dynamics(chain.joint_types()),
      chain_(std::move(chain)),
      spatial_(std::make_unique<const SpatialDynamics>(PlanarChainTree(chain_))) {
  for (const PlanarBody& b : chain_.bodies) inertia_.push_back(SpatialInertia(b));
  const int n = num_dofs();
  angle_offset_.resize(n);
  angle_gain_.resize(n);
  for (int i = 0; i < n; ++i) {
    angle_offset_[i] = chain_.joints[i].angle;
    angle_gain_[i] = chain_.joints[i].type == JointType::kRevolute ? 1.0 : 0.0;
  }
}

RecursiveDynamics::~RecursiveDynamics() = default;

void RecursiveDynamics::ComputeInverseDynamicsDerivatives(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                          ConstVecRef qdd, DynamicsTerms terms, MatRef dtau_dq,
                                                          MatRef dtau_dqd, MatRef dtau_dqdd) const {
  Data& d = Checked<Data>(data, q, qd, qdd, dtau_dq, dtau_dqd, dtau_dqdd);
  CountTerms(d, terms);
  spatial_->ComputeInverseDynamicsDerivatives(*d.spatial, q, qd, qdd, terms, dtau_dq, dtau_dqd, dtau_dqdd);
}

void RecursiveDynamics::ComputeGravityDerivatives(DynamicsData& data, ConstVecRef q, MatRef dG_dq) const {
  Data& d = Checked<Data>(data, q, dG_dq);
  spatial_->ComputeGravityDerivatives(*d.spatial, q, dG_dq);
}

std::unique_ptr<DynamicsData> RecursiveDynamics::MakeData() const { return std::make_unique<Data>(*this); }

// The joints' sines and cosines in one vectorised loop (plant/spatial_sincos.hpp, within 2 ulp of the C
// library's), as the spatial sweeps take theirs: with the C library's, they were most of the mass matrix of a
// two-link chain (bench/dynamics_bench.cpp, mass/chain2). The angles are formed by a loop of the same width, so
// that the sine's vector loads read what vector stores wrote.
void RecursiveDynamics::ComputeTransforms(Data& d, ConstVecRef q) const {
  const int n = num_dofs();
  const double *offset = angle_offset_.data(), *gain = angle_gain_.data(), *qi = q.data();
  double* angle = d.angle.data();
  for (int i = 0; i < n; ++i) angle[i] = offset[i] + gain[i] * qi[i];
  spatial::SinCos(angle, d.cosine.data(), d.sine.data(), n);
  for (int i = 0; i < n; ++i) {
    const PlanarJoint& j = chain_.joints[i];
    Xform& X = d.X[i];
    X.c = d.cosine[i];
    X.s = d.sine[i];
    X.r = j.type == JointType::kRevolute ? j.position : Eigen::Vector2d(j.position + q[i] * Eigen::Vector2d(X.c, X.s));
  }
}

void RecursiveDynamics::ComputeVelocities(Data& d, ConstVecRef qd) const {
  Vector3d v_parent = Vector3d::Zero();
  for (int i = 0; i < num_dofs(); ++i) {
    d.v[i] = ApplyX(d.X[i], v_parent);
    d.v[i][SubspaceIndex(chain_.joints[i].type)] += qd[i];
    v_parent = d.v[i];
  }
}

// (X, qd, qdd) => tau = M qdd + [C qd] + [G].
void RecursiveDynamics::Rnea(Data& d, ConstVecRef qd, ConstVecRef qdd, DynamicsTerms terms, VecRef tau) const {
  const int n = num_dofs();
  if (terms.coriolis) ComputeVelocities(d, qd);
  Vector3d a_parent(0.0, 0.0, terms.gravity ? chain_.g : 0.0);  // −a_gravity, world frame
  for (int i = 0; i < n; ++i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    d.a[i] = ApplyX(d.X[i], a_parent);
    d.a[i][k] += qdd[i];
    if (terms.coriolis) {
      Vector3d vj = Vector3d::Zero();
      vj[k] = qd[i];
      d.a[i] += CrossMotion(d.v[i], vj);
    }
    d.f[i] = inertia_[i] * d.a[i];
    if (terms.coriolis) d.f[i] += CrossForce(d.v[i], inertia_[i] * d.v[i]);
    a_parent = d.a[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    tau[i] = d.f[i][SubspaceIndex(chain_.joints[i].type)];
    if (i > 0) d.f[i - 1] += ApplyXT(d.X[i], d.f[i]);
  }
}

void RecursiveDynamics::ComputeInverseDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef qdd,
                                               DynamicsTerms terms, VecRef tau) const {
  Data& d = Checked<Data>(data, q, qd, qdd, tau);
  if (terms.gravity) CountGravity(d);
  if (terms.coriolis) CountCoriolis(d);
  ComputeTransforms(d, q);
  Rnea(d, qd, qdd, terms, tau);
}

void RecursiveDynamics::ComputeForwardDynamics(DynamicsData& data, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                                               DynamicsTerms terms, VecRef qdd) const {
  Data& d = Checked<Data>(data, q, qd, tau, qdd);
  const int n = num_dofs();
  ComputeTransforms(d, q);
  // Pass 1: velocity-product terms c_i = v_i × S qd_i and bias forces p_i = v_i ×* I v_i.
  if (terms.coriolis) {
    CountCoriolis(d);
    ComputeVelocities(d, qd);
    for (int i = 0; i < n; ++i) {
      Vector3d vj = Vector3d::Zero();
      vj[SubspaceIndex(chain_.joints[i].type)] = qd[i];
      d.c[i] = CrossMotion(d.v[i], vj);
      d.pA[i] = CrossForce(d.v[i], inertia_[i] * d.v[i]);
    }
  } else {
    for (int i = 0; i < n; ++i) {
      d.c[i].setZero();
      d.pA[i].setZero();
    }
  }
  for (int i = 0; i < n; ++i) d.IA[i] = inertia_[i];
  // Pass 2: articulated-body inertias and bias forces, tip to base.
  for (int i = n - 1; i >= 0; --i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    d.U[i] = d.IA[i].col(k);
    d.D[i] = d.U[i][k];
    d.u[i] = tau[i] - d.pA[i][k];
    if (i > 0) {
      const Matrix3d Ia = d.IA[i] - d.U[i] * d.U[i].transpose() / d.D[i];
      const Vector3d pa = d.pA[i] + Ia * d.c[i] + d.U[i] * (d.u[i] / d.D[i]);
      const Matrix3d X = XMatrix(d.X[i]);
      d.IA[i - 1].noalias() += X.transpose() * Ia * X;
      d.pA[i - 1] += ApplyXT(d.X[i], pa);
    }
  }
  // Pass 3: accelerations, base to tip.
  Vector3d a_parent(0.0, 0.0, 0.0);
  if (terms.gravity) {
    CountGravity(d);
    a_parent[2] = chain_.g;
  }
  for (int i = 0; i < n; ++i) {
    const int k = SubspaceIndex(chain_.joints[i].type);
    const Vector3d a = ApplyX(d.X[i], a_parent) + d.c[i];
    qdd[i] = (d.u[i] - d.U[i].dot(a)) / d.D[i];
    a_parent = a;
    a_parent[k] += qdd[i];
  }
}

void RecursiveDynamics::ComputeMassMatrix(DynamicsData& data, ConstVecRef q, MatRef M) const {
  ComputeMassMatrix(data, MassMatrixKernel::kBaseFrame, q, M);
}

void RecursiveDynamics::ComputeMassMatrix(DynamicsData& data, MassMatrixKernel kernel, ConstVecRef q,
                                          MatRef M) const {
  Data& d = Checked<Data>(data, q, M);
  const int n = num_dofs();
  ComputeTransforms(d, q);
  if (kernel == MassMatrixKernel::kBaseFrame) {
    MassMatrixBaseFrame(d, M);
    return;
  }
  for (int i = 0; i < n; ++i) d.IA[i] = inertia_[i];  // composite inertias
  for (int i = n - 1; i > 0; --i) {
    const Matrix3d X = XMatrix(d.X[i]);
    d.IA[i - 1].noalias() += X.transpose() * d.IA[i] * X;
  }
  for (int i = 0; i < n; ++i) {
    Vector3d F = d.IA[i].col(SubspaceIndex(chain_.joints[i].type));
    M(i, i) = F[SubspaceIndex(chain_.joints[i].type)];
    for (int j = i; j > 0; --j) {
      F = ApplyXT(d.X[j], F);
      const double m = F[SubspaceIndex(chain_.joints[j - 1].type)];
      M(i, j - 1) = m;
      M(j - 1, i) = m;
    }
  }
}

// (X) => M in base coordinates, tip to base: the subtree j..n−1's composite
// inertia Ic = [[I, −hy, hx], [−hy, m, 0], [hx, 0, m]] (mass, first moment and
// inertia about the base origin: plain sums), F_j = Ic J_j, and column j of M:
// M_ij = J_i · F_j for i <= j, F_i · J_j for i > j (F_i made on the way down).
void RecursiveDynamics::MassMatrixBaseFrame(Data& d, MatRef M) const {
  const int n = num_dofs();
  ComputeBaseFrameMotion(d, nullptr);
  double m = 0.0, hx = 0.0, hy = 0.0, I = 0.0;
  const double *J0 = d.axes.col(0).data(), *J1 = d.axes.col(1).data(), *J2 = d.axes.col(2).data();
  double *F0 = d.P.col(0).data(), *F1 = d.P.col(1).data(), *F2 = d.P.col(2).data();
  for (int j = n - 1; j >= 0; --j) {
    const PlanarBody& b = chain_.bodies[j];
    const double bm = b.mass;
    m += bm;
    hx += bm * d.com[j].x();
    hy += bm * d.com[j].y();
    I += b.inertia + bm * d.com[j].squaredNorm();
    const double a0 = J0[j], a1 = J1[j], a2 = J2[j];
    const double f0 = I * a0 - hy * a1 + hx * a2, f1 = -hy * a0 + m * a1, f2 = hx * a0 + m * a2;
    F0[j] = f0;
    F1[j] = f1;
    F2[j] = f2;
    double* col = &M(0, j);
    for (int i = 0; i <= j; ++i) col[i] = J0[i] * f0 + J1[i] * f1 + J2[i] * f2;
    for (int i = j + 1; i < n; ++i) col[i] = F0[i] * a0 + F1[i] * a1 + F2[i] * a2;
  }
}

void RecursiveDynamics::ComputeCoriolisForce(DynamicsData& data, ConstVecRef q, ConstVecRef qd, VecRef c) const {
  Data& d = Checked<Data>(data, q, qd, c);
  ComputeTransforms(d, q);
  Rnea(d, qd, d.zeros, DynamicsTerms{.gravity = false, .coriolis = true}, c);
}

void RecursiveDynamics::ComputeGravityForce(DynamicsData& data, ConstVecRef q, VecRef G) const {
  Data& d = Checked<Data>(data, q, G);
  ComputeTransforms(d, q);
  Rnea(d, d.zeros, d.zeros, DynamicsTerms{.gravity = true, .coriolis = false}, G);
}

// (X, qd) => base-frame joint axes J_j, body velocities v_j and centres of mass.
void RecursiveDynamics::ComputeBaseFrameMotion(Data& d, const double* qd) const {
  double c = 1.0, s = 0.0;  // rotation of body j's frame in the base frame
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  Vector3d v = Vector3d::Zero();
  for (int j = 0; j < num_dofs(); ++j) {
    const Xform& X = d.X[j];
    p += Eigen::Vector2d(c * X.r.x() - s * X.r.y(), s * X.r.x() + c * X.r.y());
    const double cj = c * X.c - s * X.s;
    s = s * X.c + c * X.s;
    c = cj;
    const Vector3d J =
        chain_.joints[j].type == JointType::kRevolute ? Vector3d(1.0, p.y(), -p.x()) : Vector3d(0.0, c, s);
    d.axes.row(j) = J;
    if (qd != nullptr) {
      v += qd[j] * J;
      d.ov[j] = v;
    }
    const PlanarBody& b = chain_.bodies[j];
    d.com[j] = p + Eigen::Vector2d(c * b.com.x() - s * b.com.y(), s * b.com.x() + c * b.com.y());
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
void RecursiveDynamics::ComputeCoriolisMatrix(DynamicsData& data, ConstVecRef q, ConstVecRef qd, MatRef C) const {
  Data& d = Checked<Data>(data, q, qd, C);
  const int n = num_dofs();
  if (n == 1) {  // the one body's M = S_0ᵀ I_0 S_0 in its own frame does not depend on q
    C(0, 0) = 0.0;
    return;
  }
  ComputeTransforms(d, q);
  ComputeBaseFrameMotion(d, qd.data());
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
  const double *J0 = d.axes.col(0).data(), *J1 = d.axes.col(1).data(), *J2 = d.axes.col(2).data();
  const double *P1 = d.P.col(1).data(), *P2 = d.P.col(2).data();
  const double *Q0 = d.Q.col(0).data(), *Q1 = d.Q.col(1).data(), *Q2 = d.Q.col(2).data();
  for (int j = n - 1; j >= 0; --j) {
    // Add body j to the subtree's composites.
    const PlanarBody& b = chain_.bodies[j];
    const Vector3d& vj = d.ov[j];
    const double bm = b.mass, bhx = bm * d.com[j].x(), bhy = bm * d.com[j].y();
    const double bI = b.inertia + bm * d.com[j].squaredNorm();
    h += Vector3d(bI * vj[0] - bhy * vj[1] + bhx * vj[2], -bhy * vj[0] + bm * vj[1], bhx * vj[0] + bm * vj[2]);
    dI += 2.0 * (bhx * vj[1] + bhy * vj[2]);
    dhx += bm * vj[1] - vj[0] * bhy;
    dhy += bm * vj[2] + vj[0] * bhx;
    m += bm;
    hx += bhx;
    hy += bhy;
    I += bI;
    // Column j: rows i <= j from F_j, rows i > j from P_i, Q_i made on the way down.
    const Vector3d J = d.axes.row(j).transpose();
    const Vector3d dJ = CrossMotion(vj, J);  // J̇_j; its angular part is 0
    const Vector3d F = ic(dJ) + bc(J, 1.0);
    d.P.row(j) = ic(J);
    d.Q.row(j) = bc(J, -1.0);
    double* col = &C(0, j);
    for (int i = 0; i <= j; ++i) col[i] = J0[i] * F[0] + J1[i] * F[1] + J2[i] * F[2];
    for (int i = j + 1; i < n; ++i) col[i] = P1[i] * dJ[1] + P2[i] * dJ[2] + Q0[i] * J[0] + Q1[i] * J[1] + Q2[i] * J[2];
  }
}

void RecursiveDynamics::ComputeKineticEnergyGradient(DynamicsData& data, ConstVecRef q, ConstVecRef qd,
                                                     VecRef dTdq) const {
  Data& d = Checked<Data>(data, q, qd, dTdq);
  const int n = num_dofs();
  ComputeTransforms(d, q);
  ComputeVelocities(d, qd);
  Vector3d H = Vector3d::Zero();  // Σ_{i≥j} I_i v_i in frame j
  for (int j = n - 1; j >= 0; --j) {
    const int k = SubspaceIndex(chain_.joints[j].type);
    if (j < n - 1) H = ApplyXT(d.X[j + 1], H);
    H += inertia_[j] * d.v[j];
    Vector3d u = d.v[j];  // parent's velocity in frame j
    u[k] -= qd[j];
    dTdq[j] = -CrossForce(u, H)[k];
  }
}

double RecursiveDynamics::ComputeKineticEnergy(DynamicsData& data, ConstVecRef q, ConstVecRef qd) const {
  Data& d = Checked<Data>(data, q, qd);
  ComputeTransforms(d, q);
  ComputeVelocities(d, qd);
  double T = 0.0;
  for (int i = 0; i < num_dofs(); ++i) T += 0.5 * d.v[i].dot(inertia_[i] * d.v[i]);
  return T;
}

double RecursiveDynamics::ComputePotentialEnergy(DynamicsData& data, ConstVecRef q) const {
  Checked(data, q);
  return chain_.PotentialEnergy<double>(std::span<const double>(q.data(), q.size()));
}

}  // namespace lagrange
