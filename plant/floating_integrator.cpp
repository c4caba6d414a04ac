#include "plant/floating_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "plant/free_flyer.hpp"

namespace lagrange {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

// Forward differences of the residual: the step in x_j is this times max(|x_j|, h) (x ~ h v).
constexpr double kJacobianStep = 1e-7;
// Rebuild the kept Jacobian when an iteration shrinks the residual by less than this.
constexpr double kSlowContraction = 0.25;

}  // namespace

FloatingIntegrator::FloatingIntegrator(const IntegratorConfig& config, const FloatingDynamics& model)
    : config_(config), model_(&model), data_(model.MakeData()) {
  const IntegratorType type = config.type;
  if (type != IntegratorType::kExplicitEuler && type != IntegratorType::kSemiImplicitEuler &&
      type != IntegratorType::kRk4 && type != IntegratorType::kVariational) {
    throw std::invalid_argument("floating base: integrator " + std::string(ToString(type)) +
                                " is not on the manifold yet (explicit-euler, semi-implicit-euler, rk4, variational)");
  }
  const int nv = model.num_v();
  qs_.resize(model.num_q());
  for (VectorXd* x : {&a_, &xi_, &vs_, &kx_, &kv_, &sx_, &sv_}) x->resize(nv);
  if (type != IntegratorType::kVariational) return;
  lagrangian_ = std::make_unique<FloatingLagrangian>(model.tree());
  ldata_ = lagrangian_->MakeData();
  qm_ = VectorXd::Zero(model.num_q());
  qm_[6] = 1.0;  // the identity base pose: M and T do not depend on it
  for (VectorXd* x : {&zero_, &gravity_, &c0_, &x_, &xt_, &dx_, &r_, &rt_, &vd_, &mu_}) *x = VectorXd::Zero(nv);
  dT_ = VectorXd::Zero(model.num_dofs());
  M_.resize(nv, nv);
  J_.resize(nv, nv);
  lu_ = Eigen::PartialPivLU<MatrixXd>(nv);
}

FloatingIntegrator::~FloatingIntegrator() = default;

void FloatingIntegrator::Reconfigure(const IntegratorConfig& config) {
  eigen_assert(config.type == config_.type && "Reconfigure: the same integrator type");
  config_ = config;
  jacobian_valid_ = false;
}

bool FloatingIntegrator::Step(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v) {
  const FloatingDynamics& m = *model_;
  FloatingData& d = *data_;
  ++stats_.steps;
  ++stats_.accepted;
  switch (type()) {
    case IntegratorType::kExplicitEuler:
      m.ComputeForwardDynamics(d, q, v, tau, terms, a_);
      ++stats_.evaluations;
      Integrate(q, v, h, q);
      v += h * a_;
      return true;
    case IntegratorType::kSemiImplicitEuler:
      m.ComputeForwardDynamics(d, q, v, tau, terms, a_);
      ++stats_.evaluations;
      v += h * a_;
      Integrate(q, v, h, q);
      return true;
    case IntegratorType::kVariational: {
      const bool ok = StepVariational(h, tau, terms, q, v);
      if (!ok) ++stats_.failures;
      return ok;
    }
    default:
      break;
  }
  // RK4 on (ξ, v) from ξ = 0: stage s at ξ_s = c_s h kξ_{s−1}, v_s = v + c_s h kv_{s−1}.
  m.ComputeForwardDynamics(d, q, v, tau, terms, kv_);
  kx_ = v;  // TwistRate(0, v) = v
  sx_ = kx_;
  sv_ = kv_;
  for (int stage = 2; stage <= 4; ++stage) {
    const double c = stage == 4 ? h : 0.5 * h;
    const double w = stage == 4 ? 1.0 : 2.0;
    xi_ = c * kx_;
    vs_ = v + c * kv_;
    Integrate(q, xi_, 1.0, qs_);
    m.ComputeForwardDynamics(d, qs_, vs_, tau, terms, kv_);
    TwistRate(xi_, vs_, kx_);
    sx_ += w * kx_;
    sv_ += w * kv_;
  }
  stats_.evaluations += 4;
  Integrate(q, sx_, h / 6.0, q);
  v += (h / 6.0) * sv_;
  return true;
}

