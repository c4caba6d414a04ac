#pragma once
// Model-predictive control: a receding-horizon box-DDP plan (controllers/ddp.hpp)
// followed by its time-indexed affine policy.
//
// Law:    tau = S clamp(ū(t) + K_k (x − x̄(t))),  x = (q, qd),
//         ū(t) = ū_k + s (ū_{k+1} − ū_k),  x̄(t) = x̄_k + s (x̄_{k+1} − x̄_k),
//         k = floor((t − t_0) / dt) clamped to [0, N − 1], s = (t − t_0) / dt − k clamped to [0, 1]
//         (Evaluate's clamps; ū_N is ū_{N−1}), of the latest policy (ū_k, K_k, x̄_k; its
//         start t_0, step dt, N knots): between knots the plan's state and force
//         are followed linearly, as MJPC's and the Crocoddyl-based controllers' policies are;
//         S puts the m actuated forces into tau (n), 0 on the others.
// Inputs: t (s, the instance's time), q, qd (n each); the setpoint (q_d, qd_d)
//         is the plan's reference at every knot, or the scene's trajectory
//         sampled at every knot's time when the caller gives it
//         (NextReference; lagranged: MpcStateMessage); with a frame (MpcOptions::frame)
//         its pose target too: the scene's pose trajectory (the task-space
//         controllers' `trajectory`, started from the frame's measured pose),
//         or a pose setpoint (SetPoseTarget, MoveTo), sampled at every knot's time.
// Output: tau (n), within the box [tau_lower, tau_upper] of the actuated joints.
// State:  the policy; the planner's warm start.
// Gains:  none (the weights are the scene's, fixed at load).
//
// Model and data apart, and the optimiser off the tick, as MJPC's planner:
// a DdpModel (the problem, immutable, shared) and an MpcPlanner (its own
// DdpData: one per thread that plans) produce MpcPolicy values; the
// controller only evaluates the one it was last given (SetPolicy, a copy
// between equal sizes: no allocation). Where the plan is made is the caller's
// choice: lagranged plans on a thread of its own per instance and hands
// policies over through a latest-wins mailbox (daemon/mpc_worker.hpp); offline
// (lagrangectl simulate, lagrange.simulate) the controller plans inline, every
// replan_period of simulated time, so a run is deterministic.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "controllers/controller.hpp"
#include "controllers/ddp.hpp"

namespace lagrange {

// The scene's mpc keys (sim/scene_control.cpp reads them, ValidateMpc checks them).
struct MpcOptions {
  int horizon = 100;                                          // N knots, 1..kMaxMpcHorizon
  double dt = 0.02;                                           // s per knot, >= the tick's period, <= 1
  IntegratorType integrator = IntegratorType::kSemiImplicitEuler;  // the optimiser's (explicit-euler, semi-implicit-euler, rk4)
  int iterations = 2;                                         // DDP iterations per solve, 1..1000
  double replan_period = 0.0;                                 // s between solves (0: dt); >= the tick's period
  std::optional<std::vector<int>> actuated;                   // default: the cart of a cart-pole, else every joint
  // Diagonal weights (controllers/ddp.hpp's DdpWeights); empty: MpcWeights' defaults.
  VectorXd q, qd, tau, q_terminal, qd_terminal;
  // A frame's pose error in the cost (controllers/ddp.hpp, DdpFrameCost): the
  // frame's name ("": none), its weights (position 1/m², rotation 1/rad², >= 0)
  // on every knot and at the horizon's end, and the target it follows from the
  // start (the task-space controllers' trajectory; default: hold the pose the
  // frame starts at). Pose setpoints replace the target.
  std::string frame;
  Eigen::Vector2d pose_weight = Eigen::Vector2d::Zero(), pose_terminal_weight = Eigen::Vector2d::Zero();
  PoseTrajectoryConfig trajectory;
  // Who holds the instance when the plan lapses or fails: a configured
  // controller's name or "brake"; nullopt: the first gravity-compensation or
  // computed-torque controller, else the brake (an external controller's rule).
  std::optional<std::string> fallback;
};
inline constexpr int kMaxMpcHorizon = 10000;
inline constexpr int kMaxMpcIterations = 1000;

// The time between two solves, s: replan_period, or dt when it is 0 (every knot).
inline double MpcReplanPeriod(const MpcOptions& o) { return o.replan_period > 0.0 ? o.replan_period : o.dt; }

// "key: expected ..." for options that cannot make a plan on `n` joints at the
// tick `period`, or nullopt.
std::optional<std::string> ValidateMpc(const MpcOptions& o, int n, bool cart_pole, double period);
// The joints that take a force (ascending): o.actuated, or the default.
std::vector<int> MpcActuated(const MpcOptions& o, int n, bool cart_pole);
// The cost's weights: o's, each empty one its default (q 1, qd 0.01, tau 0.01,
// q_terminal 100, qd_terminal 1; with a frame, q and q_terminal 0: the pose
// error replaces the joint error) on every entry; n joints, m actuated.
DdpWeights MpcWeights(const MpcOptions& o, int n, int m);
// The frame of `kinematics` named o.frame, or nullopt ("" names none).
std::optional<int> MpcFrame(const MpcOptions& o, const Kinematics& kinematics);
// The optimiser's model of the plant's effects, from the instance's: gravity
// and Coriolis as the scene has them (`gravity: false`, `off: [coriolis]`:
// not modelled either), and the plant's viscous joint damping b when the
// scene gives it (−b∘qd, linear in qd: its step derivatives are exact), off
// at the start when the scene's `off` says so. Coulomb friction, joint limits,
// saturation and pushes stay out (non-smooth, or the τ box already, or unknown
// ahead), as Crocoddyl's and MJPC's models leave what the plant does not
// declare smooth. An `effect` command that switches one of the three later
// reaches lagranged's optimiser (MpcPlanner::FollowEffects).
EffectsConfig MpcEffects(const EffectsConfig& plant);
// The optimiser's problem: `dynamics` under `effects` (MpcEffects of the plant's),
// limits ±torque_limits on the actuated joints; with o.frame, that frame of
// `kinematics` (the same model's frames; may be null without a frame). Throws
// std::invalid_argument (DdpModel's message) for a problem ValidateMpc would
// refuse, for limits that are not finite on an actuated joint, and for a
// frame `kinematics` does not have.
std::shared_ptr<const DdpModel> MakeMpcModel(const MpcOptions& o, std::shared_ptr<const Dynamics> dynamics,
                                             const EffectsConfig& effects, const VectorXd& torque_limits,
                                             bool cart_pole, std::shared_ptr<const Kinematics> kinematics = nullptr);

// Whether a solve's outcome can be followed: converged or still improving.
// kLineSearchFailed, kNotPositiveDefinite and kDiverged cannot (the instance
// falls back, reason ToString(status)).
inline bool IsUsable(DdpStatus status) {
  return status == DdpStatus::kConverged || status == DdpStatus::kMaxIterations;
}

// One solve's outcome, what the tick follows: time-indexed, sized once.
struct MpcPolicy {
  MpcPolicy() = default;
  MpcPolicy(int n, int m, int horizon);

