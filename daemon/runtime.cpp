#include "daemon/runtime.hpp"

#include <cmath>

namespace lagrange {

std::string_view ToString(Mode mode) {
  switch (mode) {
    case Mode::kRunning: return "running";
    case Mode::kHold: return "hold";
    case Mode::kFault: return "fault";
    case Mode::kPaused: return "paused";
    case Mode::kEstop: return "estop";
  }
  return "?";
}

namespace {

SetpointMessage SetpointPrototype(int n) { return {Setpoint(n), false}; }

CommandMessage CommandPrototype(int n) {
  CommandMessage c;
  c.gains = {VectorXd::Zero(n), VectorXd::Zero(n)};
  return c;
}

double Reach(const PlantSpec& plant) {
  return std::visit(
      [](const auto& p) -> double {
        using P = std::decay_t<decltype(p)>;
        if constexpr (std::is_same_v<P, PendulumParams>) return p.m * p.g * p.L;
        else if constexpr (std::is_same_v<P, Arm2Params>) return (p.m1 + p.m2) * p.g * (p.L1 + p.L2);
        else if constexpr (std::is_same_v<P, CartPoleParams>) return (p.mc + p.mp) * p.g * 2.0 * p.l;
        else {
          double mass = 0.0, length = 0.0;
          for (const ChainLink& l : p.links) {
            mass += l.m;
            length += l.L;
          }
          return mass * p.g * length;
        }
      },
      plant.params);
}

}  // namespace

double DefaultMaxEnergy(const PlantSpec& plant) { return 1000.0 * (1.0 + Reach(plant)); }

InstanceChannels::InstanceChannels(int n, std::size_t command_capacity)
    : setpoints(SetpointPrototype(n)), commands(command_capacity, CommandPrototype(n)) {}

InstanceRecord::InstanceRecord(int n)
    : q(VectorXd::Zero(n)), qd(VectorXd::Zero(n)), qdd(VectorXd::Zero(n)), tau(VectorXd::Zero(n)),
      q_des(VectorXd::Zero(n)), qd_des(VectorXd::Zero(n)) {}

struct Runtime::Slot {
  explicit Slot(const InstanceConfig& c)
      : instance(c),
        channels(c.plant.num_dofs(), 32),
        streamed(c.plant.num_dofs()),
        held(c.plant.num_dofs()),
        current(c.plant.num_dofs()),
        good(instance.MakeSaved()),
        zero(VectorXd::Zero(c.plant.num_dofs())),
        brake_torque(VectorXd::Zero(c.plant.num_dofs())),
        timeout(static_cast<Nanoseconds>(c.setpoint_timeout * 1e9)),
        max_energy(c.max_energy.value_or(DefaultMaxEnergy(c.plant))) {
    const int n = c.plant.num_dofs();
    if (c.estop_damping) {
      brake = *c.estop_damping;
    } else {
      MatrixXd M(n, n);
      instance.model().dynamics().ComputeMassMatrix(c.q0, M);
      brake = 20.0 * M.diagonal();  // a 50 ms time constant per joint
    }
  }

