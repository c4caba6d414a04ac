#pragma once
// Time integrators for PlantModel. Each advances (q, qd) over one interval h
// with the commanded generalized force tau_cmd held constant (zero-order hold
// from the controller), or with a ControlLaw passed as an argument and
// evaluated at every stage, and may split a tick into equal sub-steps.
//
//   explicit Euler       q⁺ = q + h qd,  qd⁺ = qd + h qdd(q, qd)              order 1
//   semi-implicit Euler  qd⁺ = qd + h qdd(q, qd),  q⁺ = q + h qd⁺            order 1
//   RK4                  classical fourth order                              order 4
//   Dormand–Prince 5(4)  adaptive, error per component below
//                        atol + rtol·|y|, FSAL, statistics                   order 5
//   variational          midpoint discrete Lagrangian
//                        L_d(q0, q1) = h L((q0 + q1)/2, (q1 − q0)/h); the forced
//                        discrete Euler–Lagrange equations in momentum form
//                          p0 + D1 L_d(q0, q1) + h/2 F = 0,  p1 = D2 L_d(q0, q1) + h/2 F
//                        with p = M(q) qd, F the effects' force at the midpoint,
//                        solved for q1 by Newton's method.                  order 2
//                        Symplectic in the true momenta p, so the energy error
//                        of a conservative system stays bounded; semi-implicit
//                        Euler on (q, qd) is not symplectic once M depends on q.
//                        It integrates the full Lagrangian: Coriolis terms on.
//
// Every buffer is allocated when the integrator is made; Step allocates nothing.

#include <Eigen/LU>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>

#include "base/vocabulary.hpp"
#include "plant/plant_model.hpp"

namespace lagrange {

// IntegratorType, its names, IntegratorConfig and CheckIntegratorConfig: base/vocabulary.hpp.

// The variational integrator integrates the full Lagrangian: a scene or a
// command that would run it with effects.coriolis off is refused with this.
inline constexpr char kVariationalNeedsCoriolis[] =
    "the variational integrator integrates the full Lagrangian; it needs effects.coriolis on";

// Cumulative counts over the integrator's life: the sum of every call's IntegratorWork.
struct IntegratorStats {
  std::int64_t steps = 0;              // sub-steps taken (Step calls, or substeps per Advance)
  std::int64_t accepted = 0;           // internal steps accepted (adaptive), = steps otherwise
  std::int64_t rejected = 0;           // internal steps rejected (adaptive)
  std::int64_t evaluations = 0;        // acceleration (or residual) evaluations
  std::int64_t newton_iterations = 0;  // variational: Newton iterations
  std::int64_t failures = 0;           // sub-steps that could not meet their tolerance
};

// The work of the last call of Step or Advance alone: reset at the call's
// start, complete when it returns. Counts as in IntegratorStats, for that call:
//   steps              1 for Step, config().substeps for Advance
//   evaluations        explicit Euler and semi-implicit Euler 1 per sub-step,
//                      RK4 4 per sub-step, dopri5 1 per sub-step + 6 per
//                      trial step, accepted or rejected (first same as last),
//                      variational 2 per sub-step (the predictor and the first
//                      residual) + 1 per Newton iteration + (n + 1) per
//                      Jacobian rebuild (forward differences)
//   accepted/rejected  dopri5's internal steps; fixed-step methods accept
//                      every sub-step and reject none
//   newton_iterations  variational, summed over the sub-steps; 0 otherwise
//   error_estimate     dopri5: the scaled error norm
//                        sqrt(mean_i (err_i / (atol + rtol·max(|y_i|, |y1_i|)))²)
//                      of the last accepted internal step, y = (q, qd); <= 1
//                      by construction (a step above 1 is rejected). NaN for
//                      the fixed-step methods, which estimate nothing (0 would
//                      read as "exact"), and for a dopri5 call that accepted
//                      no step. Test it with std::isnan, not against a number.
//   step               s: dopri5 the last accepted internal step (the one that
//                      lands on the end of the interval, so possibly shorter
//                      than the proposal it carries to the next call; 0 if
//                      none was accepted); the others h = dt / substeps
// A separate struct rather than deltas of IntegratorStats: error_estimate and
// step are per-call values with no cumulative meaning, and a reader of one
// tick's figures should not have to keep the previous totals.
struct IntegratorWork {
  std::int64_t steps = 0;
  std::int64_t evaluations = 0;
  std::int64_t accepted = 0;
  std::int64_t rejected = 0;
  std::int64_t newton_iterations = 0;
  std::int64_t failures = 0;
  double error_estimate = std::numeric_limits<double>::quiet_NaN();
  double step = 0.0;  // s
};

class Integrator {
 public:
  Integrator(const IntegratorConfig& config, int n) : config_(config), n_(n) {}
  virtual ~Integrator() = default;
  Integrator(const Integrator&) = delete;
  Integrator& operator=(const Integrator&) = delete;

