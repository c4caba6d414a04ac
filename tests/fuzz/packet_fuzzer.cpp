// libFuzzer target: what lagranged does with a packet on a setpoint, command,
// torque or measured-state channel before anything reaches the tick: the raw
// layout checks, decoding, the setpoint rules and the command rules
// (CheckCommand, with the switch commands' names and integrator numbers); and
// lagrangectl's checks of what lagranged publishes (status, telemetry, forces).
// Run with --write-seeds DIR to write valid packets as a starting corpus.

#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "controllers/factory.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/command_check.hpp"
#include "protocol/setpoint_check.hpp"
#include "protocol/wire.hpp"

namespace {

template <class T>
void WriteSeed(const std::string& path, const T& msg) {
  std::vector<char> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  std::ofstream(path, std::ios::binary).write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void WriteSeeds(const std::string& dir) {
  lagrange::setpoint_t s;
  s.utime = 1;
  s.num_dofs = 2;
  s.q = {0.5, 0.4};
  s.qd = {0.0, 1.0};
  s.qdd = {0.0, 0.0};
  WriteSeed(dir + "/setpoint", s);
  lagrange::command_t c{};
  c.utime = 1;
  c.request_id = 42;
  c.command = lagrange::command_t::SET_GAINS;
  c.controller = "pd";
  c.num_gains = 2;
  c.kp = {1.0, 2.0};
  c.kd = {0.1, 0.2};
  WriteSeed(dir + "/command", c);
  // The switch commands, one seed each: every field after the gains in use.
  c.controller = "";
  c.num_gains = 0;
  c.kp.clear();
  c.kd.clear();
  c.command = lagrange::command_t::SET_INTEGRATOR;
  c.setting = "dopri5";
  c.substeps = 2;
  c.rtol = 1e-6;
  c.atol = 1e-9;
  c.max_steps = 200;
  WriteSeed(dir + "/command_set_integrator", c);
  c.setting = "rk4";
  c.substeps = 4;
  c.rtol = c.atol = 0.0;
  c.max_steps = 0;
  WriteSeed(dir + "/command_set_integrator_defaults", c);
  c.substeps = 0;
  c.command = lagrange::command_t::SET_EFFECT;
  c.setting = "coriolis";
  c.on = 1;
  WriteSeed(dir + "/command_set_effect", c);
  c.command = lagrange::command_t::SET_METHOD;
  c.setting = "recursive";
  c.on = 0;
  WriteSeed(dir + "/command_set_method", c);
  c.command = lagrange::command_t::SET_FORCES;
  c.setting = "";
  c.on = 1;
  WriteSeed(dir + "/command_set_forces", c);
  lagrange::torque_t t;
  t.utime = 1;
  t.run_id = 7;
  t.sequence = 1;
  t.state_tick = 3;
  t.num_dofs = 2;
  t.tau = {1.0, -0.5};
  WriteSeed(dir + "/torque", t);
  lagrange::state_t st{};
  st.num_dofs = 2;
  for (auto* v : {&st.q, &st.qd, &st.qdd, &st.tau, &st.q_des, &st.qd_des}) v->assign(2, 0.25);
  st.controller = "computed-torque";
  WriteSeed(dir + "/state", st);
  lagrange::telemetry_t tm{};
  tm.run_id = 7;
  tm.integrator = "dopri5";
  tm.substeps = 1;
  tm.method = "closed-form";
  tm.error_estimate = 0.5;
  WriteSeed(dir + "/telemetry", tm);
  lagrange::forces_t f{};
  f.run_id = 7;
  f.gravity_on = f.coriolis_on = 1;
  f.num_dofs = 2;
  for (auto* v : {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.constraint, &f.disturbance,
                  &f.tau_cmd, &f.tau_applied}) {
    v->assign(2, 0.5);
  }
  f.constraint_on = 1;
  f.contacts_total = f.num_contacts = 1;  // a MuJoCo plant's contact
  f.contacts.resize(1);
  f.contacts[0].geom2 = 1;
  f.contacts[0].normal[2] = 1.0;
  f.contacts[0].force[2] = 30.0;
  WriteSeed(dir + "/forces", f);
  lagrange::status_t status{};
  status.num_instances = 1;
  status.instance_names = {"arm"};
  status.instance_modes = {0};
  status.instance_dofs = {2};
  status.instance_reasons = {""};
  status.instance_integrators = {"rk4 x4"};
  status.instance_methods = {"closed-form"};
  status.instance_effects = {"gravity,coriolis"};
  status.instance_forces = {1};
  status.num_joints = 2;
  status.joint_names = {"q1", "q2"};
  WriteSeed(dir + "/status", status);
  lagrange::pose_setpoint_t pose{};
  pose.frame = "tool0";
  pose.position[0] = 0.4;
  pose.position[2] = 0.5;
  pose.orientation[0] = 1.0;
  pose.duration = 2.0;
  WriteSeed(dir + "/pose_setpoint", pose);
  lagrange::task_state_t task{};
  task.frame = "tool0";
  task.controller = "operational-space";
  task.orientation[0] = task.orientation_des[0] = 1.0;
  WriteSeed(dir + "/task_state", task);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seeds") == 0) {
      WriteSeeds((*argv)[i + 1]);
      std::exit(0);
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace lagrange;
  static const SetpointRules rules{2, VectorXd::Constant(2, -3.1416), VectorXd::Constant(2, 3.1416)};
  static setpoint_t setpoint;  // reused, as in the receiver
  const SetpointVerdict v = CheckSetpoint(data, size, rules, setpoint);
  if (v.kind == SetpointVerdict::Kind::kAccepted) {
    // An accepted setpoint has the instance's size and finite, limited values.
    if (setpoint.num_dofs != 2 || setpoint.q.size() != 2) __builtin_trap();
    for (double x : setpoint.q) {
      if (!std::isfinite(x) || std::abs(x) > 3.1416) __builtin_trap();
    }
  }
  if (CheckCommandPacket(data, size) == WireCheck::kOk) {
    command_t command;
    if (command.decode(data, 0, static_cast<int>(size)) < 0) __builtin_trap();  // the check promised a decodable packet
  }
  // Torques (an external controller's) and measured states (an external plant's): the check
  // promises a packet that decodes to exactly its own size. (lcm-gen's decoders leave a
  // zero-length array's vector as it was: the receiver reads none, for it refuses any
  // num_dofs but the instance's n >= 1.)
  if (CheckTorquePacket(data, size) == WireCheck::kOk) {
    static torque_t torque;
    if (torque.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
    if (torque.num_dofs < 0 || (torque.num_dofs > 0 && static_cast<std::size_t>(torque.num_dofs) != torque.tau.size()))
      __builtin_trap();
  }
  if (CheckStatePacket(data, size) == WireCheck::kOk) {
    static state_t state;
    if (state.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
    if (state.num_dofs < 0 || (state.num_dofs > 0 && static_cast<std::size_t>(state.num_dofs) != state.q.size()))
      __builtin_trap();
  }
  // What lagrangectl reads: a packet that passes decodes to exactly its own size.
  if (CheckTelemetryPacket(data, size) == WireCheck::kOk) {
    telemetry_t telemetry;
    if (telemetry.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
  }
  if (CheckForcesPacket(data, size) == WireCheck::kOk) {
    forces_t forces;
    if (forces.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
    if (forces.num_dofs < 0 || forces.num_dofs > kMaxDofs ||
        static_cast<std::size_t>(forces.num_dofs) != forces.tau_applied.size())
      __builtin_trap();
  }
  // Pose setpoints: an accepted one is finite, unit, inside the workspace, for the frame.
  static PoseRules pose_rules = [] {
    PoseRules r;
    r.frame = "tool0";
    r.lower = Eigen::Vector3d(-1.0, -1.0, 0.0);
    r.upper = Eigen::Vector3d(1.0, 1.0, 1.5);
    return r;
  }();
  static pose_setpoint_t pose;  // reused, as in the receiver
  if (CheckPoseSetpoint(data, size, pose_rules, pose).kind == SetpointVerdict::Kind::kAccepted) {
    const Eigen::Map<const Eigen::Vector4d> q(pose.orientation);
    if (!(std::abs(q.norm() - 1.0) <= kUnitQuaternionTolerance)) __builtin_trap();
    for (int k = 0; k < 3; ++k) {
      if (!(pose.position[k] >= pose_rules.lower[k] && pose.position[k] <= pose_rules.upper[k])) __builtin_trap();
    }
    if (!pose.frame.empty() && pose.frame != "tool0") __builtin_trap();
    if (!std::isfinite(pose.duration) || pose.duration < 0.0) __builtin_trap();
  }
  if (CheckTaskStatePacket(data, size) == WireCheck::kOk) {
    task_state_t task;
    if (task.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
  }
  if (CheckStatusPacket(data, size) == WireCheck::kOk) {
    status_t status;
    if (status.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) __builtin_trap();
    const auto n = static_cast<std::size_t>(status.num_instances);
    if (status.instance_integrators.size() != n || status.instance_forces.size() != n) __builtin_trap();
  }
  static const CommandRules command_rules = [] {
    CommandRules r;
    r.instance = "arm";
    r.n = 2;
    r.controllers = {"pd", "none"};
    r.gain_counts = {2, 0};
    r.gains_per_task_axis = {false, false};
    // The bounds, checked as the simulator's rules check them (controllers' CheckGains).
    r.check_gains = [](std::size_t c, std::span<const double> kp, std::span<const double> kd) {
      static const GainBounds bounds[] = {
          GainBounds{false, VectorXd::Constant(2, 1e4), VectorXd::Constant(2, 1e2)}, GainBounds{}};
      return CheckGains(c == 0 ? ControllerType::kPd : ControllerType::kNone, kp, kd, bounds[c]);
    };
    r.integrator = IntegratorConfig{};  // the scene's: rk4 (set-integrator keeps its Newton settings and max_steps)
    return r;
  }();
  static command_t command;  // reused, as in the receiver
  const CommandVerdict c = CheckCommand(data, size, command_rules, 0, command);
  if (c.kind == CommandVerdict::Kind::kAccepted) {
    // An accepted command names a known code and, where it needs one, a known controller.
    if (command.command < command_t::SWITCH_CONTROLLER || command.command > command_t::SET_FORCES) __builtin_trap();
    const bool needs_controller = c.command == CommandKind::kSwitchController || c.command == CommandKind::kSetGains;
    if (needs_controller && (c.controller < 0 || c.controller > 1)) __builtin_trap();
    // A switch names what it parsed, and an integrator's numbers are ones the scene reader would take.
    if (c.command == CommandKind::kSetIntegrator &&
        (CheckIntegratorConfig(c.integrator) != nullptr || ToString(c.integrator.type) != command.setting)) {
      __builtin_trap();
    }
    if (c.command == CommandKind::kSetEffect && ToString(c.effect) != command.setting) __builtin_trap();
    if (c.command == CommandKind::kSetMethod && ToString(c.method) != command.setting) __builtin_trap();
    if (c.on != (command.on != 0)) __builtin_trap();
  }
  for (const char ch : c.reason) {
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) __builtin_trap();  // reasons are escaped
  }
  return 0;
}
