#include "controllers/controller.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace lagrange {

double JointError(bool wrap, double desired, double measured) {
  const double e = desired - measured;
  if (!wrap) return e;
  // Wrap to (−π, π]; exact for |e| within a few turns, and correct at any size.
  double w = std::remainder(e, 2.0 * std::numbers::pi);
  if (w <= -std::numbers::pi) w += 2.0 * std::numbers::pi;
  return w;
}

double JointError(JointType type, double desired, double measured) {
  return JointError(type == JointType::kRevolute, desired, measured);
}

std::vector<bool> WrappedJoints(const std::vector<JointType>& joints, const std::optional<JointLimits>& limits) {
  std::vector<bool> wrap(joints.size());
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const int j = static_cast<int>(i);
    const bool stopped = limits && j < limits->lower.size() && j < limits->upper.size() &&
                         (std::isfinite(limits->lower[j]) || std::isfinite(limits->upper[j]));
    wrap[i] = joints[i] == JointType::kRevolute && !stopped;
  }
  return wrap;
}

Controller::Controller(std::vector<JointType> joints, VectorXd torque_limits)
    : joints_(std::move(joints)),
      wrap_(WrappedJoints(joints_, std::nullopt)),
      torque_limits_(std::move(torque_limits)),
      gain_bounds_(GainBounds::Unbounded(num_dofs())) {}

void Controller::set_wrapped_joints(std::vector<bool> wrap) {
  if (static_cast<int>(wrap.size()) != num_dofs()) {
    throw std::invalid_argument("wrapped joints: expected " + std::to_string(num_dofs()) + " flags (one per joint)");
  }
  wrap_ = std::move(wrap);
}

bool Controller::Compute(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) {
  ComputeLaw(t, q, qd, sp, tau);
  return Limit(tau);
}

bool Controller::Compute(double t, ConstVecRef base_q, ConstVecRef base_v, ConstVecRef q, ConstVecRef qd,
                         const Setpoint& sp, VecRef tau) {
  ComputeFloatingLaw(t, base_q, base_v, q, qd, sp, tau);
  return Limit(tau);
}

bool Controller::Limit(VecRef tau) const {
  if (!tau.allFinite()) {
    tau.setZero();
    return false;
  }
  tau = tau.cwiseMax(-torque_limits_).cwiseMin(torque_limits_);
  return true;
}

bool Controller::SetGains(const Gains& gains) {
  if (!has_gains() || FindGainFault(gains, gain_bounds_)) return false;
  ApplyGains(gains);
  return true;
}

namespace {

// The first |v_i| not within max_i, or -1; a box left empty (no second box)
// has every gain above it, and a NaN bound admits nothing (fails closed).
int FirstAbove(const VectorXd& v, const VectorXd& max) {
  if (max.size() != v.size()) return 0;
  for (int i = 0; i < v.size(); ++i) {
    if (!(std::abs(v[i]) <= max[i])) return i;
  }
  return -1;
}

}  // namespace

GainBounds GainBounds::Unbounded(int n) {
  const double inf = std::numeric_limits<double>::infinity();
  GainBounds bounds;
  bounds.kp_max = VectorXd::Constant(n, inf);
  bounds.kd_max = VectorXd::Constant(n, inf);
  return bounds;
}

GainBounds GainBounds::UnboundedTask() {
  GainBounds bounds = Unbounded(6);
  bounds.task_axes = true;
  return bounds;
}

std::optional<GainFault> FindGainFault(const Gains& g, const GainBounds& b) {
  const int n = b.num_dofs();
  for (const bool kd : {false, true}) {
    const VectorXd& v = kd ? g.kd : g.kp;
    const VectorXd& max = kd ? b.kd_max : b.kp_max;
    if (v.size() != n) return GainFault{GainFault::Kind::kSize, kd, -1};
    if (!v.allFinite()) return GainFault{GainFault::Kind::kNotFinite, kd, -1};
    if (!b.any_sign && (v.array() < 0.0).any()) return GainFault{GainFault::Kind::kSign, kd, -1};
    const int above = FirstAbove(v, max);
    if (above >= 0 && FirstAbove(v, kd ? b.kd_max_per_joint : b.kp_max_per_joint) >= 0) {
      return GainFault{GainFault::Kind::kAboveBound, kd, above};
    }
  }
  return std::nullopt;
}

std::string DescribeGainFault(const GainFault& f, const Gains& g, const GainBounds& b) {
  const std::string key = f.kd ? "kd" : "kp";
  switch (f.kind) {
    case GainFault::Kind::kSize:
      return key + ": expected " + std::to_string(b.num_dofs()) +
             (b.task_axes ? " gains (one per task axis: x, y, z, rx, ry, rz), got " : " gains (one per joint), got ") +
             std::to_string((f.kd ? g.kd : g.kp).size());
    case GainFault::Kind::kNotFinite:
      return key + (b.any_sign ? ": expected finite gains" : ": expected finite gains >= 0");
    case GainFault::Kind::kSign: return key + ": expected finite gains >= 0";
    case GainFault::Kind::kAboveBound: {
      // The numbers first, the rules they come from last: a reason is cut to
      // fit a status (kMaxStatusReasonBytes), and the bounds must survive it.
      const VectorXd& v = f.kd ? g.kd : g.kp;
      const double max = (f.kd ? b.kd_max : b.kp_max)[f.index];
      char text[160];
      std::snprintf(text, sizeof text, "[%d]: expected |gain| <= %.6g, got %.6g", f.index, max, v[f.index]);
      std::string message = key + text;
      std::string rules = (f.kd ? b.kd_rule : b.kp_rule);
      const VectorXd& per_joint = f.kd ? b.kd_max_per_joint : b.kp_max_per_joint;
      if (per_joint.size() == v.size()) {  // beyond the second box too: its bounds, and where
        const int i = FirstAbove(v, per_joint);
        message += "; or every " + key + " within its joint's bound [";
        for (int j = 0; j < per_joint.size(); ++j) {
          std::snprintf(text, sizeof text, "%s%.4g", j ? ", " : "", per_joint[j]);
          message += text;
        }
        std::snprintf(text, sizeof text, "], but %s[%d] = %.6g", key.c_str(), i, v[i]);
        message += text;
        rules += "; per joint " + (f.kd ? b.kd_rule_per_joint : b.kp_rule_per_joint);
      }
      return message + " (" + rules + ")";
    }
  }
  return key + ": expected valid gains";
}

}  // namespace lagrange
