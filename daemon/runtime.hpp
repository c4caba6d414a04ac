#pragma once
// The tick: every instance of a scene, its mode, and the mailboxes through
// which the receive thread reaches it. Built before the loop; Tick allocates
// nothing, takes no lock, logs nothing and sends nothing.
//
// One tick, per instance:
//   take commands → take the latest setpoint → check its timeout →
//   (mpc: take the latest plan, check its horizon and status) →
//   control and integrate (by mode) → check health → record for the publisher
//   (mpc: offer the state to the optimiser thread)
//
// Modes, what moves an instance between them and when it holds: the mode
// machine (daemon/mode_machine.hpp), one transition function every Take*
// step, command and health check calls. What each mode does in a tick:
//   running  control (the streamed setpoint, the scene trajectory until one
//            arrives, or an external controller's latest torque, or an mpc
//            controller's latest plan, evaluated at the instance's time), integrate
//   hold     hold-position: q_d = q where the hold began, at rest, under the
//            active controller, or an external controller's fallback (a
//            configured controller, or the brake τ = −B q̇); zero-torque: τ = 0
//   estop    the controller bypassed, every joint braked: τ = −B q̇ within the
//            torque limits
//   fault, stopped, paused, waiting: nothing moves (fault and stopped command
//            zero torque once)
//
// An external plant's instance is not integrated: each tick its (q, q̇) are
// the latest measured ones, its controller runs on them, and the record asks
// the publisher to send the torque (fault and stopped: zero once, then nothing;
// waiting and paused never happen to command).
//
// Commands reach the tick two ways. estop, clear_estop and reset are urgent:
// the receiver posts them as latest-wins flags (PostUrgent) beside the queue,
// so no flood can crowd them out; the tick takes them first, in the order
// they came, and applies each once however often it was sent within one tick
// (the verdict then carries the latest request id; the earlier ones get none).
// Every other command waits in a bounded queue that refuses when full.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "controllers/controller.hpp"
#include "daemon/mailbox.hpp"
#include "daemon/mode_machine.hpp"
#include "protocol/clock.hpp"
#include "protocol/command_kind.hpp"
#include "protocol/mode.hpp"
#include "sim/instance.hpp"
#include "sim/instance_model.hpp"
#include "sim/scene.hpp"

