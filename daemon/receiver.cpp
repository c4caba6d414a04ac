#include "daemon/receiver.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "base/escape.hpp"
#include "protocol/command_check.hpp"
#include "protocol/receive.hpp"
#include "protocol/setpoint_check.hpp"

namespace lagrange {

void Reason::Set(const std::string& s) {
  const std::size_t n = std::min(s.size(), text.size() - 1);
  std::copy_n(s.data(), n, text.data());
  text[n] = '\0';
}

Receiver::Receiver(Bus& input, Bus* output_listener, Bus& replies, Runtime& runtime, Clock& clock, ReceiverStats& stats,
                   SetpointAge age, std::int64_t run_id)
    : input_(input),
      output_listener_(output_listener),
      replies_(replies),
      runtime_(runtime),
      model_(runtime.model()),
      clock_(clock),
      stats_(stats),
      age_(age),
      run_id_(run_id),
      data_(model_.instances.size()) {
  stats_.bus_signed = input_.signs();
  for (std::size_t i = 0; i < model_.instances.size(); ++i) {
    const InstanceChannelNames& c = model_.instances[i].channels;
    Listen(input_, c.setpoint,
           [this, i](std::string_view, const std::uint8_t* d, std::size_t n) { HandleSetpoint(i, d, n); });
    Listen(input_, c.pose, [this, i](std::string_view, const std::uint8_t* d, std::size_t n) { HandlePose(i, d, n); });
    Listen(input_, c.command,
           [this, i](std::string_view, const std::uint8_t* d, std::size_t n) { HandleCommand(i, d, n); });
    if (!c.torque_in.empty() && model_.instances[i].external_controller >= 0) {
      Listen(input_, c.torque_in,
             [this, i](std::string_view, const std::uint8_t* d, std::size_t n) { HandleTorque(i, d, n); });
    }
    if (!c.measured_in.empty()) {
      Listen(input_, c.measured_in,
             [this, i](std::string_view, const std::uint8_t* d, std::size_t n) { HandleMeasured(i, d, n); });
    }
  }
  if (output_listener_ != nullptr) {
    std::vector<std::string> outputs = {model_.status_channel};
    for (const InstanceModel& m : model_.instances) {
      for (const std::string* ch :
           {&m.channels.state, &m.channels.reply, &m.channels.telemetry, &m.channels.forces, &m.channels.task,
            &m.channels.mpc, &m.channels.torque_out}) {
        if (!ch->empty()) outputs.push_back(*ch);
      }
    }
    for (const std::string& ch : outputs) {
      Listen(*output_listener_, ch,
             [this](std::string_view name, const std::uint8_t* d, std::size_t n) { HandleOwnOutput(name, d, n); });
    }
  }
  reply_.run_id = run_id_;
}

namespace {

// s: an instance's timeouts as the scene gave them (the receiver judges ages in seconds).
double TorqueTimeout(const InstanceModel& m) {
  return m.controllers[static_cast<std::size_t>(m.external_controller)].config.external.torque_timeout;
}
double StateTimeout(const InstanceModel& m) { return m.config.external->state_timeout; }

}  // namespace

void Receiver::Run(const std::atomic<bool>& stop) {
  while (!stop.load(std::memory_order_relaxed)) Poll(20);
}

void Receiver::Poll(int timeout_ms) {
  Bus* second = output_listener_ == &input_ ? nullptr : output_listener_;
  pollfd fds[2];
  nfds_t n = 0;
  if (input_.fd() >= 0) fds[n++] = {input_.fd(), POLLIN, 0};
  if (second != nullptr && second->fd() >= 0) fds[n++] = {second->fd(), POLLIN, 0};
  if (n > 0) {
    poll(fds, n, timeout_ms);
  } else if (timeout_ms > 0) {
    usleep(static_cast<useconds_t>(timeout_ms) * 1000);  // in-process buses: nothing to wait on, and no spinning
  }
  input_.Drain();
  if (second != nullptr) second->Drain();
  UpdateBusStats();
}

void Receiver::Listen(Bus& bus, const std::string& channel, Bus::Handler handler) {
  bus.Subscribe(channel, std::move(handler));
  if (std::find(stats_.channels.begin(), stats_.channels.end(), channel) != stats_.channels.end()) return;
  stats_.channels.push_back(channel);
  stats_.unauthenticated.emplace_back(0);
}

void Receiver::UpdateBusStats() {
  std::int64_t unauthenticated = 0;
  const bool listener_apart = output_listener_ != nullptr && output_listener_ != &input_;
  for (std::size_t k = 0; k < stats_.channels.size(); ++k) {
    const std::string& channel = stats_.channels[k];
    const std::int64_t n =
        input_.unauthenticated_on(channel) + (listener_apart ? output_listener_->unauthenticated_on(channel) : 0);
    stats_.unauthenticated[k].store(n, std::memory_order_relaxed);
    unauthenticated += n;
  }
  stats_.datagrams_unauthenticated.store(unauthenticated, std::memory_order_relaxed);
  BusStats total = input_.stats();
  if (output_listener_ != nullptr && output_listener_ != &input_) {
    const BusStats out = output_listener_->stats();
    total.kernel_drops += out.kernel_drops;
    total.malformed += out.malformed;
    total.oversized += out.oversized;
    total.fragments_dropped += out.fragments_dropped;
  }
  // Signed before bus domains: refused like any unauthenticated datagram, but named once (the sender needs updating).
  total.old_format += listener_apart ? output_listener_->stats().old_format : 0;
  std::int64_t held = 0;
  if (total.old_format > old_format_said_ && old_format_throttle_.Allow(clock_.WallMicros(), held)) {  // 1 line/s
    spdlog::warn("{} datagram(s) signed in lagrange's old format (LGS1, before bus domains) refused: update their "
                 "senders (README, \"Signed traffic\")",
                 total.old_format - old_format_said_);
    old_format_said_ = total.old_format;
  }
  stats_.datagrams_dropped_kernel.store(total.kernel_drops, std::memory_order_relaxed);
  stats_.datagrams_malformed.store(total.malformed + total.oversized, std::memory_order_relaxed);
  stats_.fragments_dropped.store(total.fragments_dropped, std::memory_order_relaxed);
}

// A flood of bad packets must not become a flood of log lines.
void Receiver::Warn(const std::string& message) {
  std::int64_t suppressed = 0;
  if (!log_throttle_.Allow(clock_.WallMicros(), suppressed)) return;
  if (suppressed > 0) {
    spdlog::warn("{} ({} more refusals or decode errors since the last line, not logged)", message, suppressed);
  } else {
    spdlog::warn("{}", message);
  }
}

// Counts a refusal and keeps its reason for the status.
void Receiver::Refuse(std::atomic<std::int64_t>& counter, LatestMailbox<Reason>& last, std::size_t i,
                      const std::string& why) {
  counter.fetch_add(1, std::memory_order_relaxed);
  last.back().Set(model_.instances[i].name() + ": " + why);
  last.Publish();
}

void Receiver::DecodeError(const std::string& channel, const char* why) {
  stats_.decode_errors.fetch_add(1, std::memory_order_relaxed);
  Warn(channel + ": dropped a packet that is not a valid message: " + why);
}

void Receiver::RejectSetpoint(std::size_t i, const std::string& why) {
  Refuse(stats_.setpoints_rejected, stats_.last_setpoint_rejection, i, why);
  Warn(model_.instances[i].name() + ": setpoint rejected: " + why);
}

// `why` is already escaped where it quotes the bus.
void Receiver::RejectCommand(std::size_t i, const std::string& why) {
  Refuse(stats_.commands_rejected, stats_.last_command_error, i, why);
  Warn(model_.instances[i].name() + ": command rejected: " + why);
  const std::int64_t now = clock_.WallMicros();
  if (!reply_budget_.Take(now)) {
    stats_.replies_suppressed.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  reply_.utime = now;
  reply_.request_id = command_.request_id;
  reply_.command = command_.command;
  reply_.accepted = false;
  reply_.reason = why;
  replies_.PublishMessage(model_.instances[i].channels.reply, reply_);
}

namespace {

// a − b, saturating: hostile timestamps near ±2^63 must not overflow.
std::int64_t SaturatingSub(std::int64_t a, std::int64_t b) {
  if (b < 0 && a > INT64_MAX + b) return INT64_MAX;
  if (b > 0 && a < INT64_MIN + b) return INT64_MIN;
  return a - b;
}

}  // namespace

Receiver::AgeVerdict Receiver::Age(Timeline& info, double timeout, std::int64_t utime) {
  const std::int64_t now = clock_.WallMicros();
  const std::int64_t timeout_us = ToMicroseconds(timeout);
  const std::int64_t offset = SaturatingSub(now, utime);
  AgeVerdict v;
  if (age_ == SetpointAge::kWall) {
    v.age = static_cast<double>(offset) * 1e-6;
    v.ok = v.age <= timeout && v.age >= -timeout;
    return v;
  }
  const bool new_stream = info.last_arrival < 0 || now - info.last_arrival > timeout_us;
  const std::int64_t behind = SaturatingSub(offset, info.least_offset);  // < 0: ahead of the timeline
  if (!new_stream && (behind > timeout_us || behind < -timeout_us)) {
    // Out of line with the stream's timeline by more than the timeout: one bad
    // timestamp, a stale packet, or a timeline that really moved (the sender's
    // clock jumped; a forged first packet set the timeline). It moves the
    // timeline only when kStreamConfirmations such packets in a row agree with
    // one another, with no in-line packet between them.
    const bool agrees =
        info.candidate_count > 0 &&
        std::abs(static_cast<double>(SaturatingSub(offset, info.candidate_offset))) <= static_cast<double>(timeout_us);
    info.candidate_count = agrees ? info.candidate_count + 1 : 1;
    if (!agrees) info.candidate_offset = offset;
    if (info.candidate_count < kStreamConfirmations) {
      v.ok = false;
      if (behind < 0) v.out_of_line = "timestamp out of line with its stream (ahead by more than setpoint_timeout)";
      v.age = static_cast<double>(behind) * 1e-6;
      return v;
    }
    info.least_offset = offset;  // confirmed: the timeline moved
  }
  info.candidate_count = 0;
  if (new_stream || offset < info.least_offset) info.least_offset = offset;
  v.age = static_cast<double>(offset - info.least_offset) * 1e-6;
  v.ok = v.age <= timeout;
  if (v.ok) info.last_arrival = now;
  return v;
}

void Receiver::HandleSetpoint(std::size_t i, const std::uint8_t* data, std::size_t size) {
  const InstanceModel& m = model_.instances[i];
  InstanceData& info = data_[i];
  const SetpointVerdict verdict = CheckSetpoint(data, size, m.setpoint_rules, setpoint_);
  if (verdict.kind == SetpointVerdict::Kind::kUndecodable) {
    DecodeError(m.channels.setpoint, verdict.reason.c_str());
    return;
  }
  if (std::string why = Refusal(i, TargetKind::kJointSetpoint); !why.empty()) return RejectSetpoint(i, why);
  if (verdict.kind == SetpointVerdict::Kind::kRejected) {
    RejectSetpoint(i, verdict.reason);
    return;
  }
  const AgeVerdict age = Age(info.setpoints, m.config.setpoint_timeout, setpoint_.utime);
  if (!age.ok) {
    // Refused and counted; it does not send the instance to hold (only the timeout does).
    return RejectSetpoint(i, AgeReason(age, "setpoint_timeout", m.config.setpoint_timeout));
  }
  SetpointMessage& msg = runtime_.channels(i).setpoints.back();
  msg.setpoint.q = Eigen::Map<const VectorXd>(setpoint_.q.data(), m.num_dofs);
  msg.setpoint.qd = Eigen::Map<const VectorXd>(setpoint_.qd.data(), m.num_dofs);
  msg.setpoint.qdd = Eigen::Map<const VectorXd>(setpoint_.qdd.data(), m.num_dofs);
  runtime_.channels(i).setpoints.Publish();
  stats_.setpoints_accepted.fetch_add(1, std::memory_order_relaxed);
}

const ControllerModel& Receiver::ActiveController(std::size_t i) const {
  const int active = runtime_.channels(i).active_controller.load(std::memory_order_acquire);
  return model_.instances[i].controllers[static_cast<std::size_t>(active)];
}

// Whether the active controller follows a `kind` target (protocol/setpoint_check.hpp's one rule).
std::string Receiver::Refusal(std::size_t i, TargetKind kind) const {
  const ControllerModel& c = ActiveController(i);
  return RefusedByController(kind, !c.pose_rules.frame.empty(), c.name);
}

std::string Receiver::AgeReason(const AgeVerdict& age, const char* timeout_name, double timeout) {
  if (age.out_of_line) return age.out_of_line;
  return age.age > 0 ? fmt::format("stale: sent {:.6g} s ago ({} {:.6g} s)", age.age, timeout_name, timeout)
                     : fmt::format("timestamp {:.6g} s in the future (clocks out of step?)", -age.age);
}

// A pose setpoint, checked against the active controller's rules (its frame,
// the workspace), counted with the setpoints.
void Receiver::HandlePose(std::size_t i, const std::uint8_t* data, std::size_t size) {
  const InstanceModel& m = model_.instances[i];
  const ControllerModel& controller = ActiveController(i);
  const SetpointVerdict verdict = CheckPoseSetpoint(data, size, controller.pose_rules, pose_);
  if (verdict.kind == SetpointVerdict::Kind::kUndecodable) return DecodeError(m.channels.pose, verdict.reason.c_str());
  std::atomic<std::int64_t>& rejected = stats_.setpoints_rejected;
  if (std::string why = Refusal(i, TargetKind::kPose); !why.empty()) return RejectInput(i, rejected, "pose", why);
  if (verdict.kind == SetpointVerdict::Kind::kRejected) return RejectInput(i, rejected, "pose", verdict.reason);
  const AgeVerdict age = Age(data_[i].poses, m.config.setpoint_timeout, pose_.utime);
  if (!age.ok) return RejectInput(i, rejected, "pose", AgeReason(age, "setpoint_timeout", m.config.setpoint_timeout));
  PoseMessage& msg = runtime_.channels(i).poses.back();
  msg.target.position = Eigen::Map<const Eigen::Vector3d>(pose_.position);
  msg.target.orientation =
      Eigen::Quaterniond(pose_.orientation[0], pose_.orientation[1], pose_.orientation[2], pose_.orientation[3])
          .normalized();
  msg.twist = Eigen::Map<const Vector6d>(pose_.twist);
  msg.duration = pose_.duration;
  runtime_.channels(i).poses.Publish();
  stats_.setpoints_accepted.fetch_add(1, std::memory_order_relaxed);
}

void Receiver::RejectInput(std::size_t i, std::atomic<std::int64_t>& counter, const char* what,
                           const std::string& why) {
  Refuse(counter, stats_.last_setpoint_rejection, i, std::string(what) + ": " + why);
  Warn(model_.instances[i].name() + ": " + what + " rejected: " + why);
}

// The first problem since the tick last looked stays: a good state after a bad one cannot hide it.
void Receiver::Trip(std::size_t i, MeasuredProblem problem, const std::string& why) {
  std::uint8_t none = 0;
  runtime_.channels(i).measured_problem.compare_exchange_strong(none, static_cast<std::uint8_t>(problem),
                                                                std::memory_order_acq_rel);
  RejectInput(i, stats_.measured_rejected, "measured state", why);
}

namespace {

// The first non-finite or out-of-range value of `v` (|x| <= bound), as a reason; "" when none.
std::string CheckValues(const char* field, const std::vector<double>& v, double bound) {
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!std::isfinite(v[k])) return fmt::format("non-finite value in {}[{}]", field, k);
    if (std::abs(v[k]) > bound)
      return fmt::format("{}[{}] = {:.6g} is out of range (|x| <= {:.0e})", field, k, v[k], bound);
  }
  return "";
}

}  // namespace

