#pragma once
// Building and encoding lagrange messages in tests.

#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace lagrange::testing {

// The message as its bytes on the wire.
template <class T>
std::vector<std::uint8_t> Encode(const T& msg) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

// A setpoint for q sent at `utime` (µs); qd and qdd default to zeros.
inline setpoint_t MakeSetpoint(std::vector<double> q, std::int64_t utime, std::vector<double> qd = {},
                               std::vector<double> qdd = {}) {
  setpoint_t s;
  s.utime = utime;
  s.num_dofs = static_cast<int32_t>(q.size());
  s.qd = qd.empty() ? std::vector<double>(q.size(), 0.0) : std::move(qd);
  s.qdd = qdd.empty() ? std::vector<double>(q.size(), 0.0) : std::move(qdd);
  s.q = std::move(q);
  return s;
}

// A well-formed state of a two-joint instance under "pd" at `tick` (t = 1 ms
// per tick), every vector 0.25, from run `run_id`.
inline state_t MakeState(std::int64_t tick = 0, std::int64_t run_id = 0x1234) {
  state_t s{};
  s.run_id = run_id;
  s.tick = tick;
  s.t = 1e-3 * static_cast<double>(tick);
  s.num_dofs = 2;
  for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(2, 0.25);
  s.controller = "pd";
  return s;
}

// A command of `kind` (command_t's constants) sent at `utime` (µs); kd has
// kp's size in a well-formed SET_GAINS, but a test may make them differ.
inline command_t MakeCommand(int8_t kind, std::int64_t request_id, std::int64_t utime,
                             const std::string& controller = "", std::vector<double> kp = {},
                             std::vector<double> kd = {}) {
  command_t c{};
  c.utime = utime;
  c.request_id = request_id;
  c.command = kind;
  c.controller = controller;
  c.num_gains = static_cast<int32_t>(kp.size());
  c.kp = std::move(kp);
  c.kd = std::move(kd);
  return c;
}

// A well-formed command with every field in use: set-gains for "pd" on two
// joints (a string and two arrays, the layout the wire checks walk).
inline command_t MakeSetGainsCommand() {
  command_t c{};
  c.utime = 5;
  c.request_id = 1;
  c.command = command_t::SET_GAINS;
  c.controller = "pd";
  c.num_gains = 2;
  c.kp = {1.0, 2.0};
  c.kd = {0.1, 0.2};
  return c;
}

// The fields of a switch command (SET_INTEGRATOR, SET_EFFECT, SET_METHOD,
// SET_FORCES): the setting's name, the integrator's numbers (0: the
// default) and `on`.
struct SwitchFields {
  std::string setting;
  std::int32_t substeps = 0;
  double rtol = 0.0;
  double atol = 0.0;
  std::int32_t max_steps = 0;
  bool on = false;
};

// A switch command of `kind` sent at `utime` (µs), every field of command_t
// set (no controller, no gains).
inline command_t MakeSwitchCommand(int8_t kind, std::int64_t request_id, std::int64_t utime, SwitchFields f) {
  command_t c{};
  c.utime = utime;
  c.request_id = request_id;
  c.command = kind;
  c.num_gains = 0;
  c.setting = std::move(f.setting);
  c.substeps = f.substeps;
  c.rtol = f.rtol;
  c.atol = f.atol;
  c.max_steps = f.max_steps;
  c.on = f.on ? 1 : 0;
  return c;
}

}  // namespace lagrange::testing
