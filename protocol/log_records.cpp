#include "protocol/log_records.hpp"

#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <algorithm>
#include <cstring>
#include <map>
#include <optional>
#include <regex>

#include "base/escape.hpp"
#include "protocol/big_endian.hpp"
#include "protocol/format.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/receive.hpp"
#include "protocol/signing.hpp"
#include "protocol/status.hpp"

namespace lagrange {
namespace {

// A record's message, decoded after its type's check; a signed bus's message
// with or without its (unverified) trailer (see the header).
template <class Message>
bool CheckedDecode(Message& m, const void* data, std::size_t size) {
  return ReceiveInto(m, data, size, Framing::kRecorded) == Drop::kNone;
}

std::string Join(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ";") + FormatDouble(x);
  return s;
}

// A row under construction.
class Row {
 public:
  explicit Row(LogRow& row, std::int64_t log_utime) : row_(row) {
    row_.values.clear();
    Int(log_utime);
  }
  Row& Int(std::int64_t x) { return Put(x); }
  Row& Real(double x) { return Put(x); }
  Row& Text(const std::string& escaped) { return Put(escaped); }
  Row& Reals(const std::vector<double>& v) {
    for (double x : v) Real(x);
    return *this;
  }
  Row& Reals(const double* x, int n) {
    for (int i = 0; i < n; ++i) Real(x[i]);
    return *this;
  }

 private:
  Row& Put(LogValue v) {
    row_.values.push_back(std::move(v));
    return *this;
  }
  LogRow& row_;
};

// The fields of one type, built once per channel.
class Fields {
 public:
  Fields& Int(const char* name) { return Add(name, LogFieldKind::kInt); }
  Fields& Id(const char* name) { return Add(name, LogFieldKind::kId); }
  Fields& Real(const char* name) { return Add(name, LogFieldKind::kReal); }
  Fields& Text(const char* name) { return Add(name, LogFieldKind::kText); }
  Fields& Reals(const char* name, int width, const char* separator = "") {
    return Add(name, LogFieldKind::kReal, width, separator);
  }
  std::vector<LogField> Take() { return std::move(fields_); }

 private:
  Fields& Add(const char* name, LogFieldKind kind, int width = 0, const char* separator = "") {
    fields_.push_back({name, kind, width, separator});
    return *this;
  }
  std::vector<LogField> fields_ = {{"log_utime", LogFieldKind::kInt, 0, ""}};
};

// One channel's decoding: its fields, fixed by the first message that decodes.
class Decoder {
 public:
  virtual ~Decoder() = default;
  // False when the message does not decode or does not fit the fields.
  virtual bool Decode(std::int64_t log_utime, const void* data, std::size_t size, LogRow& row) = 0;
  const std::vector<LogField>& fields() const { return fields_; }

 protected:
  std::vector<LogField> fields_;
  int n_ = -1;  // num_dofs of a joint-array type, once fixed
};

// A decoder of one message type: the typed receive of a recording, then the type's row.
template <class Message>
class MessageDecoder : public Decoder {
 public:
  bool Decode(std::int64_t log_utime, const void* data, std::size_t size, LogRow& out) final {
    return Read(message_, data, size) && Write(message_, log_utime, out);
  }

 protected:
  virtual bool Read(Message& m, const void* data, std::size_t size) { return CheckedDecode(m, data, size); }
  // False when the message does not fit the fields.
  virtual bool Write(const Message& m, std::int64_t log_utime, LogRow& out) = 0;

