#include "plant/floating_lagrangian.hpp"

#include "plant/floating_dynamics.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <span>
#include <stdexcept>
#include <utility>

namespace lagrange {
namespace {

using namespace rigid_tree_energy;

Eigen::Matrix3d BaseRotation(ConstVecRef q) {
  return Eigen::Quaterniond(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
}

}  // namespace

FloatingLagrangianData::FloatingLagrangianData(const FloatingLagrangian& model)
    : model_(&model),
      r1(static_cast<std::size_t>(model.tree().num_dofs())),
      v1(static_cast<std::size_t>(model.num_v())),
      r2(r1.size()),
      v2(v1.size()),
      M(model.num_v(), model.num_v()),
      bias(model.num_v()) {}

FloatingLagrangian::FloatingLagrangian(RigidTree tree) : tree_(std::move(tree)) {
  if (auto error = ValidateFloatingTree(tree_)) throw std::invalid_argument("FloatingLagrangian: " + *error);
  n_ = tree_.num_dofs();
}

std::unique_ptr<FloatingLagrangianData> FloatingLagrangian::MakeData() const {
  return std::make_unique<FloatingLagrangianData>(*this);
}

void FloatingLagrangian::CheckSizes([[maybe_unused]] const FloatingLagrangianData& data,
                                    [[maybe_unused]] ConstVecRef q) const {
  eigen_assert(&data.model() == this && "FloatingLagrangianData made by another model");
  eigen_assert(q.size() == num_q() && "q: expected num_q() = num_v() + 1 entries (p, quaternion x y z w, joints)");
}

#define LAGRANGE_CHECK_NV(x) eigen_assert((x).size() == num_v() && #x ": expected num_v() entries (v_b, ω_b, joints)")

// T(r, v) at the identity base pose (T is left-invariant).
template <class S>
S FloatingLagrangian::Kinetic(const std::vector<S>& r, const std::vector<S>& v) const {
  const Vec3<S> zero{S(0.0), S(0.0), S(0.0)};
  const Placement<S> base{Identity<S>(), zero};
  return FloatingKineticEnergy<S>(tree_, base, {v[0], v[1], v[2]}, {v[3], v[4], v[5]}, std::span<const S>(r),
                                  std::span<const S>(v).subspan(kFreeFlyerNv));
}

void FloatingLagrangian::ComputeMassMatrix(FloatingLagrangianData& d, ConstVecRef q, MatRef M) const {
  CheckSizes(d, q);
  eigen_assert(M.rows() == num_v() && M.cols() == num_v() && "M: expected num_v() x num_v()");
  for (int k = 0; k < n_; ++k) d.r2[k] = Dual2(q[kFreeFlyerNq + k]);
  for (Dual2& x : d.v2) x = Dual2(0.0);
  for (int i = 0; i < num_v(); ++i) {
    for (int j = 0; j <= i; ++j) {
      d.v2[i].v.d = 1.0;  // ε1 on v_i
      d.v2[j].d.v = 1.0;  // ε2 on v_j
      M(i, j) = M(j, i) = Kinetic(d.r2, d.v2).d.d;
      d.v2[i] = Dual2(0.0);
      d.v2[j] = Dual2(0.0);
    }
  }
}

void FloatingLagrangian::ComputeBias(FloatingLagrangianData& d, ConstVecRef q, ConstVecRef v, DynamicsTerms terms,
                                     VecRef bias) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  LAGRANGE_CHECK_NV(bias);
  bias.setZero();
  if (terms.coriolis) {
    // μ_i = ∂T/∂v_i (ε1) and its rate along ṙ at v̇ = 0 (ε2 moves r by ṙ).
    for (int k = 0; k < n_; ++k) d.r2[k] = Dual2(Dual1(q[kFreeFlyerNq + k]), Dual1(v[kFreeFlyerNv + k]));
    for (int k = 0; k < num_v(); ++k) d.v2[k] = Dual2(v[k]);
    Eigen::Matrix<double, 6, 1> mu;
    for (int i = 0; i < num_v(); ++i) {
      d.v2[i].v.d = 1.0;
      const Dual2 T = Kinetic(d.r2, d.v2);
      d.v2[i].v.d = 0.0;
      if (i < kFreeFlyerNv) mu[i] = T.v.d;
      bias[i] = T.d.d;
    }
    // Base: − ad*_ξ μ = ξ ×* μ, ξ = (v_b, ω_b), μ = (p, L): (f, n) = (ω × p, ω × L + v_b × p).
    const Eigen::Vector3d vb = v.head<3>(), wb = v.segment<3>(3), p = mu.head<3>(), L = mu.tail<3>();
    bias.head<3>() += wb.cross(p);
    bias.segment<3>(3) += wb.cross(L) + vb.cross(p);
    // Joints: − ∂T/∂r.
    for (int k = 0; k < n_; ++k) d.r1[k] = Dual1(q[kFreeFlyerNq + k]);
    for (int k = 0; k < num_v(); ++k) d.v1[k] = Dual1(v[k]);
    for (int j = 0; j < n_; ++j) {
      d.r1[j].d = 1.0;
      bias[kFreeFlyerNv + j] -= Kinetic(d.r1, d.v1).d;
      d.r1[j].d = 0.0;
    }
  }
  if (terms.gravity) {
    // ∂V/∂g along g exp(ε e_k), to first order: R (1 + ε [e]×), p + ε R e.
    const Eigen::Matrix3d R0 = BaseRotation(q);
    for (int k = 0; k < n_; ++k) d.r1[k] = Dual1(q[kFreeFlyerNq + k]);
    auto V = [&](const Eigen::Matrix3d& dR, const Eigen::Vector3d& dp) {
      Placement<Dual1> base;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) base.R.m[r][c] = Dual1(R0(r, c), dR(r, c));
      }
      base.o = {Dual1(q[0], dp.x()), Dual1(q[1], dp.y()), Dual1(q[2], dp.z())};
      return FloatingPotentialEnergy<Dual1>(tree_, base, std::span<const Dual1>(d.r1)).d;
    };
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
      Eigen::Matrix3d K;  // [e]×
      K << 0.0, -e.z(), e.y(), e.z(), 0.0, -e.x(), -e.y(), e.x(), 0.0;
      bias[k] += V(Eigen::Matrix3d::Zero(), R0.col(k));
      bias[3 + k] += V(R0 * K, Eigen::Vector3d::Zero());
    }
    for (int j = 0; j < n_; ++j) {
      d.r1[j].d = 1.0;
      bias[kFreeFlyerNv + j] += V(Eigen::Matrix3d::Zero(), Eigen::Vector3d::Zero());
      d.r1[j].d = 0.0;
    }
  }
}