// The header's equations: c0 = p0 − h/2 (G(q0) − tau), Newton on x, then p1 and v1.
bool FloatingIntegrator::StepVariational(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v) {
  const FloatingDynamics& m = *model_;
  FloatingData& d = *data_;
  const int n = m.num_dofs();
  const DynamicsTerms gravity_only{.gravity = true, .coriolis = false};
  m.ComputeMassMatrix(d, q, M_);
  c0_.noalias() = M_ * v;  // p0
  const double momentum_scale = c0_.lpNorm<Eigen::Infinity>();
  if (terms.gravity) {
    m.ComputeInverseDynamics(d, q, zero_, zero_, gravity_only, gravity_);  // G(q0)
  } else {
    gravity_.setZero();
  }
  c0_ -= (0.5 * h) * (gravity_ - tau);
  qm_.tail(n) = q.tail(n);  // r0, read by Residual through r_m = r0 + x_r / 2
  // Predictor x = h v + h²/2 a (the Cayley map and exp agree to second order).
  m.ComputeForwardDynamics(d, q, v, tau, terms, a_);
  ++stats_.evaluations;
  x_ = h * v + (0.5 * h * h) * a_;
  Residual(h, x_, r_);
  // Success: the residual, once it stops decreasing, within newton_tol of the step's momenta.
  const double scale = std::max(momentum_scale, mu_.lpNorm<Eigen::Infinity>()) +
                       h * (gravity_.lpNorm<Eigen::Infinity>() + tau.lpNorm<Eigen::Infinity>());
  const double tol = config_.newton_tol * scale;
  double norm = r_.lpNorm<Eigen::Infinity>();
  bool refreshed = false;
  if (norm > 0.0 && (!jacobian_valid_ || h != jacobian_h_)) {
    Jacobian(h);
    refreshed = true;
  }
  for (int it = 0; it < config_.newton_max_iterations && norm > 0.0; ++it) {
    ++stats_.newton_iterations;
    dx_ = lu_.solve(r_);
    xt_ = x_ - dx_;
    Residual(h, xt_, rt_);
    const double trial = rt_.lpNorm<Eigen::Infinity>();
    if (trial < norm) {  // NaN compares false: a non-finite trial is never taken
      const double previous = norm;
      x_.swap(xt_);
      r_.swap(rt_);
      norm = trial;
      if (norm > tol && norm > kSlowContraction * previous && !refreshed) {
        Jacobian(h);
        refreshed = true;
      }
      continue;
    }
    // The residual stopped decreasing: round-off, or a Jacobian too stale to descend.
    if (norm <= tol || refreshed) break;
    Jacobian(h);
    refreshed = true;
  }
  const bool converged = norm <= tol;
  if (!converged) jacobian_valid_ = false;
  // p1 = ((dcay⁻¹_−x_b)ᵀ μ_b, μ_r + h/2 ∂T/∂r) − h/2 (G(q1) − tau), at the x taken. The base's
  // (dcay⁻¹_−x_b)ᵀ μ_b is the transport of (dcay⁻¹_x_b)ᵀ μ_b = c0_b (the first equation): taken as
  // the transport of c0_b, so that Newton's last residual (round-off, but of one sign step after
  // step) does not accumulate in the momentum.
  Residual(h, x_, r_);
  const Vector6d xb = x_.head<6>(), c0b = c0_.head<6>();
  const Vector6d p1b = CayleyTransport(xb, c0b);
  IntegrateCayley(q, x_, q);
  vd_.head<6>() = p1b;
  vd_.tail(n) = mu_.tail(n) + (0.5 * h) * dT_;
  if (terms.gravity) {
    m.ComputeInverseDynamics(d, q, zero_, zero_, gravity_only, gravity_);  // G(q1)
    vd_ -= (0.5 * h) * gravity_;
  }
  vd_ += (0.5 * h) * tau;
  m.ComputeMassMatrix(d, q, M_);
  CholeskySolveInPlace(M_, vd_);
  v = vd_;
  return converged;
}

void FloatingIntegrator::Residual(double h, const VectorXd& x, VectorXd& r) {
  const int n = model_->num_dofs();
  // r_m = r0 + x_r / 2 (qm_'s joints hold r0 between calls).
  qs_ = qm_;
  qs_.tail(n) += 0.5 * x.tail(n);
  vd_ = x / h;
  model_->ComputeMassMatrix(*data_, qs_, M_);
  mu_.noalias() = M_ * vd_;
  if (n > 0) lagrangian_->ComputeKineticEnergyGradient(*ldata_, qs_, vd_, dT_);
  const Vector6d xb = x.head<6>(), mb = mu_.head<6>();
  r.head<6>() = CayleyMomentum(xb, mb);
  r.tail(n) = mu_.tail(n) - (0.5 * h) * dT_;
  r -= c0_;
  ++stats_.evaluations;
}

void FloatingIntegrator::Jacobian(double h) {
  const int nv = model_->num_v();
  for (int j = 0; j < nv; ++j) {
    const double delta = kJacobianStep * std::max(std::abs(x_[j]), h);
    xt_ = x_;
    xt_[j] += delta;
    Residual(h, xt_, rt_);
    J_.col(j) = (rt_ - r_) / delta;
  }
  Residual(h, x_, r_);  // mu_ and dT_ back at x_
  lu_.compute(J_);
  jacobian_valid_ = true;
  jacobian_h_ = h;
}

}  // namespace lagrange
