#include "daemon/publisher.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "daemon/timing_csv.hpp"
#include "plant/escape.hpp"
#include "protocol/status.hpp"

namespace lagrange {
namespace {

double Percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(std::min(k, v.size() - 1)), v.end());
  return v[std::min(k, v.size() - 1)];
}

}  // namespace

Publisher::Publisher(Bus& output, const ChannelNames& channels, Runtime& runtime, SpscRing<TickRecord>& ring,
                     const Loop& loop, ReceiverStats& stats, int notify_fd, std::int64_t run_id)
    : bus_(output),
      channels_(channels),
      ring_(ring),
      loop_(loop),
      stats_(stats),
      notify_fd_(notify_fd),
      run_id_(run_id),
      status_every_(std::max(1, static_cast<int>(std::lround(0.1 / runtime.period())))),
      period_(runtime.period()),
      last_(runtime.MakeRecord()) {
  for (std::size_t i = 0; i < runtime.size(); ++i) {
    Instance& inst = runtime.instance(i);
    names_.push_back(inst.name());
    controller_names_.push_back(inst.controller_names());
    state_t s;
    s.run_id = run_id_;
    s.num_dofs = inst.num_dofs();
    for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->resize(static_cast<std::size_t>(s.num_dofs));
    states_.push_back(s);
    torque_t tq{};
    tq.run_id = run_id_;
    tq.sequence = 0;
    tq.num_dofs = inst.num_dofs();
    tq.tau.resize(static_cast<std::size_t>(tq.num_dofs));
    torques_.push_back(tq);
    telemetry_t tm{};
    tm.run_id = run_id_;
    telemetry_.push_back(tm);
    forces_t f{};
    f.run_id = run_id_;
    f.num_dofs = inst.num_dofs();
    for (auto* v :
         {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.disturbance, &f.tau_cmd, &f.tau_applied}) {
      v->resize(static_cast<std::size_t>(f.num_dofs));
    }
    forces_.push_back(f);
    modes_.push_back(Mode::kRunning);
    reasons_.push_back(nullptr);
    dofs_.push_back(inst.num_dofs());
    for (const std::string& joint : JointNamesOf(inst.config().plant)) {
      joint_names_.push_back(Escape(joint, kMaxJointNameBytes));
    }
  }
  if (!StatusFits(names_, dofs_, joint_names_)) {
    spdlog::warn("the {} joint names do not fit in a {} status datagram: statuses carry none (num_joints = 0)",
                 joint_names_.size(), channels_.status);
    joint_names_.clear();
  }
  latencies_.reserve(static_cast<std::size_t>(status_every_) * 2);
  computes_.reserve(static_cast<std::size_t>(status_every_) * 2);
  reply_.run_id = run_id_;
}

void Publisher::Run(const std::atomic<bool>& stop) {
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

void Publisher::Drain() {
  while (TickRecord* r = ring_.Front()) {
    Publish(*r);
    ring_.Pop();
  }
  if (have_record_) PublishStatus(last_);
}

void Publisher::Publish(const TickRecord& record) {
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    const InstanceRecord& r = record.instances[i];
    if (r.publish_torque && !channels_.torque_out[i].empty()) {
      PublishTorque(i, r, record.utime);  // first: the external plant waits for it
    }
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
    bus_.PublishMessage(channels_.state[i], s);
    ++states_published_;
    if (r.telemetry) PublishTelemetry(i, r, record);
    if (r.publish_forces) PublishForces(i, r, record);
    PublishReplies(i, r, record.utime);
  }
  LogEvents(record);
  if (timing_ != nullptr) {
    timing_->Offer(record.tick, record.utime, record.wake_latency, record.compute, record.overruns);
  }
  latencies_.push_back(static_cast<double>(record.wake_latency) * 1e-3);
  computes_.push_back(static_cast<double>(record.compute) * 1e-3);
  last_.tick = record.tick;
  last_.utime = record.utime;
  last_.overruns = record.overruns;
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    last_.instances[i].mode = record.instances[i].mode;
    last_.instances[i].reason = record.instances[i].reason;
    last_.instances[i].integrator = record.instances[i].integrator;
    last_.instances[i].external_plant = record.instances[i].external_plant;
    last_.instances[i].method = record.instances[i].method;
    last_.instances[i].effects = record.instances[i].effects;
    last_.instances[i].forces_on = record.instances[i].forces_on;
  }
  have_record_ = true;
  if ((record.tick + 1) % status_every_ == 0) PublishStatus(record);
}

