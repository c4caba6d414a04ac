// Floating-base recursive dynamics (FloatingDynamics): RNEA, CRBA and ABA
// with a free-flyer root checked against each other, against an independent
// world-frame forward kinematics written here (its kinetic energy gives M by
// polarisation, its momentum's exact time derivative by dual numbers) and
// against the physics of free bodies: Euler's equations, free fall at g,
// conserved momentum.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <numbers>
#include <random>
#include <memory>
#include <stdexcept>
#include <utility>

#include "plant/dual.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/free_flyer.hpp"
#include "plant/lagrangian.hpp"
#include "plant/random_tree.hpp"
#include "plant/spatial_dynamics.hpp"
#include "tests/support/plant_cases.hpp"

// Dual numbers as an Eigen scalar, for the reference below.
namespace Eigen {
template <>
struct NumTraits<lagrange::Dual1> : GenericNumTraits<lagrange::Dual1> {
  using Real = lagrange::Dual1;
  using NonInteger = lagrange::Dual1;
  using Literal = lagrange::Dual1;
  using Nested = lagrange::Dual1;
  enum { IsComplex = 0, IsInteger = 0, IsSigned = 1, RequireInitialization = 1, ReadCost = 1, AddCost = 3, MulCost = 3 };
};
}  // namespace Eigen

