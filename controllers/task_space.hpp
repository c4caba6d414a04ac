#pragma once
// Task-space controllers: one frame of the robot (its 6-D pose) under
// Cartesian impedance or operational-space computed torque, each with a
// null-space posture task.
//
// Symbols (n joints, n >= 6; the frame's world-aligned quantities of
// plant/kinematics.hpp; poses, twists and e as in controllers/task_trajectory.hpp):
//   J     (6 x n)  the frame's Jacobian, rows (ṗ m/s, ω rad/s) per unit qd, world axes at its origin
//   J̇qd   (6)      its bias acceleration (p̈, ω̇ at qdd = 0)
//   e     (6)      desired ⊖ measured pose: (p_d − p, log(R_d Rᵀ)), m and rad, world axes
//   ė     (6)      ẋ_d − J qd, m/s and rad/s
//   M     (n x n)  the controller model's mass matrix; C qd + G its Coriolis and gravity forces
//   A     (6 x 6)  J M⁻¹ Jᵀ, the frame's inverse task inertia
//   Λ     (6 x 6)  (A + λ² I)⁻¹, the task inertia (kg, kg·m, kg·m²), damped near singularities
//   J̄     (n x 6)  M⁻¹ Jᵀ Λ, the dynamically consistent pseudo-inverse: J J̄ = I when λ = 0
//   P     (n x n)  I − Jᵀ J̄ᵀ, the null-space projector of torques: P Jᵀ F = 0 for any
//                  task force F, and J M⁻¹ P τ0 = 0 (a projected torque does not
//                  accelerate the frame), both when λ = 0
//   τ0    (n)      the posture torque k_ns ∘ (q_ns − q) − d_ns ∘ qd (the joint errors
//                  wrapped as the joint controllers', Controller::wrapped_joints)
//
// Singularities (damped least squares): σ = σmin(J), the smallest singular
// value of J (from the eigenvalues of J Jᵀ; J's linear rows are in m, its
// angular rows unitless, so σ is a length for a robot's position and 1 for
// its orientation). Below the threshold ε the damping ramps in:
//   λ² = 0                          for σ >= ε
//   λ² = λ²max (1 − (σ/ε)²)         for σ <  ε
// so Λ is continuous in q and bounded, |Λ| <= 1/λ² in every direction, and
// the task torque Jᵀ Λ(...) stays bounded through the singularity instead of
// growing as 1/σ. Defaults ε = 0.05, λ²max = 0.01 (1/kg along translations,
// 1/(kg·m²) along rotations: at σ = 0 the task inertia of a lost direction is
// capped at 100 kg or kg·m²). Below ε, J J̄ = A Λ ≠ I and P Jᵀ ≠ 0: the task
// is tracked less exactly there and the posture task leaks into it. If M is
// not positive definite (its Cholesky factorisation fails: a non-finite q,
// a broken model) the law is not finite and Compute faults, as the Controller
// contract says; no NaN ever leaves Compute.
//
// Targets: the frame follows a PoseTrajectory (task_trajectory.hpp) started
// from its measured pose: the scene's (TaskSpaceOptions::trajectory; default:
// hold the pose it has when the controller starts), a streamed setpoint
// (SetPoseTarget) or a minimum-jerk move (MoveTo). Every command takes effect
// at the next Compute and allocates nothing, so the tick may give it.
//
// Model and data apart: the dynamics and kinematics models are shared and
// immutable; the controller keeps its own DynamicsData and KinematicsData
// and every buffer its law needs, all sized at construction: Compute
// allocates nothing.

#include <Eigen/Cholesky>
#include <memory>
#include <optional>
#include <string>

#include "controllers/controller.hpp"
#include "controllers/task_trajectory.hpp"
#include "plant/kinematics.hpp"

namespace lagrange {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// The task's gains are per task axis (kTaskDims, base/vocabulary.hpp: x, y, z, rx, ry, rz).

// Damped least squares near singularities (above): ε and λ²max.
struct SingularityDamping {
  double threshold = 0.05;    // ε on σmin(J), > 0 (m for the linear rows, 1 for the angular)
  double max_damping = 0.01;  // λ²max, > 0: 1/kg along translations, 1/(kg·m²) along rotations
};

// The posture task in the null space: τ0 = k_ns ∘ (q_ns − q) − d_ns ∘ qd, projected by P.
struct NullSpaceOptions {
  VectorXd kp;                      // k_ns (n), N·m/rad or N/m, >= 0; empty: no posture task
  VectorXd kd;                      // d_ns (n), N·m·s/rad or N·s/m, >= 0; empty: zeros
  std::optional<VectorXd> posture;  // q_ns (n), rad or m; default: the initial q
};

struct TaskSpaceOptions {
  std::string frame;  // the controlled frame's name; "": the model's last frame (a robot's tip)
  // cartesian-impedance without explicit damping: D_i = 2 ζ sqrt(K_i Λ_ii(q0)) (CartesianImpedanceController).
  double damping_ratio = 1.0;
  NullSpaceOptions null_space;
  SingularityDamping singularity;
  PoseTrajectoryConfig trajectory;  // what the frame follows from the start; default: hold its pose
};

// The operational-space quantities of one frame at one q, every buffer sized
// for n joints at construction: Compute allocates nothing.
class OperationalSpace {
 public:
  OperationalSpace(int n, SingularityDamping damping);

