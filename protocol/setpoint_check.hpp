#pragma once
// A setpoint packet from the wire to a verdict, without LCM or threads: the
// raw layout check (wire.hpp), decoding, then the content rules. Its age is
// judged by the receiver, which knows the clocks.

#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/setpoint_t.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

namespace lagrange {

using Eigen::VectorXd;  // as plant/types.hpp has it

struct SetpointRules {
  int n = 0;              // the instance's num_dofs
  VectorXd lower, upper;  // setpoint limits on q (n), ±inf for none
};

struct SetpointVerdict {
  enum class Kind : std::uint8_t { kAccepted, kRejected, kUndecodable } kind = Kind::kUndecodable;
  std::string reason;  // why, for kRejected and kUndecodable
};

// |q|, |qd|, |qdd| above this are refused as mistakes (rad, m and their rates).
inline constexpr double kMaxSetpointMagnitude = 1e6;

// Checks `data` (size bytes) as a setpoint_t for an instance with `rules`,
// decoding it into `out` (whose vectors keep their capacity).
SetpointVerdict CheckSetpoint(const void* data, std::size_t size, const SetpointRules& rules, setpoint_t& out);

// The two targets an instance takes over LCM, and the controllers that follow
// each: joint setpoints (setpoint_t on <NAME>_SETPOINT) a joint-space
// controller, poses (pose_setpoint_t on <NAME>_POSE) a task-space one
// (cartesian-impedance, operational-space). The other kind is refused, never
// taken and ignored: a target the active controller does not follow would
// otherwise be counted as accepted and, streamed, time out into a hold.
enum class TargetKind : std::uint8_t { kJointSetpoint, kPose };
// Why a `kind` target is refused while `controller` is the active controller
// (`task_space`: it moves a frame), or "" when it follows it. The one rule for
// both kinds; the receiver checks it after decoding and before the content.
std::string RefusedByController(TargetKind kind, bool task_space, const std::string& controller);

// What a pose setpoint (pose_setpoint_t, on <NAME>_POSE) must satisfy for one
// instance: the frame its task-space controller moves, the scene's workspace
// box for the target's position (world frame, m; ±inf where unbounded), the
// longest timed move, and the fastest feed-forward twist: the most the
// joints' velocity limits allow the frame anywhere (plant/frame_speed.hpp;
// +inf for a robot without velocity limits).
struct PoseRules {
  std::string frame;  // the frame the task-space controller moves ("" for another controller)
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  double max_duration = 600.0;                                         // s
  double max_linear_speed = std::numeric_limits<double>::infinity();   // m/s: ‖twist[0..2]‖
  double max_angular_speed = std::numeric_limits<double>::infinity();  // rad/s: ‖twist[3..5]‖
};

// |‖q‖ − 1| above this and a quaternion is refused as not a rotation (a sender
// normalises; float rounding stays far below it).
inline constexpr double kUnitQuaternionTolerance = 1e-6;

// Checks `data` (size bytes) as a pose_setpoint_t against `rules`, decoding it
// into `out`. Refused: non-finite or beyond kMaxSetpointMagnitude, a quaternion
// that is not unit, a position outside the workspace box, a frame other than
// rules.frame ("" in the message means rules.frame), a duration outside
// [0, max_duration], a non-zero twist with a duration (a timed move ends at
// rest), a twist whose linear or angular part is faster than the frame can
// move within the joints' velocity limits. Whether the instance's active controller takes poses at all is
// RefusedByController's rule, checked by the caller.
SetpointVerdict CheckPoseSetpoint(const void* data, std::size_t size, const PoseRules& rules, pose_setpoint_t& out);

// Why a torque (torque_t, on <NAME>_TORQUE) is refused while the instance runs
// `active` (a controller's name, as its states carry it) instead of its
// external controller: "the instance is not running its external controller
// (active: pd)". lagranged's receiver counts such a torque as rejected with
// it; Python's Client.send_torque refuses to send one with it.
std::string NotRunningExternalReason(std::string_view active);

}  // namespace lagrange
