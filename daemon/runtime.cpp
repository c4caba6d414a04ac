#include "daemon/runtime.hpp"

#include "protocol/wire.hpp"
#include "sim/health.hpp"
#include "sim/work_bound.hpp"

#include <algorithm>
#include <cmath>

namespace lagrange {

namespace {

SetpointMessage SetpointPrototype(int n) { return {Setpoint(n)}; }
TorqueMessage TorquePrototype(int n) { return {VectorXd::Zero(n)}; }
MeasuredMessage MeasuredPrototype(int n) { return {VectorXd::Zero(n), VectorXd::Zero(n)}; }
// Sized for n joints and a plan of N knots (the reference per knot: N + 1 columns).
MpcStateMessage MpcStatePrototype(int n, int N) {
  return {0.0,           VectorXd::Zero(n), VectorXd::Zero(n), MatrixXd::Zero(n, N + 1), MatrixXd::Zero(n, N + 1),
          PoseTarget{}, EffectFlags{}};
}

// The reason a plan's status gives for falling back (mode_machine.hpp), for one that is not usable.
const char* PlanFailure(DdpStatus status) {
  switch (status) {
    case DdpStatus::kLineSearchFailed: return kPlanLineSearchFailed;
    case DdpStatus::kNotPositiveDefinite: return kPlanNotPositiveDefinite;
    default: return kPlanDiverged;
  }
}

// The instance's first mpc controller (sim/instance_model.hpp, FirstMpc); null when it has none.
const MpcController* FirstMpcController(Instance& inst) {
  const std::optional<std::size_t> k = FirstMpc(inst.instance_model());
  return k ? inst.mpc_controller(*k) : nullptr;
}

// The plan prototype of an instance: sized for its mpc controller, else empty.
MpcPolicy PlanPrototype(Instance& inst) {
  const MpcController* c = FirstMpcController(inst);
  return c != nullptr ? c->policy() : MpcPolicy{};
}

// The N of an instance's mpc controller; 0 when it has none.
int PlanHorizon(Instance& inst) {
  const MpcController* c = FirstMpcController(inst);
  return c != nullptr ? c->ddp_model()->horizon() : 0;
}

// (plan) => record: its figures and knots (no allocation: the record is sized for the plan).
void RecordPlan(const MpcPolicy& plan, PlanRecord& r) {
  r.taken = true;
  r.sequence = plan.sequence;
  r.start = plan.start;
  r.dt = plan.dt;
  r.solve_time = plan.solve_time;
  r.cost_before = plan.cost_before;
  r.cost = plan.cost;
  r.horizon = plan.horizon;
  r.iterations = plan.iterations;
  r.status = plan.status;
  r.followed = IsUsable(plan.status);
  const auto knots = static_cast<std::int32_t>(r.knot_t.size());
  for (std::int32_t j = 0; j < knots; ++j) {
    const std::int32_t k = MpcKnotOnWire(j, knots, plan.horizon);
    r.knot_t[j] = plan.start + k * plan.dt;
    r.knot_x.col(j) = plan.x.col(k);
  }
}

CommandMessage CommandPrototype(int n) {
  CommandMessage c;
  c.gains = {VectorXd::Zero(n), VectorXd::Zero(n)};
  return c;
}

}  // namespace

std::optional<Urgent> UrgentKind(CommandKind kind) {
  switch (kind) {
    case CommandKind::kEstop: return Urgent::kEstop;
    case CommandKind::kClearEstop: return Urgent::kClearEstop;
    case CommandKind::kReset: return Urgent::kReset;
    default: return std::nullopt;
  }
}

InstanceChannels::InstanceChannels(int n, std::size_t command_capacity, const MpcPolicy& plan)
    : setpoints(SetpointPrototype(n)),
      poses(PoseMessage{}),
      torques(TorquePrototype(n)),
      measured(MeasuredPrototype(n)),
      commands(command_capacity, CommandPrototype(n)),
      mpc_state(MpcStatePrototype(plan.horizon > 0 ? n : 0, plan.horizon)),
      mpc_plans(plan) {}

InstanceRecord::InstanceRecord(int n, int plan_horizon)
    : q(VectorXd::Zero(n)),
      qd(VectorXd::Zero(n)),
      qdd(VectorXd::Zero(n)),
      tau(VectorXd::Zero(n)),
      q_des(VectorXd::Zero(n)),
      qd_des(VectorXd::Zero(n)),
      forces(n) {
  const std::int32_t knots = MpcKnotsOnWire(2 * n, plan_horizon);
  plan.knot_t = VectorXd::Zero(knots);
  plan.knot_x = MatrixXd::Zero(2 * n, knots);
}

// The tick's data for one instance: its Instance, its mailboxes, its mode
// and the timers and state the tick keeps between ticks. Everything fixed
// is the model's (`m`, sim/instance_model.hpp).
struct Runtime::Slot {
  explicit Slot(std::shared_ptr<const InstanceModel> model)
      : m(*model),
        instance(std::move(model)),
        channels(m.num_dofs, kCommandQueueCapacity, PlanPrototype(instance)),
        streamed(m.num_dofs),
        held(m.num_dofs),
        current(m.num_dofs),
        good(instance.MakeSaved()),
        zero(VectorXd::Zero(m.num_dofs)),
        brake_torque(VectorXd::Zero(m.num_dofs)),
        energies{instance.KineticEnergy(), instance.PotentialEnergy()},
        forces(m.config.forces) {}

