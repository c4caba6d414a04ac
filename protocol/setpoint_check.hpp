#pragma once
// A setpoint packet from the wire to a verdict, without LCM or threads: the
// raw layout check (wire.hpp), decoding, then the content rules. Its age is
// judged by the receiver, which knows the clocks.

#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/setpoint_t.hpp>

#include <Eigen/Core>

#include <limits>
#include <string>
#include <string_view>

#include "plant/types.hpp"

namespace lagrange {

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

// What a pose setpoint (pose_setpoint_t, on <NAME>_POSE) must satisfy for one
// instance: the frame its task-space controller moves, the scene's workspace
// box for the target's position (world frame, m; ±inf where unbounded), and
// the longest timed move.
struct PoseRules {
  std::string frame;  // "" : the instance has no task-space controller (every pose refused)
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  double max_duration = 600.0;  // s
};

// |‖q‖ − 1| above this and a quaternion is refused as not a rotation (a sender
// normalises; float rounding stays far below it).
inline constexpr double kUnitQuaternionTolerance = 1e-6;

// Checks `data` (size bytes) as a pose_setpoint_t against `rules`, decoding it
// into `out`. Refused: non-finite or beyond kMaxSetpointMagnitude, a quaternion
// that is not unit, a position outside the workspace box, a frame other than
// rules.frame ("" in the message means rules.frame), a duration outside
// [0, max_duration], a non-zero twist with a duration (a timed move ends at
// rest), and any pose for an instance without a task-space controller.
SetpointVerdict CheckPoseSetpoint(const void* data, std::size_t size, const PoseRules& rules, pose_setpoint_t& out);

// Why a torque (torque_t, on <NAME>_TORQUE) is refused while the instance runs
// `active` (a controller's name, as its states carry it) instead of its
// external controller: "the instance is not running its external controller
// (active: pd)". lagranged's receiver counts such a torque as rejected with
// it; Python's Client.send_torque refuses to send one with it.
std::string NotRunningExternalReason(std::string_view active);

}  // namespace lagrange
