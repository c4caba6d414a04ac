#include "daemon/lcm_bridge.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "controllers/factory.hpp"
#include "daemon/setpoint_check.hpp"
#include "daemon/wire.hpp"
#include "lcmtypes/subscribe.hpp"

namespace lagrange {
namespace {

double Percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(std::min(k, v.size() - 1)), v.end());
  return v[std::min(k, v.size() - 1)];
}

}  // namespace

void Reason::Set(const std::string& s) {
  const std::size_t n = std::min(s.size(), text.size() - 1);
  std::copy_n(s.data(), n, text.data());
  text[n] = '\0';
}

// ---- receive thread ------------------------------------------------------

LcmReceiver::LcmReceiver(lcm::LCM& lcm, const ChannelNames& channels, Runtime& runtime, Clock& clock,
                         ReceiverStats& stats, SetpointAge age)
    : lcm_(lcm), runtime_(runtime), clock_(clock), stats_(stats), age_(age) {
  handlers_.reserve(runtime.size());  // subscriptions keep pointers to the handlers
  for (std::size_t i = 0; i < runtime.size(); ++i) {
    const Instance& inst = runtime.instance(i);
    const InstanceConfig& c = inst.config();
    info_.push_back({inst.name(), inst.num_dofs(), inst.controller_names(), inst.controller_types(),
                     SetpointRules{inst.num_dofs(), c.setpoint_lower, c.setpoint_upper}, c.setpoint_timeout, 0, -1});
    handlers_.push_back({this, i});
    Subscribe<&Handler::OnSetpoint>(lcm_, channels.setpoint[i], &handlers_.back());
    Subscribe<&Handler::OnCommand>(lcm_, channels.command[i], &handlers_.back());
  }
}

void LcmReceiver::Run(const std::atomic<bool>& stop) {
  while (!stop.load(std::memory_order_relaxed)) lcm_.handleTimeout(20);
}

void LcmReceiver::Handler::OnSetpoint(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  self->HandleSetpoint(index, rbuf);
}
void LcmReceiver::Handler::OnCommand(const lcm::ReceiveBuffer* rbuf, const std::string&) {
  self->HandleCommand(index, rbuf);
}

// A flood of bad packets must not become a flood of log lines.
void LcmReceiver::WarnAtMostOncePerSecond(std::string message) {
  const std::int64_t now = clock_.WallMicros();
  if (now - last_log_us_ < 1'000'000) {
    ++suppressed_;
    return;
  }
  if (suppressed_ > 0) message += fmt::format(" ({} more in the last second, not logged)", suppressed_);
  spdlog::warn("{}", message);
  last_log_us_ = now;
  suppressed_ = 0;
}

// Counts a refusal and keeps its reason for the status.
void LcmReceiver::Refuse(std::atomic<std::int64_t>& counter, LatestMailbox<Reason>& last, std::size_t i,
                         const std::string& why) {
  counter.fetch_add(1, std::memory_order_relaxed);
  last.back().Set(info_[i].name + ": " + why);
  last.Publish();
}

void LcmReceiver::DecodeError(const std::string& channel, const char* why) {
  stats_.decode_errors.fetch_add(1, std::memory_order_relaxed);
  WarnAtMostOncePerSecond(channel + ": dropped a packet that is not a valid message: " + why);
}

void LcmReceiver::RejectSetpoint(std::size_t i, const std::string& why) {
  Refuse(stats_.setpoints_rejected, stats_.last_setpoint_rejection, i, why);
  WarnAtMostOncePerSecond(info_[i].name + ": setpoint rejected: " + why);
}

void LcmReceiver::RejectCommand(std::size_t i, const std::string& why) {
  Refuse(stats_.commands_rejected, stats_.last_command_error, i, why);
  spdlog::warn("{}: command rejected: {}", info_[i].name, why);
}