  const InstanceModel& m;
  Instance instance;
  InstanceChannels channels;
  ModeState mode;
  bool streaming = false;         // a streamed setpoint has been accepted since start or reset
  Nanoseconds last_setpoint = 0;  // when it was
  // The task-space target is a streamed one with a twist (a pose setpoint of
  // duration 0 and a non-zero twist): it must be refreshed within
  // setpoint_timeout, or the target is held at rest where it was.
  bool pose_streaming = false;
  Nanoseconds last_pose = 0;
  Setpoint streamed, held, current;
  Instance::Saved good;  // the last state that passed the health check
  VectorXd zero, brake_torque;
  // This tick's results, computed once and read by the health check and the record.
  Instance::StepFailure step_failure = nullptr;
  const Setpoint* in_use = nullptr;  // the setpoint this tick followed (running, hold), decided once for the record
  StepEnergies energies;
  std::uint64_t urgent_seen[kNumUrgent] = {};  // the latest posted number applied, per urgent kind
  Nanoseconds last_torque = 0;                 // when the active external controller last got one (or became active)
  // External plant.
  Nanoseconds last_measured = 0;
  std::int64_t measured_tick = -1;
  std::int64_t source = 0;        // the run id the watchdog locked onto (0: none yet)
  Nanoseconds clock_origin = -1;  // monotonic time of step 0 (-1: set at the next step)
  bool send_zero_once = false;    // fault or stopped: command zero torque in this tick's record, once
  bool forces;                    // publish <NAME>_FORCES
  bool integrated = false;        // this tick ran the integrator
  double worst_s = 0.0;           // this instance's worst case per tick as it runs now (sim/work_bound.hpp)
  bool estop_this_tick = false;   // an estop was posted for this tick (a clear_estop in it is refused)
  Nanoseconds estop_at = 0;       // when the latest estop was applied (estop_dwell counts from there)
  WorkFigures refusal;            // the figures of the last switch the work bound refused