namespace lagrange {

// A setpoint the receive thread has validated and found fresh.
struct SetpointMessage {
  Setpoint setpoint;
};

// A torque for an external controller, validated and fresh (daemon/receiver.hpp).
// `sent`: when it was sent on the monotonic clock, as the receiver judged
// its age (arrival − age): the timeouts count from there, so a torque or
// state is never used once older than its timeout, however long it waited.
// kSentUnknown: from when the tick takes it.
inline constexpr Nanoseconds kSentUnknown = std::numeric_limits<Nanoseconds>::max();
struct TorqueMessage {
  VectorXd tau;  // (n) N·m or N
  Nanoseconds sent = kSentUnknown;
};

// A pose setpoint for a task-space controller, validated (protocol/
// setpoint_check.hpp: unit, finite, in the workspace, for its frame) and fresh.
// duration > 0: a minimum-jerk move there from the measured pose; 0: the
// target at once, with `twist` as its feed-forward.
struct PoseMessage {
  Pose target;
  Vector6d twist = Vector6d::Zero();
  double duration = 0.0;  // s
};

// An external plant's measured state, validated (size, finite, bounded) and fresh.
struct MeasuredMessage {
  VectorXd q, qd;           // (n)
  std::int64_t tick = -1;   // the sender's state_t.tick
  std::int64_t run_id = 0;  // the sender's state_t.run_id
  Nanoseconds sent = kSentUnknown;
  Nanoseconds arrived = kSentUnknown;  // when the receiver took it (monotonic), for the phase lock
};

// What the tick offers an mpc instance's optimiser thread (daemon/mpc_worker.hpp)
// after every tick it commands: the state a plan starts from, at the
// instance's time, and the reference (the setpoint it follows), n each.
struct MpcStateMessage {
  double t = 0.0;  // s, the instance's time
  VectorXd q, qd;
  MatrixXd q_ref, qd_ref;  // (n x N+1) the reference at every knot of the plan
  PoseTarget pose;  // the frame's target (an mpc controller with a frame; MpcController::PoseReference)
  EffectFlags effects;  // the instance's effects as switched now (MpcPlanner::FollowEffects)
};

// What the receiver found wrong with an external plant's measured state: each
// trips the watchdog (the instance stops commanding).
enum class MeasuredProblem : std::uint8_t { kNone = 0, kNotFinite, kWrongSize, kSecondSource };

// A command the receive thread has decoded and checked against what does not
// change (controller names, gain sizes); the tick checks the rest.
struct CommandMessage {
  CommandKind kind = CommandKind::kReset;
  std::int64_t utime = 0;
  std::int64_t request_id = 0;  // the sender's, echoed with the verdict
  int controller = -1;          // switch: the target; set-gains: the controller the gains are for
  Gains gains;                  // sized n (6 for a task-space controller's)
  // set-integrator: the integrator as asked (CheckIntegratorConfig passed);
  // default_max_steps: dopri5 takes the scene's max_steps, lowered to what fits the period.
  IntegratorConfig integrator;
  bool default_max_steps = false;
  EffectKind effect = EffectKind::kGravity;  // set-effect
  Method method = Method::kClosedForm;       // set-method
  bool on = false;                           // set-effect, set-forces
};

// The urgent commands, by index into UrgentFlags.
enum class Urgent : std::uint8_t { kEstop = 0, kClearEstop = 1, kReset = 2 };
inline constexpr std::size_t kNumUrgent = 3;
// The urgent kind of a command, if it is one.
std::optional<Urgent> UrgentKind(CommandKind kind);

// Latest-wins flags for the urgent commands (single producer: the receive
// thread). `posted[k]` is the receiver's sequence number of the latest
// command of kind k (0: none yet); the tick applies a kind whose number grew.
// The request id of post number p is in request_id[k][p % kIdSlots], written
// before `posted` is released, so the tick reads the id that belongs to the
// number it read; it could only be overwritten by kIdSlots more posts of the
// same kind between two adjacent loads in the tick.
struct UrgentFlags {
  static constexpr std::size_t kIdSlots = 8;
  std::atomic<std::uint64_t> posted[kNumUrgent] = {};
  std::atomic<std::int64_t> request_id[kNumUrgent][kIdSlots] = {};
  std::uint64_t sequence = 0;  // the receiver's counter
};

// Where the receive thread (and an mpc instance's optimiser thread) meets one instance.
struct InstanceChannels {
  // `plan`: a policy sized for the instance's mpc controller (empty: none).
  InstanceChannels(int n, std::size_t command_capacity, const MpcPolicy& plan = {});
  LatestMailbox<SetpointMessage> setpoints;
  LatestMailbox<PoseMessage> poses;
  LatestMailbox<TorqueMessage> torques;
  LatestMailbox<MeasuredMessage> measured;
  // The first MeasuredProblem since the tick last looked (the receiver sets it
  // only from kNone, so a good state after a bad one cannot hide it).
  std::atomic<std::uint8_t> measured_problem{0};
  SpscRing<CommandMessage> commands;
  UrgentFlags urgent;
  std::atomic<int> active_controller{0};  // published by the tick, read by the receiver
  // An mpc controller's optimiser (latest wins both ways): the tick offers
  // its latest state, the optimiser publishes each finished solve's policy.
  LatestMailbox<MpcStateMessage> mpc_state;
  LatestMailbox<MpcPolicy> mpc_plans;
};

// Why a run-time switch was refused by the work bound (sim/work_bound.hpp);
// the reply adds the figures (WorkFigures).
inline constexpr char kSwitchDoesNotFit[] =
    "the instances' worst case per tick would not fit the period (as lagranged refuses such a scene): lower "
    "substeps or max_steps, or choose a cheaper method";

// The figures behind a kSwitchDoesNotFit refusal, for the reply to quote (the
// tick never formats): the instances' worst case per tick with the switch, the
// budget (kTickBudgetFraction of the period), and for dopri5 the most
// max_steps that would fit (-1: another integrator).
struct WorkFigures {
  double worst_s = 0.0;
  double budget_s = 0.0;
  int max_steps_fit = -1;
};

// The tick's verdict on one command, for the reply the publisher sends.
struct Verdict {
  std::int64_t request_id = 0;
  CommandKind kind = CommandKind::kReset;
  const char* error = nullptr;  // null: applied
  WorkFigures work;             // error == kSwitchDoesNotFit: its figures
};
// Verdicts one tick can produce: a full command queue plus every urgent kind.
inline constexpr std::size_t kCommandQueueCapacity = 32;
inline constexpr std::size_t kMaxVerdictsPerTick = kCommandQueueCapacity + kNumUrgent;

// A plan an mpc instance's tick took from its optimiser (mpc_t on <NAME>_MPC):
// its figures and a few knots of its x̄, evenly spaced (protocol/wire.hpp's
// MpcKnotsOnWire, MpcKnotOnWire). Sized when the record is made: a copy, no allocation.
struct PlanRecord {
  bool taken = false;  // a plan was taken this tick (followed or not)
  std::int64_t sequence = 0;
  double start = 0.0, dt = 0.0, solve_time = 0.0, cost_before = 0.0, cost = 0.0;
  int horizon = 0, iterations = 0;
  DdpStatus status = DdpStatus::kMaxIterations;
  bool followed = false;  // usable: the tick follows it; else the instance fell back with its status
  VectorXd knot_t;        // (knots) s
  MatrixXd knot_x;        // (2n x knots) x̄ at those knots
};

// One instance at one tick, as the publisher sends it.
struct InstanceRecord {
  // `plan_horizon`: the N of the instance's mpc controller (0: none).
  explicit InstanceRecord(int n = 0, int plan_horizon = 0);
  double t = 0.0;
  VectorXd q, qd, qdd, tau, q_des, qd_des;
  double kinetic_energy = 0.0, potential_energy = 0.0;
  int controller = 0;
  Mode mode = Mode::kRunning;
  // What happened in this tick (static strings: the tick never formats).
  const char* fault = nullptr;
  int commands_accepted = 0;
  int commands_rejected = 0;
  const char* command_error = nullptr;
  std::array<Verdict, kMaxVerdictsPerTick> verdicts;  // the first num_verdicts
  std::size_t num_verdicts = 0;
  const char* reason = nullptr;  // why the mode is not running (one of the k* reasons or a fault); null when running
  // A task-space controller active (task_state_t): its frame as of its last
  // computation, measured and commanded, e = commanded ⊖ measured and the
  // measured twist (controllers/task_space.hpp).
  bool task = false;
  Pose task_pose, task_commanded;
  Vector6d task_error = Vector6d::Zero(), task_twist = Vector6d::Zero();
  // A floating base (base_state_t): its pose and twist (the full state's
  // first 7 and 6 entries), centre of mass and momentum (Instance::ComputeBaseMotion).
  bool base = false;
  Eigen::Matrix<double, kFreeFlyerNq, 1> base_q = Eigen::Matrix<double, kFreeFlyerNq, 1>::Zero();
  Vector6d base_v = Vector6d::Zero();
  Instance::BaseMotion base_motion;
  // External plant: publish tau on the torque channel this tick (it then
  // answers the measured state of tick state_tick).
  bool publish_torque = false;
  std::int64_t state_tick = -1;
  // An mpc controller's plan taken this tick (plan.taken).
  PlanRecord plan;