 private:
  Message message_;
};

class StateDecoder final : public MessageDecoder<state_t> {
 public:
  bool Write(const state_t& s, std::int64_t log_utime, LogRow& out) override {
    if (n_ < 0) {
      n_ = s.num_dofs;
      Fields f;
      f.Int("utime").Id("run_id").Int("tick").Real("t").Int("num_dofs");
      for (const char* field : {"q", "qd", "qdd", "tau", "q_des", "qd_des"}) f.Reals(field, n_);
      fields_ = f.Real("kinetic_energy").Real("potential_energy").Text("controller").Int("mode").Take();
    }
    if (s.num_dofs != n_) return false;
    Row row(out, log_utime);
    row.Int(s.utime).Int(s.run_id).Int(s.tick).Real(s.t).Int(s.num_dofs);
    for (const auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) row.Reals(*v);
    row.Real(s.kinetic_energy).Real(s.potential_energy).Text(Escape(s.controller)).Int(s.mode);
    return true;
  }
};

class SetpointDecoder final : public MessageDecoder<setpoint_t> {
 public:
  bool Write(const setpoint_t& s, std::int64_t log_utime, LogRow& out) override {
    if (n_ < 0) {
      n_ = s.num_dofs;
      fields_ = Fields().Int("utime").Int("num_dofs").Reals("q", n_).Reals("qd", n_).Reals("qdd", n_).Take();
    }
    if (s.num_dofs != n_) return false;
    Row(out, log_utime).Int(s.utime).Int(s.num_dofs).Reals(s.q).Reals(s.qd).Reals(s.qdd);
    return true;
  }
};

class TorqueDecoder final : public MessageDecoder<torque_t> {
 public:
  bool Write(const torque_t& t, std::int64_t log_utime, LogRow& out) override {
    if (n_ < 0) {
      n_ = t.num_dofs;
      fields_ =
          Fields().Int("utime").Id("run_id").Int("sequence").Int("state_tick").Int("num_dofs").Reals("tau", n_).Take();
    }
    if (t.num_dofs != n_) return false;
    Row(out, log_utime).Int(t.utime).Int(t.run_id).Int(t.sequence).Int(t.state_tick).Int(t.num_dofs).Reals(t.tau);
    return true;
  }
};

class CommandDecoder final : public MessageDecoder<command_t> {
 public:
  bool Write(const command_t& c, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      fields_ = Fields()
                    .Int("utime")
                    .Id("request_id")
                    .Int("command")
                    .Text("controller")
                    .Int("num_gains")
                    .Text("kp")
                    .Text("kd")
                    .Take();
    }
    Row(out, log_utime)
        .Int(c.utime)
        .Int(c.request_id)
        .Int(c.command)
        .Text(Escape(c.controller))
        .Int(c.num_gains)
        .Text(Escape(Join(c.kp)))
        .Text(Escape(Join(c.kd)));
    return true;
  }
};

class StatusDecoder final : public MessageDecoder<status_t> {
 public:
  bool Write(const status_t& s, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      Fields f;
      f.Int("utime").Id("run_id").Int("ticks").Int("ticks_in_window").Real("period");
      for (const char* name :
           {"wake_latency_p50", "wake_latency_p99", "wake_latency_max", "compute_p50", "compute_p99", "compute_max"}) {
        f.Real(name);
      }
      f.Int("overruns").Int("state_messages_dropped");
      for (const char* name : {"setpoints_accepted", "setpoints_rejected", "torques_accepted", "torques_rejected",
                               "measured_accepted", "measured_rejected"}) {
        f.Int(name);
      }
      f.Text("last_rejection").Int("commands_accepted").Int("commands_rejected").Text("last_command_error");
      f.Int("decode_errors").Int("datagrams_dropped_kernel").Int("datagrams_malformed").Int("fragments_dropped");
      f.Int("foreign_messages").Id("last_foreign_run_id").Int("replies_suppressed").Int("bus_signed");
      f.Int("datagrams_unauthenticated").Text("unauthenticated");
      for (const char* name : {"instances", "reasons", "integrators", "methods", "effects", "forces", "joints"}) {
        f.Text(name);
      }
      fields_ = f.Take();
    }
    // CHANNEL=count;..: the messages refused for their signature on each channel that had any.
    std::string unauthenticated;
    for (std::size_t k = 0; k < s.unauthenticated_channels.size() && k < s.unauthenticated_counts.size(); ++k) {
      unauthenticated +=
          (k ? ";" : "") + Escape(s.unauthenticated_channels[k]) + "=" + std::to_string(s.unauthenticated_counts[k]);
    }
    std::string instances, reasons, integrators, methods, effects, forces, joints;
    // NAME=j1,j2,..: each instance's share of joint_names (none when the
    // status carries none or its counts do not add up: JointNamesByInstance).
    const std::vector<std::vector<std::string>> names = JointNamesByInstance(s);
    for (int i = 0; i < s.num_instances; ++i) {
      const auto k = static_cast<std::size_t>(i);
      instances += (i ? ";" : "") + Escape(s.instance_names[k]) + "=" + std::to_string(s.instance_modes[k]);
      reasons += (i ? ";" : "") + Escape(s.instance_names[k]) + "=" + Escape(s.instance_reasons[k]);
      if (const std::optional<InstanceSettings> set = SettingsIn(s, s.instance_names[k])) {
        const std::string name = (i ? ";" : "") + Escape(s.instance_names[k]) + "=";
        integrators += name + set->integrator;
        methods += name + set->method;
        effects += name + set->effects;
        forces += name + (set->forces ? "1" : "0");
      }
      joints += (i ? ";" : "") + Escape(s.instance_names[k]) + "=";
      if (k >= names.size()) continue;
      for (std::size_t j = 0; j < names[k].size(); ++j) joints += (j ? "," : "") + names[k][j];
    }
    Row row(out, log_utime);
    row.Int(s.utime).Int(s.run_id).Int(s.ticks).Int(s.ticks_in_window).Real(s.period);
    for (double x :
         {s.wake_latency_p50, s.wake_latency_p99, s.wake_latency_max, s.compute_p50, s.compute_p99, s.compute_max}) {
      row.Real(x);
    }
    row.Int(s.overruns).Int(s.state_messages_dropped);
    for (std::int64_t x : {s.setpoints_accepted, s.setpoints_rejected, s.torques_accepted, s.torques_rejected,
                           s.measured_accepted, s.measured_rejected}) {
      row.Int(x);
    }
    row.Text(Escape(s.last_rejection))
        .Int(s.commands_accepted)
        .Int(s.commands_rejected)
        .Text(Escape(s.last_command_error));
    row.Int(s.decode_errors).Int(s.datagrams_dropped_kernel).Int(s.datagrams_malformed).Int(s.fragments_dropped);
    row.Int(s.foreign_messages).Int(s.last_foreign_run_id).Int(s.replies_suppressed).Int(s.bus_signed ? 1 : 0);
    row.Int(s.datagrams_unauthenticated).Text(unauthenticated);
    for (const std::string* text : {&instances, &reasons, &integrators, &methods, &effects, &forces, &joints}) {
      row.Text(*text);
    }
    return true;
  }
};