namespace lagrange {
namespace {

using testing::RandomVector;
using testing::RelativeDifference;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr double kInverseTol = 1e-10;  // ID(FD(tau)) − tau, relative
constexpr double kAgreeTol = 1e-12;    // between derivations, relative
constexpr double kMomentumRateTol = 1e-10;
constexpr int kTrees = 24;

RigidTree FloatingTree(int k, std::mt19937& rng) {
  RandomTreeOptions options;
  options.bodies = k % 9;  // 0: a lone free body
  options.chain = k % 2 == 0;
  return RandomFloatingTree(options, rng);
}

// q: p within ±1 m, a random unit quaternion, joints within ±π (±1 m prismatic); v within ±2.
struct State {
  VectorXd q, v;
};
State RandomState(const RigidTree& tree, std::mt19937& rng) {
  State s{RandomVector(tree.num_q(), -1.0, 1.0, rng), RandomVector(tree.num_v(), -2.0, 2.0, rng)};
  s.q.segment<4>(3) = Eigen::Quaterniond(RandomRotation(rng)).coeffs();  // x y z w
  for (int i = 0; i < tree.num_joints(); ++i) {
    if (tree.joints[i].type == JointType::kRevolute) s.q[kFreeFlyerNq + i] *= std::numbers::pi;
  }
  return s;
}

// ---- an independent reference: world-frame kinematics, templated over the scalar ----

template <class S>
using V3 = Eigen::Matrix<S, 3, 1>;
template <class S>
using M3 = Eigen::Matrix<S, 3, 3>;

template <class S>
M3<S> Lift(const Eigen::Matrix3d& A) {
  return A.template cast<S>();
}

// Rotation of a quaternion (x, y, z, w), homogeneous of degree 2 (a rotation on the unit sphere).
template <class S>
M3<S> QuaternionRotation(const S& x, const S& y, const S& z, const S& w) {
  const V3<S> u(x, y, z);
  M3<S> K;
  K << S(0.0), -z, y, z, S(0.0), -x, -y, x, S(0.0);
  return (w * w - u.dot(u)) * M3<S>::Identity() + S(2.0) * (u * u.transpose()) + S(2.0) * w * K;
}

template <class S>
M3<S> AxisRotation(const Eigen::Vector3d& a, const S& angle) {
  using std::cos;
  using std::sin;
  M3<S> K;
  K << S(0.0), S(-a.z()), S(a.y()), S(a.z()), S(0.0), S(-a.x()), S(-a.y()), S(a.x()), S(0.0);
  return M3<S>::Identity() + sin(angle) * K + (S(1.0) - cos(angle)) * (K * K);
}

// Kinetic energy and spatial momentum (world axes, about the world origin)
// of the tree at (q, v), by world-frame forward kinematics.
template <class S>
struct Reference {
  S T{};
  V3<S> angular = V3<S>::Zero(), linear = V3<S>::Zero();
};

template <class S>
Reference<S> Evaluate(const RigidTree& tree, const std::vector<S>& q, const std::vector<S>& v) {
  const int n = tree.num_joints();
  std::vector<M3<S>> R(n + 1);
  std::vector<V3<S>> o(n + 1), w(n + 1), vo(n + 1);  // origin, angular velocity, origin's velocity
  R[0] = QuaternionRotation(q[3], q[4], q[5], q[6]);
  o[0] = V3<S>(q[0], q[1], q[2]);
  w[0] = R[0] * V3<S>(v[3], v[4], v[5]);
  vo[0] = R[0] * V3<S>(v[0], v[1], v[2]);
  Reference<S> out;
  auto add = [&](const RigidBody& b, int k) {
    const V3<S> r = R[k] * b.com.cast<S>();
    const V3<S> c = o[k] + r, vc = vo[k] + w[k].cross(r);
    const M3<S> I = R[k] * Lift<S>(b.inertia) * R[k].transpose();
    const V3<S> L = I * w[k];
    const V3<S> p = S(b.mass) * vc;
    out.T += S(0.5) * vc.dot(p) + S(0.5) * w[k].dot(L);
    out.linear += p;
    out.angular += L + c.cross(p);
  };
  add(tree.base, 0);
  for (int i = 0; i < n; ++i) {
    const TreeJoint& j = tree.joints[i];
    const int p = j.parent + 1, k = i + 1;
    const M3<S> Rj = R[p] * Lift<S>(j.rotation);
    const V3<S> oj = o[p] + R[p] * j.position.cast<S>();
    const V3<S> axis = Rj * j.axis.cast<S>();
    const S qi = q[kFreeFlyerNq + i], qdi = v[kFreeFlyerNv + i];
    if (j.type == JointType::kRevolute) {
      R[k] = Rj * AxisRotation(j.axis, qi);
      o[k] = oj;
      w[k] = w[p] + axis * qdi;
      vo[k] = vo[p] + w[p].cross(V3<S>(oj - o[p]));
    } else {
      R[k] = Rj;
      o[k] = oj + axis * qi;
      w[k] = w[p];
      vo[k] = vo[p] + w[p].cross(V3<S>(o[k] - o[p])) + axis * qdi;
    }
    add(tree.bodies[i], k);
  }
  return out;
}

std::vector<double> Std(const VectorXd& x) { return {x.data(), x.data() + x.size()}; }

double ReferenceT(const RigidTree& tree, const VectorXd& q, const VectorXd& v) {
  return Evaluate<double>(tree, Std(q), Std(v)).T;
}

// q̇ of the configuration at (q, v): ṗ = R v_b, quaternion ½ quat ⊗ (ω_b, 0), joints qd.
VectorXd ConfigurationRate(const VectorXd& q, const VectorXd& v) {
  VectorXd qdot(q.size());
  const Eigen::Quaterniond quat(q[6], q[3], q[4], q[5]);
  qdot.head<3>() = quat.toRotationMatrix() * v.head<3>();
  const Eigen::Quaterniond rate = quat * Eigen::Quaterniond(0.0, v[3], v[4], v[5]);
  qdot.segment<4>(3) = 0.5 * rate.coeffs();
  qdot.tail(q.size() - kFreeFlyerNq) = v.tail(v.size() - kFreeFlyerNv);
  return qdot;
}

DynamicsTerms AllTerms() { return {}; }

// A model of `tree`, its data and a random state.
struct Case {
  Case(RigidTree tree, std::mt19937& rng)
      : model(std::move(tree)), data(model.MakeData()), s(RandomState(model.tree(), rng)) {}
  FloatingDynamics model;
  std::unique_ptr<FloatingData> data;
  State s;
};

// ---- the tree description ----

TEST(FloatingTree, SizesCountTheFreeFlyer) {
  std::mt19937 rng{42};
  const RigidTree tree = RandomFloatingTree(5, rng);
  EXPECT_EQ(tree.num_q(), 5 + 7);
  EXPECT_EQ(tree.num_v(), 5 + 6);
  RandomTreeOptions options;
  options.bodies = 5;
  const RigidTree fixed = RandomRigidTree(options, rng);
  EXPECT_EQ(fixed.num_q(), fixed.num_v());
  EXPECT_EQ(fixed.num_q(), 5);
}

TEST(FloatingTree, FixedBaseAlgorithmsRefuseAFloatingTree) {
  std::mt19937 rng{42};
  const RigidTree tree = RandomFloatingTree(3, rng);
  ASSERT_TRUE(ValidateRigidTree(tree).has_value());
  EXPECT_NE(ValidateRigidTree(tree)->find("floating_base"), std::string::npos);
  EXPECT_THROW(SpatialDynamics{tree}, std::invalid_argument);
  EXPECT_FALSE(ValidateFloatingTree(tree).has_value()) << *ValidateFloatingTree(tree);
}

TEST(FloatingTree, FloatingDynamicsRefusesWhatItCannotModel) {
  std::mt19937 rng{42};
  RandomTreeOptions options;
  options.bodies = 3;
  EXPECT_THROW(FloatingDynamics{RandomRigidTree(options, rng)}, std::invalid_argument);  // a fixed base
  RigidTree massless = RandomFloatingTree(options, rng);
  massless.base.mass = 0.0;
  ASSERT_TRUE(ValidateFloatingTree(massless).has_value());
  EXPECT_NE(ValidateFloatingTree(massless)->find("base.mass"), std::string::npos);
  RigidTree flat = RandomFloatingTree(options, rng);
  flat.base.inertia = Eigen::Vector3d(0.0, 0.1, 0.1).asDiagonal();
  EXPECT_NE(ValidateFloatingTree(flat).value_or("").find("base.inertia"), std::string::npos);
  RigidTree mimic = RandomFloatingTree(options, rng);
  mimic.joints[2].mimic = 0;
  EXPECT_FALSE(ValidateFloatingTree(mimic).has_value());  // mimics compose with the free-flyer
  mimic.joints[2].mimic = 2;                              // but a joint cannot follow itself
  EXPECT_NE(ValidateFloatingTree(mimic).value_or("").find("joints[2].mimic"), std::string::npos);
  RigidTree lone;
  lone.floating_base = true;
  lone.base = RandomRigidBody(rng);
  EXPECT_FALSE(ValidateFloatingTree(lone).has_value());  // a free body: no joints
}

#ifndef NDEBUG
// Debug builds check sizes at the top of every query, naming which size was expected.
TEST(FloatingTree, DebugBuildsNameTheExpectedSize) {
  std::mt19937 rng{42};
  const FloatingDynamics model(RandomFloatingTree(2, rng));
  auto data = model.MakeData();
  const VectorXd q = VectorXd::Zero(model.num_q()), v = VectorXd::Zero(model.num_v());
  VectorXd out(model.num_v()), wrong(model.num_q());
  MatrixXd M(model.num_v(), model.num_v());
  EXPECT_DEATH(model.ComputeMassMatrix(*data, v, M), "num_q");  // v where q belongs
  EXPECT_DEATH(model.ComputeForwardDynamics(*data, q, q, v, {}, out), "num_v");
  EXPECT_DEATH(model.ComputeInverseDynamics(*data, q, v, v, {}, wrong), "num_v");
  // The Lagrangian path's energies are the fixed-base tree's (no validation on that constructor).
  const LagrangianDynamics<RigidTree> lagrangian(model.tree());
  auto lagrangian_data = lagrangian.MakeData();
  const VectorXd qj = VectorXd::Zero(model.num_joints());
  EXPECT_DEATH(lagrangian.ComputeKineticEnergy(*lagrangian_data, qj, qj), "FloatingDynamics");
}
#endif

// ---- RNEA, CRBA, ABA ----

TEST(FloatingDynamics, ForwardThenInverseDynamicsGivesTheForceBack) {
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const VectorXd tau = RandomVector(model.num_v(), -3.0, 3.0, rng);
    VectorXd a(model.num_v()), back(model.num_v());
    model.ComputeForwardDynamics(*data, s.q, s.v, tau, AllTerms(), a);
    model.ComputeInverseDynamics(*data, s.q, s.v, a, AllTerms(), back);
    EXPECT_LT(RelativeDifference(back, tau), kInverseTol) << "tree " << k;
  }
}

TEST(FloatingDynamics, ForwardDynamicsIsTheSameFarFromTheWorldOrigin) {
  // Gravity is uniform, so moving the whole robot 10 km changes no acceleration
  // (v̇ is in base axes); an algorithm that summed inertias about the world
  // origin would lose about nine digits to m |p|² here.
  constexpr double kFar = 1e4;  // m
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const VectorXd tau = RandomVector(model.num_v(), -3.0, 3.0, rng);
    VectorXd far_q = s.q, a(model.num_v()), far_a(model.num_v());
    far_q.head<3>() += Eigen::Vector3d(-kFar, 0.5 * kFar, kFar);
    model.ComputeForwardDynamics(*data, s.q, s.v, tau, AllTerms(), a);
    model.ComputeForwardDynamics(*data, far_q, s.v, tau, AllTerms(), far_a);
    EXPECT_LT(RelativeDifference(far_a, a), kInverseTol) << "tree " << k;
  }
}

