#include "plant/integrators.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "base/enum_names.hpp"

namespace lagrange {
namespace {

// Explicit Euler: q⁺ = q + h qd, qd⁺ = qd + h qdd; semi-implicit (symplectic)
// Euler takes the new velocity for the position: qd⁺ first, then q⁺ = q + h qd⁺.
class Euler final : public Integrator {
 public:
  Euler(const IntegratorConfig& c, int n) : Integrator(c, n), qdd_(n) {}
  bool DoStep(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, VecRef q, VecRef qd) override {
    m.ComputeAcceleration(law, t, q, qd, tau, qdd_);
    if (config_.type == IntegratorType::kSemiImplicitEuler) {
      qd += h * qdd_;
      q += h * qd;
    } else {
      q += h * qd;
      qd += h * qdd_;
    }
    CountAccepted();
    CountEvaluations(1);
    work_.step = h;
    return true;
  }

 private:
  VectorXd qdd_;
};

// Dormand–Prince 5(4) on y = (q, qd), f(y) = (qd, qdd).
class DormandPrince final : public Integrator {
 public:
  DormandPrince(const IntegratorConfig& c, int n) : Integrator(c, n), y_(2 * n), y1_(2 * n), yt_(2 * n), err_(2 * n) {
    for (auto& k : k_) k.resize(2 * n);
  }

  bool DoStep(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, VecRef q, VecRef qd) override {
    y_.head(n_) = q;
    y_.tail(n_) = qd;
    const double t_end = t + h;
    double dt = h_next_ > 0.0 ? h_next_ : h;  // proposed step, carried across calls
    Derivative(m, law, t, y_, tau, k_[0]);
    bool ok = true;
    for (int taken = 0; t < t_end; ++taken) {
      if (taken >= config_.max_steps || dt <= 1e-14 * std::max(1.0, std::abs(t))) {
        ok = false;
        break;
      }
      const double remaining = t_end - t;
      const bool last = dt >= remaining * (1.0 - 1e-12);
      const double step = last ? remaining : dt;
      const double err = TryStep(m, law, t, step, tau);
      if (!std::isfinite(err)) {
        ok = false;
        break;
      }
      const double factor = err == 0.0 ? 5.0 : 0.9 * std::pow(err, -0.2);
      if (err <= 1.0) {
        CountAccepted();
        work_.error_estimate = err;
        work_.step = step;
        t = last ? t_end : t + step;
        y_ = y1_;
        k_[0] = k_[6];  // first same as last
        // A step cut short to land on t_end does not shrink the next proposal.
        dt = std::max(step < dt ? dt : 0.0, step * std::clamp(factor, 0.2, 5.0));
      } else {
        CountRejected();
        dt = step * std::clamp(factor, 0.2, 1.0);
      }
    }
    h_next_ = dt;
    q = y_.head(n_);
    qd = y_.tail(n_);
    return ok;
  }

 private:
  void Derivative(PlantModel& m, ControlLaw* law, double t, const VectorXd& y, ConstVecRef tau, VectorXd& dy) {
    dy.head(n_) = y.tail(n_);
    m.ComputeAcceleration(law, t, y.head(n_), y.tail(n_), tau, dy.tail(n_));
    CountEvaluations(1);
  }