  const ControllerModel& active() const { return m.controllers[instance.active_controller()]; }
  bool external_active() const { return active().external; }
  bool mpc_active() const { return active().mpc; }
  // Held by a fallback (HoldBy) rather than the active controller.
  bool holds_by_fallback() const { return active().external || active().mpc; }
  bool task_space_active() const { return !active().pose_rules.frame.empty(); }
};

Runtime::Runtime(const Scene& scene, const BuildOptions& options) : Runtime(BuildDaemonModel(scene, options)) {}

Runtime::Runtime(std::shared_ptr<const DaemonModel> model) : model_(std::move(model)) {
  for (const InstanceModel& m : model_->instances) {
    // Each slot keeps its instance's model alive with the whole run's.
    slots_.push_back(std::make_unique<Slot>(std::shared_ptr<const InstanceModel>(model_, &m)));
    // lagranged plans on a thread of its own (daemon/mpc_worker.hpp): the tick only follows plans.
    Instance& inst = slots_.back()->instance;
    for (std::size_t k = 0; k < m.controllers.size(); ++k) {
      if (MpcController* c = inst.mpc_controller(k)) c->set_plan_inline(false);
    }
    On(*slots_.back(), ModeEvent::kStart, 0);
    slots_.back()->worst_s = WorkBoundOf(m, m.config.integrator, m.config.method, m.config.forces).tick_s();
    worst_total_s_ += slots_.back()->worst_s;
  }
}

Runtime::~Runtime() = default;
Instance& Runtime::instance(std::size_t i) { return slots_[i]->instance; }
InstanceChannels& Runtime::channels(std::size_t i) { return slots_[i]->channels; }
Mode Runtime::mode(std::size_t i) const { return slots_[i]->mode.mode; }

TickRecord Runtime::MakeRecord() const {
  TickRecord r;
  for (const auto& s : slots_) r.instances.emplace_back(s->m.num_dofs, PlanHorizon(s->instance));
  return r;
}

void Runtime::Tick(Nanoseconds now, TickRecord& record) {
  phase_shift_ = 0;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    Slot& s = *slots_[i];
    InstanceRecord& r = record.instances[i];
    const Nanoseconds start = clock_ != nullptr ? clock_->Now() : 0;
    r.fault = nullptr;
    r.commands_accepted = r.commands_rejected = 0;
    r.command_error = nullptr;
    r.num_verdicts = 0;
    r.plan.taken = false;
    TakeUrgent(s, now, r);
    TakeCommands(s, now, r);
    if (s.m.external_plant()) TakeMeasured(s, now);
    TakeSetpoint(s, now);
    TakePose(s, now);
    TakeTorque(s, now);
    TakePlan(s, now, r.plan);
    if (s.m.external_plant()) KeepPlantTime(s, now);
    ControlAndIntegrate(s);
    CheckHealth(s, r);
    Record(s, r);
    OfferState(s);
    r.compute = clock_ != nullptr ? clock_->Now() - start : 0;
  }
}

void Runtime::PostUrgent(std::size_t i, Urgent kind, std::int64_t request_id) {
  UrgentFlags& u = slots_[i]->channels.urgent;
  const auto k = static_cast<std::size_t>(kind);
  const std::uint64_t number = ++u.sequence;
  u.request_id[k][number % UrgentFlags::kIdSlots].store(request_id, std::memory_order_relaxed);
  u.posted[k].store(number, std::memory_order_release);
}

namespace {

void AddVerdict(InstanceRecord& r, std::int64_t request_id, CommandKind kind, const char* error,
                const WorkFigures& work = {}) {
  if (error) {
    ++r.commands_rejected;
    r.command_error = error;
  } else {
    ++r.commands_accepted;
  }
  if (r.num_verdicts < r.verdicts.size()) {
    r.verdicts[r.num_verdicts++] = {request_id, kind, error, error == kSwitchDoesNotFit ? work : WorkFigures{}};
  }
}

constexpr CommandKind kUrgentCommand[kNumUrgent] = {CommandKind::kEstop, CommandKind::kClearEstop, CommandKind::kReset};

// Whether no accepted input came for `timeout` since `last` (when the last one was sent).
bool TimedOut(Nanoseconds now, Nanoseconds last, Nanoseconds timeout) { return now - last > timeout; }

}  // namespace

const char* Runtime::On(Slot& s, ModeEvent event, Nanoseconds now, const char* fault, const char* plan_reason) {
  const bool task_space = s.task_space_active();
  const ModeContext context{
      .external_plant = s.m.external_plant(),
      .external_controller = s.external_active(),
      .task_space = task_space,
      .mpc = s.mpc_active(),
      .setpoints_timed_out = !task_space && s.streaming && TimedOut(now, s.last_setpoint, s.m.setpoint_timeout),
      .estop_this_tick = s.estop_this_tick,
      .estop_dwelling = s.mode.estop_latched && now - s.estop_at < s.m.estop_dwell,
      .fault = fault,
      .plan_reason = plan_reason};
  const ModeOutcome out = Transition(s.mode, event, context);
  const Mode before = s.mode.mode;
  s.mode = out.next;
  if (out.refused != nullptr || !out.entered) return out.refused;
  // An external plant commanded from its first fresh state: the scene's
  // trajectory starts there, not where the scene assumed the robot was.
  if (before == Mode::kWaiting && Commands(s.mode.mode)) s.instance.RestartTrajectory();
  // Entry actions.
  switch (s.mode.mode) {
    case Mode::kHold:  // where the hold began, at rest; a fallback starts afresh
      s.held.q = s.instance.q();
      s.held.qd.setZero();
      s.held.qdd.setZero();
      if (s.holds_by_fallback() && s.active().fallback.kind == HoldBy::Kind::kController) {
        s.instance.controller(s.active().fallback.controller).Reset();
      }
      break;
    case Mode::kStopped:  // the watchdog: the last good state kept, zero torque commanded once
    case Mode::kFault:    // the last good state kept, zero torque; nothing moves until reset
      s.in_use = nullptr;
      s.instance.Restore(s.good);
      s.energies = {s.instance.KineticEnergy(), s.instance.PotentialEnergy()};
      s.send_zero_once = s.mode.mode == Mode::kStopped || s.m.external_plant();
      break;
    case Mode::kWaiting:  // (re-)armed: a new source, and the plant's clock resumes from its first state
      s.clock_origin = -1;
      s.source = 0;
      break;
    case Mode::kRunning:
    case Mode::kPaused:
    case Mode::kEstop: break;
  }
  return nullptr;
}