double LcmReceiver::Age(InstanceInfo& info, std::int64_t utime) {
  const std::int64_t now = clock_.WallMicros();
  if (age_ == SetpointAge::kWall) return static_cast<double>(now - utime) * 1e-6;
  const std::int64_t offset = now - utime;
  const bool new_stream = info.last_arrival < 0 || static_cast<double>(now - info.last_arrival) * 1e-6 > info.timeout;
  info.last_arrival = now;
  if (new_stream || offset < info.least_offset) info.least_offset = offset;
  return static_cast<double>(offset - info.least_offset) * 1e-6;
}

void LcmReceiver::HandleSetpoint(std::size_t i, const lcm::ReceiveBuffer* rbuf) {
  InstanceInfo& info = info_[i];
  const SetpointVerdict verdict = CheckSetpoint(rbuf->data, rbuf->data_size, info.rules, setpoint_);
  if (verdict.kind == SetpointVerdict::Kind::kUndecodable) {
    DecodeError(info.name + "_SETPOINT", verdict.reason.c_str());
    return;
  }
  if (verdict.kind == SetpointVerdict::Kind::kRejected) {
    RejectSetpoint(i, verdict.reason);
    return;
  }
  const double age = Age(info, setpoint_.utime);
  if (age > info.timeout || age < -info.timeout) {
    // Not applied; the instance holds until a fresh setpoint comes.
    SetpointMessage& stale = runtime_.channels(i).setpoints.back();
    stale.stale = true;
    runtime_.channels(i).setpoints.Publish();
    RejectSetpoint(i, age > 0 ? fmt::format("stale: sent {:.6g} s ago (setpoint_timeout {:.6g} s)", age, info.timeout)
                              : fmt::format("timestamp {:.6g} s in the future (clocks out of step?)", -age));
    return;
  }
  SetpointMessage& m = runtime_.channels(i).setpoints.back();
  m.stale = false;
  m.setpoint.q = Eigen::Map<const VectorXd>(setpoint_.q.data(), info.n);
  m.setpoint.qd = Eigen::Map<const VectorXd>(setpoint_.qd.data(), info.n);
  m.setpoint.qdd = Eigen::Map<const VectorXd>(setpoint_.qdd.data(), info.n);
  runtime_.channels(i).setpoints.Publish();
  stats_.setpoints_accepted.fetch_add(1, std::memory_order_relaxed);
}

void LcmReceiver::HandleCommand(std::size_t i, const lcm::ReceiveBuffer* rbuf) {
  const InstanceInfo& info = info_[i];
  if (const WireCheck w = CheckCommandPacket(rbuf->data, rbuf->data_size); w != WireCheck::kOk) {
    DecodeError(info.name + "_COMMAND", ToString(w));
    return;
  }
  if (command_.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
    DecodeError(info.name + "_COMMAND", "decode failed");
    return;
  }
  if (command_.command < command_t::SWITCH_CONTROLLER || command_.command > command_t::CLEAR_ESTOP) {
    RejectCommand(i, "unknown command " + std::to_string(command_.command));
    return;
  }
  auto find_controller = [&](const std::string& name) -> int {
    const auto it = std::find(info.controllers.begin(), info.controllers.end(), name);
    return it == info.controllers.end() ? -1 : static_cast<int>(it - info.controllers.begin());
  };
  auto unknown = [&](const std::string& name) {
    std::string list;
    for (const std::string& c : info.controllers) list += (list.empty() ? "" : ", ") + c;
    return "unknown controller '" + name + "' for " + info.name + " (available: " + list + ")";
  };
  const auto kind = static_cast<CommandKind>(command_.command);
  int controller = -1;
  if (kind == CommandKind::kSwitchController) {
    controller = find_controller(command_.controller);
    if (controller < 0) return RejectCommand(i, unknown(command_.controller));
  }
  if (kind == CommandKind::kSetGains) {
    controller = command_.controller.empty() ? runtime_.channels(i).active_controller.load(std::memory_order_acquire)
                                             : find_controller(command_.controller);
    if (controller < 0) return RejectCommand(i, unknown(command_.controller));
    if (command_.num_gains != info.n) {
      return RejectCommand(i, "gains: num_gains is " + std::to_string(command_.num_gains) + ", expected " +
                                  std::to_string(info.n));
    }
    const Gains g{Eigen::Map<const VectorXd>(command_.kp.data(), info.n),
                  Eigen::Map<const VectorXd>(command_.kd.data(), info.n)};
    if (auto err = CheckGains(info.controller_types[static_cast<std::size_t>(controller)], info.n, g)) {
      return RejectCommand(i, "gains for " + info.controllers[static_cast<std::size_t>(controller)] + ": " + *err);
    }
  }
  CommandMessage* slot = runtime_.channels(i).commands.BeginPush();
  if (slot == nullptr) return RejectCommand(i, "the command queue is full");
  slot->kind = kind;
  slot->utime = command_.utime;
  slot->controller = controller;
  if (kind == CommandKind::kSetGains) {
    slot->gains.kp = Eigen::Map<const VectorXd>(command_.kp.data(), info.n);
    slot->gains.kd = Eigen::Map<const VectorXd>(command_.kd.data(), info.n);
  }
  runtime_.channels(i).commands.Push();  // the tick applies or refuses it; its record says which
}