TEST(FloatingDynamics, MassMatrixIsTheKineticEnergysHessian) {
  // T is quadratic in v: M_ij = T(e_i + e_j) − T(e_i) − T(e_j), M_ii = 2 T(e_i),
  // with T from the world-frame reference.
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    MatrixXd M(nv, nv), reference(nv, nv);
    model.ComputeMassMatrix(*data, s.q, M);
    const MatrixXd E = MatrixXd::Identity(nv, nv);
    for (int i = 0; i < nv; ++i) {
      for (int j = 0; j < nv; ++j) {
        reference(i, j) = i == j ? 2.0 * ReferenceT(model.tree(), s.q, E.col(i))
                                 : ReferenceT(model.tree(), s.q, E.col(i) + E.col(j)) -
                                       ReferenceT(model.tree(), s.q, E.col(i)) - ReferenceT(model.tree(), s.q, E.col(j));
      }
    }
    EXPECT_LT(RelativeDifference(M, reference), kAgreeTol) << "tree " << k;
    EXPECT_NEAR(0.5 * s.v.dot(M * s.v), model.ComputeKineticEnergy(*data, s.q, s.v),
                kAgreeTol * (1.0 + s.v.dot(M * s.v)));
  }
}

TEST(FloatingDynamics, InverseDynamicsIsMassMatrixTimesAccelerationPlusBias) {
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    const VectorXd a = RandomVector(nv, -3.0, 3.0, rng);
    MatrixXd M(nv, nv);
    VectorXd tau(nv), bias(nv), Ma(nv);
    model.ComputeMassMatrix(*data, s.q, M);
    model.ComputeInverseDynamics(*data, s.q, s.v, a, AllTerms(), tau);
    model.ComputeInverseDynamics(*data, s.q, s.v, VectorXd::Zero(nv), AllTerms(), bias);
    model.ComputeInverseDynamics(*data, s.q, s.v, a, {.gravity = false, .coriolis = false}, Ma);
    EXPECT_LT(RelativeDifference(tau, M * a + bias), kAgreeTol) << "tree " << k;
    EXPECT_LT(RelativeDifference(Ma, M * a), kAgreeTol) << "tree " << k;
  }
}