  // Telemetry (telemetry_t), when `telemetry`. The balance is the instance's
  // (zero for an external plant); work is this tick's, zero when nothing
  // was integrated (`integrated` false).
  bool telemetry = false;
  double energy_residual = 0.0, quadrature_bound = 0.0, work = 0.0, power = 0.0;
  // |ε| above the scene's energy_balance.bound under on_exceed: warn (the
  // balance is kept whenever a bound is, telemetry on or off).
  bool residual_exceeded = false;
  bool integrated = false;
  IntegratorWork integrator_work;
  Nanoseconds compute = 0;  // this instance's share of the tick (0 without a clock)
  // What the instance runs with now (status_t).
  IntegratorConfig integrator;
  bool external_plant = false;
  std::optional<MujocoIntegrator> mujoco_integrator;  // set: MuJoCo steps the plant with this; `integrator` never runs
  Method method = Method::kClosedForm;
  EffectFlags effects;
  // Forces (forces_t): every effect's force at the tick's end state, when
  // publish_forces: asked (forces_on) and the state is not one a fault or
  // the watchdog restored (frozen under zero torque, with q̈ zeroed).
  bool forces_on = false;
  bool publish_forces = false;
  EffectForces forces;
};

struct TickRecord {
  std::int64_t tick = 0;
  std::int64_t utime = 0;  // wall clock, µs
  Nanoseconds wake_latency = 0;
  Nanoseconds compute = 0;
  std::int64_t overruns = 0;  // total so far
  std::vector<InstanceRecord> instances;
};

class Runtime {
 public:
  // The tick's data for every instance of `model` (which it keeps, shared
  // with the receive and publish threads). Throws std::invalid_argument as
  // Instance does.
  explicit Runtime(std::shared_ptr<const DaemonModel> model);
  // The same on a model built from `scene` (tests, benches: by default no
  // prefix and no measured costs).
  explicit Runtime(const Scene& scene, const BuildOptions& options = {});
  ~Runtime();