// (record) => torque_t on an external plant's torque_channel.
void Publisher::PublishTorque(std::size_t i, const InstanceRecord& r, std::int64_t utime) {
  torque_t& t = torques_[i];
  t.utime = utime;
  ++t.sequence;
  t.state_tick = r.state_tick;
  std::copy_n(r.tau.data(), t.tau.size(), t.tau.data());
  bus_.PublishMessage(channels_.torque_out[i], t);
}

// (record) => telemetry_t: the balance, the integrator's work, the instance's compute.
void Publisher::PublishTelemetry(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  telemetry_t& m = telemetry_[i];
  m.utime = record.utime;
  m.tick = record.tick;
  m.t = r.t;
  m.mode = static_cast<int8_t>(r.mode);
  m.energy = r.kinetic_energy + r.potential_energy;
  m.energy_residual = r.energy_residual;
  m.quadrature_bound = r.quadrature_bound;
  m.work = r.work;
  m.power = r.power;
  m.integrator = r.external_plant ? "none" : ToString(r.integrator.type);
  m.substeps = r.integrator.substeps;
  m.method = ToString(r.method);
  const IntegratorWork& w = r.integrator_work;
  const auto clamp32 = [](std::int64_t v) {
    return static_cast<std::int32_t>(std::min<std::int64_t>(v, std::numeric_limits<std::int32_t>::max()));
  };
  m.evaluations = clamp32(w.evaluations);
  m.steps_accepted = clamp32(w.accepted);
  m.steps_rejected = clamp32(w.rejected);
  m.newton_iterations = clamp32(w.newton_iterations);
  m.failures = clamp32(w.failures);
  m.error_estimate = std::isfinite(w.error_estimate) ? w.error_estimate : -1.0;  // NaN: none; never on the wire
  m.step = w.step;
  m.compute_us = static_cast<double>(r.compute) * 1e-3;
  bus_.PublishMessage(channels_.telemetry[i], m);
}

// (record) => forces_t.
void Publisher::PublishForces(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  forces_t& f = forces_[i];
  const EffectForces& e = r.forces;
  f.utime = record.utime;
  f.tick = record.tick;
  f.t = r.t;
  f.gravity_on = e.active.gravity;
  f.coriolis_on = e.active.coriolis;
  f.damping_on = e.active.damping;
  f.friction_on = e.active.friction;
  f.limits_on = e.active.limits;
  f.saturation_on = e.active.saturation;
  f.disturbance_on = e.active.disturbance;
  const auto n = static_cast<std::size_t>(f.num_dofs);
  std::copy_n(e.gravity.data(), n, f.gravity.data());
  std::copy_n(e.coriolis.data(), n, f.coriolis.data());
  std::copy_n(e.damping.data(), n, f.damping.data());
  std::copy_n(e.friction.data(), n, f.friction.data());
  std::copy_n(e.limits.data(), n, f.limits.data());
  std::copy_n(e.disturbance.data(), n, f.disturbance.data());
  std::copy_n(e.tau_cmd.data(), n, f.tau_cmd.data());
  std::copy_n(e.tau_applied.data(), n, f.tau_applied.data());
  bus_.PublishMessage(channels_.forces[i], f);
}