// ---- publish thread ------------------------------------------------------

LcmPublisher::LcmPublisher(lcm::LCM& lcm, const ChannelNames& channels, Runtime& runtime, SpscRing<TickRecord>& ring,
                           const Loop& loop, ReceiverStats& stats, int notify_fd)
    : lcm_(lcm),
      channels_(channels),
      ring_(ring),
      loop_(loop),
      stats_(stats),
      notify_fd_(notify_fd),
      status_every_(std::max(1, static_cast<int>(std::lround(0.1 / runtime.period())))),
      period_(runtime.period()),
      last_(runtime.MakeRecord()) {
  for (std::size_t i = 0; i < runtime.size(); ++i) {
    Instance& inst = runtime.instance(i);
    names_.push_back(inst.name());
    controller_names_.push_back(inst.controller_names());
    state_t s;
    s.num_dofs = inst.num_dofs();
    for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->resize(static_cast<std::size_t>(s.num_dofs));
    states_.push_back(s);
    modes_.push_back(Mode::kRunning);
  }
  latencies_.reserve(static_cast<std::size_t>(status_every_) * 2);
  computes_.reserve(static_cast<std::size_t>(status_every_) * 2);
}

void LcmPublisher::Run(const std::atomic<bool>& stop) {
  pollfd fd{notify_fd_, POLLIN, 0};
  while (!stop.load(std::memory_order_relaxed)) {
    if (poll(&fd, 1, 50) > 0) {
      std::uint64_t count;
      [[maybe_unused]] const ssize_t n = read(notify_fd_, &count, sizeof count);
    }
    while (TickRecord* r = ring_.Front()) {
      Publish(*r);
      ring_.Pop();
    }
  }
}

void LcmPublisher::Drain() {
  while (TickRecord* r = ring_.Front()) {
    Publish(*r);
    ring_.Pop();
  }
  if (have_record_) PublishStatus(last_);
}

void LcmPublisher::Publish(const TickRecord& record) {
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    const InstanceRecord& r = record.instances[i];
    state_t& s = states_[i];
    s.utime = record.utime;
    s.tick = record.tick;
    s.t = r.t;
    const auto n = static_cast<std::size_t>(s.num_dofs);
    std::copy_n(r.q.data(), n, s.q.data());
    std::copy_n(r.qd.data(), n, s.qd.data());
    std::copy_n(r.qdd.data(), n, s.qdd.data());
    std::copy_n(r.tau.data(), n, s.tau.data());
    std::copy_n(r.q_des.data(), n, s.q_des.data());
    std::copy_n(r.qd_des.data(), n, s.qd_des.data());
    s.kinetic_energy = r.kinetic_energy;
    s.potential_energy = r.potential_energy;
    s.controller = controller_names_[i][static_cast<std::size_t>(r.controller)];
    s.mode = static_cast<int8_t>(r.mode);
    lcm_.publish(channels_.state[i], &s);
    ++states_published_;
  }
  LogEvents(record);
  WriteTiming(record);
  latencies_.push_back(static_cast<double>(record.wake_latency) * 1e-3);
  computes_.push_back(static_cast<double>(record.compute) * 1e-3);
  last_.tick = record.tick;
  last_.overruns = record.overruns;
  for (std::size_t i = 0; i < record.instances.size(); ++i) last_.instances[i].mode = record.instances[i].mode;
  have_record_ = true;
  if ((record.tick + 1) % status_every_ == 0) PublishStatus(record);
}