TEST(FloatingDynamics, TorqueFreeBodyObeysEulersEquations) {
  // One body, centre of mass at its origin, no gravity: I ω̇ + ω × I ω = 0 and,
  // in body axes, v̇_b = −ω × v_b.
  std::mt19937 rng{42};
  RigidTree tree;
  tree.floating_base = true;
  tree.base.mass = 2.5;
  const Eigen::Matrix3d Rp = RandomRotation(rng);
  tree.base.inertia = Rp * Eigen::Vector3d(0.1, 0.2, 0.25).asDiagonal() * Rp.transpose();
  tree.base.inertia = 0.5 * (tree.base.inertia + tree.base.inertia.transpose()).eval();
  tree.gravity.setZero();
  const FloatingDynamics model(tree);
  auto data = model.MakeData();
  const State s = RandomState(tree, rng);
  VectorXd a(6);
  model.ComputeForwardDynamics(*data, s.q, s.v, VectorXd::Zero(6), AllTerms(), a);
  const Eigen::Vector3d v = s.v.head<3>(), w = s.v.tail<3>();
  const Eigen::Vector3d euler = tree.base.inertia * a.tail<3>() + w.cross(tree.base.inertia * w);
  EXPECT_LT(euler.norm(), kAgreeTol * (tree.base.inertia * w).norm() * w.norm());
  EXPECT_LT((a.head<3>() + w.cross(v)).norm(), kAgreeTol * w.norm() * v.norm());
}