  // (M (n x n), J (6 x n)) => M's Cholesky factor, M⁻¹Jᵀ, A, σmin(J), λ², Λ.
  // False when M is not positive definite or Λ is not finite.
  bool Compute(const MatrixXd& M, const Matrix6Xd& J);

  const Matrix6d& inertia() const { return lambda_; }        // Λ (6 x 6)
  double smallest_singular_value() const { return sigma_; }  // σmin(J)
  double damping() const { return damping_; }                // λ² applied
  // τ0 (n) => P τ0 = τ0 − Jᵀ Λ J M⁻¹ τ0 (n), with the J of the last Compute.
  void ProjectToNullSpace(const Matrix6Xd& J, ConstVecRef tau0, VecRef out);
  // J̄ = M⁻¹ Jᵀ Λ (n x 6) of the last Compute. Allocates: for tests and set-up.
  MatrixXd DynamicallyConsistentInverse() const { return minv_jt_ * lambda_; }

 private:
  SingularityDamping dls_;
  Eigen::LLT<MatrixXd> mass_;  // M = L Lᵀ
  MatrixXd minv_jt_;           // M⁻¹ Jᵀ (n x 6)
  Matrix6d a_, lambda_;
  Eigen::LLT<Matrix6d> task_;  // A + λ² I
  VectorXd y_;                 // (n) scratch
  double sigma_ = 0.0, damping_ = 0.0;
};

// The frame called `name` in `kinematics` ("" the last), or nullopt.
std::optional<int> FindTaskFrame(const Kinematics& kinematics, const std::string& name);

// Λ of `frame` at q (n), damped as `damping` says, through new data of both
// models: configure-time (allocates). NaN when M(q) is not positive definite.
Matrix6d TaskInertiaAt(const Dynamics& dynamics, const Kinematics& kinematics, int frame, const VectorXd& q,
                       SingularityDamping damping);

// What the two laws share: measuring the frame, following its target, the
// operational-space quantities, C qd + G and the posture task.
//
// Inputs: t (s), q, qd (n); the joint setpoint is not used (the target is a pose).
// Output: tau (n) = Jᵀ F + C qd + G + P τ0, F the law's task force (TaskForce).
// State:  the pose trajectory being followed and its start time.
class TaskSpaceController : public Controller {
 public:
  // `frame` of `kinematics`; gains (6 each, per task axis); q0 (n) the
  // posture's default. Throws std::invalid_argument for gains of another
  // size, or null-space vectors not of size n.
  TaskSpaceController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains, TaskSpaceOptions options,
                      const VectorXd& q0, std::shared_ptr<const Dynamics> dynamics,
                      std::shared_ptr<const Kinematics> kinematics, int frame);

  Gains gains() const override { return gains_; }
  bool has_gains() const override { return true; }

  // Commands: each takes effect at the next Compute; none allocates.
  // Follow `setpoint` (pose, twist and acceleration feed-forward) until the next command.
  void SetPoseTarget(const PoseSetpoint& setpoint);
  // A minimum-jerk move with slerp from the measured pose to `target` over `duration` s (> 0).
  void MoveTo(const Pose& target, double duration);
  // `config` (valid: ValidatePoseTrajectory) from the measured pose.
  void StartTrajectory(const PoseTrajectoryConfig& config);
  // The scene's trajectory again, from the measured pose.
  void Reset() override;

  // What the last Compute measured and commanded, for publishing.
  int frame() const { return frame_; }
  const std::string& frame_name() const { return kinematics_->frame_names()[static_cast<std::size_t>(frame_)]; }
  const Pose& pose() const { return pose_; }                    // measured
  const PoseSetpoint& commanded() const { return commanded_; }  // the target followed
  const Vector6d& pose_error() const { return e_; }             // e = commanded ⊖ measured (m, rad)
  const Vector6d& twist() const { return xdot_; }               // measured J qd (m/s, rad/s), world axes
  const OperationalSpace& operational_space() const { return os_; }
  const TaskSpaceOptions& options() const { return options_; }

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) final;
  void ApplyGains(const Gains& gains) override;
  // The task force F (6: N and N·m, world axes) from the quantities below.
  virtual Vector6d TaskForce() const = 0;

  Gains gains_;                       // kp, kd (6 each)
  const Matrix6Xd* J_ = nullptr;      // the frame's Jacobian (in kinematics data), this Compute
  Vector6d bias_ = Vector6d::Zero();  // J̇ qd
  Vector6d e_ = Vector6d::Zero(), edot_ = Vector6d::Zero();
  PoseSetpoint commanded_;
  OperationalSpace os_;

 private:
  // (q, qd) => pose_, J_, bias_, ẋ.
  void MeasureFrame(ConstVecRef q, ConstVecRef qd);
  // t => commanded_, e_, ė_ (a pending start begins at t from the measured pose).
  void FollowTarget(double t);
  // tau += P (k_ns ∘ (q_ns − q) − d_ns ∘ qd).
  void AddPosture(ConstVecRef q, ConstVecRef qd, VecRef tau);

  TaskSpaceOptions options_;
  std::shared_ptr<const Dynamics> dynamics_;      // shared, immutable
  std::shared_ptr<const Kinematics> kinematics_;  // shared, immutable
  std::unique_ptr<DynamicsData> dynamics_data_;
  std::unique_ptr<KinematicsData> kinematics_data_;
  int frame_;
  bool posture_on_;
  VectorXd posture_, k_ns_, d_ns_;               // (n)
  MatrixXd M_;                                   // (n x n)
  VectorXd zero_, bias_tau_, tau0_, projected_;  // (n)
  Pose pose_;
  Vector6d xdot_ = Vector6d::Zero();
  PoseTarget target_;  // a pending start begins from the measured pose at the next Compute
};