// (tick verdicts) => one reply_t each, within the reply budget.
void Publisher::PublishReplies(std::size_t i, const InstanceRecord& r, std::int64_t utime) {
  for (std::size_t k = 0; k < r.num_verdicts; ++k) {
    const Verdict& v = r.verdicts[k];
    if (!reply_budget_.Take(utime)) {
      stats_.replies_suppressed.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    reply_.utime = utime;
    reply_.request_id = v.request_id;
    reply_.command = static_cast<int8_t>(v.kind);
    reply_.accepted = v.error == nullptr;
    reply_.reason = v.error ? v.error : "";
    bus_.PublishMessage(channels_.reply[i], reply_);
  }
}

void Publisher::LogEvents(const TickRecord& record) {
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    const InstanceRecord& r = record.instances[i];
    if (r.fault)
      spdlog::error("{}: fault at t = {:.3f} s: {}; zero torque, state frozen until reset", names_[i], r.t, r.fault);
    commands_applied_ += r.commands_accepted;
    if (r.commands_accepted > 0 && spdlog::should_log(spdlog::level::debug)) {
      spdlog::debug("{}: {} command(s) applied at t = {:.3f} s", names_[i], r.commands_accepted, r.t);
    }
    if (r.commands_rejected > 0) {
      commands_refused_by_tick_ += r.commands_rejected;
      last_command_error_ = names_[i] + ": " + r.command_error;
      std::int64_t suppressed = 0;
      if (refusal_throttle_.Allow(record.utime, suppressed)) {
        spdlog::warn(
            "{}: command refused: {}{}", names_[i], r.command_error,
            suppressed > 0 ? fmt::format(" ({} more refusals since the last line, not logged)", suppressed) : "");
      }
    }
    if (r.mode != modes_[i] || r.reason != reasons_[i]) {
      const bool alarm = r.mode == Mode::kFault || r.mode == Mode::kEstop || r.mode == Mode::kStopped;
      spdlog::log(alarm ? spdlog::level::warn : spdlog::level::info, "{}: {} -> {} at t = {:.3f} s{}", names_[i],
                  ToString(modes_[i]), ToString(r.mode), r.t, r.reason ? fmt::format(" ({})", r.reason) : "");
      modes_[i] = r.mode;
      reasons_[i] = r.reason;
    }
  }
}

void Publisher::PublishStatus(const TickRecord& last) {
  status_t s;
  s.utime = last.utime;
  s.run_id = run_id_;
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
  s.torques_accepted = stats_.torques_accepted.load(std::memory_order_relaxed);
  s.torques_rejected = stats_.torques_rejected.load(std::memory_order_relaxed);
  s.measured_accepted = stats_.measured_accepted.load(std::memory_order_relaxed);
  s.measured_rejected = stats_.measured_rejected.load(std::memory_order_relaxed);
  if (const Reason* r = stats_.last_setpoint_rejection.Take()) last_setpoint_rejection_ = r->text.data();
  if (const Reason* r = stats_.last_command_error.Take()) last_command_error_ = r->text.data();
  s.last_rejection = last_setpoint_rejection_;
  // Accepted once the tick has applied it, so a status never counts a command the tick may still refuse.
  s.commands_accepted = commands_applied_;
  s.commands_rejected = stats_.commands_rejected.load(std::memory_order_relaxed) + commands_refused_by_tick_;
  s.last_command_error = last_command_error_;
  s.decode_errors = stats_.decode_errors.load(std::memory_order_relaxed);
  s.datagrams_dropped_kernel = stats_.datagrams_dropped_kernel.load(std::memory_order_relaxed);
  s.datagrams_malformed = stats_.datagrams_malformed.load(std::memory_order_relaxed);
  s.fragments_dropped = stats_.fragments_dropped.load(std::memory_order_relaxed);
  s.foreign_messages = stats_.foreign_messages.load(std::memory_order_relaxed);
  s.last_foreign_run_id = stats_.last_foreign_run_id.load(std::memory_order_relaxed);
  s.replies_suppressed = stats_.replies_suppressed.load(std::memory_order_relaxed);
  s.num_instances = static_cast<int32_t>(names_.size());
  s.instance_names = names_;
  for (const Mode m : modes_) s.instance_modes.push_back(static_cast<int8_t>(m));
  s.instance_dofs = dofs_;
  for (const InstanceRecord& r : last.instances) {
    s.instance_reasons.emplace_back(r.reason ? r.reason : "");
    s.instance_integrators.push_back(IntegratorDescription(r.integrator, r.external_plant));
    s.instance_methods.emplace_back(ToString(r.method));
    s.instance_effects.push_back(EffectsDescription(r.effects));
    s.instance_forces.push_back(r.forces_on);
  }
  s.num_joints = static_cast<int32_t>(joint_names_.size());
  s.joint_names = joint_names_;
  bus_.PublishMessage(channels_.status, s);
}

}  // namespace lagrange