// (urgent flags) => estop, clear_estop, reset: each kind posted since the
// last tick applied once, in the order the receiver posted them.
void Runtime::TakeUrgent(Slot& s, Nanoseconds now, InstanceRecord& r) {
  UrgentFlags& u = s.channels.urgent;
  std::uint64_t posted[kNumUrgent];
  for (std::size_t k = 0; k < kNumUrgent; ++k) posted[k] = u.posted[k].load(std::memory_order_acquire);
  const auto estop = static_cast<std::size_t>(Urgent::kEstop);
  s.estop_this_tick = posted[estop] > s.urgent_seen[estop];
  for (;;) {
    std::size_t next = kNumUrgent;
    for (std::size_t k = 0; k < kNumUrgent; ++k) {
      if (posted[k] > s.urgent_seen[k] && (next == kNumUrgent || posted[k] < posted[next])) next = k;
    }
    if (next == kNumUrgent) return;
    s.urgent_seen[next] = posted[next];
    const CommandKind kind = kUrgentCommand[next];
    const std::int64_t id = u.request_id[next][posted[next] % UrgentFlags::kIdSlots].load(std::memory_order_relaxed);
    AddVerdict(r, id, kind, Apply(s, kind, -1, nullptr, now));
  }
}

// (command queue) => mode, controller, gains, state.
void Runtime::TakeCommands(Slot& s, Nanoseconds now, InstanceRecord& r) {
  while (CommandMessage* c = s.channels.commands.Front()) {
    AddVerdict(r, c->request_id, c->kind, Apply(s, c->kind, c->controller, &c->gains, now, c), s.refusal);
    s.channels.commands.Pop();
  }
  s.channels.active_controller.store(static_cast<int>(s.instance.active_controller()), std::memory_order_release);
}

// Applies one command; returns why it was refused, or null.
const char* Runtime::Apply(Slot& s, CommandKind kind, int controller, const Gains* gains, Nanoseconds now,
                           const CommandMessage* message) {
  Instance& inst = s.instance;
  switch (kind) {
    case CommandKind::kSetIntegrator:
    case CommandKind::kSetEffect:
    case CommandKind::kSetMethod:
    case CommandKind::kSetForces:
      if (message == nullptr) return "unknown command";
      return ApplySwitch(s, *message);
    case CommandKind::kSwitchController:
      inst.SelectController(static_cast<std::size_t>(controller));
      if (s.external_active()) s.last_torque = now;  // its torque timeout counts from here
      return On(s, ModeEvent::kControllerSwitched, now);
    case CommandKind::kSetGains:
      if (!inst.controller(static_cast<std::size_t>(controller)).SetGains(*gains)) {
        return "the gains do not fit the controller";
      }
      return nullptr;
    case CommandKind::kReset:
      inst.Reset();
      inst.Save(s.good);
      s.streaming = false;
      s.pose_streaming = false;
      s.source = 0;
      if (s.external_active()) s.last_torque = now;
      return On(s, ModeEvent::kReset, now);
    case CommandKind::kPause: return On(s, ModeEvent::kPause, now);
    case CommandKind::kResume: {
      const char* refused = On(s, ModeEvent::kResume, now);
      // The setpoint timeout restarts; a torque's age never does (it is never
      // applied once older than torque_timeout: TakeTorque holds this tick).
      if (refused == nullptr) s.last_setpoint = now;
      return refused;
    }
    case CommandKind::kEstop: {
      const char* refused = On(s, ModeEvent::kEstop, now);
      if (refused == nullptr) s.estop_at = now;  // every estop brakes a dwell of its own
      return refused;
    }
    case CommandKind::kClearEstop: return On(s, ModeEvent::kClearEstop, now);
  }
  return "unknown command";
}

