#pragma once
// Poses, pose setpoints and task-space trajectories for the task-space
// controllers (controllers/task_space.hpp).
//
// Conventions (those of plant/kinematics.hpp's world-aligned Jacobian):
//   position      p (3), m, the frame's origin in the world (root link) frame
//   orientation   a unit quaternion (w, x, y, z) rotating the frame's axes
//                 into the world's: R = R(q), the frame's x, y, z in world coordinates
//   twist         (ṗ, ω) (6): linear m/s then angular rad/s, world axes
//   acceleration  (p̈, ω̇) (6): m/s² then rad/s², world axes
//   pose error    e = desired ⊖ measured (6): (p_d − p, log(R_d Rᵀ)), m and
//                 rad, world axes: the position difference, and the rotation
//                 vector θu (rotation angle θ in [0, π] about the unit axis u)
//                 of the rotation that takes the measured axes onto the
//                 desired ones (the log map, not the quaternion's vector part:
//                 see PoseError)
//
// Trajectories are values of fixed size: sampling, starting and assigning
// them allocate nothing, so the tick may do all three.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>

#include "plant/kinematics.hpp"

namespace lagrange {

struct Pose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               // m, world
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // unit (w, x, y, z): frame axes in world
};

// What a task-space controller is asked to follow at one instant. The twist
// and acceleration are feed-forward (zero: hold the pose at rest).
struct PoseSetpoint {
  Pose pose;
  Vector6d twist = Vector6d::Zero();         // (ṗ m/s, ω rad/s), world axes
  Vector6d acceleration = Vector6d::Zero();  // (p̈ m/s², ω̇ rad/s²), world axes
};

// The rotation vector θu of the unit quaternion q (θ in [0, π]: q and −q
// give the same vector, the short way round), rad. Exact at every angle; for
// small θ it runs on the series of θ/sin(θ/2), so θ → 0 is smooth.
Eigen::Vector3d LogMap(const Eigen::Quaterniond& q);
// The unit quaternion of the rotation vector r (rad): a turn of |r| about r/|r|.
Eigen::Quaterniond ExpMap(const Eigen::Vector3d& r);

// e = desired ⊖ measured (6): (p_d − p (m), LogMap(q_d q⁻¹) (rad)), world axes.
// The orientation error is the rotation vector θu (the log map), not the
// error quaternion's vector part sin(θ/2)u that libfranka's
// cartesian_impedance_control example uses: that is θ/2 for small θ (its
// rotational stiffness acts at half its value) and sin(θ/2) beyond (at
// θ = π, 2/π of a linear pull). The rotation vector is the angle itself, so
// a rotational stiffness K pulls with K·θ N·m at every angle, as its unit
// N·m/rad says, and ė = ω_d − ω + O(|e| |ω|) in the twist's own units. Both
// flip their axis at θ = π (the short way round changes side).
Vector6d PoseError(const Pose& desired, const Pose& measured);

// The minimum-jerk time scaling s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, τ = t/T clamped to
// [0, 1], with ṡ (1/s) and s̈ (1/s²): from rest at s = 0 to rest at s = 1.
struct TimeScaling {
  double s = 0.0, sd = 0.0, sdd = 0.0;
};
TimeScaling MinimumJerkScaling(double t, double duration);

// A task-space trajectory: t (s since it started) => PoseSetpoint, with the
// twist and acceleration the exact derivatives of the pose it samples.
//   hold          the pose, at rest
//   min-jerk      position p0 + s(t)(p1 − p0), orientation slerp from q0 to
//                 q1 on the same s(t): q(t) = ExpMap(s(t)·r) q0 with
//                 r = LogMap(q1 q0⁻¹), so ω = ṡ r and ω̇ = s̈ r (the axis is
//                 fixed); at rest at both ends, then holding (p1, q1)
//   circle        the position on a circle through the start point p0, at
//                 angle φ(t) about the unit normal n from it (right-handed):
//                 p = c + ρ (cos φ a + sin φ b), c = p0 + center (the centre,
//                 `center` the offset from p0, ⊥ n), ρ = |center|,
//                 a = −center/ρ, b = n × a; φ̇ rises from 0 to 2π f by the
//                 minimum-jerk profile over `ramp` s, then stays (so the
//                 motion starts at rest with no jump in acceleration); the
//                 orientation holds q0
class PoseTrajectory {
 public:
  enum class Type : std::uint8_t { kHold, kMinimumJerk, kCircle };

  // Holding `pose` (its twist and acceleration zero).
  PoseTrajectory() = default;
  static PoseTrajectory Hold(const Pose& pose);
  // A constant setpoint: the pose with its twist and acceleration as given
  // (a streamed setpoint, refreshed every tick; the feed-forward is the
  // sender's, not this pose's derivative).
  static PoseTrajectory Constant(const PoseSetpoint& setpoint);
  // From `from` to `to` over duration > 0 s, at rest at both ends.
  static PoseTrajectory MinimumJerk(const Pose& from, const Pose& to, double duration);
  // From `from` round the circle of `center` (offset from from.position, m,
  // ⊥ normal, nonzero) about the unit `normal` at `frequency` Hz (turns per
  // second, > 0), reaching it over `ramp` s (>= 0; 0: at once).
  static PoseTrajectory Circle(const Pose& from, const Eigen::Vector3d& center, const Eigen::Vector3d& normal,
                               double frequency, double ramp);

