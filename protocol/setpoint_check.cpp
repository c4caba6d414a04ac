#include "protocol/setpoint_check.hpp"

#include <cmath>
#include <span>
#include <sstream>
#include <tuple>

#include "base/escape.hpp"
#include "protocol/receive.hpp"
#include "protocol/wire.hpp"

namespace lagrange {
namespace {

std::string Number(double x) {
  std::ostringstream os;
  os.precision(6);
  os << x;
  return os.str();
}

// The first non-finite or out-of-range entry of a field, as a reason ("" if none).
std::string CheckField(const char* field, std::span<const double> v) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) return std::string("non-finite value in ") + field + "[" + std::to_string(i) + "]";
    if (std::abs(v[i]) > kMaxSetpointMagnitude) {
      return std::string(field) + "[" + std::to_string(i) + "] = " + Number(v[i]) + " is out of range (|x| <= 1e6)";
    }
  }
  return "";
}

SetpointVerdict Reject(std::string why) { return {SetpointVerdict::Kind::kRejected, std::move(why)}; }

}  // namespace

SetpointVerdict CheckSetpoint(const void* data, std::size_t size, const SetpointRules& rules, setpoint_t& out) {
  if (const Drop d = ReceiveInto(out, data, size); d != Drop::kNone) {
    return {SetpointVerdict::Kind::kUndecodable, ToString(d)};
  }
  if (out.num_dofs != rules.n) {
    return Reject("num_dofs is " + std::to_string(out.num_dofs) + ", expected " + std::to_string(rules.n));
  }
  for (const auto& [field, values] : {std::pair{"q", &out.q}, std::pair{"qd", &out.qd}, std::pair{"qdd", &out.qdd}}) {
    if (std::string why = CheckField(field, *values); !why.empty()) return Reject(why);
  }
  for (int j = 0; j < rules.n; ++j) {
    if (out.q[static_cast<std::size_t>(j)] < rules.lower[j] || out.q[static_cast<std::size_t>(j)] > rules.upper[j]) {
      return Reject("q[" + std::to_string(j) + "] = " + Number(out.q[static_cast<std::size_t>(j)]) +
                    " is outside the setpoint limits [" + Number(rules.lower[j]) + ", " + Number(rules.upper[j]) + "]");
    }
  }
  return {SetpointVerdict::Kind::kAccepted, ""};
}

std::string RefusedByController(TargetKind kind, bool task_space, const std::string& controller) {
  if (kind == TargetKind::kPose && !task_space) {
    return "the instance is not running a controller that moves a frame (active: " + controller +
           "; pose setpoints need a task-space controller or an mpc with a frame)";
  }
  if (kind == TargetKind::kJointSetpoint && task_space) {
    return "the instance is running a controller that moves a frame (active: " + controller +
           "), which follows pose setpoints (pose_setpoint_t, lagrangectl send --pose), not joint setpoints";
  }
  return "";
}

SetpointVerdict CheckPoseSetpoint(const void* data, std::size_t size, const PoseRules& rules, pose_setpoint_t& out) {
  if (const Drop d = ReceiveInto(out, data, size); d != Drop::kNone) {
    return {SetpointVerdict::Kind::kUndecodable, ToString(d)};
  }
  if (!out.frame.empty() && out.frame != rules.frame) {
    return Reject("frame '" + Escape(out.frame, 64) + "': the task-space controller moves '" + rules.frame + "'");
  }
  for (const auto& [field, values] : {std::pair{"position", std::span<const double>(out.position, 3)},
                                      std::pair{"orientation", std::span<const double>(out.orientation, 4)},
                                      std::pair{"twist", std::span<const double>(out.twist, 6)},
                                      std::pair{"duration", std::span<const double>(&out.duration, 1)}}) {
    if (std::string why = CheckField(field, values); !why.empty()) return Reject(why);
  }
  const Eigen::Map<const Eigen::Vector4d> q(out.orientation);
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) {
    return Reject("orientation: expected a unit quaternion (w, x, y, z), got norm " + Number(q.norm()));
  }
  const Eigen::Map<const Eigen::Vector3d> p(out.position);
  for (int k = 0; k < 3; ++k) {
    if (p[k] < rules.lower[k] || p[k] > rules.upper[k]) {
      return Reject("position[" + std::to_string(k) + "] = " + Number(p[k]) + " m is outside the workspace [" +
                    Number(rules.lower[k]) + ", " + Number(rules.upper[k]) + "]");
    }
  }
  if (out.duration < 0.0 || out.duration > rules.max_duration) {
    return Reject("duration " + Number(out.duration) + " s: expected 0 (at once) to " + Number(rules.max_duration) +
                  " s");
  }
  if (out.duration > 0.0 && Eigen::Map<const Eigen::Matrix<double, 6, 1>>(out.twist).cwiseAbs().maxCoeff() > 0.0) {
    return Reject("twist with duration " + Number(out.duration) + " s: a timed move ends at rest (send zeros)");
  }
  for (const auto& [part, at, bound, unit] : {std::tuple{"linear", 0, rules.max_linear_speed, "m/s"},
                                              std::tuple{"angular", 3, rules.max_angular_speed, "rad/s"}}) {
    const double speed = Eigen::Map<const Eigen::Vector3d>(out.twist + at).norm();
    if (speed > bound) {
      return Reject("twist: " + std::string(part) + " speed " + Number(speed) + " " + unit +
                    " is more than the joints' velocity limits allow '" + rules.frame + "' (at most " + Number(bound) +
                    " " + unit + " anywhere)");
    }
  }
  return {SetpointVerdict::Kind::kAccepted, ""};
}

std::string NotRunningExternalReason(std::string_view active) {
  return "the instance is not running its external controller (active: " + std::string(active) + ")";
}

}  // namespace lagrange