  // One trial step from (t, y_) with k_[0] = f(y_); returns the scaled error norm
  // and leaves the fifth-order solution in y1_ and f(y1_) in k_[6].
  double TryStep(PlantModel& m, ControlLaw* law, double t, double dt, ConstVecRef tau) {
    static constexpr double c[7] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
    static constexpr double a[7][6] = {
        {},
        {1.0 / 5},
        {3.0 / 40, 9.0 / 40},
        {44.0 / 45, -56.0 / 15, 32.0 / 9},
        {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
        {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
        {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84},
    };
    // Fifth-order minus embedded fourth-order weights.
    static constexpr double e[7] = {71.0 / 57600,      0.0,        -71.0 / 16695, 71.0 / 1920,
                                    -17253.0 / 339200, 22.0 / 525, -1.0 / 40};
    for (int s = 1; s < 7; ++s) {
      yt_ = y_;
      for (int j = 0; j < s; ++j) {
        if (a[s][j] != 0.0) yt_ += (dt * a[s][j]) * k_[j];
      }
      Derivative(m, law, t + c[s] * dt, yt_, tau, k_[s]);
      if (s == 6) y1_ = yt_;  // the last stage's point is the fifth-order solution
    }
    err_.setZero();
    for (int j = 0; j < 7; ++j) {
      if (e[j] != 0.0) err_ += (dt * e[j]) * k_[j];
    }
    double sum = 0.0;
    for (int i = 0; i < 2 * n_; ++i) {
      const double scale = config_.atol + config_.rtol * std::max(std::abs(y_[i]), std::abs(y1_[i]));
      const double r = err_[i] / scale;
      sum += r * r;
    }
    return std::sqrt(sum / (2 * n_));
  }

  void StartOver() override { h_next_ = 0.0; }

  VectorXd y_, y1_, yt_, err_;
  VectorXd k_[7];
  double h_next_ = 0.0;
};

// Midpoint variational integrator; see the header for the equations.
class Variational final : public Integrator {
 public:
  Variational(const IntegratorConfig& c, int n)
      : Integrator(c, n),
        p0_(n),
        q1_(n),
        qm_(n),
        v_(n),
        x_(n),
        r_(n),
        r_trial_(n),
        q_trial_(n),
        dq_(n),
        tmp_(n),
        M_(n, n),
        J_(n, n),
        lu_(n),
        llt_(n) {}

  bool DoStep(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, VecRef q, VecRef qd) override {
    CountAccepted();
    work_.step = h;
    const Dynamics& dyn = m.dynamics();
    // p0 = M(q0) qd0.
    dyn.ComputeMassMatrix(m.data(), q, M_);
    p0_.noalias() = M_ * qd;
    // Predictor: q1 = q0 + h qd0 + h²/2 qdd0.
    m.ComputeAcceleration(law, t, q, qd, tau, tmp_);
    CountEvaluations(1);
    q1_ = q + h * qd + (0.5 * h * h) * tmp_;

    // Newton on r(q1) = 0. The Jacobian is kept from step to step and rebuilt
    // only when the iteration stops contracting fast (or h changed).
    Residual(m, law, t, h, tau, q, q1_, r_);
    if (!jacobian_valid_ || h != jacobian_h_) Jacobian(m, law, t, h, tau, q);
    bool converged = false;
    bool refreshed = false;
    double previous = std::numeric_limits<double>::infinity();
    for (int it = 0; it < config_.newton_max_iterations; ++it) {
      CountNewtonIteration();
      dq_ = lu_.solve(r_);
      q1_ -= dq_;
      Residual(m, law, t, h, tau, q, q1_, r_);
      const double step = dq_.lpNorm<Eigen::Infinity>();
      const double scale = 1.0 + q1_.lpNorm<Eigen::Infinity>();
      if (!std::isfinite(step)) break;
      // Converged at the tolerance, or stalled at round-off far below anything physical.
      if (step <= config_.newton_tol * scale || (step <= kRoundOffFloor * scale && step >= 0.5 * previous)) {
        converged = true;
        break;
      }
      if (step > kSlowContraction * previous && !refreshed) {
        Jacobian(m, law, t, h, tau, q);
        refreshed = true;
      }
      previous = step;
    }
    // p1 = p0 + h (∂T/∂q − G + F) at the midpoint; x_ holds that bracket from the last residual.
    p0_ += h * x_;
    q = q1_;
    dyn.ComputeMassMatrix(m.data(), q, M_);
    llt_.compute(M_);
    qd = llt_.solve(p0_);
    if (!converged) jacobian_valid_ = false;
    return converged;
  }

 private:
  // r(q1) = p0 − M(qm) v + h/2 (∂T/∂q(qm, v) − G(qm) + F(tm, qm, v)); leaves the bracket in x_.
  void Residual(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, ConstVecRef q0, const VectorXd& q1,
                VectorXd& r) {
    const Dynamics& dyn = m.dynamics();
    DynamicsData& data = m.data();
    qm_ = 0.5 * (q0 + q1);
    v_ = (q1 - q0) / h;
    dyn.ComputeKineticEnergyGradient(data, qm_, v_, x_);
    if (m.effects().terms().gravity) {
      dyn.ComputeGravityForce(data, qm_, tmp_);
      x_ -= tmp_;
    }
    m.ComputeGeneralizedForce(law, t + 0.5 * h, qm_, v_, tau, tmp_);
    x_ += tmp_;
    dyn.ComputeMassMatrix(data, qm_, M_);
    r = p0_;
    r.noalias() -= M_ * v_;
    r += (0.5 * h) * x_;
    CountEvaluations(1);
  }

  // J = ∂r/∂q1 by forward differences at q1_, factorised into lu_.
  void Jacobian(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, ConstVecRef q0) {
    for (int j = 0; j < n_; ++j) {
      const double delta = 1e-7 * std::max(1.0, std::abs(q1_[j]));
      q_trial_ = q1_;
      q_trial_[j] += delta;
      Residual(m, law, t, h, tau, q0, q_trial_, r_trial_);
      J_.col(j) = (r_trial_ - r_) / delta;
    }
    // Restore the residual's side output x_ for q1_.
    Residual(m, law, t, h, tau, q0, q1_, r_);
    lu_.compute(J_);
    jacobian_valid_ = true;
    jacobian_h_ = h;
  }

  void StartOver() override { jacobian_valid_ = false; }

  static constexpr double kRoundOffFloor = 1e-9;    // |Δq| / (1 + |q|) below which a stall is round-off
  static constexpr double kSlowContraction = 0.25;  // rebuild the Jacobian when |Δq| shrinks slower than this

  VectorXd p0_, q1_, qm_, v_, x_, r_, r_trial_, q_trial_, dq_, tmp_;
  MatrixXd M_, J_;
  Eigen::PartialPivLU<MatrixXd> lu_;
  Eigen::LLT<MatrixXd> llt_;
  bool jacobian_valid_ = false;
  double jacobian_h_ = 0.0;
};

}  // namespace

Rk4::Rk4(const IntegratorConfig& c, int n)
    : Integrator(c, n), q1_(n), qd1_(n), dq_(n), dqd_(n), kqd_(n), q1_view_(q1_), qd1_view_(qd1_) {}

bool Rk4::DoStep(PlantModel& m, ControlLaw* law, double t, double h, ConstVecRef tau, VecRef q, VecRef qd) {
  Stages([&](double ts, ConstVecRef qs, ConstVecRef qds,
             VecRef qdd) { m.ComputeAcceleration(law, ts, qs, qds, tau, qdd); },
         t, h, q, qd);
  CountAccepted();
  CountEvaluations(4);
  work_.step = h;
  return true;
}

const char* Integrator::Reconfigure(const IntegratorConfig& config) {
  if (config.type != config_.type) return "integrator.type differs from this integrator's";
  if (const char* reason = CheckIntegratorConfig(config)) return reason;
  // Every buffer is sized by n_ alone (see the classes above): only numbers change.
  config_ = config;
  StartOver();
  return nullptr;
}

bool Integrator::Step(PlantModel& model, ControlLaw* law, double t, double h, ConstVecRef tau_cmd, VecRef q,
                      VecRef qd) {
  work_ = IntegratorWork{};
  return CountedStep(model, law, t, h, tau_cmd, q, qd);
}

bool Integrator::Advance(PlantModel& model, ControlLaw* law, double t, double dt, ConstVecRef tau_cmd, VecRef q,
                         VecRef qd) {
  work_ = IntegratorWork{};
  const double h = dt / config_.substeps;
  bool ok = true;
  for (int i = 0; i < config_.substeps; ++i) ok = CountedStep(model, law, t + i * h, h, tau_cmd, q, qd) && ok;
  return ok;
}

bool Integrator::CountedStep(PlantModel& model, ControlLaw* law, double t, double h, ConstVecRef tau_cmd, VecRef q,
                             VecRef qd) {
  ++work_.steps;
  ++stats_.steps;
  const bool ok = DoStep(model, law, t, h, tau_cmd, q, qd);
  if (!ok) {
    ++work_.failures;
    ++stats_.failures;
  }
  return ok;
}

std::unique_ptr<Integrator> MakeIntegrator(const IntegratorConfig& c, int n) {
  if (const char* reason = CheckIntegratorConfig(c)) throw std::invalid_argument(reason);
  switch (c.type) {
    case IntegratorType::kExplicitEuler:
    case IntegratorType::kSemiImplicitEuler: return std::make_unique<Euler>(c, n);
    case IntegratorType::kRk4: return std::make_unique<Rk4>(c, n);
    case IntegratorType::kDormandPrince: return std::make_unique<DormandPrince>(c, n);
    case IntegratorType::kVariational: return std::make_unique<Variational>(c, n);
  }
  throw std::invalid_argument("unknown integrator");
}

const char* NoStepDerivativesReason(IntegratorType type) {
  switch (type) {
    case IntegratorType::kExplicitEuler:
    case IntegratorType::kSemiImplicitEuler:
    case IntegratorType::kRk4: return nullptr;
    case IntegratorType::kDormandPrince:
      return "integrator dopri5 has no step derivatives (explicit-euler, semi-implicit-euler or rk4 have)";
    case IntegratorType::kVariational:
      return "integrator variational has no step derivatives (explicit-euler, semi-implicit-euler or rk4 have)";
  }
  return "unknown integrator (explicit-euler, semi-implicit-euler or rk4 have step derivatives)";
}

StepDerivatives::StepDerivatives(IntegratorType type, int n)
    : type_(type),
      n_(n),
      Aq_(n, n),
      Av_(n, n),
      Bt_(n, n),
      Kx_(2 * n, 2 * n),
      Kt_(2 * n, n),
      Sx_(2 * n, 2 * n),
      St_(2 * n, n),
      Xq_(n, 2 * n),
      Xv_(n, 2 * n),
      Yq_(n, n),
      Yv_(n, n),
      Ak_(2 * n, 2 * n),
      Bk_(2 * n, n),
      PA_(2 * n, 2 * n),
      PB_(2 * n, n),
      qs_(n),
      qds_(n),
      kq_(n),
      kqd_(n),
      qdd_(n),
      sum_q_(n),
      sum_qd_(n),
      x_q_(n),
      x_qd_(n),
      q_next_(n),
      qd_next_(n) {
  if (const char* reason = NoStepDerivativesReason(type)) throw std::invalid_argument(reason);
}

void StepDerivatives::Step(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd, ConstVecRef tau_cmd,
                           MatRef A, MatRef B) {
  eigen_assert(q.size() == n_ && qd.size() == n_ && tau_cmd.size() == n_ && model.num_dofs() == n_);
  eigen_assert(A.rows() == 2 * n_ && A.cols() == 2 * n_ && B.rows() == 2 * n_ && B.cols() == n_);
  if (type_ == IntegratorType::kRk4) {
    Rk4Step(model, t, h, q, qd, tau_cmd, A, B);
  } else {
    EulerStep(model, t, h, q, qd, tau_cmd, A, B);
  }
}

void StepDerivatives::EulerStep(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd,
                                ConstVecRef tau, MatRef A, MatRef B) {
  const int n = n_;
  model.ComputeAccelerationDerivatives(t, q, qd, tau, qdd_, Aq_, Av_, Bt_);
  // qd⁺ = qd + h qdd: its rows are the same for both.
  A.bottomLeftCorner(n, n) = h * Aq_;
  A.bottomRightCorner(n, n) = h * Av_;
  A.bottomRightCorner(n, n).diagonal().array() += 1.0;
  B.topRows(n).setZero();
  B.bottomRows(n) = h * Bt_;
  qd_next_ = qd + h * qdd_;
  if (type_ == IntegratorType::kSemiImplicitEuler) {  // q⁺ = q + h qd⁺
    A.topRows(n) = h * A.bottomRows(n);
    A.topLeftCorner(n, n).diagonal().array() += 1.0;
    B.topRows(n) = h * B.bottomRows(n);
    q_next_ = q + h * qd_next_;
  } else {  // q⁺ = q + h qd
    A.topLeftCorner(n, n).setIdentity();
    A.topRightCorner(n, n).setZero();
    A.topRightCorner(n, n).diagonal().setConstant(h);
    q_next_ = q + h * qd;
  }
}

// The stages of Rk4::Stages, each with its derivative (see the header).
void StepDerivatives::Rk4Step(PlantModel& model, double t, double h, ConstVecRef q, ConstVecRef qd, ConstVecRef tau,
                              MatRef A, MatRef B) {
  const int n = n_;
  // Stage 1 at x: ∂k1/∂x = F1, ∂k1/∂tau = G1.
  model.ComputeAccelerationDerivatives(t, q, qd, tau, qdd_, Aq_, Av_, Bt_);
  Kx_.topLeftCorner(n, n).setZero();
  Kx_.topRightCorner(n, n).setIdentity();
  Kx_.bottomLeftCorner(n, n) = Aq_;
  Kx_.bottomRightCorner(n, n) = Av_;
  Kt_.topRows(n).setZero();
  Kt_.bottomRows(n) = Bt_;
  Sx_ = Kx_;
  St_ = Kt_;
  kq_ = qd;
  kqd_ = qdd_;
  sum_q_ = kq_;
  sum_qd_ = kqd_;
  // Stages 2 and 3 at the midpoint, stage 4 at the end.
  for (int stage = 2; stage <= 4; ++stage) {
    const double a = stage == 4 ? h : 0.5 * h;
    const double w = stage == 4 ? 1.0 : 2.0;
    qs_ = q + a * kq_;
    qds_ = qd + a * kqd_;
    // The stage point's derivative I + a ∂k_{s−1}, by rows (q's, qd's).
    Xq_ = a * Kx_.topRows(n);
    Xq_.leftCols(n).diagonal().array() += 1.0;
    Xv_ = a * Kx_.bottomRows(n);
    Xv_.rightCols(n).diagonal().array() += 1.0;
    Yq_ = a * Kt_.topRows(n);
    Yv_ = a * Kt_.bottomRows(n);
    model.ComputeAccelerationDerivatives(t + a, qs_, qds_, tau, qdd_, Aq_, Av_, Bt_);
    // ∂k = (∂qd_s, ∂qdd_s) = (Xv, Aq Xq + Av Xv) [+ Bt].
    Kx_.topRows(n) = Xv_;
    Kx_.bottomRows(n).noalias() = Aq_ * Xq_;
    Kx_.bottomRows(n).noalias() += Av_ * Xv_;
    Kt_.topRows(n) = Yv_;
    Kt_.bottomRows(n) = Bt_;
    Kt_.bottomRows(n).noalias() += Aq_ * Yq_;
    Kt_.bottomRows(n).noalias() += Av_ * Yv_;
    Sx_ += w * Kx_;
    St_ += w * Kt_;
    kq_ = qds_;
    kqd_ = qdd_;
    sum_q_ += w * kq_;
    sum_qd_ += w * kqd_;
  }
  A = (h / 6.0) * Sx_;
  A.diagonal().array() += 1.0;
  B = (h / 6.0) * St_;
  q_next_ = q + (h / 6.0) * sum_q_;
  qd_next_ = qd + (h / 6.0) * sum_qd_;
}

void StepDerivatives::Advance(PlantModel& model, double t, double dt, int substeps, ConstVecRef q, ConstVecRef qd,
                              ConstVecRef tau_cmd, MatRef A, MatRef B) {
  eigen_assert(substeps >= 1);
  const double h = dt / substeps;
  Step(model, t, h, q, qd, tau_cmd, A, B);
  for (int k = 1; k < substeps; ++k) {
    x_q_ = q_next_;
    x_qd_ = qd_next_;
    Step(model, t + k * h, h, x_q_, x_qd_, tau_cmd, Ak_, Bk_);
    PA_.noalias() = Ak_ * A;
    A = PA_;
    PB_.noalias() = Ak_ * B;
    B = PB_ + Bk_;
  }
}

}  // namespace lagrange