double Runtime::FreeFor(const Slot& s) const {
  return kTickBudgetFraction * period() - (worst_total_s_ - s.worst_s);
}

bool Runtime::Fits(Slot& s, const IntegratorConfig& config, Method method, bool forces) {
  const double worst = WorkBoundOf(s.m, config, method, forces).tick_s();
  if (worst <= FreeFor(s)) {  // costs of 0 (not measured) always fit
    worst_total_s_ += worst - s.worst_s;
    s.worst_s = worst;
    return true;
  }
  s.refusal = {worst_total_s_ - s.worst_s + worst, kTickBudgetFraction * period(),
               config.type == IntegratorType::kDormandPrince ? DefaultMaxSteps(s.m, config.substeps, FreeFor(s)) : -1};
  return false;
}

// Integrator, effect, method, forces: at this tick boundary, allocation-free
// (Instance built every combination before the loop).
const char* Runtime::ApplySwitch(Slot& s, const CommandMessage& c) {
  Instance& inst = s.instance;
  switch (c.kind) {
    case CommandKind::kSetIntegrator: {
      IntegratorConfig config = c.integrator;
      if (c.default_max_steps) {
        config.max_steps = inst.config().integrator.max_steps;
        // dopri5: the largest that fits at the costliest method, so a later method switch still fits.
        if (config.type == IntegratorType::kDormandPrince) {
          config.max_steps = std::max(1, DefaultMaxSteps(s.m, config.substeps, FreeFor(s)));
        }
      }
      if (const char* refused = inst.CheckIntegrator(config)) return refused;
      if (!Fits(s, config, inst.method(), s.forces)) return kSwitchDoesNotFit;
      return inst.SetIntegrator(config);
    }
    case CommandKind::kSetEffect: {
      if (const char* refused = inst.SetEffect(c.effect, c.on)) return refused;
      // V may have changed: the energies published while nothing steps
      // (paused, fault) follow, and the good state to return to after a
      // fault carries the re-based balance (it is the current state: commands
      // come between ticks, after the health check).
      s.energies = {inst.KineticEnergy(), inst.PotentialEnergy()};
      inst.Save(s.good);
      return nullptr;
    }
    case CommandKind::kSetMethod:
      if (!inst.instance_model().dynamics[static_cast<std::size_t>(c.method)]) return inst.SetMethod(c.method);
      if (!Fits(s, inst.integrator().config(), c.method, s.forces)) return kSwitchDoesNotFit;
      return inst.SetMethod(c.method);
    case CommandKind::kSetForces:
      if (!Fits(s, inst.integrator().config(), inst.method(), c.on)) return kSwitchDoesNotFit;
      s.forces = c.on;
      return nullptr;
    default: return "unknown command";
  }
}

// (measured mailbox, watchdog) => an external plant's (q, qd), or stopped.
void Runtime::TakeMeasured(Slot& s, Nanoseconds now) {
  const auto problem = static_cast<MeasuredProblem>(s.channels.measured_problem.exchange(0, std::memory_order_acq_rel));
  const MeasuredMessage* m = s.channels.measured.Take();
  if (s.mode.mode == Mode::kStopped || s.mode.mode == Mode::kFault) return;
  switch (problem) {
    case MeasuredProblem::kNone: break;
    case MeasuredProblem::kNotFinite: On(s, ModeEvent::kMeasuredNotFinite, now); break;
    case MeasuredProblem::kWrongSize: On(s, ModeEvent::kMeasuredWrongSize, now); break;
    case MeasuredProblem::kSecondSource: On(s, ModeEvent::kMeasuredSecondSource, now); break;
  }
  if (s.mode.mode == Mode::kStopped) return;
  if (m != nullptr) {
    if (s.source != 0 && m->run_id != s.source) {
      On(s, ModeEvent::kMeasuredSecondSource, now);
      return;
    }
    s.source = m->run_id;
    LockPhase(s, now, m->arrived);
    s.instance.SetMeasured(m->q, m->qd);
    s.measured_tick = m->tick;
    s.last_measured = std::min(now, m->sent);
    On(s, ModeEvent::kMeasuredArrived, now);
  }
  if (TimedOut(now, s.last_measured, s.m.state_timeout)) On(s, ModeEvent::kMeasuredTimedOut, now);
}

