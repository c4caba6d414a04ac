#include "tools/log_csv.hpp"

#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <stdexcept>
#include <string_view>

#include "plant/escape.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/lcm_log.hpp"
#include "protocol/signing.hpp"
#include "protocol/status.hpp"
#include "protocol/wire.hpp"
#include "tools/cli_support.hpp"

namespace lagrange::cli {
namespace {

// Text already escaped, as one CSV field: quotes doubled.
std::string QuoteEscaped(const std::string& escaped) {
  std::string q = "\"";
  for (char c : escaped) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// Decodes a message only after its wire check: a recorded packet is as
// untrusted as a live one. A signed bus's message is followed by its
// signature trailer (protocol/signing.hpp), decoded without it; the signature
// is not checked here (a log is read after the fact, without the key).
template <class Message>
bool CheckedDecode(Message& m, WireCheck (*check)(const void*, std::size_t), const void* data, int size) {
  if (size < 0) return false;
  const auto whole = static_cast<std::size_t>(size);
  for (const std::size_t n : {whole, MessageSizeBeforeTrailer(static_cast<const std::uint8_t*>(data), whole)}) {
    if (check(data, n) == WireCheck::kOk && m.decode(data, 0, static_cast<int>(n)) == static_cast<int>(n)) return true;
  }
  return false;
}

void Columns(std::ostream& out, const char* name, int n, const char* separator = "") {
  out << JointColumns(name, n, separator);
}

void Values(std::ostream& out, const std::vector<double>& v) {
  for (double x : v) out << ',' << FormatDouble(x);
}

std::string Join(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ";") + FormatDouble(x);
  return s;
}

// One output CSV and how to write a message of its type.
class Writer {
 public:
  virtual ~Writer() = default;
  // False when the message does not decode or does not fit the header.
  virtual bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) = 0;
};

class StateWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    state_t s;
    if (!CheckedDecode(s, CheckStatePacket, data, size)) return false;
    if (n_ < 0) {
      n_ = s.num_dofs;
      out << "log_utime,utime,run_id,tick,t,num_dofs";
      for (const char* field : {"q", "qd", "qdd", "tau", "q_des", "qd_des"}) Columns(out, field, n_);
      out << ',' << kKineticEnergyColumn << ',' << kPotentialEnergyColumn
          << ",controller,mode\n";
    }
    if (s.num_dofs != n_) return false;
    out << log_utime << ',' << s.utime << ',' << RunIdText(s.run_id) << ',' << s.tick << ',' << FormatDouble(s.t) << ','
        << s.num_dofs;
    for (const auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) Values(out, *v);
    out << ',' << FormatDouble(s.kinetic_energy) << ',' << FormatDouble(s.potential_energy) << ','
        << CsvText(s.controller) << ',' << static_cast<int>(s.mode) << '\n';
    return true;
  }

 private:
  int n_ = -1;
};

class SetpointWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    setpoint_t s;
    if (!CheckedDecode(s, CheckSetpointPacket, data, size)) return false;
    if (n_ < 0) {
      n_ = s.num_dofs;
      out << "log_utime,utime,num_dofs";
      for (const char* field : {"q", "qd", "qdd"}) Columns(out, field, n_);
      out << '\n';
    }
    if (s.num_dofs != n_) return false;
    out << log_utime << ',' << s.utime << ',' << s.num_dofs;
    for (const auto* v : {&s.q, &s.qd, &s.qdd}) Values(out, *v);
    out << '\n';
    return true;
  }

 private:
  int n_ = -1;
};

class TorqueWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    torque_t t;
    if (!CheckedDecode(t, CheckTorquePacket, data, size)) return false;
    if (n_ < 0) {
      n_ = t.num_dofs;
      out << "log_utime,utime,run_id,sequence,state_tick,num_dofs";
      Columns(out, "tau", n_);
      out << '\n';
    }
    if (t.num_dofs != n_) return false;
    out << log_utime << ',' << t.utime << ',' << RunIdText(t.run_id) << ',' << t.sequence << ',' << t.state_tick << ','
        << t.num_dofs;
    Values(out, t.tau);
    out << '\n';
    return true;
  }

 private:
  int n_ = -1;
};

class CommandWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    command_t c;
    if (!CheckedDecode(c, CheckCommandPacket, data, size)) return false;
    if (!header_) out << "log_utime,utime,request_id,command,controller,num_gains,kp,kd\n";
    header_ = true;
    out << log_utime << ',' << c.utime << ',' << RunIdText(c.request_id) << ',' << static_cast<int>(c.command) << ','
        << CsvText(c.controller) << ',' << c.num_gains << ',' << CsvText(Join(c.kp)) << ',' << CsvText(Join(c.kd))
        << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

class StatusWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    status_t s;
    if (!CheckedDecode(s, CheckStatusPacket, data, size)) return false;
    if (!header_) {
      out << "log_utime,utime,run_id,ticks,ticks_in_window,period,wake_latency_p50,wake_latency_p99,wake_latency_max,"
             "compute_p50,compute_p99,compute_max,overruns,state_messages_dropped,setpoints_accepted,"
             "setpoints_rejected,torques_accepted,torques_rejected,measured_accepted,measured_rejected,"
             "last_rejection,commands_accepted,commands_rejected,last_command_error,decode_errors,"
             "datagrams_dropped_kernel,datagrams_malformed,fragments_dropped,foreign_messages,last_foreign_run_id,"
             "replies_suppressed,bus_signed,datagrams_unauthenticated,unauthenticated,"
             "instances,reasons,integrators,methods,effects,forces,joints\n";
    }
    header_ = true;
    // CHANNEL=count;..: the messages refused for their signature on each channel that had any.
    std::string unauthenticated;
    for (std::size_t k = 0; k < s.unauthenticated_channels.size() && k < s.unauthenticated_counts.size(); ++k) {
      unauthenticated += (k ? ";" : "") + Escape(s.unauthenticated_channels[k]) + "=" +
                         std::to_string(s.unauthenticated_counts[k]);
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
    out << log_utime << ',' << s.utime << ',' << RunIdText(s.run_id) << ',' << s.ticks << ',' << s.ticks_in_window
        << ',' << FormatDouble(s.period);
    for (double x :
         {s.wake_latency_p50, s.wake_latency_p99, s.wake_latency_max, s.compute_p50, s.compute_p99, s.compute_max}) {
      out << ',' << FormatDouble(x);
    }
    out << ',' << s.overruns << ',' << s.state_messages_dropped;
    for (std::int64_t x : {s.setpoints_accepted, s.setpoints_rejected, s.torques_accepted, s.torques_rejected,
                           s.measured_accepted, s.measured_rejected}) {
      out << ',' << x;
    }
    out << ',' << CsvText(s.last_rejection) << ',' << s.commands_accepted << ',' << s.commands_rejected << ','
        << CsvText(s.last_command_error) << ',' << s.decode_errors << ',' << s.datagrams_dropped_kernel << ','
        << s.datagrams_malformed << ',' << s.fragments_dropped << ',' << s.foreign_messages << ','
        << RunIdText(s.last_foreign_run_id) << ',' << s.replies_suppressed << ',' << (s.bus_signed ? 1 : 0) << ','
        << s.datagrams_unauthenticated << ',' << QuoteEscaped(unauthenticated) << ',' << QuoteEscaped(instances)
        << ',' << QuoteEscaped(reasons);
    for (const std::string* text : {&integrators, &methods, &effects, &forces}) out << ',' << QuoteEscaped(*text);
    out << ',' << QuoteEscaped(joints) << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

class TelemetryWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    telemetry_t m;
    if (!CheckedDecode(m, CheckTelemetryPacket, data, size)) return false;
    if (!header_) {
      out << "log_utime,utime,run_id,tick,t,mode,energy,energy_residual,quadrature_bound,work,power,integrator,"
             "substeps,method,evaluations,steps_accepted,steps_rejected,newton_iterations,failures,error_estimate,"
             "step,compute_us\n";
    }
    header_ = true;
    out << log_utime << ',' << m.utime << ',' << RunIdText(m.run_id) << ',' << m.tick << ',' << FormatDouble(m.t) << ','
        << static_cast<int>(m.mode);
    for (double x : {m.energy, m.energy_residual, m.quadrature_bound, m.work, m.power}) out << ',' << FormatDouble(x);
    out << ',' << CsvText(m.integrator) << ',' << m.substeps << ',' << CsvText(m.method);
    for (std::int32_t x : {m.evaluations, m.steps_accepted, m.steps_rejected, m.newton_iterations, m.failures})
      out << ',' << x;
    out << ',' << FormatDouble(m.error_estimate) << ',' << FormatDouble(m.step) << ',' << FormatDouble(m.compute_us)
        << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

// Fixed-size arrays as columns: NAME0, NAME1, ...
void FixedColumns(std::ostream& out, const char* name, int n) {
  for (int i = 0; i < n; ++i) out << ',' << name << i;
}
void FixedValues(std::ostream& out, const double* x, int n) {
  for (int i = 0; i < n; ++i) out << ',' << FormatDouble(x[i]);
}

class PoseSetpointWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    pose_setpoint_t m;
    if (!CheckedDecode(m, CheckPoseSetpointPacket, data, size)) return false;
    if (!header_) {
      out << "log_utime,utime,frame";
      FixedColumns(out, "position", 3);
      FixedColumns(out, "orientation", 4);
      FixedColumns(out, "twist", 6);
      out << ",duration\n";
    }
    header_ = true;
    out << log_utime << ',' << m.utime << ',' << CsvText(m.frame);
    FixedValues(out, m.position, 3);
    FixedValues(out, m.orientation, 4);
    FixedValues(out, m.twist, 6);
    out << ',' << FormatDouble(m.duration) << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

class TaskStateWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    task_state_t m;
    if (!CheckedDecode(m, CheckTaskStatePacket, data, size)) return false;
    if (!header_) {
      out << "log_utime,utime,run_id,tick,t,frame,controller";
      FixedColumns(out, "position", 3);
      FixedColumns(out, "orientation", 4);
      FixedColumns(out, "position_des", 3);
      FixedColumns(out, "orientation_des", 4);
      FixedColumns(out, "error", 6);
      FixedColumns(out, "twist", 6);
      out << '\n';
    }
    header_ = true;
    out << log_utime << ',' << m.utime << ',' << RunIdText(m.run_id) << ',' << m.tick << ',' << FormatDouble(m.t) << ','
        << CsvText(m.frame) << ',' << CsvText(m.controller);
    FixedValues(out, m.position, 3);
    FixedValues(out, m.orientation, 4);
    FixedValues(out, m.position_des, 3);
    FixedValues(out, m.orientation_des, 4);
    FixedValues(out, m.error, 6);
    FixedValues(out, m.twist, 6);
    out << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

class ForcesWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    forces_t f;
    if (!CheckedDecode(f, CheckForcesPacket, data, size)) return false;
    if (n_ < 0) {
      n_ = f.num_dofs;
      out << "log_utime,utime,run_id,tick,t";
      for (const char* effect : kEffects) out << ',' << effect << "_on";
      out << ",num_dofs";
      for (const char* row : kRows) Columns(out, row, n_, "_");
      out << '\n';
    }
    if (f.num_dofs != n_) return false;
    out << log_utime << ',' << f.utime << ',' << RunIdText(f.run_id) << ',' << f.tick << ',' << FormatDouble(f.t);
    for (bool on :
         {f.gravity_on, f.coriolis_on, f.damping_on, f.friction_on, f.limits_on, f.saturation_on, f.disturbance_on}) {
      out << ',' << (on ? 1 : 0);
    }
    out << ',' << f.num_dofs;
    for (const auto* v :
         {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.disturbance, &f.tau_cmd, &f.tau_applied}) {
      Values(out, *v);
    }
    out << '\n';
    return true;
  }

 private:
  // forces_t's flags and rows, in its order.
  static constexpr const char* kEffects[] = {"gravity", "coriolis",   "damping",    "friction",
                                             "limits",  "saturation", "disturbance"};
  static constexpr const char* kRows[] = {"gravity", "coriolis",    "damping", "friction",
                                          "limits",  "disturbance", "tau_cmd", "tau_applied"};
  int n_ = -1;
};

