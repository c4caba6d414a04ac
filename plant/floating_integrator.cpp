#include "plant/floating_integrator.hpp"

#include <stdexcept>
#include <string>

#include "plant/free_flyer.hpp"

namespace lagrange {

FloatingIntegrator::FloatingIntegrator(IntegratorType type, const FloatingDynamics& model)
    : type_(type), model_(&model), data_(model.MakeData()) {
  if (type != IntegratorType::kExplicitEuler && type != IntegratorType::kSemiImplicitEuler &&
      type != IntegratorType::kRk4) {
    throw std::invalid_argument("floating base: integrator " + std::string(ToString(type)) +
                                " is not on the manifold yet (explicit-euler, semi-implicit-euler, rk4)");
  }
  qs_.resize(model.num_q());
  for (VectorXd* x : {&a_, &xi_, &vs_, &kx_, &kv_, &sx_, &sv_}) x->resize(model.num_v());
}

void FloatingIntegrator::Step(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v) {
  const FloatingDynamics& m = *model_;
  FloatingData& d = *data_;
  switch (type_) {
    case IntegratorType::kExplicitEuler:
      m.ComputeForwardDynamics(d, q, v, tau, terms, a_);
      Integrate(q, v, h, q);
      v += h * a_;
      return;
    case IntegratorType::kSemiImplicitEuler:
      m.ComputeForwardDynamics(d, q, v, tau, terms, a_);
      v += h * a_;
      Integrate(q, v, h, q);
      return;
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
  Integrate(q, sx_, h / 6.0, q);
  v += (h / 6.0) * sv_;
}

}  // namespace lagrange