TEST(FloatingDynamics, AnyTreeAtRestFallsAtGravity) {
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    VectorXd a(nv);
    model.ComputeForwardDynamics(*data, s.q, VectorXd::Zero(nv), VectorXd::Zero(nv), AllTerms(), a);
    const Eigen::Matrix3d R = Eigen::Quaterniond(s.q[6], s.q[3], s.q[4], s.q[5]).toRotationMatrix();
    VectorXd expected = VectorXd::Zero(nv);
    expected.head<3>() = R.transpose() * model.tree().gravity;  // the base's linear acceleration, base axes
    EXPECT_LT((a - expected).norm(), kAgreeTol * kStandardGravity) << "tree " << k;
  }
}

TEST(FloatingDynamics, MomentumIsConservedWithoutExternalForce) {
  // No gravity, zero base wrench: dh/dt = (∂h/∂q) q̇ + (∂h/∂v) a = 0, taken
  // exactly by dual numbers through the world-frame reference, with the joint
  // torques zero and then random (internal forces either way).
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    RigidTree tree = FloatingTree(k, rng);
    tree.gravity.setZero();
    const FloatingDynamics model(tree);
    auto data = model.MakeData();
    const State s = RandomState(tree, rng);
    const int nv = model.num_v();
    for (const bool torques : {false, true}) {
      VectorXd tau = VectorXd::Zero(nv), a(nv);
      if (torques) tau.tail(nv - 6) = RandomVector(nv - 6, -3.0, 3.0, rng);
      model.ComputeForwardDynamics(*data, s.q, s.v, tau, AllTerms(), a);
      const VectorXd qdot = ConfigurationRate(s.q, s.v);
      std::vector<Dual1> q(s.q.size()), v(nv);
      for (int i = 0; i < s.q.size(); ++i) q[i] = {s.q[i], qdot[i]};
      for (int i = 0; i < nv; ++i) v[i] = {s.v[i], a[i]};
      const Reference<Dual1> h = Evaluate<Dual1>(tree, q, v);
      Eigen::Vector3d rate_angular, rate_linear, angular, linear;
      for (int r = 0; r < 3; ++r) {
        rate_angular[r] = h.angular[r].d;
        rate_linear[r] = h.linear[r].d;
        angular[r] = h.angular[r].v;
        linear[r] = h.linear[r].v;
      }
      const double scale = 1.0 + a.norm() + s.v.squaredNorm();
      EXPECT_LT(rate_angular.norm(), kMomentumRateTol * scale) << "tree " << k << " torques " << torques;
      EXPECT_LT(rate_linear.norm(), kMomentumRateTol * scale) << "tree " << k << " torques " << torques;
      const spatial::Force mine = model.ComputeMomentum(*data, s.q, s.v);
      EXPECT_LT((mine.n - angular).norm() + (mine.f - linear).norm(), kAgreeTol * (1.0 + angular.norm()));
    }
  }
}

TEST(FloatingDynamics, PotentialEnergyFallsAsTheBaseMovesWithGravity) {
  std::mt19937 rng{42};
  for (int k = 0; k < 6; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    double mass = model.tree().base.mass;
    for (const RigidBody& b : model.tree().bodies) mass += b.mass;
    VectorXd moved = s.q;
    moved.head<3>() += 0.3 * model.tree().gravity;
    const double drop = model.ComputePotentialEnergy(*data, s.q) - model.ComputePotentialEnergy(*data, moved);
    EXPECT_NEAR(drop, mass * 0.3 * model.tree().gravity.squaredNorm(), kAgreeTol * mass * 100.0);
  }
}

