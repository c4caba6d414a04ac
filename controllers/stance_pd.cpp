#include "controllers/stance_pd.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "base/escape.hpp"
#include "plant/eigenvalues.hpp"

namespace lagrange {
namespace {

// Eigenvalues of A Aᵀ below this fraction of the largest are a direction no foot can push: dropped.
constexpr double kRankTolerance = 1e-12;

}  // namespace

std::string StanceProblem(const StanceOptions& stance, const std::vector<std::string>& frames) {
  if (!stance.on) {
    return stance.feet.empty() ? "" : "feet: expected only with gravity_compensation: stance";
  }
  if (stance.feet.empty() || static_cast<int>(stance.feet.size()) > kMaxStanceFeet) {
    return "feet: expected 1 to " + std::to_string(kMaxStanceFeet) + " frames of the robot's feet, got " +
           std::to_string(stance.feet.size());
  }
  for (std::size_t i = 0; i < stance.feet.size(); ++i) {
    const std::string& foot = stance.feet[i];
    if (std::find(frames.begin(), frames.end(), foot) == frames.end()) {
      std::string names;
      for (const std::string& f : frames) names += (names.empty() ? "" : ", ") + Escape(f, 64);
      return "feet: expected frames of the robot (" + names + "), got '" + Escape(foot, 64) + "'";
    }
    if (std::find(stance.feet.begin(), stance.feet.begin() + static_cast<std::ptrdiff_t>(i), foot) !=
        stance.feet.begin() + static_cast<std::ptrdiff_t>(i)) {
      return "feet: expected each frame once, got '" + Escape(foot, 64) + "' twice";
    }
  }
  if (!(stance.contact_height > 0.0) || !std::isfinite(stance.contact_height)) {
    return "contact_height: expected a positive height (m)";
  }
  return "";
}

StancePdController::StancePdController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains,
                                       bool velocity_feedforward, StanceOptions stance,
                                       std::shared_ptr<const FloatingDynamics> model)
    : Controller(std::move(joints), std::move(torque_limits)),
      gains_(std::move(gains)),
      velocity_feedforward_(velocity_feedforward),
      contact_height_(stance.contact_height),
      model_(std::move(model)) {
  if (!model_) throw std::invalid_argument("gravity_compensation: stance needs a floating base's model");
  if (model_->num_dofs() != num_dofs()) {
    throw std::invalid_argument("gravity_compensation: stance: expected the floating model's " +
                                std::to_string(model_->num_dofs()) + " joints, got " + std::to_string(num_dofs()));
  }
  const std::vector<std::string> frames = model_->tree().frame_names();
  if (const std::string why = StanceProblem(stance, frames); !why.empty()) throw std::invalid_argument(why);
  if (auto fault = FindGainFault(gains_, gain_bounds())) {
    throw std::invalid_argument(DescribeGainFault(*fault, gains_, gain_bounds()));
  }
  for (const std::string& foot : stance.feet) {
    feet_.push_back(static_cast<int>(std::find(frames.begin(), frames.end(), foot) - frames.begin()));
  }
  data_ = model_->MakeData();
  fq_ = VectorXd::Zero(model_->num_q());
  zero_v_ = VectorXd::Zero(model_->num_v());
  G_ = VectorXd::Zero(model_->num_v());
  J_ = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model_->num_v());
  joint_rows_ = MatrixXd::Zero(kMaxRows, num_dofs());
  lambda_ = VectorXd::Zero(kMaxRows);
}

void StancePdController::ApplyGains(const Gains& gains) {
  gains_.kp = gains.kp;
  gains_.kd = gains.kd;
}

void StancePdController::ComputeLaw(double, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  for (int i = 0; i < num_dofs(); ++i) {
    const double edot = (velocity_feedforward_ ? sp.qd[i] : 0.0) - qd[i];
    tau[i] = gains_.kp[i] * Error(i, sp.q[i], q[i]) + gains_.kd[i] * edot;
  }
}

void StancePdController::ComputeFloatingLaw(double, ConstVecRef base_q, ConstVecRef, ConstVecRef q, ConstVecRef qd,
                                            const Setpoint& sp, VecRef tau) {
  ComputeStanceGravity(base_q, q, tau);
  for (int i = 0; i < num_dofs(); ++i) {
    const double edot = (velocity_feedforward_ ? sp.qd[i] : 0.0) - qd[i];
    tau[i] += gains_.kp[i] * Error(i, sp.q[i], q[i]) + gains_.kd[i] * edot;
  }
}

// G = Sᵀ tau_g + J_cᵀ λ: λ from the base's six rows (least norm, least residual), tau_g from the joints'.
void StancePdController::ComputeStanceGravity(ConstVecRef base_q, ConstVecRef q, VecRef tau_g) {
  const int n = num_dofs();
  fq_.head<kFreeFlyerNq>() = base_q;
  fq_.tail(n) = q;
  model_->ComputeInverseDynamics(*data_, fq_, zero_v_, zero_v_, DynamicsTerms{.gravity = true, .coriolis = false}, G_);
  contacts_ = 0;
  for (const int foot : feet_) {
    model_->ComputeFrameJacobian(*data_, fq_, foot, J_);  // its placement too
    if (data_->frame_position(foot).z() > contact_height_) continue;
    joint_rows_.middleRows(3 * contacts_, 3) = J_.topRows<3>().rightCols(n);
    base_rows_.middleCols<3>(3 * contacts_) = J_.topRows<3>().leftCols<kFreeFlyerNv>().transpose();
    ++contacts_;
  }
  if (contacts_ == 0) {  // in the air
    tau_g.setZero();
    return;
  }
  // λ = A⁺ G_base = Aᵀ (A Aᵀ)⁺ G_base: the least-norm solution of least residual.
  const auto A = base_rows_.leftCols(3 * contacts_);
  Eigen::Matrix<double, 6, 1> d;  // ascending
  Matrix6d V;
  SymmetricEigen6(Matrix6d(A * A.transpose()), d, V);
  const Eigen::Matrix<double, 6, 1> inverse =
      (d.array() > kRankTolerance * d[5]).select(d.cwiseInverse(), Eigen::Matrix<double, 6, 1>::Zero());
  const Eigen::Matrix<double, 6, 1> y = V * inverse.asDiagonal() * (V.transpose() * G_.head<kFreeFlyerNv>());
  lambda_.resize(3 * contacts_);
  lambda_.noalias() = A.transpose() * y;
  tau_g = G_.tail(n);
  tau_g.noalias() -= joint_rows_.topRows(3 * contacts_).transpose() * lambda_;
}

}  // namespace lagrange