// Law:    tau = Jᵀ (K e + D (ẋ_d − J qd)) + C(q, qd) qd + G(q) + P τ0
//         libfranka's cartesian_impedance_control, τ = Jᵀ(−K e_f − D J q̇) + C q̇
//         (its robot adds G), with e_f = −e and ẋ_d = 0 when holding; here with
//         the twist feed-forward ẋ_d of a moving target, and the rotation vector
//         for the orientation error (task_trajectory.hpp, PoseError).
// Gains:  kp = K (6): N/m (x, y, z), N·m/rad (rx, ry, rz); kd = D (6): N·s/m,
//         N·m·s/rad; >= 0. Without explicit D, D_i = 2 ζ sqrt(K_i Λ_ii(q0))
//         (ζ the damping ratio, default 1): axis i's own mass–spring
//         Λ_ii ẍ + D_i ẋ + K_i x = 0 at the initial state is damped at ζ.
//         (libfranka's 2·sqrt(K) is that with Λ_ii = 1 kg or kg·m², ζ = 1;
//         a Panda's hand has Λ_ii of a few kg but 0.005 to 0.15 kg·m²,
//         where 2·sqrt(K) would damp the rotations at ζ ≈ 3 to 14.)
//         Bounded by the tick h (ComputeGainBounds): at rest on the target with
//         an exact model (C qd + G compensated, the posture task apart) the
//         frame obeys Λ ẍ + D ẋ + K x = 0, a joint PD's equation with M → Λ;
//         held over h it needs every mode of Λ⁻¹K h² within 1 and of Λ⁻¹D h
//         within 2 (joint_controllers.hpp). With Λ = Λ(q0) and
//         c = λmax(Λ⁻¹ diag Λ) (>= 1; ρ(Λ⁻¹ diag k) grows with every k_i, so
//         the box's corner is its worst point):
//           K_i h² c / Λ_ii(q0) <= 1,    D_i h c / Λ_ii(q0) <= 2
//         (per axis, dimensionally sound: Λ_ii is kg for a translation and
//         kg·m² for a rotation, which a single λmin(Λ) would mix).
// Inputs/Output/State: as TaskSpaceController.
class CartesianImpedanceController final : public TaskSpaceController {
 public:
  using TaskSpaceController::TaskSpaceController;
  std::string_view name() const override { return "cartesian-impedance"; }

 protected:
  Vector6d TaskForce() const override;
};

// Law:    tau = Jᵀ Λ (ẍ_d + Kd ė + Kp e − J̇qd) + C(q, qd) qd + G(q) + P τ0
//         Khatib's operational-space control in its joint-space form: C qd + G
//         compensated in full. (The μ, p form, F = Λ a + μ + p with
//         μ = J̄ᵀ C qd − Λ J̇ qd, p = J̄ᵀ G, compensates only their task part
//         Jᵀ J̄ᵀ (C qd + G) and leaves P (C qd + G) to the posture task; the two
//         are equal for n = 6 away from singularities, where P = 0.)
//         With an exact model and λ = 0 the frame obeys
//           J qdd + J̇ qd = ẍ_d + Kd ė + Kp e
//         so the position error obeys ë + Kd ė + Kp e = 0, and the rotation
//         vector the same to first order in e (d/dt log(R_d Rᵀ) = ω_d − ω + O(|e| |ė|)).
// Gains:  kp (6) 1/s², kd (6) 1/s, >= 0. Bounded by the tick h as computed
//         torque, the unit-mass error dynamics being the same
//         (ComputeGainBounds): Kp_i h² <= 1, Kd_i h <= 2.
// Inputs/Output/State: as TaskSpaceController.
class OperationalSpaceController final : public TaskSpaceController {
 public:
  using TaskSpaceController::TaskSpaceController;
  std::string_view name() const override { return "operational-space"; }

 protected:
  Vector6d TaskForce() const override;
};

}  // namespace lagrange