// ---- kinematics ----

// A floating tree with a frame at a random placement on every body, the base's too.
RigidTree TreeWithFrames(int k, std::mt19937& rng) {
  RigidTree tree = FloatingTree(k, rng);
  std::uniform_real_distribution<double> offset(-0.3, 0.3);
  for (int b = -1; b < tree.num_joints(); ++b) {
    tree.frames.push_back({"f" + std::to_string(b + 1), b, Eigen::Vector3d(offset(rng), offset(rng), offset(rng)),
                           RandomRotation(rng)});
  }
  return tree;
}

constexpr double kEps = 1e-6;
constexpr double kFiniteDifferenceTol = 1e-8;  // central differences at kEps, relative

TEST(FloatingKinematics, FrameJacobianGivesTheFramesVelocity) {
  // J_k v = (ṗ_k, ω_k) by central differences along q ⊕ ±ε v.
  std::mt19937 rng{42};
  for (int k = 0; k < 12; ++k) {
    const FloatingDynamics model(TreeWithFrames(k, rng));
    auto data = model.MakeData();
    const State s = RandomState(model.tree(), rng);
    VectorXd plus(model.num_q()), minus(model.num_q());
    Integrate(s.q, s.v, kEps, plus);
    Integrate(s.q, s.v, -kEps, minus);
    MatrixXd J(6, model.num_v());
    for (int f = 0; f < static_cast<int>(model.tree().frames.size()); ++f) {
      model.ComputeFramePlacements(*data, plus);
      const Eigen::Matrix3d Rp = data->frame_rotation(f);
      const Eigen::Vector3d pp = data->frame_position(f);
      model.ComputeFramePlacements(*data, minus);
      const Eigen::Matrix3d Rm = data->frame_rotation(f);
      const Eigen::Vector3d pm = data->frame_position(f);
      model.ComputeFrameJacobian(*data, s.q, f, J);
      const Eigen::Matrix3d W = (Rp - Rm) / (2.0 * kEps) * data->frame_rotation(f).transpose();  // [ω]×
      Vector6d expected;
      expected << (pp - pm) / (2.0 * kEps), 0.5 * Eigen::Vector3d(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1));
      EXPECT_LT(RelativeDifference(J * s.v, expected), kFiniteDifferenceTol) << "tree " << k << " frame " << f;
    }
  }
}

TEST(FloatingKinematics, CentroidalMomentumMatrixGivesTheMomentumAboutTheCentreOfMass) {
  // A_G v = (linear momentum, angular momentum about c), against the
  // world-frame reference; J_c v = ċ by central differences, and m J_c v the
  // linear momentum.
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    MatrixXd A(6, nv), Jc(3, nv), unused(3, nv);
    const Eigen::Vector3d c = model.ComputeCentroidalMomentumMatrix(*data, s.q, A);
    const Reference<double> h = Evaluate<double>(model.tree(), Std(s.q), Std(s.v));
    Vector6d expected;
    expected << h.linear, h.angular - c.cross(h.linear);
    EXPECT_LT(RelativeDifference(A * s.v, expected), kAgreeTol) << "tree " << k;
    EXPECT_LT((model.ComputeCenterOfMass(*data, s.q, Jc) - c).norm(), kAgreeTol);
    double mass = model.tree().base.mass;
    for (const RigidBody& b : model.tree().bodies) mass += b.mass;
    EXPECT_LT(RelativeDifference(mass * Jc * s.v, h.linear), kAgreeTol) << "tree " << k;
    VectorXd plus(model.num_q()), minus(model.num_q());
    Integrate(s.q, s.v, kEps, plus);
    Integrate(s.q, s.v, -kEps, minus);
    const Eigen::Vector3d rate =
        (model.ComputeCenterOfMass(*data, plus, unused) - model.ComputeCenterOfMass(*data, minus, unused)) / (2.0 * kEps);
    EXPECT_LT(RelativeDifference(rate, Jc * s.v), kFiniteDifferenceTol) << "tree " << k;
  }
}