void FloatingLagrangian::ComputeKineticEnergyGradient(FloatingLagrangianData& d, ConstVecRef q, ConstVecRef v,
                                                      VecRef grad) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  eigen_assert(grad.size() == n_ && "grad: expected num_dofs() entries");
  for (int k = 0; k < n_; ++k) d.r1[k] = Dual1(q[kFreeFlyerNq + k]);
  for (int k = 0; k < num_v(); ++k) d.v1[k] = Dual1(v[k]);
  for (int j = 0; j < n_; ++j) {
    d.r1[j].d = 1.0;
    grad[j] = Kinetic(d.r1, d.v1).d;
    d.r1[j].d = 0.0;
  }
}

void FloatingLagrangian::ComputeInverseDynamics(FloatingLagrangianData& d, ConstVecRef q, ConstVecRef v,
                                                ConstVecRef a, DynamicsTerms terms, VecRef tau) const {
  LAGRANGE_CHECK_NV(a);
  LAGRANGE_CHECK_NV(tau);
  ComputeMassMatrix(d, q, d.M);
  ComputeBias(d, q, v, terms, d.bias);
  tau.noalias() = d.M * a;
  tau += d.bias;
}

void FloatingLagrangian::ComputeForwardDynamics(FloatingLagrangianData& d, ConstVecRef q, ConstVecRef v,
                                                ConstVecRef tau, DynamicsTerms terms, VecRef a) const {
  LAGRANGE_CHECK_NV(tau);
  LAGRANGE_CHECK_NV(a);
  ComputeMassMatrix(d, q, d.M);
  ComputeBias(d, q, v, terms, d.bias);
  a = tau - d.bias;
  CholeskySolveInPlace(d.M, a);
}

double FloatingLagrangian::ComputeKineticEnergy(FloatingLagrangianData& d, ConstVecRef q, ConstVecRef v) const {
  CheckSizes(d, q);
  LAGRANGE_CHECK_NV(v);
  for (int k = 0; k < n_; ++k) d.r1[k] = Dual1(q[kFreeFlyerNq + k]);
  for (int k = 0; k < num_v(); ++k) d.v1[k] = Dual1(v[k]);
  return Kinetic(d.r1, d.v1).v;
}

double FloatingLagrangian::ComputePotentialEnergy(FloatingLagrangianData& d, ConstVecRef q) const {
  CheckSizes(d, q);
  const Eigen::Matrix3d R0 = BaseRotation(q);
  Placement<double> base;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) base.R.m[r][c] = R0(r, c);
  }
  base.o = {q[0], q[1], q[2]};
  return FloatingPotentialEnergy<double>(tree_, base, std::span<const double>(q.data() + kFreeFlyerNq, n_));
}

#undef LAGRANGE_CHECK_NV

}  // namespace lagrange