bool LcmPublisher::WriteTimingCsv(const std::string& path) {
  timing_csv_.open(path, std::ios::out | std::ios::trunc);
  if (!timing_csv_) return false;
  timing_csv_ << "tick,utime_us,wake_latency_ns,compute_ns,overruns\n";
  return true;
}

void LcmPublisher::WriteTiming(const TickRecord& record) {
  if (!timing_csv_.is_open()) return;
  timing_csv_ << record.tick << ',' << record.utime << ',' << record.wake_latency << ',' << record.compute << ','
              << record.overruns << '\n';
}

void LcmPublisher::LogEvents(const TickRecord& record) {
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    const InstanceRecord& r = record.instances[i];
    if (r.fault) spdlog::error("{}: fault at t = {:.3f} s: {}; zero torque, state frozen until reset", names_[i], r.t, r.fault);
    commands_applied_ += r.commands_accepted;
    if (r.commands_rejected > 0) {
      commands_refused_by_tick_ += r.commands_rejected;
      last_command_error_ = names_[i] + ": " + r.command_error;
      spdlog::warn("{}: command refused: {}", names_[i], r.command_error);
    }
    if (r.mode != modes_[i]) {
      const auto level = r.mode == Mode::kFault || r.mode == Mode::kEstop ? spdlog::level::warn : spdlog::level::info;
      spdlog::log(level, "{}: {} -> {} at t = {:.3f} s", names_[i], ToString(modes_[i]), ToString(r.mode), r.t);
      modes_[i] = r.mode;
    }
  }
}

void LcmPublisher::PublishStatus(const TickRecord& last) {
  status_t s;
  s.utime = last.utime;
  s.ticks = last.tick + 1;
  s.ticks_in_window = static_cast<int32_t>(latencies_.size());
  s.period = period_;
  s.wake_latency_max = latencies_.empty() ? 0.0 : *std::max_element(latencies_.begin(), latencies_.end());
  s.compute_max = computes_.empty() ? 0.0 : *std::max_element(computes_.begin(), computes_.end());
  s.wake_latency_p50 = Percentile(latencies_, 0.50);
  s.wake_latency_p99 = Percentile(latencies_, 0.99);
  s.compute_p50 = Percentile(computes_, 0.50);
  s.compute_p99 = Percentile(computes_, 0.99);
  latencies_.clear();
  computes_.clear();
  s.overruns = last.overruns;
  s.state_messages_dropped = loop_.records_dropped();
  s.setpoints_accepted = stats_.setpoints_accepted.load(std::memory_order_relaxed);
  s.setpoints_rejected = stats_.setpoints_rejected.load(std::memory_order_relaxed);
  if (const Reason* r = stats_.last_setpoint_rejection.Take()) last_setpoint_rejection_ = r->text.data();
  if (const Reason* r = stats_.last_command_error.Take()) last_command_error_ = r->text.data();
  s.last_rejection = last_setpoint_rejection_;
  // Accepted once the tick has applied it, so a status never counts a command the tick may still refuse.
  s.commands_accepted = commands_applied_;
  s.commands_rejected = stats_.commands_rejected.load(std::memory_order_relaxed) + commands_refused_by_tick_;
  s.last_command_error = last_command_error_;
  s.decode_errors = stats_.decode_errors.load(std::memory_order_relaxed);
  s.num_instances = static_cast<int32_t>(names_.size());
  s.instance_names = names_;
  for (const Mode m : modes_) s.instance_modes.push_back(static_cast<int8_t>(m));
  lcm_.publish(channels_.status, &s);
}

}  // namespace lagrange