  Type type() const { return type_; }
  // t (s since the start; before 0 as at 0) => the setpoint.
  void Sample(double t, PoseSetpoint& out) const;

 private:
  Type type_ = Type::kHold;
  PoseSetpoint start_;                                  // hold, constant: the setpoint; else the start pose
  Eigen::Vector3d delta_ = Eigen::Vector3d::Zero();     // min-jerk: p1 − p0; circle: c
  Eigen::Vector3d rotation_ = Eigen::Vector3d::Zero();  // min-jerk: LogMap(q1 q0⁻¹)
  Eigen::Vector3d a_ = Eigen::Vector3d::Zero(), b_ = Eigen::Vector3d::Zero();  // circle: the plane's axes
  Pose end_;                                                                   // min-jerk: the target
  double duration_ = 0.0;                                                      // min-jerk: s; circle: the ramp
  double radius_ = 0.0, omega_ = 0.0;                                          // circle: m, rad/s
};

// A task-space trajectory as a scene or a command gives it, before its start
// pose is known: MakePoseTrajectory starts it from the frame's measured pose.
struct PoseTrajectoryConfig {
  PoseTrajectory::Type type = PoseTrajectory::Type::kHold;
  std::optional<Pose> target;  // hold: the pose held (default: the start pose); min-jerk: where to (required)
  double duration = 1.0;       // min-jerk, s
  Eigen::Vector3d center = Eigen::Vector3d(0.1, 0.0, 0.0);  // circle: the centre's offset from the start, m
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();        // circle: the plane's unit normal
  double frequency = 0.25;                                  // circle: Hz
  double ramp = 1.0;                                        // circle: s
};

// A minimum-jerk move to `target` in `duration` s from wherever the frame is
// when it starts: what a move setpoint (<NAME>_POSE with a duration) asks of
// a frame's controller, task-space or mpc.
inline PoseTrajectoryConfig MinimumJerkMoveTo(const Pose& target, double duration) {
  PoseTrajectoryConfig c;
  c.type = PoseTrajectory::Type::kMinimumJerk;
  c.target = target;
  c.duration = duration;
  return c;
}

// Why `config` describes no trajectory, "key: expected ..." (a finite unit
// target, duration > 0, a unit normal, a nonzero centre ⊥ the normal, ...),
// or nullopt.
std::optional<std::string> ValidatePoseTrajectory(const PoseTrajectoryConfig& config);
// The trajectory of a valid `config` starting at `start`. Allocates nothing.
PoseTrajectory MakePoseTrajectory(const PoseTrajectoryConfig& config, const Pose& start);
std::string_view ToString(PoseTrajectory::Type type);

// A frame's target as a task-space or mpc controller keeps it: a trajectory
// started at an instance time from the frame's measured pose (the scene's at
// the start, a command's later), or a constant setpoint; a start stays
// pending until the controller has measured the pose (Begin). A value of
// fixed size: commands, Begin and copies allocate nothing.
class PoseTarget {
 public:
  // `config` (valid: ValidatePoseTrajectory) pending from the start.
  explicit PoseTarget(PoseTrajectoryConfig config = {}) : pending_(std::move(config)) {}

  // Follow `setpoint` (pose, twist and acceleration feed-forward) from now on.
  void Set(const PoseSetpoint& setpoint) {
    trajectory_ = PoseTrajectory::Constant(setpoint);
    start_pending_ = false;
  }
  // `config` (valid) from the measured pose at the next Begin.
  void Start(const PoseTrajectoryConfig& config) {
    pending_ = config;
    start_pending_ = true;
  }
  // A minimum-jerk move to `target` over `duration` s (> 0) from the measured pose at the next Begin.
  void MoveTo(const Pose& target, double duration) { Start(MinimumJerkMoveTo(target, duration)); }
  // Holds the pose the target is at at t, at rest (a streamed target that stopped).
  void Hold(double t) {
    PoseSetpoint now;
    Sample(t, now);
    Set(PoseSetpoint{now.pose, Vector6d::Zero(), Vector6d::Zero()});
  }

  bool start_pending() const { return start_pending_; }
  // A pending start begins at instance time t (s) from `measured`; otherwise nothing.
  void Begin(double t, const Pose& measured) {
    if (!start_pending_) return;
    trajectory_ = MakePoseTrajectory(pending_, measured);
    start_ = t;
    start_pending_ = false;
  }
  // The target at instance time t (s).
  void Sample(double t, PoseSetpoint& out) const { trajectory_.Sample(t - start_, out); }

 private:
  PoseTrajectory trajectory_;
  double start_ = 0.0;  // s, the instance time the trajectory started at
  PoseTrajectoryConfig pending_;
  bool start_pending_ = true;
};

}  // namespace lagrange