class ReplyWriter final : public Writer {
 public:
  bool Write(std::ostream& out, std::int64_t log_utime, const void* data, int size) override {
    reply_t r;
    if (!CheckedDecode(r, CheckReplyPacket, data, size)) return false;
    if (!header_) out << "log_utime,utime,run_id,request_id,command,accepted,reason\n";
    header_ = true;
    out << log_utime << ',' << r.utime << ',' << RunIdText(r.run_id) << ',' << RunIdText(r.request_id) << ','
        << static_cast<int>(r.command) << ',' << (r.accepted ? 1 : 0) << ',' << CsvText(r.reason) << '\n';
    return true;
  }

 private:
  bool header_ = false;
};

std::unique_ptr<Writer> WriterFor(MessageType type) {
  switch (type) {
    case MessageType::kState: return std::make_unique<StateWriter>();
    case MessageType::kSetpoint: return std::make_unique<SetpointWriter>();
    case MessageType::kTorque: return std::make_unique<TorqueWriter>();
    case MessageType::kCommand: return std::make_unique<CommandWriter>();
    case MessageType::kStatus: return std::make_unique<StatusWriter>();
    case MessageType::kReply: return std::make_unique<ReplyWriter>();
    case MessageType::kTelemetry: return std::make_unique<TelemetryWriter>();
    case MessageType::kForces: return std::make_unique<ForcesWriter>();
    case MessageType::kPoseSetpoint: return std::make_unique<PoseSetpointWriter>();
    case MessageType::kTaskState: return std::make_unique<TaskStateWriter>();
    case MessageType::kUnknown: break;
  }
  return nullptr;
}