  IntegratorType type() const { return config_.type; }
  const IntegratorConfig& config() const { return config_; }
  // Totals over every call so far.
  const IntegratorStats& stats() const { return stats_; }
  // The last call of Step or Advance alone (see IntegratorWork).
  const IntegratorWork& work() const { return work_; }

  // Takes new numbers (substeps, rtol, atol, max_steps, Newton settings) for
  // this integrator; config.type must be type(). Allocates nothing: every
  // buffer depends on n only. What a step carries to the next (dopri5's step
  // proposal, the variational Jacobian) starts over, so the next call steps
  // exactly as a new integrator of `config` would; stats() keep counting.
  // Returns why it was refused (CheckIntegratorConfig, or a type mismatch;
  // nothing changed), or null.
  const char* Reconfigure(const IntegratorConfig& config);

  // (law, t, h, q, qd, tau_cmd) => (q, qd) at t + h. `law` null: tau_cmd is
  // held; otherwise tau_cmd is ignored and the law is evaluated at every stage.
  // False when the step failed its tolerance (the state is then the best
  // available, and may be non-finite).
  bool Step(PlantModel& model, ControlLaw* law, double t, double h, ConstVecRef tau_cmd, VecRef q, VecRef qd);
  // The same with tau_cmd held.
  bool Step(PlantModel& model, double t, double h, ConstVecRef tau_cmd, VecRef q, VecRef qd) {
    return Step(model, nullptr, t, h, tau_cmd, q, qd);
  }

  // One tick of length dt in config().substeps equal sub-steps; `law` as in Step.
  bool Advance(PlantModel& model, ControlLaw* law, double t, double dt, ConstVecRef tau_cmd, VecRef q, VecRef qd);
  // The same with tau_cmd held.
  bool Advance(PlantModel& model, double t, double dt, ConstVecRef tau_cmd, VecRef q, VecRef qd) {
    return Advance(model, nullptr, t, dt, tau_cmd, q, qd);
  }

 protected:
  // One sub-step of length h, as Step. Counts its evaluations, accepted and
  // rejected steps and Newton iterations (the Count functions below) and sets
  // work_.step (and work_.error_estimate when it has one); the caller counts
  // steps and failures.
  virtual bool DoStep(PlantModel& model, ControlLaw* law, double t, double h, ConstVecRef tau_cmd, VecRef q,
                      VecRef qd) = 0;
  // Forgets what one step carries to the next, as at construction (Reconfigure).
  virtual void StartOver() {}

  // What DoStep counts, into the call's work_ and the totals at once: adding
  // work_ to the totals at the call's end read back the counts just written
  // (measured: a sixth of the cart-pole's RK4 step, bench/effects_bench.cpp).
  void CountEvaluations(std::int64_t k) {
    work_.evaluations += k;
    stats_.evaluations += k;
  }
  void CountAccepted() {
    ++work_.accepted;
    ++stats_.accepted;
  }
  void CountRejected() {
    ++work_.rejected;
    ++stats_.rejected;
  }
  void CountNewtonIteration() {
    ++work_.newton_iterations;
    ++stats_.newton_iterations;
  }