// (torque_t) => the external controller's mailbox: checked like a setpoint
// (layout, size, finite, |tau| <= 1e6, age), and one sender at a time whose
// sequence grows.
void Receiver::HandleTorque(std::size_t i, const std::uint8_t* data, std::size_t size) {
  const InstanceModel& m = model_.instances[i];
  InstanceData& info = data_[i];
  if (const Drop d = ReceiveInto(torque_, data, size); d != Drop::kNone)
    return DecodeError(m.channels.torque_in, ToString(d));
  std::atomic<std::int64_t>& rejected = stats_.torques_rejected;
  if (torque_.num_dofs != m.num_dofs) {
    return RejectInput(i, rejected, "torque", fmt::format("num_dofs is {}, expected {}", torque_.num_dofs, m.num_dofs));
  }
  if (std::string why = CheckValues("tau", torque_.tau, kMaxSetpointMagnitude); !why.empty()) {
    return RejectInput(i, rejected, "torque", why);
  }
  const int active = runtime_.channels(i).active_controller.load(std::memory_order_acquire);
  if (active != m.external_controller) {
    return RejectInput(i, rejected, "torque",
                       NotRunningExternalReason(m.command_rules.controllers[static_cast<std::size_t>(active)]));
  }
  if (torque_.run_id == 0) return RejectInput(i, rejected, "torque", "run_id 0: expected the sender's non-zero id");
  // One sender at a time: while the current stream is fresh (a torque within
  // torque_timeout), another run_id is refused and the sequence must grow;
  // once it has lapsed, any sender starts a new stream.
  const std::int64_t now = clock_.WallMicros();
  const bool current_fresh = info.torque_source != 0 && now - info.torque_last_us <= ToMicroseconds(TorqueTimeout(m));
  if (current_fresh && torque_.run_id != info.torque_source) {
    return RejectInput(
        i, rejected, "torque",
        fmt::format("from a second sender (run_id {:016x}) while {:016x} streams",
                    static_cast<std::uint64_t>(torque_.run_id), static_cast<std::uint64_t>(info.torque_source)));
  }
  if (current_fresh && torque_.sequence <= info.torque_sequence) {
    return RejectInput(i, rejected, "torque",
                       fmt::format("sequence {} does not grow (last {}): a duplicate or reordered packet",
                                   torque_.sequence, info.torque_sequence));
  }
  const AgeVerdict age = Age(info.torques, TorqueTimeout(m), torque_.utime);
  if (!age.ok) return RejectInput(i, rejected, "torque", AgeReason(age, "torque_timeout", TorqueTimeout(m)));
  info.torque_source = torque_.run_id;
  info.torque_sequence = torque_.sequence;
  info.torque_last_us = now;
  TorqueMessage& msg = runtime_.channels(i).torques.back();
  msg.tau = Eigen::Map<const VectorXd>(torque_.tau.data(), m.num_dofs);
  msg.sent = clock_.Now() - ToNanoseconds(std::max(age.age, 0.0));
  runtime_.channels(i).torques.Publish();
  stats_.torques_accepted.fetch_add(1, std::memory_order_relaxed);
}