  std::int64_t sequence = 0;  // 0: no plan yet; then 1, 2, ... per solve
  double start = 0.0;         // s, the instance time x̄_0 was planned from
  double dt = 0.0;            // s per knot
  int horizon = 0;            // N
  DdpStatus status = DdpStatus::kMaxIterations;
  int iterations = 0;
  double cost_before = 0.0;  // J of the first rollout (the warm start's), before any iteration
  double cost = 0.0;         // J after the last iteration
  double solve_time = 0.0;   // s of wall clock the solve took, as the optimiser thread measured it (0: not measured)
  MatrixXd u;  // (m x N) ū_k
  MatrixXd K;  // (m x 2n·N) K_k in columns [2n k, 2n (k + 1))
  MatrixXd x;  // (2n x N+1) x̄_k

  // The knot of time t: floor((t − start) / dt); may be < 0 or >= N.
  std::int64_t Knot(double t) const;
  // Has a plan whose horizon has not run out at t.
  bool LiveAt(double t) const { return sequence > 0 && Knot(t) < horizon; }
  // u = clamp(ū(t) + K_k (x − x̄(t))) into [lower, upper], ū and x̄ linear between knots k and k + 1 (the law
  // above); no allocation.
  void Evaluate(double t, ConstVecRef q, ConstVecRef qd, const VectorXd& lower, const VectorXd& upper, VecRef u) const;
};

// The optimiser: the model's problem and its own data (one per thread).
class MpcPlanner {
 public:
  explicit MpcPlanner(std::shared_ptr<const DdpModel> model);
  const DdpModel& model() const { return *model_; }
  // A policy sized for the model.
  MpcPolicy MakePolicy() const;

  // (t, q, qd, q_ref, qd_ref) => out: a plan of N knots from x_0 = (q, qd) at
  // time t toward the reference (n each, held over the horizon), warm-started
  // from the previous plan shifted by the knots elapsed since it, a fraction
  // interpolated (DdpData::ShiftSolution(double)); cold (the actuated joints'
  // share of the gravity force G(q) held, when the model's gravity is on: a robot
  // that holds its pose, not one that falls) after Reset, after a failed
  // solve, or when t went back. `stop` (may be
  // null) is polled at every knot of every pass of the solve (DdpData::stop):
  // set, the solve ends early with what it has (kStopped: not a plan to follow). Returns the status. Allocates nothing.
  // q_ref, qd_ref: one column (n x 1), held over the horizon, or one per
  // knot (n x N+1), knot k's at t + k dt (a trajectory followed ahead).
  // `pose` (may be null: the frame's reference stays as it was) sets the
  // frame's reference at every knot when the model has a frame cost: knot k's
  // is pose->Sample(t + k dt) (a started target: not start_pending()).
  DdpStatus Plan(double t, ConstVecRef q, ConstVecRef qd, const Eigen::Ref<const MatrixXd>& q_ref,
                 const Eigen::Ref<const MatrixXd>& qd_ref, MpcPolicy& out, const std::atomic<bool>* stop = nullptr,
                 const PoseTarget* pose = nullptr);
  void Reset();
  // The plant's effects as switched now (Instance::SetEffect): the next
  // solves model its gravity, Coriolis and damping (those MpcEffects models)
  // as `plant` has them on; the rest are not modelled. Damping turns on only
  // when the model was given it. Allocates nothing.
  void FollowEffects(const EffectFlags& plant);