  const DaemonModel& model() const { return *model_; }
  std::size_t size() const { return slots_.size(); }
  double period() const { return model_->period; }
  Instance& instance(std::size_t i);
  InstanceChannels& channels(std::size_t i);
  Mode mode(std::size_t i) const;

  // A record sized for this scene (the publisher ring's prototype).
  TickRecord MakeRecord() const;

  // One tick at monotonic time `now`: fills record.instances.
  void Tick(Nanoseconds now, TickRecord& record);

  // The clock each instance's compute time is read from (InstanceRecord::compute);
  // none (the default): 0. The loop sets its own.
  void SetClock(Clock* clock) { clock_ = clock; }

  // The loop's phase correction after this tick, ns (0: none): set by the
  // first external plant with phase_lock that took a measured state this
  // tick, −(wait − phase_lag)/4 clamped to ±kMaxPhaseStep, where wait is how
  // long that state had been waiting; the loop moves its next deadline by it.
  Nanoseconds PhaseShift() const { return phase_shift_; }
  static constexpr Nanoseconds kMaxPhaseStep = 50'000;

  // Receive thread: posts an urgent command (estop, clear_estop, reset) for
  // instance i; never blocks, never refused for lack of room.
  void PostUrgent(std::size_t i, Urgent kind, std::int64_t request_id);

 private:
  struct Slot;
  void TakeUrgent(Slot& s, Nanoseconds now, InstanceRecord& r);
  void TakeCommands(Slot& s, Nanoseconds now, InstanceRecord& r);
  const char* Apply(Slot& s, CommandKind kind, int controller, const Gains* gains, Nanoseconds now,
                    const CommandMessage* message = nullptr);
  void TakeMeasured(Slot& s, Nanoseconds now);
  void TakeSetpoint(Slot& s, Nanoseconds now);
  void TakePose(Slot& s, Nanoseconds now);
  void TakeTorque(Slot& s, Nanoseconds now);
  void TakePlan(Slot& s, Nanoseconds now, PlanRecord& record);
  void OfferState(Slot& s);
  void ControlAndIntegrate(Slot& s);
  void CheckHealth(Slot& s, InstanceRecord& r);
  void Record(Slot& s, InstanceRecord& r);
  // Runs `event` through the mode machine (daemon/mode_machine.hpp) and, when
  // it enters a mode, that mode's entry actions. Returns a command's refusal, or null.
  const char* On(Slot& s, ModeEvent event, Nanoseconds now, const char* fault = nullptr,
                 const char* plan_reason = nullptr);
  void KeepPlantTime(Slot& s, Nanoseconds now);
  void LockPhase(Slot& s, Nanoseconds now, Nanoseconds arrived);

  const char* ApplySwitch(Slot& s, const CommandMessage& c);
  // Whether instance s by `config` and `method` (and publishing its forces
  // when `forces`) keeps the instances' worst case within the budget; when
  // not, s's refusal figures say by how much.
  bool Fits(Slot& s, const IntegratorConfig& config, Method method, bool forces);
  // The budget less every other instance's worst case, s.
  double FreeFor(const Slot& s) const;

  std::shared_ptr<const DaemonModel> model_;
  double worst_total_s_ = 0.0;  // Σ every instance's current worst case per tick
  Clock* clock_ = nullptr;
  std::vector<std::unique_ptr<Slot>> slots_;
  Nanoseconds phase_shift_ = 0;
};

}  // namespace lagrange
