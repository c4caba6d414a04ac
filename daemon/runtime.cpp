#include "daemon/runtime.hpp"

#include "daemon/health.hpp"
#include "daemon/work_bound.hpp"

#include <algorithm>
#include <cmath>

namespace lagrange {

namespace {

SetpointMessage SetpointPrototype(int n) { return {Setpoint(n)}; }
TorqueMessage TorquePrototype(int n) { return {VectorXd::Zero(n)}; }
MeasuredMessage MeasuredPrototype(int n) { return {VectorXd::Zero(n), VectorXd::Zero(n)}; }

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

InstanceChannels::InstanceChannels(int n, std::size_t command_capacity)
    : setpoints(SetpointPrototype(n)),
      torques(TorquePrototype(n)),
      measured(MeasuredPrototype(n)),
      commands(command_capacity, CommandPrototype(n)) {}

InstanceRecord::InstanceRecord(int n)
    : q(VectorXd::Zero(n)),
      qd(VectorXd::Zero(n)),
      qdd(VectorXd::Zero(n)),
      tau(VectorXd::Zero(n)),
      q_des(VectorXd::Zero(n)),
      qd_des(VectorXd::Zero(n)),
      forces(n) {}

struct Runtime::Slot {
  explicit Slot(const InstanceConfig& c)
      : instance(c),
        channels(c.plant.num_dofs(), kCommandQueueCapacity),
        streamed(c.plant.num_dofs()),
        held(c.plant.num_dofs()),
        current(c.plant.num_dofs()),
        good(instance.MakeSaved()),
        zero(VectorXd::Zero(c.plant.num_dofs())),
        brake_torque(VectorXd::Zero(c.plant.num_dofs())),
        timeout(ToNanoseconds(c.setpoint_timeout)),
        max_energy(MaxEnergy(c)),
        energies{instance.KineticEnergy(), instance.PotentialEnergy()},
        state_timeout(c.external ? ToNanoseconds(c.external->state_timeout) : 0),
        forces(c.forces) {
    const int n = c.plant.num_dofs();
    const std::vector<ControllerType> types = instance.controller_types();
    const std::vector<const ControllerConfig*> configs = ControllerConfigs(c);
    for (std::size_t k = 0; k < types.size(); ++k) {
      const bool external = types[k] == ControllerType::kExternal;
      torque_timeout.push_back(external ? ToNanoseconds(configs[k]->external.torque_timeout) : 0);
      fallback.push_back(external ? Fallback(types, configs[k]->external.fallback) : -1);
    }
    if (c.external) {
      mode = Mode::kWaiting;
      reason = kWaitingForState;
    }
    if (c.estop_damping) {
      brake = *c.estop_damping;
    } else {
      MatrixXd M(n, n);
      instance.model().dynamics().ComputeMassMatrix(instance.model().data(), c.q0, M);
      brake = 20.0 * M.diagonal();  // a 50 ms time constant per joint
    }
  }

  Instance instance;
  InstanceChannels channels;
  Mode mode = Mode::kRunning;
  Mode before_pause = Mode::kRunning;
  const char* paused_reason = nullptr;  // the reason before the pause
  bool streaming = false;               // a streamed setpoint has been accepted since start or reset
  Nanoseconds last_setpoint = 0;        // when it was
  Setpoint streamed, held, current;
  Instance::Saved good;  // the last state that passed the health check
  VectorXd zero, brake, brake_torque;
  Nanoseconds timeout;
  double max_energy;
  // This tick's results, computed once and read by the health check and the record.
  Instance::StepFailure step_failure = nullptr;
  const Setpoint* in_use = nullptr;  // the setpoint this tick followed (running, hold), decided once for the record
  StepEnergies energies;
  std::uint64_t urgent_seen[kNumUrgent] = {};  // the latest posted number applied, per urgent kind
  const char* reason = nullptr;                // why the mode is not running
  bool estop_latched = false;                  // an estop not yet cleared: survives a fault, the watchdog and reset
  bool hold_on_arrival = false;                // external plant waiting after clear_estop: its first state holds
  // External controllers, by controller index: torque_timeout (0: not external)
  // and the fallback's index in hold (-1: the brake).
  std::vector<Nanoseconds> torque_timeout;
  std::vector<int> fallback;
  Nanoseconds last_torque = 0;  // when the active external controller last got one (or became active)
  // External plant.
  Nanoseconds state_timeout;
  Nanoseconds last_measured = 0;
  std::int64_t measured_tick = -1;
  std::int64_t source = 0;        // the run id the watchdog locked onto (0: none yet)
  Nanoseconds clock_origin = -1;  // monotonic time of step 0 (-1: set at the next step)
  bool send_zero_once = false;    // fault or stopped: command zero torque in this tick's record, once
  // Issue 14: switching and telemetry.
  bool forces;                           // publish <NAME>_FORCES
  std::array<double, 3> evaluation_s{};  // by Method: one evaluation's cost, s (0: unknown)
  bool integrated = false;               // this tick ran the integrator