// (now) => an external plant's step count: the plant is real, so its time is
// the wall's, ticks the loop skipped included, while it is commanded; a
// stopped or waiting instance's clock stands, and resumes from there.
void Runtime::KeepPlantTime(Slot& s, Nanoseconds now) {
  const Nanoseconds period = ToNanoseconds(this->period());
  if (!Commands(s.mode.mode) || period <= 0) {
    s.clock_origin = -1;
    return;
  }
  if (s.clock_origin < 0) s.clock_origin = now - s.instance.steps() * period;
  s.instance.CatchUp((now - s.clock_origin) / period, this->period());
}

// (how long the state this tick takes had waited) => the loop's phase shift:
// a state that waited longer than phase_lag moves the next deadline earlier,
// one that waited less moves it later, by a quarter of the difference and at
// most kMaxPhaseStep a tick, so the loop settles phase_lag after the plant's
// states. A wait beyond a period (a late tick, a gap) is not a phase: ignored.
void Runtime::LockPhase(Slot& s, Nanoseconds now, Nanoseconds arrived) {
  const ExternalPlantConfig& e = *s.m.config.external;
  const Nanoseconds period = ToNanoseconds(this->period());
  const Nanoseconds wait = now - arrived;
  if (!e.phase_lock || phase_shift_ != 0 || arrived == kSentUnknown || wait < 0 || wait > period) return;
  const Nanoseconds error = wait - ToNanoseconds(e.phase_lag);
  phase_shift_ = std::clamp<Nanoseconds>(-error / 4, -kMaxPhaseStep, kMaxPhaseStep);
}

// (mailbox) => the streamed setpoint; its timeout. Stale setpoints never get
// here (the receiver refuses them) and so cannot cause hold: only the
// timeout does (daemon/mode_machine.hpp has the whole rule). A task-space
// controller follows poses: a setpoint the receiver let through before a
// switch to one is dropped, as TakePose drops a pose after a switch away.
void Runtime::TakeSetpoint(Slot& s, Nanoseconds now) {
  // Taken even when unused, so an old one never applies later.
  const SetpointMessage* msg = s.channels.setpoints.Take();
  if (s.task_space_active()) return;
  if (msg != nullptr) {
    s.streamed.q = msg->setpoint.q;
    s.streamed.qd = msg->setpoint.qd;
    s.streamed.qdd = msg->setpoint.qdd;
    s.streaming = true;
    s.last_setpoint = now;
    On(s, ModeEvent::kSetpointArrived, now);
  }
  if (s.streaming && TimedOut(now, s.last_setpoint, s.m.setpoint_timeout)) On(s, ModeEvent::kSetpointsTimedOut, now);
}

// (mailbox) => the active task-space controller's target: a move from the
// measured pose, or the pose at once. A pose brings a held instance back to
// running as a setpoint does; it latches (no stream, so no timeout).
//
// A target streamed with a twist (a feed-forward that would otherwise stay
// on) must come again within setpoint_timeout: when it does not, the target
// stops where it is, at rest, and the instance holds as for a joint stream.
void Runtime::TakePose(Slot& s, Nanoseconds now) {
  const PoseMessage* msg = s.channels.poses.Take();  // taken even when unused, so an old one never applies later
  TaskSpaceController* c = s.instance.task_space_controller(s.instance.active_controller());
  MpcController* mpc = c == nullptr ? s.instance.mpc_controller(s.instance.active_controller()) : nullptr;
  if (c == nullptr && (mpc == nullptr || !mpc->has_frame())) {  // switched away since the receiver checked it
    s.pose_streaming = false;
    return;
  }
  if (msg != nullptr) {
    const PoseSetpoint target{msg->target, msg->twist, Vector6d::Zero()};
    if (msg->duration > 0.0) {
      c != nullptr ? c->MoveTo(msg->target, msg->duration) : mpc->MoveTo(msg->target, msg->duration);
    } else {
      c != nullptr ? c->SetPoseTarget(target) : mpc->SetPoseTarget(target);
    }
    s.pose_streaming = msg->duration == 0.0 && !msg->twist.isZero(0.0);
    s.last_pose = now;
    On(s, ModeEvent::kPoseArrived, now);
  }
  if (s.pose_streaming && TimedOut(now, s.last_pose, s.m.setpoint_timeout)) {
    if (c != nullptr) {
      c->SetPoseTarget(PoseSetpoint{c->commanded().pose, Vector6d::Zero(), Vector6d::Zero()});
    } else {
      mpc->HoldPoseTarget(s.instance.t());
    }
    s.pose_streaming = false;
    On(s, ModeEvent::kPosesTimedOut, now);
  }
}