// (state_t) => an external plant's measured state, or a watchdog trip: the
// wrong size, a non-finite (or |x| > 1e6) q or qd, or a run id other than the
// previous packet's trip it; a stale one, or one whose tick does not grow (a
// duplicate, a reordered packet), is refused and counted (the absence of
// fresh ones trips the watchdog once state_timeout passes).
void Receiver::HandleMeasured(std::size_t i, const std::uint8_t* data, std::size_t size) {
  const InstanceModel& m = model_.instances[i];
  InstanceData& info = data_[i];
  if (const Drop d = ReceiveInto(measured_, data, size); d != Drop::kNone) {
    return DecodeError(m.channels.measured_in, ToString(d));
  }
  if (measured_.num_dofs != m.num_dofs) {
    return Trip(i, MeasuredProblem::kWrongSize,
                fmt::format("num_dofs is {}, expected {}", measured_.num_dofs, m.num_dofs));
  }
  for (const auto& [field, values] : {std::pair{"q", &measured_.q}, std::pair{"qd", &measured_.qd}}) {
    if (std::string why = CheckValues(field, *values, kMaxSetpointMagnitude); !why.empty()) {
      return Trip(i, MeasuredProblem::kNotFinite, why);
    }
  }
  if (measured_.run_id == 0) {  // the watchdog locks onto a source by its id: 0 would lock onto nothing
    return RejectInput(i, stats_.measured_rejected, "measured state", "run_id 0: expected the sender's non-zero id");
  }
  const std::int64_t previous = info.measured_source;
  info.measured_source = measured_.run_id;
  if (previous != 0 && measured_.run_id != previous) {
    return Trip(i, MeasuredProblem::kSecondSource,
                fmt::format("from run_id {:016x} after {:016x}: a second source, or the plant restarted",
                            static_cast<std::uint64_t>(measured_.run_id), static_cast<std::uint64_t>(previous)));
  }
  // Within one fresh stream the tick must grow; after a lapse of state_timeout any tick starts a new one.
  const std::int64_t arrival = clock_.WallMicros();
  const bool fresh_stream =
      info.measured_last_us >= 0 && arrival - info.measured_last_us <= ToMicroseconds(StateTimeout(m));
  if (fresh_stream && previous == measured_.run_id && measured_.tick <= info.measured_tick) {
    return RejectInput(i, stats_.measured_rejected, "measured state",
                       fmt::format("tick {} does not grow (last {}): a duplicate or reordered state", measured_.tick,
                                   info.measured_tick));
  }
  const AgeVerdict age = Age(info.measured, StateTimeout(m), measured_.utime);
  if (!age.ok) {
    return RejectInput(i, stats_.measured_rejected, "measured state", AgeReason(age, "state_timeout", StateTimeout(m)));
  }
  info.measured_tick = measured_.tick;
  info.measured_last_us = arrival;
  MeasuredMessage& msg = runtime_.channels(i).measured.back();
  msg.q = Eigen::Map<const VectorXd>(measured_.q.data(), m.num_dofs);
  msg.qd = Eigen::Map<const VectorXd>(measured_.qd.data(), m.num_dofs);
  msg.tick = measured_.tick;
  msg.run_id = measured_.run_id;
  msg.arrived = clock_.Now();
  msg.sent = msg.arrived - ToNanoseconds(std::max(age.age, 0.0));
  runtime_.channels(i).measured.Publish();
  stats_.measured_accepted.fetch_add(1, std::memory_order_relaxed);
}