  bool external_active() const { return torque_timeout[instance.active_controller()] > 0; }

  // The fallback of an external controller: the named one, "brake" (-1), or
  // the first gravity-compensation or computed-torque controller, else the brake.
  static int Fallback(const std::vector<ControllerType>& types, const std::optional<std::string>& name) {
    for (std::size_t k = 0; k < types.size(); ++k) {
      const bool named = name && *name != "brake" && ToString(types[k]) == *name;
      const bool model_based =
          !name && (types[k] == ControllerType::kGravityCompensation || types[k] == ControllerType::kComputedTorque);
      if (named || model_based) return static_cast<int>(k);
    }
    return -1;
  }
};

Runtime::Runtime(const Scene& scene) : period_(scene.period) {
  for (const InstanceConfig& c : scene.instances) {
    slots_.push_back(std::make_unique<Slot>(c));
    if (slots_.back()->external_active()) EnterHold(*slots_.back(), kNoTorqueYet);  // until the first torque
  }
}

Runtime::~Runtime() = default;
Instance& Runtime::instance(std::size_t i) { return slots_[i]->instance; }
InstanceChannels& Runtime::channels(std::size_t i) { return slots_[i]->channels; }
Mode Runtime::mode(std::size_t i) const { return slots_[i]->mode; }

TickRecord Runtime::MakeRecord() const {
  TickRecord r;
  for (const auto& s : slots_) r.instances.emplace_back(s->instance.num_dofs());
  return r;
}

void Runtime::SetEvaluationCosts(std::size_t i, const std::array<double, 3>& seconds) {
  slots_[i]->evaluation_s = seconds;
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
    TakeUrgent(s, now, r);
    TakeCommands(s, now, r);
    if (s.instance.external_plant()) TakeMeasured(s, now);
    TakeSetpoint(s, now);
    TakeTorque(s, now);
    if (s.instance.external_plant()) KeepPlantTime(s, now);
    ControlAndIntegrate(s);
    CheckHealth(s, r);
    Record(s, r);
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

void AddVerdict(InstanceRecord& r, std::int64_t request_id, CommandKind kind, const char* error) {
  if (error) {
    ++r.commands_rejected;
    r.command_error = error;
  } else {
    ++r.commands_accepted;
  }
  if (r.num_verdicts < r.verdicts.size()) r.verdicts[r.num_verdicts++] = {request_id, kind, error};
}

constexpr CommandKind kUrgentCommand[kNumUrgent] = {CommandKind::kEstop, CommandKind::kClearEstop, CommandKind::kReset};

}  // namespace

// (urgent flags) => estop, clear_estop, reset: each kind posted since the
// last tick applied once, in the order the receiver posted them.
void Runtime::TakeUrgent(Slot& s, Nanoseconds now, InstanceRecord& r) {
  UrgentFlags& u = s.channels.urgent;
  std::uint64_t posted[kNumUrgent];
  for (std::size_t k = 0; k < kNumUrgent; ++k) posted[k] = u.posted[k].load(std::memory_order_acquire);
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
    AddVerdict(r, c->request_id, c->kind, Apply(s, c->kind, c->controller, &c->gains, now, c));
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
    case CommandKind::kSwitchController: {
      const bool torque_hold = s.mode == Mode::kHold && (s.reason == kTorquesTimedOut || s.reason == kNoTorqueYet);
      inst.SelectController(static_cast<std::size_t>(controller));
      if (s.external_active()) {
        Activated(s, now);
      } else if (torque_hold) {
        RunOrHold(s, now);  // the torque stream no longer matters: the setpoints decide
      }
      return nullptr;
    }
    case CommandKind::kSetGains:
      if (!inst.controller(static_cast<std::size_t>(controller)).SetGains(*gains)) {
        return "the gains do not fit the controller";
      }
      return nullptr;
    case CommandKind::kReset:
      inst.Reset();
      inst.Save(s.good);
      s.streaming = false;
      s.source = 0;
      if (inst.external_plant()) {  // re-armed; the first fresh state runs it (or brakes it, estop latched)
        s.clock_origin = -1;
        s.hold_on_arrival = false;
        s.mode = Mode::kWaiting;
        s.reason = s.estop_latched ? kWaitingEstopLatched : kWaitingForState;
      } else if (s.estop_latched) {  // reset keeps an estop, also one a fault interrupted
        s.mode = Mode::kEstop;
        s.reason = kEstopped;
      } else {
        s.mode = Mode::kRunning;
        s.reason = nullptr;
        if (s.external_active()) Activated(s, now);
      }
      return nullptr;
    case CommandKind::kPause:
      if (inst.external_plant()) return "pause: an external plant keeps moving and cannot be frozen (estop brakes it)";
      if (s.mode != Mode::kRunning && s.mode != Mode::kHold) return "pause: the instance is not running or holding";
      s.before_pause = s.mode;
      s.mode = Mode::kPaused;
      s.paused_reason = s.reason;
      s.reason = kPausedByCommand;
      return nullptr;
    case CommandKind::kResume:
      if (s.mode != Mode::kPaused) return "resume: the instance is not paused";
      s.mode = s.before_pause;
      s.reason = s.paused_reason;
      s.last_setpoint = now;  // the setpoint timeout restarts; a torque's age never does (it is never
                              // applied once older than torque_timeout: TakeTorque holds this tick)
      return nullptr;
    case CommandKind::kEstop:
      if (s.mode == Mode::kFault) return "estop: the instance is faulted (frozen); reset it";
      s.estop_latched = true;
      s.hold_on_arrival = false;
      // An external plant that commands nothing keeps its mode; its first
      // fresh state after re-arming then brakes instead of running.
      if (s.mode == Mode::kStopped) return nullptr;
      if (s.mode == Mode::kWaiting) {
        s.reason = kWaitingEstopLatched;
        return nullptr;
      }
      s.mode = Mode::kEstop;
      s.reason = kEstopped;
      return nullptr;
    case CommandKind::kClearEstop:
      if (s.mode == Mode::kStopped) {  // an external plant's watchdog, re-armed; a latched estop stays
        s.clock_origin = -1;           // its trajectory resumes where it stopped
        s.mode = Mode::kWaiting;
        s.reason = s.estop_latched ? kWaitingEstopLatched : kWaitingForState;
        s.source = 0;
        return nullptr;
      }
      if (s.mode == Mode::kWaiting && s.estop_latched) {  // the estop cleared: the first state holds
        s.estop_latched = false;
        s.hold_on_arrival = true;
        s.reason = kWaitingForState;
        return nullptr;
      }
      if (s.mode != Mode::kEstop) return "clear_estop: the instance is not in an emergency stop";
      s.estop_latched = false;
      EnterHold(s, kLeftEstop);
      return nullptr;
  }
  return "unknown command";
}

// Whether `config` by `method` fits the period at the measured cost (as
// lagranged checks a scene before the loop); true when the cost is unknown.
bool Runtime::Fits(const Slot& s, const IntegratorConfig& config, Method method) const {
  const double cost = s.evaluation_s[static_cast<std::size_t>(method)];
  if (cost <= 0.0 || s.instance.external_plant()) return true;
  return static_cast<double>(WorstCaseEvaluations(config, s.instance.num_dofs())) * cost <= period_;
}

// Integrator, effect, method, forces: at this tick boundary, allocation-free
// (Instance built every combination before the loop).
const char* Runtime::ApplySwitch(Slot& s, const CommandMessage& c) {
  Instance& inst = s.instance;
  switch (c.kind) {
    case CommandKind::kSetIntegrator: {
      IntegratorConfig config = c.integrator;
      if (c.default_max_steps) config.max_steps = inst.config().integrator.max_steps;
      const double cost = s.evaluation_s[static_cast<std::size_t>(inst.method())];
      if (c.default_max_steps && config.type == IntegratorType::kDormandPrince && cost > 0.0) {
        // The largest max_steps that fits: s·(1 + 6·max_steps) + 1 evaluations in the period.
        const double fit = LargestMaxStepsThatFit(period_ / cost, config.substeps);
        if (fit < 1.0) return kSwitchDoesNotFit;
        config.max_steps = static_cast<int>(std::min<double>(config.max_steps, fit));
      }
      if (!Fits(s, config, inst.method())) return kSwitchDoesNotFit;
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
      if (!Fits(s, inst.integrator().config(), c.method)) return kSwitchDoesNotFit;
      return inst.SetMethod(c.method);
    case CommandKind::kSetForces: s.forces = c.on; return nullptr;
    default: return "unknown command";
  }
}

// (leaving a mode that ignored the setpoints) => running, or hold when the
// streamed setpoint it would follow has already timed out.
void Runtime::RunOrHold(Slot& s, Nanoseconds now) {
  if (s.streaming && now - s.last_setpoint > s.timeout) return EnterHold(s, kSetpointsTimedOut);
  s.mode = Mode::kRunning;
  s.reason = nullptr;
}

// (an external controller became active) => hold until its first torque.
void Runtime::Activated(Slot& s, Nanoseconds now) {
  s.last_torque = now;
  if (s.mode == Mode::kRunning || s.mode == Mode::kHold) EnterHold(s, kNoTorqueYet);
}

// (measured mailbox, watchdog) => an external plant's (q, qd), or stopped.
void Runtime::TakeMeasured(Slot& s, Nanoseconds now) {
  const auto problem = static_cast<MeasuredProblem>(s.channels.measured_problem.exchange(0, std::memory_order_acq_rel));
  const MeasuredMessage* m = s.channels.measured.Take();
  if (s.mode == Mode::kStopped || s.mode == Mode::kFault) return;
  switch (problem) {
    case MeasuredProblem::kNone: break;
    case MeasuredProblem::kNotFinite: return Stop(s, kMeasuredNotFinite);
    case MeasuredProblem::kWrongSize: return Stop(s, kMeasuredWrongSize);
    case MeasuredProblem::kSecondSource:
      if (s.mode != Mode::kWaiting) return Stop(s, kMeasuredSecondSource);  // nothing is locked while waiting
      break;
  }
  if (m != nullptr) {
    if (s.source != 0 && m->run_id != s.source) return Stop(s, kMeasuredSecondSource);
    s.source = m->run_id;
    LockPhase(s, now, m->arrived);
    s.instance.SetMeasured(m->q, m->qd);
    s.measured_tick = m->tick;
    s.last_measured = std::min(now, m->sent);
    if (s.mode == Mode::kWaiting) {
      if (s.estop_latched) {
        s.mode = Mode::kEstop;
        s.reason = kEstopped;
      } else if (s.hold_on_arrival) {
        EnterHold(s, kLeftEstop);
      } else {
        RunOrHold(s, now);
      }
      s.hold_on_arrival = false;
    }
  }
  if (s.mode != Mode::kWaiting && now - s.last_measured > s.state_timeout) Stop(s, kMeasuredTimedOut);
}

// (now) => an external plant's step count: the plant is real, so its time is
// the wall's, ticks the loop skipped included, while it is commanded; a
// stopped or waiting instance's clock stands, and resumes from there.
void Runtime::KeepPlantTime(Slot& s, Nanoseconds now) {
  const bool commanding = s.mode == Mode::kRunning || s.mode == Mode::kHold || s.mode == Mode::kEstop;
  const Nanoseconds period = ToNanoseconds(period_);
  if (!commanding || period <= 0) {
    s.clock_origin = -1;
    return;
  }
  if (s.clock_origin < 0) s.clock_origin = now - s.instance.steps() * period;
  s.instance.CatchUp((now - s.clock_origin) / period, period_);
}

// (how long the state this tick takes had waited) => the loop's phase shift:
// a state that waited longer than phase_lag moves the next deadline earlier,
// one that waited less moves it later, by a quarter of the difference and at
// most kMaxPhaseStep a tick, so the loop settles phase_lag after the plant's
// states. A wait beyond a period (a late tick, a gap) is not a phase: ignored.
void Runtime::LockPhase(Slot& s, Nanoseconds now, Nanoseconds arrived) {
  const ExternalPlantConfig& e = *s.instance.config().external;
  const Nanoseconds period = ToNanoseconds(period_);
  const Nanoseconds wait = now - arrived;
  if (!e.phase_lock || phase_shift_ != 0 || arrived == kSentUnknown || wait < 0 || wait > period) return;
  const Nanoseconds error = wait - ToNanoseconds(e.phase_lag);
  phase_shift_ = std::clamp<Nanoseconds>(-error / 4, -kMaxPhaseStep, kMaxPhaseStep);
}

// (watchdog) => stopped: the last good state is kept, zero torque is commanded once.
void Runtime::Stop(Slot& s, const char* why) {
  s.mode = Mode::kStopped;
  s.reason = why;
  s.in_use = nullptr;
  s.instance.Restore(s.good);
  s.energies = {s.instance.KineticEnergy(), s.instance.PotentialEnergy()};
  s.send_zero_once = true;
}

// (mailbox) => streamed setpoint, hold on staleness or timeout.
void Runtime::TakeSetpoint(Slot& s, Nanoseconds now) {
  // Stale setpoints never get here (the receiver refuses them) and so cannot
  // cause hold: only the timeout does, while no fresh setpoint arrives. Under
  // an external controller the torques decide running and hold instead.
  const bool torques_decide = s.external_active();
  if (const SetpointMessage* m = s.channels.setpoints.Take()) {
    s.streamed.q = m->setpoint.q;
    s.streamed.qd = m->setpoint.qd;
    s.streamed.qdd = m->setpoint.qdd;
    s.streaming = true;
    s.last_setpoint = now;
    if (s.mode == Mode::kHold && !torques_decide) {
      s.mode = Mode::kRunning;
      s.reason = nullptr;
    }
  }
  if (!torques_decide && s.mode == Mode::kRunning && s.streaming && now - s.last_setpoint > s.timeout) {
    EnterHold(s, kSetpointsTimedOut);
  }
}

// (mailbox) => the external controller's torque; hold on timeout.
void Runtime::TakeTorque(Slot& s, Nanoseconds now) {
  const TorqueMessage* m = s.channels.torques.Take();  // taken even when unused, so an old one never applies later
  if (!s.external_active()) return;
  if (m != nullptr) {
    s.instance.external_controller(s.instance.active_controller())->SetTorque(m->tau);
    s.last_torque = std::min(now, m->sent);
    if (s.mode == Mode::kHold) {
      s.mode = Mode::kRunning;
      s.reason = nullptr;
    }
  }
  if (s.mode == Mode::kRunning && now - s.last_torque > s.torque_timeout[s.instance.active_controller()]) {
    EnterHold(s, kTorquesTimedOut);
  }
}

void Runtime::EnterHold(Slot& s, const char* why) {
  s.mode = Mode::kHold;
  s.reason = why;
  s.held.q = s.instance.q();
  s.held.qd.setZero();
  s.held.qdd.setZero();
  if (s.external_active()) {
    const int fallback = s.fallback[s.instance.active_controller()];
    if (fallback >= 0) s.instance.controller(static_cast<std::size_t>(fallback)).Reset();
  }
}

// (mode, setpoint) => control, integrate.
void Runtime::ControlAndIntegrate(Slot& s) {
  Instance& inst = s.instance;
  const InstanceConfig& c = inst.config();
  s.in_use = nullptr;
  s.integrated =
      !inst.external_plant() && (s.mode == Mode::kRunning || s.mode == Mode::kHold || s.mode == Mode::kEstop);
  const auto brake = [&] {
    s.brake_torque = (-s.brake.cwiseProduct(inst.qd())).cwiseMax(-c.torque_limits).cwiseMin(c.torque_limits);
    return inst.StepWithTorque(period_, s.brake_torque);
  };
  switch (s.mode) {
    case Mode::kRunning:
      if (!s.streaming) inst.SampleTrajectory(s.current);
      s.in_use = s.streaming ? &s.streamed : &s.current;
      s.step_failure = inst.Step(period_, *s.in_use);
      break;
    case Mode::kHold: {
      s.in_use = &s.held;  // also published under zero-torque: where hold began
      if (c.on_timeout == TimeoutBehaviour::kZeroTorque) {
        s.step_failure = inst.StepWithTorque(period_, s.zero);
        break;
      }
      const int fallback = s.external_active() ? s.fallback[inst.active_controller()] : -2;
      s.step_failure = fallback == -1  ? brake()
                       : fallback >= 0 ? inst.Step(period_, s.held, static_cast<std::size_t>(fallback))
                                       : inst.Step(period_, s.held);
      break;
    }
    case Mode::kEstop: s.step_failure = brake(); break;
    case Mode::kPaused:
    case Mode::kFault:
    case Mode::kStopped:
    case Mode::kWaiting: s.step_failure = nullptr; break;
  }
}

// (step, state) => energies; fault (daemon/health.hpp's rule), or remember
// the state as good. The energies computed here are the ones the record publishes.
void Runtime::CheckHealth(Slot& s, InstanceRecord& r) {
  Instance& inst = s.instance;
  if (s.mode == Mode::kFault || s.mode == Mode::kPaused || s.mode == Mode::kStopped || s.mode == Mode::kWaiting) {
    return;  // nothing moved (or nothing was measured); the energies stand
  }
  if (const char* fault = CheckStepHealth(inst, s.step_failure, s.max_energy, s.energies)) return Fault(s, fault, r);
  inst.Save(s.good);
}

void Runtime::Fault(Slot& s, const char* why, InstanceRecord& r) {
  s.mode = Mode::kFault;
  s.reason = why;
  s.in_use = nullptr;
  s.instance.Restore(s.good);
  s.energies = {s.instance.KineticEnergy(), s.instance.PotentialEnergy()};  // of the restored, good state
  s.send_zero_once = s.instance.external_plant();
  r.fault = why;
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
  r.mode = s.mode;
  r.reason = s.reason;
  const bool commanding = s.mode == Mode::kRunning || s.mode == Mode::kHold || s.mode == Mode::kEstop;
  r.publish_torque = inst.external_plant() && (commanding || s.send_zero_once);
  r.state_tick = s.measured_tick;
  s.send_zero_once = false;
  // Telemetry and forces.
  r.telemetry = inst.config().telemetry;
  const EnergyBalance& balance = inst.energy_balance();
  r.energy_residual = balance.residual();
  r.quadrature_bound = balance.quadrature_bound();
  r.work = balance.work();
  r.power = inst.power();
  r.integrated = s.integrated && s.mode != Mode::kFault;  // a faulted step's work is of the step undone
  r.integrator_work = r.integrated ? inst.integrator().work() : IntegratorWork{};
  r.integrator = inst.integrator().config();
  r.external_plant = inst.external_plant();
  r.method = inst.method();
  r.effects = inst.model().effects().flags();
  r.forces_on = s.forces;
  r.publish_forces = s.forces && s.mode != Mode::kFault && s.mode != Mode::kStopped;
  if (r.publish_forces) inst.ComputeForces(r.forces);
}

}  // namespace lagrange