class TelemetryDecoder final : public MessageDecoder<telemetry_t> {
 public:
  bool Write(const telemetry_t& m, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      Fields f;
      f.Int("utime").Id("run_id").Int("tick").Real("t").Int("mode");
      for (const char* name : {"energy", "energy_residual", "quadrature_bound", "work", "power"}) f.Real(name);
      f.Text("integrator").Int("substeps").Text("method");
      for (const char* name : {"evaluations", "steps_accepted", "steps_rejected", "newton_iterations", "failures"}) {
        f.Int(name);
      }
      fields_ = f.Real("error_estimate").Real("step").Real("compute_us").Take();
    }
    Row row(out, log_utime);
    row.Int(m.utime).Int(m.run_id).Int(m.tick).Real(m.t).Int(m.mode);
    for (double x : {m.energy, m.energy_residual, m.quadrature_bound, m.work, m.power}) row.Real(x);
    row.Text(Escape(m.integrator)).Int(m.substeps).Text(Escape(m.method));
    for (std::int32_t x : {m.evaluations, m.steps_accepted, m.steps_rejected, m.newton_iterations, m.failures}) {
      row.Int(x);
    }
    row.Real(m.error_estimate).Real(m.step).Real(m.compute_us);
    return true;
  }
};

class PoseSetpointDecoder final : public MessageDecoder<pose_setpoint_t> {
 public:
  bool Write(const pose_setpoint_t& m, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      fields_ = Fields()
                    .Int("utime")
                    .Text("frame")
                    .Reals("position", 3)
                    .Reals("orientation", 4)
                    .Reals("twist", 6)
                    .Real("duration")
                    .Take();
    }
    Row(out, log_utime)
        .Int(m.utime)
        .Text(Escape(m.frame))
        .Reals(m.position, 3)
        .Reals(m.orientation, 4)
        .Reals(m.twist, 6)
        .Real(m.duration);
    return true;
  }
};

