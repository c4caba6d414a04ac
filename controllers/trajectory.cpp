#include "controllers/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lagrange {
namespace {

class Hold final : public Trajectory {
 public:
  Hold(VectorXd q, bool follows_start) : q_(std::move(q)), follows_start_(follows_start) {}
  void StartFrom(ConstVecRef q, ConstVecRef) override {
    if (follows_start_) q_ = q;
  }
  void Sample(double, Setpoint& out) const override {
    out.q = q_;
    out.qd.setZero();
    out.qdd.setZero();
  }
  std::string_view name() const override { return "hold"; }

 private:
  VectorXd q_;
  bool follows_start_;
};

class Step final : public Trajectory {
 public:
  Step(VectorXd from, VectorXd target, double at) : from_(std::move(from)), target_(std::move(target)), at_(at) {}
  void StartFrom(ConstVecRef q, ConstVecRef) override { from_ = q; }
  void Sample(double t, Setpoint& out) const override {
    out.q = t < at_ ? from_ : target_;
    out.qd.setZero();
    out.qdd.setZero();
  }
  std::string_view name() const override { return "step"; }

 private:
  VectorXd from_, target_;
  double at_;
};

class Sine final : public Trajectory {
 public:
  Sine(VectorXd center, VectorXd amplitude, VectorXd frequency, bool follows_start)
      : center_(std::move(center)),
        amplitude_(std::move(amplitude)),
        omega_(2.0 * std::numbers::pi * frequency),
        follows_start_(follows_start) {}
  void StartFrom(ConstVecRef q, ConstVecRef) override {
    if (follows_start_) center_ = q;  // q_d(0) = center
  }
  void Sample(double t, Setpoint& out) const override {
    for (int i = 0; i < center_.size(); ++i) {
      const double s = std::sin(omega_[i] * t), c = std::cos(omega_[i] * t);
      out.q[i] = center_[i] + amplitude_[i] * s;
      out.qd[i] = amplitude_[i] * omega_[i] * c;
      out.qdd[i] = -amplitude_[i] * omega_[i] * omega_[i] * s;
    }
  }
  std::string_view name() const override { return "sine"; }

 private:
  VectorXd center_, amplitude_, omega_;
  bool follows_start_;
};

// Quintic q(s) = Σ c_k s^k on s = t/T in [0, 1] per joint.
class MinimumJerk final : public Trajectory {
 public:
  MinimumJerk(const VectorXd& q0, const VectorXd& qd0, const VectorXd& qdd0, const VectorXd& target, double T)
      : c_(q0.size(), 6), target_(target), qdd0_(qdd0), T_(T) {
    Fit(q0, qd0);
  }
  void StartFrom(ConstVecRef q, ConstVecRef qd) override { Fit(q, qd); }
  // (q0, qd0, qdd0_) => the quintic's coefficients to (target, 0, 0).
  void Fit(ConstVecRef q0, ConstVecRef qd0) {
    const VectorXd& qdd0 = qdd0_;
    const VectorXd& target = target_;
    const double T = T_;
    for (int i = 0; i < q0.size(); ++i) {
      // Boundary conditions in s: q(0) = q0, q'(0) = T qd0, q''(0) = T² qdd0, q(1) = target, q'(1) = q''(1) = 0.
      const double a0 = q0[i], a1 = T * qd0[i], a2 = 0.5 * T * T * qdd0[i];
      const double d = target[i] - a0 - a1 - a2;
      c_(i, 0) = a0;
      c_(i, 1) = a1;
      c_(i, 2) = a2;
      // c3..c5 from the end conditions q(1) = target, q'(1) = q''(1) = 0:
      //   c3 + c4 + c5 = e1,  3c3 + 4c4 + 5c5 = e2,  6c3 + 12c4 + 20c5 = e3
      const double e1 = d, e2 = -a1 - 2.0 * a2, e3 = -2.0 * a2;
      c_(i, 3) = 10.0 * e1 - 4.0 * e2 + 0.5 * e3;
      c_(i, 4) = -15.0 * e1 + 7.0 * e2 - e3;
      c_(i, 5) = 6.0 * e1 - 3.0 * e2 + 0.5 * e3;
    }
  }
  void Sample(double t, Setpoint& out) const override {
    if (t >= T_) {  // arrived: exactly the target, at rest
      out.q = target_;
      out.qd.setZero();
      out.qdd.setZero();
      return;
    }
    const double s = std::max(t / T_, 0.0);
    for (int i = 0; i < c_.rows(); ++i) {
      const auto c = c_.row(i);
      out.q[i] = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))));
      out.qd[i] = (c[1] + s * (2 * c[2] + s * (3 * c[3] + s * (4 * c[4] + s * 5 * c[5])))) / T_;
      out.qdd[i] = (2 * c[2] + s * (6 * c[3] + s * (12 * c[4] + s * 20 * c[5]))) / (T_ * T_);
    }
  }
  std::string_view name() const override { return "min-jerk"; }

 private:
  MatrixXd c_;
  VectorXd target_, qdd0_;
  double T_;
};

}  // namespace

std::unique_ptr<Trajectory> MakeHold(const VectorXd& q, bool follows_start) {
  return std::make_unique<Hold>(q, follows_start);
}

std::unique_ptr<Trajectory> MakeStep(const VectorXd& from, const VectorXd& target, double at) {
  return std::make_unique<Step>(from, target, at);
}

std::unique_ptr<Trajectory> MakeSine(const VectorXd& center, const VectorXd& amplitude, const VectorXd& frequency,
                                     bool follows_start) {
  return std::make_unique<Sine>(center, amplitude, frequency, follows_start);
}

std::unique_ptr<Trajectory> MakeMinimumJerk(const VectorXd& q0, const VectorXd& qd0, const VectorXd& qdd0,
                                            const VectorXd& target, double duration) {
  return std::make_unique<MinimumJerk>(q0, qd0, qdd0, target, duration);
}

}  // namespace lagrange
