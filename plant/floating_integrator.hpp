#pragma once
// Fixed-step integrators for a floating-base tree (FloatingDynamics), on its
// configuration manifold (plant/free_flyer.hpp): q ⊕ h v replaces q + h qd,
// since q̇ ≠ v. With a = FD(q, v, tau) and tau held over the step:
//
//   explicit Euler       q⁺ = q ⊕ h v,  v⁺ = v + h a(q, v)                 order 1
//   semi-implicit Euler  v⁺ = v + h a(q, v),  q⁺ = q ⊕ h v⁺                order 1
//   RK4                  Runge–Kutta–Munthe-Kaas: the classical stages on the
//                        local coordinates ξ of q = q0 ⊕ ξ, whose rate is
//                        TwistRate(ξ, v); q⁺ = q0 ⊕ ξ⁺                      order 4
//
// The quaternion stays unit (Integrate renormalises). Every buffer is
// allocated when the integrator is made; Step allocates nothing.

#include <memory>

#include "base/vocabulary.hpp"
#include "plant/floating_dynamics.hpp"

namespace lagrange {

class FloatingIntegrator {
 public:
  // explicit-euler, semi-implicit-euler or rk4; std::invalid_argument otherwise.
  FloatingIntegrator(IntegratorType type, const FloatingDynamics& model);

  IntegratorType type() const { return type_; }
  // (q (nq), v (nv)) => at t + h, with tau (nv) held and `terms` as in FloatingDynamics.
  void Step(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v);

 private:
  IntegratorType type_;
  const FloatingDynamics* model_;
  std::unique_ptr<FloatingData> data_;
  VectorXd qs_;                                // (nq) a stage's configuration
  VectorXd a_, xi_, vs_, kx_, kv_, sx_, sv_;  // (nv) each
};

}  // namespace lagrange