class TaskStateDecoder final : public MessageDecoder<task_state_t> {
 public:
  bool Write(const task_state_t& m, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      fields_ = Fields()
                    .Int("utime")
                    .Id("run_id")
                    .Int("tick")
                    .Real("t")
                    .Text("frame")
                    .Text("controller")
                    .Reals("position", 3)
                    .Reals("orientation", 4)
                    .Reals("position_des", 3)
                    .Reals("orientation_des", 4)
                    .Reals("error", 6)
                    .Reals("twist", 6)
                    .Take();
    }
    Row(out, log_utime)
        .Int(m.utime)
        .Int(m.run_id)
        .Int(m.tick)
        .Real(m.t)
        .Text(Escape(m.frame))
        .Text(Escape(m.controller))
        .Reals(m.position, 3)
        .Reals(m.orientation, 4)
        .Reals(m.position_des, 3)
        .Reals(m.orientation_des, 4)
        .Reals(m.error, 6)
        .Reals(m.twist, 6);
    return true;
  }
};

// An mpc_t: its scalars, then its knots' times (knot_t0 ..) and states (knot0_x_0 .. : knot 0's q then qd, ...).
// The knots' shape (num_knots, num_states) is fixed by the channel's first plan; another shape is skipped.
class MpcDecoder final : public MessageDecoder<mpc_t> {
 public:
  bool Write(const mpc_t& m, std::int64_t log_utime, LogRow& out) override {
    if (n_ < 0) {
      n_ = m.num_states;
      knots_ = m.num_knots;
      Fields fields;
      fields.Int("utime").Id("run_id").Int("tick").Real("t").Text("controller").Int("plan").Real("start").Real("age");
      fields.Real("solve_time").Int("iterations").Real("cost_before").Real("cost").Text("status").Int("followed");
      fields.Real("dt").Int("horizon").Int("num_states").Int("num_knots").Reals("knot_t", knots_);
      fields_ = fields.Take();
      for (int k = 0; k < knots_; ++k) {
        fields_.push_back({"knot" + std::to_string(k) + "_x", LogFieldKind::kReal, n_, "_"});
      }
    }
    if (m.num_states != n_ || m.num_knots != knots_) return false;
    Row row(out, log_utime);
    row.Int(m.utime).Int(m.run_id).Int(m.tick).Real(m.t).Text(Escape(m.controller)).Int(m.plan).Real(m.start);
    row.Real(m.age).Real(m.solve_time).Int(m.iterations).Real(m.cost_before).Real(m.cost).Text(Escape(m.status));
    row.Int(m.followed ? 1 : 0).Real(m.dt).Int(m.horizon).Int(m.num_states).Int(m.num_knots).Reals(m.knot_t);
    for (const std::vector<double>& x : m.knot_x) row.Reals(x);
    return true;
  }

 private:
  int knots_ = 0;
};

// A forces_t of lagrange before the constraint row and the contacts (kForcesV1Fingerprint), read into
// today's: constraint_on false and its row zeros (not computed then), no contacts. Its check has passed.
forces_t ForcesFromV1(const std::uint8_t* p) {
  forces_t f;
  std::size_t at = 8;
  const auto int64 = [&] {
    const auto v = static_cast<std::int64_t>(ReadBigEndian64(p + at));
    at += 8;
    return v;
  };
  const auto real = [&] {
    const std::uint64_t bits = ReadBigEndian64(p + at);
    at += 8;
    double v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  };
  f.utime = int64();
  f.run_id = int64();
  f.tick = int64();
  f.t = real();
  for (std::int8_t* flag : {&f.gravity_on, &f.coriolis_on, &f.damping_on, &f.friction_on, &f.limits_on,
                            &f.saturation_on, &f.disturbance_on}) {
    *flag = p[at++] != 0;
  }
  f.constraint_on = false;
  f.num_dofs = static_cast<std::int32_t>(ReadBigEndian32(p + at));
  at += 4;
  const auto n = static_cast<std::size_t>(f.num_dofs);
  for (auto* v :
       {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.disturbance, &f.tau_cmd, &f.tau_applied}) {
    v->resize(n);
    for (double& x : *v) x = real();
  }
  f.constraint.assign(n, 0.0);
  f.contacts_total = f.num_contacts = 0;
  return f;
}

// A forces packet of today's layout or lagrange's earlier one (ForcesFromV1), checked before it is decoded.
bool DecodeForces(forces_t& f, const void* data, std::size_t size) {
  if (CheckedDecode(f, data, size)) return true;
  std::size_t n = 0;
  const auto* p = static_cast<const std::uint8_t*>(data);
  if (CheckFramed(CheckForcesV1Packet, Framing::kRecorded, p, size, n) != Drop::kNone) return false;
  f = ForcesFromV1(p);
  return true;
}