  Instance instance;
  InstanceChannels channels;
  Mode mode = Mode::kRunning;
  Mode before_pause = Mode::kRunning;
  bool streaming = false;           // a streamed setpoint has been accepted since start or reset
  Nanoseconds last_setpoint = 0;    // when it was
  Setpoint streamed, held, current;
  Instance::Saved good;             // the last state that passed the health check
  VectorXd zero, brake, brake_torque;
  Nanoseconds timeout;
  double max_energy;
  bool stepped_ok = true;
};

Runtime::Runtime(const Scene& scene) : period_(scene.period) {
  for (const InstanceConfig& c : scene.instances) slots_.push_back(std::make_unique<Slot>(c));
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

void Runtime::Tick(Nanoseconds now, TickRecord& record) {
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    Slot& s = *slots_[i];
    InstanceRecord& r = record.instances[i];
    r.fault = nullptr;
    r.commands_accepted = r.commands_rejected = 0;
    r.command_error = nullptr;
    TakeCommands(s, now, r);
    TakeSetpoint(s, now);
    ControlAndIntegrate(s);
    CheckHealth(s, s.stepped_ok, r);
    Record(s, r);
  }
}

// (commands) => mode, controller, gains, state.
void Runtime::TakeCommands(Slot& s, Nanoseconds now, InstanceRecord& r) {
  while (CommandMessage* c = s.channels.commands.Front()) {
    const char* error = nullptr;
    switch (c->kind) {
      case CommandKind::kSwitchController:
        s.instance.SelectController(static_cast<std::size_t>(c->controller));
        break;
      case CommandKind::kSetGains:
        if (!s.instance.controller(static_cast<std::size_t>(c->controller)).SetGains(c->gains)) {
          error = "the gains do not fit the controller";
        }
        break;
      case CommandKind::kReset:
        s.instance.Reset();
        s.instance.Save(s.good);
        s.streaming = false;
        if (s.mode != Mode::kEstop) s.mode = Mode::kRunning;
        break;
      case CommandKind::kPause:
        if (s.mode == Mode::kRunning || s.mode == Mode::kHold) {
          s.before_pause = s.mode;
          s.mode = Mode::kPaused;
        } else {
          error = "pause: the instance is not running or holding";
        }
        break;
      case CommandKind::kResume:
        if (s.mode == Mode::kPaused) {
          s.mode = s.before_pause;
          s.last_setpoint = now;  // the setpoint timeout restarts
        } else {
          error = "resume: the instance is not paused";
        }
        break;
      case CommandKind::kEstop:
        if (s.mode == Mode::kFault) error = "estop: the instance is faulted (frozen); reset it";
        else s.mode = Mode::kEstop;
        break;
      case CommandKind::kClearEstop:
        if (s.mode == Mode::kEstop) EnterHold(s);
        else error = "clear_estop: the instance is not in an emergency stop";
        break;
    }
    if (error) {
      ++r.commands_rejected;
      r.command_error = error;
    } else {
      ++r.commands_accepted;
    }
    s.channels.commands.Pop();
  }
  s.channels.active_controller.store(static_cast<int>(s.instance.active_controller()), std::memory_order_release);
}

// (mailbox) => streamed setpoint, hold on staleness or timeout.
void Runtime::TakeSetpoint(Slot& s, Nanoseconds now) {
  if (const SetpointMessage* m = s.channels.setpoints.Take()) {
    if (m->stale) {
      if (s.mode == Mode::kRunning && s.streaming) EnterHold(s);
    } else {
      s.streamed.q = m->setpoint.q;
      s.streamed.qd = m->setpoint.qd;
      s.streamed.qdd = m->setpoint.qdd;
      s.streaming = true;
      s.last_setpoint = now;
      if (s.mode == Mode::kHold) s.mode = Mode::kRunning;
    }
  }
  if (s.mode == Mode::kRunning && s.streaming && now - s.last_setpoint > s.timeout) EnterHold(s);
}

void Runtime::EnterHold(Slot& s) {
  s.mode = Mode::kHold;
  s.held.q = s.instance.q();
  s.held.qd.setZero();
  s.held.qdd.setZero();
}

// (mode, setpoint) => control, integrate.
void Runtime::ControlAndIntegrate(Slot& s) {
  Instance& inst = s.instance;
  const InstanceConfig& c = inst.config();
  switch (s.mode) {
    case Mode::kRunning:
      if (!s.streaming) inst.SampleTrajectory(s.current);
      s.stepped_ok = inst.Step(period_, s.streaming ? s.streamed : s.current);
      break;
    case Mode::kHold:
      s.stepped_ok = c.on_timeout == TimeoutBehaviour::kHoldPosition ? inst.Step(period_, s.held)
                                                                     : inst.StepWithTorque(period_, s.zero);
      break;
    case Mode::kEstop:
      s.brake_torque = (-s.brake.cwiseProduct(inst.qd())).cwiseMax(-c.torque_limits).cwiseMin(c.torque_limits);
      s.stepped_ok = inst.StepWithTorque(period_, s.brake_torque);
      break;
    case Mode::kPaused:
    case Mode::kFault: s.stepped_ok = true; break;
  }
}

// (state) => fault, or remember it as good.
void Runtime::CheckHealth(Slot& s, bool stepped_ok, InstanceRecord& r) {
  if (s.mode == Mode::kFault || s.mode == Mode::kPaused) return;
  Instance& inst = s.instance;
  if (!stepped_ok) {
    Fault(s, inst.tau().allFinite() ? "the integrator failed its tolerance" : "the controller's output was not finite", r);
    return;
  }
  if (!inst.q().allFinite() || !inst.qd().allFinite() || !inst.qdd().allFinite()) {
    Fault(s, "the state became non-finite", r);
    return;
  }
  const double energy = inst.KineticEnergy() + inst.PotentialEnergy();
  if (!std::isfinite(energy) || std::abs(energy) > s.max_energy) {
    Fault(s, "the energy left its bound (max_energy)", r);
    return;
  }
  inst.Save(s.good);
}

void Runtime::Fault(Slot& s, const char* why, InstanceRecord& r) {
  s.mode = Mode::kFault;
  s.instance.Restore(s.good);
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
  const Setpoint& sp = s.mode == Mode::kHold ? s.held : (s.streaming ? s.streamed : s.current);
  r.q_des = s.mode == Mode::kRunning || s.mode == Mode::kHold ? sp.q : inst.q_des();
  r.qd_des = s.mode == Mode::kRunning || s.mode == Mode::kHold ? sp.qd : s.zero;
  r.kinetic_energy = inst.KineticEnergy();
  r.potential_energy = inst.PotentialEnergy();
  r.controller = static_cast<int>(inst.active_controller());
  r.mode = s.mode;
}

}  // namespace lagrange