  IntegratorConfig config_;
  int n_;
  IntegratorWork work_;

 private:
  // DoStep with the call's step and failure counted.
  bool CountedStep(PlantModel& model, ControlLaw* law, double t, double h, ConstVecRef tau_cmd, VecRef q, VecRef qd);
  IntegratorStats stats_;
};

// The classical fourth-order Runge–Kutta integrator. Its stages are written
// once, for any acceleration function qdd = f(t, q, qd): DoStep runs them on
// a PlantModel; bench/effects_bench.cpp runs them on bare Dynamics, the
// baseline that shows what the effects layer costs.
class Rk4 final : public Integrator {
 public:
  Rk4(const IntegratorConfig& config, int n);

  // (t, h, q, qd) => (q, qd) at t + h. `acceleration(t, q, qd, qdd)` writes
  // qdd at (t, q, qd); it is called four times. Allocates nothing.
  template <class Acceleration>
  void Stages(Acceleration&& acceleration, double t, double h, VecRef q, VecRef qd) {
    // Stage s at (q1, qd1) gives k_s = (qd1, qdd_s); dq and dqd gather
    // k1 + 2 k2 + 2 k3 + k4. Each stage's point is built from the last
    // stage's before that is overwritten, so nothing is copied, in plain
    // loops: Eigen's assignments here compiled to out-of-line calls
    // (bench/effects_bench.cpp, bare against default).
    const int n = static_cast<int>(q.size());
    const double a = 0.5 * h;
    double *q1 = q1_.data(), *qd1 = qd1_.data(), *dq = dq_.data(), *dqd = dqd_.data(), *k = kqd_.data();
    acceleration(t, q, qd, dqd_);  // stage 1 at (q, qd)
    for (int i = 0; i < n; ++i) {
      q1[i] = q[i] + a * qd[i];
      qd1[i] = qd[i] + a * dqd[i];
    }
    acceleration(t + a, q1_view_, qd1_view_, kqd_);  // stage 2 at the midpoint
    for (int i = 0; i < n; ++i) {
      dq[i] = qd[i] + 2.0 * qd1[i];
      dqd[i] += 2.0 * k[i];
      q1[i] = q[i] + a * qd1[i];
      qd1[i] = qd[i] + a * k[i];
    }
    acceleration(t + a, q1_view_, qd1_view_, kqd_);  // stage 3 at the midpoint
    for (int i = 0; i < n; ++i) {
      dq[i] += 2.0 * qd1[i];
      dqd[i] += 2.0 * k[i];
      q1[i] = q[i] + h * qd1[i];
      qd1[i] = qd[i] + h * k[i];
    }
    acceleration(t + h, q1_view_, qd1_view_, kqd_);  // stage 4 at the end
    const double w = h / 6.0;
    for (int i = 0; i < n; ++i) {
      q[i] += w * (dq[i] + qd1[i]);
      qd[i] += w * (dqd[i] + k[i]);
    }
  }

 protected:
  bool DoStep(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, VecRef q, VecRef qd) override;

