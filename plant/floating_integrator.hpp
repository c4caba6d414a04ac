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
//   variational          a Lie-group variational integrator on SE(3) × ℝⁿ
//                        (the discrete Euler–Poincaré equations; Kobilarov,
//                        Crane & Desbrun 2009; Bou-Rabee & Marsden 2009),
//                        with SE(3)'s Cayley map as its retraction (not exp):
//                        g1 = g0 cay(x_b), r1 = r0 + x_r, x = (x_b, x_r) (nv),
//                        and the discrete Lagrangian
//                          L_d = h T(r_m, x / h) − h/2 (V(q0) + V(q1)),  r_m = (r0 + r1)/2,
//                        T in the base twist in base axes, so L_d is invariant
//                        under any left translation of the base. With p = M v
//                        (base: the momentum in base axes), μ = M(r_m) x / h and
//                        the held force entering as h/2 tau at either end:
//                          p0 − h/2 (G(q0) − tau) = ((dcay⁻¹_x_b)ᵀ μ_b,  μ_r − h/2 ∂T/∂r(r_m, x/h))
//                          p1 + h/2 (G(q1) − tau) = ((dcay⁻¹_−x_b)ᵀ μ_b, μ_r + h/2 ∂T/∂r(r_m, x/h))
//                        solved for x by Newton's method (forward-difference
//                        Jacobian, kept from step to step while it contracts),
//                        iterated until the residual stops decreasing; then
//                        v1 = M(q1)⁻¹ p1. The two base momenta are one momentum
//                        in the world (discrete Noether): with no gravity and no
//                        base wrench the world's linear and angular momentum
//                        are kept to round-off; the energy error of a
//                        conservative system stays bounded (symplectic).   order 2
//                        It integrates the whole kinetic energy: Coriolis terms
//                        on (terms.coriolis is not read; terms.gravity is).
//                        A step fails (Step returns false, stats().failures)
//                        when the residual stops decreasing above
//                        newton_tol times the step's momentum scale, or after
//                        newton_max_iterations.
//
// The quaternion stays unit (Integrate and IntegrateCayley renormalise). Every
// buffer is allocated when the integrator is made; Step allocates nothing.

#include <memory>

#include "base/vocabulary.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/floating_lagrangian.hpp"
#include "plant/integrators.hpp"

namespace lagrange {

class FloatingIntegrator {
 public:
  // explicit-euler, semi-implicit-euler, rk4 or variational (Newton's settings
  // from `config`); std::invalid_argument otherwise.
  FloatingIntegrator(const IntegratorConfig& config, const FloatingDynamics& model);
  FloatingIntegrator(IntegratorType type, const FloatingDynamics& model)
      : FloatingIntegrator(IntegratorConfig{.type = type}, model) {}
  ~FloatingIntegrator();
  FloatingIntegrator(const FloatingIntegrator&) = delete;
  FloatingIntegrator& operator=(const FloatingIntegrator&) = delete;

  IntegratorType type() const { return config_.type; }
  // Totals over every Step so far: steps, evaluations (forward dynamics, or
  // the variational residual), newton_iterations and failures (variational).
  const IntegratorStats& stats() const { return stats_; }
  // Takes `config`'s Newton settings (its type must be type()); forgets the kept Jacobian. Allocates nothing.
  void Reconfigure(const IntegratorConfig& config);
  // (q (nq), v (nv)) => at t + h, with tau (nv) held and `terms` as in
  // FloatingDynamics. False when the step failed its tolerance (variational).
  bool Step(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v);

 private:
  bool StepVariational(double h, ConstVecRef tau, DynamicsTerms terms, VecRef q, VecRef v);
  // x (nv) => r = A(x) − c0_ (the first equation above); μ and ∂T/∂r left in mu_, dT_.
  void Residual(double h, const VectorXd& x, VectorXd& r);
  // J = ∂r/∂x at x_ (r_ its residual) by forward differences, factorised into lu_.
  void Jacobian(double h);

  IntegratorConfig config_;
  const FloatingDynamics* model_;
  std::unique_ptr<FloatingData> data_;
  IntegratorStats stats_;
  VectorXd qs_;                                // (nq) a stage's configuration
  VectorXd a_, xi_, vs_, kx_, kv_, sx_, sv_;  // (nv) each
  // Variational alone (empty otherwise): the exact ∂T/∂r, and Newton's buffers.
  std::unique_ptr<FloatingLagrangian> lagrangian_;
  std::unique_ptr<FloatingLagrangianData> ldata_;
  VectorXd qm_;                                           // (nq) identity base pose, the joints at r_m
  VectorXd zero_, gravity_, c0_, x_, xt_, dx_, r_, rt_, vd_, mu_;  // (nv) each
  VectorXd dT_;                                           // (n) ∂T/∂r
  MatrixXd M_, J_;                                        // (nv x nv)
  Eigen::PartialPivLU<MatrixXd> lu_;
  bool jacobian_valid_ = false;
  double jacobian_h_ = 0.0;
};

}  // namespace lagrange