// Values joined by ';' (a contact's three coordinates in a row, contact after contact).
template <class Get>
std::string JoinContacts(const forces_t& f, int width, Get get) {
  std::string s;
  for (const contact_t& c : f.contacts) {
    for (int k = 0; k < width; ++k) s += (s.empty() ? "" : ";") + FormatDouble(get(c, k));
  }
  return s;
}

class ForcesDecoder final : public MessageDecoder<forces_t> {
 public:
  bool Read(forces_t& f, const void* data, std::size_t size) override { return DecodeForces(f, data, size); }
  bool Write(const forces_t& f, std::int64_t log_utime, LogRow& out) override {
    if (n_ < 0) {
      n_ = f.num_dofs;
      Fields fields;
      fields.Int("utime").Id("run_id").Int("tick").Real("t");
      for (const char* flag : kFlags) fields.Int(flag);
      fields.Int("num_dofs");
      for (const char* row : kRows) fields.Reals(row, n_, "_");
      fields.Int("contacts_total").Int("num_contacts");
      for (const char* column : kContactColumns) fields.Text(column);
      fields_ = fields.Take();
    }
    if (f.num_dofs != n_) return false;
    Row row(out, log_utime);
    row.Int(f.utime).Int(f.run_id).Int(f.tick).Real(f.t);
    for (bool on : {f.gravity_on, f.coriolis_on, f.damping_on, f.friction_on, f.limits_on, f.saturation_on,
                    f.disturbance_on, f.constraint_on}) {
      row.Int(on ? 1 : 0);
    }
    row.Int(f.num_dofs);
    for (const auto* v : {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.constraint, &f.disturbance,
                          &f.tau_cmd, &f.tau_applied}) {
      row.Reals(*v);
    }
    row.Int(f.contacts_total).Int(f.num_contacts);
    row.Text(JoinContacts(f, 1, [](const contact_t& c, int) { return c.geom1; }))
        .Text(JoinContacts(f, 1, [](const contact_t& c, int) { return c.geom2; }))
        .Text(JoinContacts(f, 1, [](const contact_t& c, int) { return c.distance; }))
        .Text(JoinContacts(f, 3, [](const contact_t& c, int k) { return c.position[k]; }))
        .Text(JoinContacts(f, 3, [](const contact_t& c, int k) { return c.normal[k]; }))
        .Text(JoinContacts(f, 3, [](const contact_t& c, int k) { return c.force[k]; }))
        .Text(JoinContacts(f, 3, [](const contact_t& c, int k) { return c.torque[k]; }));
    return true;
  }

 private:
  // forces_t's flags and rows, in its order.
  static constexpr const char* kFlags[] = {"gravity_on", "coriolis_on",   "damping_on",     "friction_on",
                                           "limits_on",  "saturation_on", "disturbance_on", "constraint_on"};
  static constexpr const char* kRows[] = {"gravity",    "coriolis",    "damping", "friction",   "limits",
                                          "constraint", "disturbance", "tau_cmd", "tau_applied"};
  // Its contacts, one text column per field: the contacts' values joined by ';' (3 per contact for a vector).
  static constexpr const char* kContactColumns[] = {"contact_geom1",    "contact_geom2",  "contact_distance",
                                                    "contact_position", "contact_normal", "contact_force",
                                                    "contact_torque"};
};

class ReplyDecoder final : public MessageDecoder<reply_t> {
 public:
  bool Write(const reply_t& r, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      fields_ =
          Fields().Int("utime").Id("run_id").Id("request_id").Int("command").Int("accepted").Text("reason").Take();
    }
    Row(out, log_utime)
        .Int(r.utime)
        .Int(r.run_id)
        .Int(r.request_id)
        .Int(r.command)
        .Int(r.accepted ? 1 : 0)
        .Text(Escape(r.reason));
    return true;
  }
};