std::string SafeFileName(const std::string& channel) {
  std::string s = channel;
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') c = '_';
  }
  return s;
}

// FILE.WHAT.csv for FILE.csv; PATH.WHAT.csv for any other PATH.
std::string BesidePath(const std::string& csv_path, const char* what) {
  constexpr std::string_view csv = ".csv";
  const bool has_csv = csv_path.size() > csv.size() && csv_path.ends_with(csv);
  return (has_csv ? csv_path.substr(0, csv_path.size() - csv.size()) : csv_path) + "." + what + ".csv";
}

}  // namespace

std::string CsvText(const std::string& text) { return QuoteEscaped(Escape(text)); }

std::string JointNamesPath(const std::string& csv_path) { return BesidePath(csv_path, "joints"); }

std::string TaskCsvPath(const std::string& csv_path) { return BesidePath(csv_path, "task"); }

std::string WriteJointNames(const std::string& csv_path, const std::vector<std::string>& names) {
  const std::string path = JointNamesPath(csv_path);
  std::ofstream out(path);
  out << "joint,name\n";
  for (std::size_t i = 0; i < names.size(); ++i) out << i << ',' << CsvText(names[i]) << '\n';
  out.flush();
  if (!out) throw std::runtime_error("cannot write " + path);
  return path;
}

std::string JointColumns(const char* field, int n, const char* separator) {
  std::string columns;
  for (int i = 0; i < n; ++i) columns += std::string(",") + field + separator + std::to_string(i);
  return columns;
}

LogToCsvResult LogToCsv(const std::string& log_path, const std::string& dir, const std::string& channel_regex) {
  LcmLogReader log(log_path);
  std::filesystem::create_directories(dir);
  const std::regex wanted(channel_regex.empty() ? ".*" : channel_regex);
  struct Output {
    std::unique_ptr<Writer> writer;
    std::ofstream file;
  };
  std::map<std::string, Output> outputs;
  LogToCsvResult result;
  while (const LcmLogEvent* e = log.Next()) {
    const std::string channel(e->channel);
    if (!std::regex_match(channel, wanted)) continue;
    auto it = outputs.find(channel);
    if (it == outputs.end()) {
      const MessageType type = TypeOf(e->data, e->size);
      std::unique_ptr<Writer> writer = WriterFor(type);
      if (!writer) {
        ++result.unknown[channel];
        continue;
      }
      const std::string path = (std::filesystem::path(dir) / (SafeFileName(channel) + ".csv")).string();
      Output o{std::move(writer), std::ofstream(path)};
      if (!o.file) throw std::runtime_error("cannot write " + path);
      result.written[channel] = {ToString(type), path, 0, 0};
      it = outputs.emplace(channel, std::move(o)).first;
    }
    ChannelCsv& c = result.written[channel];
    if (it->second.writer->Write(it->second.file, e->utime, e->data, static_cast<int>(e->size)))
      ++c.rows;
    else
      ++c.skipped;
  }
  for (auto& [channel, o] : outputs) {
    o.file.flush();
    if (!o.file) throw std::runtime_error("writing " + result.written[channel].path + " failed");
  }
  return result;
}

}  // namespace lagrange::cli