// (mailbox) => the external controller's torque; its timeout.
void Runtime::TakeTorque(Slot& s, Nanoseconds now) {
  const TorqueMessage* msg = s.channels.torques.Take();  // taken even when unused, so an old one never applies later
  if (!s.external_active()) return;
  if (msg != nullptr) {
    s.instance.external_controller(s.instance.active_controller())->SetTorque(msg->tau);
    s.last_torque = std::min(now, msg->sent);
    On(s, ModeEvent::kTorqueArrived, now);
  }
  if (TimedOut(now, s.last_torque, s.active().torque_timeout)) On(s, ModeEvent::kTorquesTimedOut, now);
}

// (mailbox) => the active mpc controller's plan; its horizon and status. A
// usable plan is followed from now (SetPolicy: a copy, no allocation); one
// whose solve failed is not, and hands the instance to the fallback with its
// status; so does the followed plan once its horizon has run out. A plan made
// before a reset or a switch (it starts after the instance's time) is dropped.
// A plan taken, followed or not, goes into the record (mpc_t).
void Runtime::TakePlan(Slot& s, Nanoseconds now, PlanRecord& record) {
  const MpcPolicy* plan = s.channels.mpc_plans.Take();  // taken even when unused, so an old one never applies later
  MpcController* c = s.instance.mpc_controller(s.instance.active_controller());
  if (c == nullptr) return;
  const double t = s.instance.t();
  if (plan != nullptr && plan->sequence > 0 && plan->start <= t + 0.5 * period()) {
    RecordPlan(*plan, record);
    if (!IsUsable(plan->status)) {
      On(s, ModeEvent::kPlanLapsed, now, nullptr, PlanFailure(plan->status));
      return;
    }
    c->SetPolicy(*plan);
    On(s, ModeEvent::kPlanArrived, now);
  }
  if (c->policy().sequence > 0 && !c->policy().LiveAt(t)) On(s, ModeEvent::kPlanLapsed, now, nullptr, kPlanRanOut);
}

// (state, setpoint) => the mpc optimiser's next start: the state the next
// tick begins from and the reference it follows at every knot (the streamed
// setpoint, held; else the scene's trajectory ahead, knot by knot), whatever
// the mode that commands the plant.
void Runtime::OfferState(Slot& s) {
  Instance& inst = s.instance;
  if (!s.mpc_active() || !Commands(s.mode.mode)) return;
  MpcController* c = inst.mpc_controller(inst.active_controller());
  MpcStateMessage& m = s.channels.mpc_state.back();
  m.t = inst.t();
  m.q = inst.q();
  m.qd = inst.qd();
  if (s.streaming) {
    m.q_ref.colwise() = s.streamed.q;
    m.qd_ref.colwise() = s.streamed.qd;
  } else {
    inst.SampleTrajectoryAhead(c->ddp_model()->dt(), m.q_ref, m.qd_ref);
  }
  if (c->has_frame()) m.pose = c->PoseReference(m.t, m.q);
  m.effects = inst.model().effects().flags();
  s.channels.mpc_state.Publish();
}

// (mode, setpoint) => control, integrate.
void Runtime::ControlAndIntegrate(Slot& s) {
  Instance& inst = s.instance;
  s.in_use = nullptr;
  s.integrated = !inst.external_plant() && Commands(s.mode.mode);
  const auto brake = [&] {
    s.brake_torque = (-s.m.brake.cwiseProduct(inst.qd())).cwiseMax(-s.m.torque_limits).cwiseMin(s.m.torque_limits);
    return inst.StepWithTorque(period(), s.brake_torque);
  };
  switch (s.mode.mode) {
    case Mode::kRunning:
      if (!s.streaming) inst.SampleTrajectory(s.current);
      s.in_use = s.streaming ? &s.streamed : &s.current;
      s.step_failure = inst.Step(period(), *s.in_use);
      break;
    case Mode::kHold: {
      s.in_use = &s.held;  // also published under zero-torque: where hold began
      if (s.m.config.on_timeout == TimeoutBehaviour::kZeroTorque) {
        s.step_failure = inst.StepWithTorque(period(), s.zero);
      } else if (!s.holds_by_fallback()) {
        s.step_failure = inst.Step(period(), s.held);
      } else if (s.active().fallback.kind == HoldBy::Kind::kController) {
        s.step_failure = inst.Step(period(), s.held, s.active().fallback.controller);
      } else {
        s.step_failure = brake();
      }
      break;
    }
    case Mode::kEstop: s.step_failure = brake(); break;
    case Mode::kPaused:
    case Mode::kFault:
    case Mode::kStopped:
    case Mode::kWaiting: s.step_failure = nullptr; break;
  }
}