class BaseStateDecoder final : public MessageDecoder<base_state_t> {
 public:
  bool Write(const base_state_t& m, std::int64_t log_utime, LogRow& out) override {
    if (fields_.empty()) {
      Fields f;
      f.Int("utime").Id("run_id").Int("tick").Real("t");
      for (const BaseStateArray& a : kBaseStateArrays) f.Reals(a.name, a.width);
      fields_ = f.Take();
    }
    const std::array<double, kBaseStateWidth> values = BaseStateValues(m);
    Row row(out, log_utime);
    row.Int(m.utime).Int(m.run_id).Int(m.tick).Real(m.t);
    const double* next = values.data();
    for (const BaseStateArray& a : kBaseStateArrays) {
      row.Reals(next, a.width);
      next += a.width;
    }
    return true;
  }
};

std::unique_ptr<Decoder> DecoderFor(MessageType type) {
  switch (type) {
    case MessageType::kState: return std::make_unique<StateDecoder>();
    case MessageType::kSetpoint: return std::make_unique<SetpointDecoder>();
    case MessageType::kTorque: return std::make_unique<TorqueDecoder>();
    case MessageType::kCommand: return std::make_unique<CommandDecoder>();
    case MessageType::kStatus: return std::make_unique<StatusDecoder>();
    case MessageType::kReply: return std::make_unique<ReplyDecoder>();
    case MessageType::kTelemetry: return std::make_unique<TelemetryDecoder>();
    case MessageType::kForces: return std::make_unique<ForcesDecoder>();
    case MessageType::kPoseSetpoint: return std::make_unique<PoseSetpointDecoder>();
    case MessageType::kTaskState: return std::make_unique<TaskStateDecoder>();
    case MessageType::kMpc: return std::make_unique<MpcDecoder>();
    case MessageType::kBaseState: return std::make_unique<BaseStateDecoder>();
    case MessageType::kUnknown: break;
  }
  return nullptr;
}

}  // namespace

std::array<double, kBaseStateWidth> BaseStateValues(const base_state_t& m) {
  // In kBaseStateArrays' order.
  const double* arrays[] = {m.position, m.orientation,     m.linear_velocity, m.angular_velocity,
                            m.com,      m.linear_momentum, m.angular_momentum};
  static_assert(std::size(arrays) == std::size(kBaseStateArrays));
  std::array<double, kBaseStateWidth> values;
  double* out = values.data();
  for (std::size_t k = 0; k < std::size(arrays); ++k) out = std::copy_n(arrays[k], kBaseStateArrays[k].width, out);
  return values;
}

std::string LogColumnName(const LogField& field, int i) { return field.name + field.separator + std::to_string(i); }

void ReadLogRecords(const std::string& log_path, const std::string& channel_regex,
                    const std::function<void(const LogRecord&)>& visit) {
  LcmLogReader log(log_path);
  const std::regex wanted(channel_regex.empty() ? ".*" : channel_regex);
  std::map<std::string, std::unique_ptr<Decoder>, std::less<>> decoders;
  std::map<std::string, MessageType, std::less<>> types;  // by channel, once its type is known
  LogRow row;
  while (const LcmLogEvent* e = log.Next()) {
    auto it = decoders.find(e->channel);
    if (it == decoders.end()) {
      const std::string channel(e->channel);
      if (!std::regex_match(channel, wanted)) continue;
      // A channel's type is that of its first message of a lagrange type
      // (log2csv's rule); a later message of another type does not decode.
      MessageType type = TypeOf(e->data, e->size);
      // An earlier lagrange's forces_t is read too (DecodeForces).
      if (type == MessageType::kUnknown && Fingerprint(e->data, e->size) == kForcesV1Fingerprint) {
        type = MessageType::kForces;
      }
      std::unique_ptr<Decoder> decoder = DecoderFor(type);
      if (!decoder) {
        visit(LogRecord{e->channel, MessageType::kUnknown, nullptr, nullptr});
        continue;
      }
      it = decoders.emplace(channel, std::move(decoder)).first;
      types.emplace(channel, type);
    }
    Decoder& decoder = *it->second;
    const bool ok = decoder.Decode(e->utime, e->data, e->size, row);
    const LogRecord record{e->channel, types.find(e->channel)->second, &decoder.fields(), ok ? &row : nullptr};
    visit(record);
  }
  if (log.end() == LcmLogReader::End::kTruncated) throw LcmLogCutShortError(log_path + ": " + log.EndReason());
  if (log.end() == LcmLogReader::End::kCorrupt) throw LcmLogError(log_path + ": " + log.EndReason());
}

}  // namespace lagrange