// ---- J̇v and Ȧ_G v ----

constexpr double kDriftStep = 1e-4;     // s: the central difference's step along q(t) = q ⊕ t v
constexpr double kDriftTol = 1e-6;      // relative (the difference's error is O(step²))

TEST(FloatingKinematics, FrameDriftIsTheRateOfTheJacobianAlongTheMotion) {
  // J̇_k v = d/dt (J_k(q(t)) v) with v held and q(t) = q ⊕ t v on the manifold.
  std::mt19937 rng{42};
  for (int k = 0; k < 12; ++k) {
    const FloatingDynamics model(TreeWithFrames(k, rng));
    auto data = model.MakeData();
    const State s = RandomState(model.tree(), rng);
    VectorXd plus(model.num_q()), minus(model.num_q());
    Integrate(s.q, s.v, kDriftStep, plus);
    Integrate(s.q, s.v, -kDriftStep, minus);
    MatrixXd Jp(6, model.num_v()), Jm(6, model.num_v());
    for (int f = 0; f < static_cast<int>(model.tree().frames.size()); ++f) {
      model.ComputeFrameJacobian(*data, plus, f, Jp);
      model.ComputeFrameJacobian(*data, minus, f, Jm);
      Vector6d drift;
      model.ComputeFrameAccelerationBias(*data, s.q, s.v, f, drift);
      EXPECT_LT(RelativeDifference(drift, (Jp - Jm) * s.v / (2.0 * kDriftStep)), kDriftTol)
          << "tree " << k << " frame " << f;
    }
  }
}

TEST(FloatingKinematics, CentroidalDriftIsTheRateOfTheCentroidalMatrixAlongTheMotion) {
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    VectorXd plus(model.num_q()), minus(model.num_q());
    Integrate(s.q, s.v, kDriftStep, plus);
    Integrate(s.q, s.v, -kDriftStep, minus);
    MatrixXd Ap(6, nv), Am(6, nv);
    model.ComputeCentroidalMomentumMatrix(*data, plus, Ap);
    model.ComputeCentroidalMomentumMatrix(*data, minus, Am);
    Vector6d drift;
    model.ComputeCentroidalMomentumBias(*data, s.q, s.v, drift);
    EXPECT_LT(RelativeDifference(drift, (Ap - Am) * s.v / (2.0 * kDriftStep)), kDriftTol) << "tree " << k;
  }
}

TEST(FloatingKinematics, CentroidalMomentumChangesOnlyByGravityWhateverTheJointsDo) {
  // ḣ_G = A_G a + Ȧ_G v with a = FD(q, v, tau): joint torques are internal, so
  // with no base wrench ḣ_G = (m g, 0) (zero without gravity).
  std::mt19937 rng{42};
  for (int k = 0; k < kTrees; ++k) {
    const auto& [model, data, s] = Case(FloatingTree(k, rng), rng);
    const int nv = model.num_v();
    VectorXd tau = RandomVector(nv, -3.0, 3.0, rng), a(nv);
    tau.head<6>().setZero();
    double mass = model.tree().base.mass;
    for (const RigidBody& b : model.tree().bodies) mass += b.mass;
    for (const bool gravity : {false, true}) {
      model.ComputeForwardDynamics(*data, s.q, s.v, tau, {.gravity = gravity, .coriolis = true}, a);
      MatrixXd A(6, nv);
      Vector6d drift, expected = Vector6d::Zero();
      model.ComputeCentroidalMomentumMatrix(*data, s.q, A);
      model.ComputeCentroidalMomentumBias(*data, s.q, s.v, drift);
      if (gravity) expected.head<3>() = mass * model.tree().gravity;
      // Scaled by the terms' size: ḣ_G is a difference of large numbers.
      const double scale = 1.0 + (A * a).norm() + drift.norm();
      EXPECT_LT((A * a + drift - expected).norm() / scale, kAgreeTol * 10.0) << "tree " << k << " gravity " << gravity;
    }
  }
}

}  // namespace
}  // namespace lagrange