 private:
  VectorXd q1_, qd1_, dq_, dqd_, kqd_;  // (n) each
  // q1_ and qd1_ as the acceleration's arguments take them, made once: a Ref<const> made at each stage is two
  // constructions and two frees (of its unused copy) per stage.
  const Eigen::Ref<const VectorXd> q1_view_, qd1_view_;
};

// Throws std::invalid_argument with CheckIntegratorConfig's reason for a bad config.
std::unique_ptr<Integrator> MakeIntegrator(const IntegratorConfig& config, int n);

// Why `type` has no step derivatives (a static string that names the
// integrators that have them), or null: explicit-euler, semi-implicit-euler
// and rk4 have them; dopri5 (adaptive: its step sizes are decided, not
// differentiable) and variational (an implicit solve) do not.
const char* NoStepDerivativesReason(IntegratorType type);

// Exact derivatives of one integrator step with the command held (the tick's
// zero-order hold), x = (q, qd) (2n):
//
//   x⁺ = Φ(x, tau_cmd, h),   A = ∂x⁺/∂x (2n x 2n),   B = ∂x⁺/∂tau_cmd (2n x n)
//
// by the chain rule through the integrator's own stages, not by differencing
// the step. At each stage the plant's acceleration derivatives
// (PlantModel::ComputeAccelerationDerivatives: the dynamics' and the effects')
// give F = ∂f/∂x = [[0, I], [∂qdd/∂q, ∂qdd/∂qd]] and G = ∂f/∂tau_cmd =
// [[0], [∂qdd/∂tau_cmd]] of f(x) = (qd, qdd); then
//   explicit Euler       x⁺ = x + h f(x):            A = I + h F,  B = h G
//   semi-implicit Euler  qd⁺ = qd + h qdd(x), q⁺ = q + h qd⁺: qd⁺'s rows as
//                        explicit Euler's, q⁺'s = [I 0] + h (qd⁺'s rows)
//   RK4                  k_s = f(x + c_s h k_{s−1}), c = (0, ½, ½, 1):
//                        ∂k_s = F_s (I + c_s h ∂k_{s−1}) [+ G_s],
//                        A = I + h/6 Σ w_s ∂k_s/∂x, B = h/6 Σ w_s ∂k_s/∂tau, w = (1, 2, 2, 1)
// and over a tick of `substeps` sub-steps, A = A_s ⋯ A_1, B = Σ_k A_s ⋯ A_{k+1} B_k.
// As h → 0, A = I + h F + O(h²) for each.
//
// Per-user data, like an Integrator: every buffer is allocated when it is
// made; Step and Advance allocate nothing. Cost per step: one (Euler) or four
// (RK4) acceleration derivatives, plus (RK4) about 18 n³ multiply-adds of
// block products.
class StepDerivatives {
 public:
  // Throws std::invalid_argument with NoStepDerivativesReason for the others.
  StepDerivatives(IntegratorType type, int n);

  IntegratorType type() const { return type_; }

  // (model, t, h, q, qd, tau_cmd) => A, B of one step of length h from (q, qd)
  // at t, and its end x⁺ (q_next, qd_next): the integrator's Step, to round-off.
  void Step(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd, MatRef A,
            MatRef B);
  // The same over one tick of length dt in `substeps` (>= 1) equal sub-steps, as Integrator::Advance.
  void Advance(PlantModel& model, double t, double dt, int substeps, ConstVecRef q, ConstVecRef qd,
               ConstVecRef tau_cmd, MatRef A, MatRef B);

  // The state at the end of the last Step or Advance.
  const VectorXd& q_next() const { return q_next_; }
  const VectorXd& qd_next() const { return qd_next_; }

 private:
  void EulerStep(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, MatRef A,
                 MatRef B);
  void Rk4Step(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd, ConstVecRef tau, MatRef A,
               MatRef B);

  IntegratorType type_;
  int n_;
  MatrixXd Aq_, Av_, Bt_;          // (n x n) ∂qdd/∂q, ∂qdd/∂qd, ∂qdd/∂tau at a stage
  MatrixXd Kx_, Kt_, Sx_, St_;     // (2n x 2n), (2n x n): a stage's ∂k, and their weighted sums
  MatrixXd Xq_, Xv_, Yq_, Yv_;     // (n x 2n), (n x n): a stage point's derivative, by rows
  MatrixXd Ak_, Bk_, PA_, PB_;     // (2n x 2n), (2n x n): Advance's sub-step and products
  VectorXd qs_, qds_, kq_, kqd_, qdd_, sum_q_, sum_qd_, x_q_, x_qd_, q_next_, qd_next_;  // (n)
};

}  // namespace lagrange