 private:
  std::shared_ptr<const DdpModel> model_;
  DdpData data_;
  std::unique_ptr<DynamicsData> dynamics_data_;  // the cold start's G(q)
  VectorXd gravity_, hold_;                      // (n), (m)
  bool warm_ = false;
  double last_start_ = 0.0;
  std::int64_t sequence_ = 0;
};

class MpcController final : public Controller {
 public:
  // `model` from MakeMpcModel; `replan_period` s between solves (> 0:
  // MpcReplanPeriod). Plans inline (offline) until set_plan_inline(false).
  // `trajectory`: the frame's target from the start (with a frame cost).
  MpcController(std::vector<JointType> joints, VectorXd torque_limits, std::shared_ptr<const DdpModel> model,
                double replan_period, PoseTrajectoryConfig trajectory = {});
  std::string_view name() const override { return "mpc"; }
  // Drops the policy and the warm start.
  void Reset() override;

  const std::shared_ptr<const DdpModel>& ddp_model() const { return model_; }
  double replan_period() const { return replan_period_; }
  // lagranged plans elsewhere (daemon/mpc_worker.hpp): the inline planner and
  // its data are released. Before the loop only.
  void set_plan_inline(bool on);
  bool plan_inline() const { return planner_ != nullptr; }
  // The policy to follow from now on (a copy between equal sizes: no allocation).
  void SetPolicy(const MpcPolicy& policy) { policy_ = policy; }
  const MpcPolicy& policy() const { return policy_; }
  // Inline solves since the start or Reset, and those whose status was not
  // usable (their policy is not taken), in all and by status.
  std::int64_t solves() const { return solves_; }
  std::int64_t failed_solves() const { return failed_; }
  std::int64_t failed_solves(DdpStatus status) const { return failed_by_status_[static_cast<std::size_t>(status)]; }

  // Offline: whether the next Compute at t plans (inline); then the caller
  // may fill NextReference (n x N+1 each: knot k's reference at t + k dt, the
  // scene's trajectory ahead), which that plan follows instead of holding the
  // setpoint; used once. No allocation.
  bool plan_due(double t) const { return planner_ != nullptr && (!planned_ || t >= next_plan_ - 1e-9); }
  struct Reference {
    MatrixXd q, qd;  // (n x N+1)
  };
  Reference& NextReference() {
    reference_ready_ = true;
    return reference_;
  }

  // The frame's target (a model with a frame cost; else ignored), as a
  // task-space controller's: each takes effect at the next plan and none allocates.
  bool has_frame() const { return model_->has_frame_cost(); }
  void SetPoseTarget(const PoseSetpoint& setpoint);
  void MoveTo(const Pose& target, double duration);
  // Holds the target where the frame's reference is at t, at rest (a streamed target that stopped).
  void HoldPoseTarget(double t);
  // The frame at (t, q, qd), as a task-space controller reports it: its
  // measured pose, the target the reference is at t, e = target ⊖ measured
  // (m, rad) and its twist J qd (m/s, rad/s, world axes). No allocation.
  void MeasureTask(double t, ConstVecRef q, ConstVecRef qd, Pose& pose, Pose& commanded, Vector6d& error,
                   Vector6d& twist);
  // The frame's reference at t from q (n): a pending start (the scene's
  // trajectory at the first call and after Reset, or a move) begins here from
  // the frame's measured pose. What the optimiser thread is handed. No allocation.
  const PoseTarget& PoseReference(double t, ConstVecRef q);

 protected:
  void ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint& sp, VecRef tau) override;

 private:
  std::shared_ptr<const DdpModel> model_;
  double replan_period_;
  std::unique_ptr<MpcPlanner> planner_;  // inline only
  MpcPolicy policy_, candidate_;
  VectorXd u_;  // (m)
  double next_plan_ = 0.0;
  bool planned_ = false;
  std::int64_t solves_ = 0, failed_ = 0;
  std::array<std::int64_t, kNumDdpStatuses> failed_by_status_{};
  Reference reference_;  // NextReference's
  bool reference_ready_ = false;
  // The frame's target (has_frame()).
  PoseTrajectoryConfig scene_trajectory_;
  PoseTarget target_;
  std::unique_ptr<KinematicsData> kinematics_data_;  // null without a frame
};

}  // namespace lagrange