// (step, state) => energies; fault (sim/health.hpp's rule), or remember
// the state as good. The energies computed here are the ones the record publishes.
void Runtime::CheckHealth(Slot& s, InstanceRecord& r) {
  if (!Commands(s.mode.mode)) return;  // nothing moved (or nothing was measured); the energies stand
  Instance& inst = s.instance;
  if (const char* fault = CheckStepHealth(inst, s.step_failure, s.m.max_energy, s.m.residual_bound, s.energies)) {
    On(s, ModeEvent::kFault, 0, fault);
    r.fault = fault;
    return;
  }
  inst.Save(s.good);
}

// (instance, mode) => record.
void Runtime::Record(Slot& s, InstanceRecord& r) {
  Instance& inst = s.instance;
  r.t = inst.t();
  r.q = inst.q();
  r.qd = inst.qd();
  r.qdd = inst.qdd();
  r.tau = inst.tau();
  r.q_des = s.in_use ? s.in_use->q : inst.q_des();
  r.qd_des = s.in_use ? s.in_use->qd : s.zero;
  r.kinetic_energy = s.energies.kinetic;
  r.potential_energy = s.energies.potential;
  r.controller = static_cast<int>(inst.active_controller());
  r.mode = s.mode.mode;
  r.reason = s.mode.reason;
  const TaskSpaceController* task = inst.task_space_controller(inst.active_controller());
  MpcController* mpc = task == nullptr ? inst.mpc_controller(inst.active_controller()) : nullptr;
  r.task = task != nullptr || (mpc != nullptr && mpc->has_frame());
  if (task != nullptr) {
    r.task_pose = task->pose();
    r.task_commanded = task->commanded().pose;
    r.task_error = task->pose_error();
    r.task_twist = task->twist();
  } else if (r.task) {  // an mpc controller's frame, reported as a task-space controller's
    mpc->MeasureTask(inst.t(), inst.q(), inst.qd(), r.task_pose, r.task_commanded, r.task_error, r.task_twist);
  }
  r.base = inst.floating_base();
  if (r.base) {
    r.base_q = inst.floating_q().head<kFreeFlyerNq>();
    r.base_v = inst.floating_v().head<kFreeFlyerNv>();
    r.base_motion = inst.ComputeBaseMotion();
  }
  r.publish_torque = inst.external_plant() && (Commands(s.mode.mode) || s.send_zero_once);
  r.state_tick = s.measured_tick;
  s.send_zero_once = false;
  // Telemetry and forces.
  r.telemetry = inst.config().telemetry;
  const EnergyBalance& balance = inst.energy_balance();
  r.energy_residual = balance.residual();
  r.residual_exceeded = s.m.residual_bound.on_exceed == OnResidualExceeded::kWarn && ResidualExceeds(inst, s.m.residual_bound);
  r.quadrature_bound = balance.quadrature_bound();
  r.work = balance.work();
  r.power = inst.power();
  r.integrated = s.integrated && s.mode.mode != Mode::kFault;  // a faulted step's work is of the step undone
  r.integrator_work = r.integrated ? inst.integrator_work() : IntegratorWork{};
  r.integrator = inst.integrator().config();
  r.external_plant = inst.external_plant();
  r.mujoco_integrator = s.m.config.mujoco ? std::optional(s.m.config.mujoco->integrator) : std::nullopt;
  r.method = inst.method();
  r.effects = inst.model().effects().flags();
  r.forces_on = s.forces;
  r.publish_forces = s.forces && s.mode.mode != Mode::kFault && s.mode.mode != Mode::kStopped;
  if (r.publish_forces) inst.ComputeForces(r.forces);
}

}  // namespace lagrange