void Receiver::HandleCommand(std::size_t i, const std::uint8_t* data, std::size_t size) {
  const InstanceModel& m = model_.instances[i];
  const int active = runtime_.channels(i).active_controller.load(std::memory_order_acquire);
  const CommandVerdict v = CheckCommand(data, size, m.command_rules, active, command_);
  if (v.kind == CommandVerdict::Kind::kUndecodable) return DecodeError(m.channels.command, v.reason.c_str());
  if (v.kind == CommandVerdict::Kind::kRejected) return RejectCommand(i, v.reason);
  if (const std::optional<Urgent> urgent = UrgentKind(v.command)) {
    runtime_.PostUrgent(i, *urgent, command_.request_id);  // never refused for room; the tick decides
    return;
  }
  CommandMessage* slot = runtime_.channels(i).commands.BeginPush();
  if (slot == nullptr) return RejectCommand(i, "the command queue is full");
  slot->kind = v.command;
  slot->utime = command_.utime;
  slot->request_id = command_.request_id;
  slot->controller = v.controller;
  if (v.command == CommandKind::kSetGains) {
    // num_gains was checked: n, or 6 for a task-space controller (the slot then resizes, here, off the tick).
    slot->gains.kp = Eigen::Map<const VectorXd>(command_.kp.data(), command_.num_gains);
    slot->gains.kd = Eigen::Map<const VectorXd>(command_.kd.data(), command_.num_gains);
  }
  slot->integrator = v.integrator;
  slot->default_max_steps = v.default_max_steps;
  slot->effect = v.effect;
  slot->method = v.method;
  slot->on = v.on;
  runtime_.channels(i).commands.Push();  // the tick applies or refuses it; its record says which
}

// A message on one of this run's output channels: ours (our own multicast,
// looped back), or another publisher's.
void Receiver::HandleOwnOutput(std::string_view channel, const std::uint8_t* data, std::size_t size) {
  const std::optional<std::int64_t> id = RunIdOf(data, size);
  const bool ours_type = id.has_value();
  const std::int64_t run_id = id.value_or(0);
  if (ours_type && run_id == run_id_) return;
  stats_.foreign_messages.fetch_add(1, std::memory_order_relaxed);
  stats_.last_foreign_run_id.store(ours_type ? run_id : 0, std::memory_order_relaxed);
  std::int64_t suppressed = 0;
  if (!foreign_throttle_.Allow(clock_.WallMicros(), suppressed)) return;
  spdlog::warn("another publisher on {} (run id {:016x}{}): a second lagranged or a spoofer shares this bus{}",
               Escape(channel, 64), static_cast<std::uint64_t>(run_id), ours_type ? "" : ", not a lagrange message",
               suppressed > 0 ? fmt::format(" ({} more such messages since the last line)", suppressed) : "");
}

}  // namespace lagrange
