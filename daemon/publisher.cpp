#include "daemon/publisher.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "base/escape.hpp"
#include "daemon/timing_csv.hpp"
#include "protocol/status.hpp"
#include "protocol/wire.hpp"

namespace lagrange {
namespace {

// A status figure: nearest rank (protocol/status.hpp), 0 for an empty window.
double Percentile(std::vector<double>& v, double p) { return v.empty() ? 0.0 : NearestRankPercentile(v, p); }

// What a work-bound refusal quotes, as the scene's refusal does.
std::string WorkFiguresText(const WorkFigures& w) {
  std::string text =
      fmt::format(": the worst case would be {:.4g} ms per tick, {:.4g} ms fit", w.worst_s * 1e3, w.budget_s * 1e3);
  if (w.max_steps_fit > 0) text += fmt::format("; at most {} max_steps fit", w.max_steps_fit);
  if (w.max_steps_fit == 0) text += "; no max_steps fits";
  return text;
}

}  // namespace

Publisher::Publisher(Bus& output, const Runtime& runtime, SpscRing<TickRecord>& ring, const Loop& loop,
                     ReceiverStats& stats, int notify_fd, std::int64_t run_id)
    : bus_(output),
      model_(runtime.model()),
      ring_(ring),
      loop_(loop),
      stats_(stats),
      notify_fd_(notify_fd),
      run_id_(run_id),
      status_every_(std::max(1, static_cast<int>(std::lround(0.1 / model_.period)))),
      last_(runtime.MakeRecord()) {
  status_ = status_t{};
  status_.run_id = run_id_;
  status_.period = model_.period;
  for (const InstanceModel& m : model_.instances) {
    const auto n = static_cast<std::size_t>(m.num_dofs);
    Outgoing o;
    o.state.run_id = run_id_;
    o.state.num_dofs = m.num_dofs;
    for (auto* v : {&o.state.q, &o.state.qd, &o.state.qdd, &o.state.tau, &o.state.q_des, &o.state.qd_des}) v->resize(n);
    o.torque.run_id = run_id_;
    o.torque.num_dofs = m.num_dofs;
    o.torque.tau.resize(n);
    o.telemetry.run_id = run_id_;
    o.task.run_id = run_id_;
    o.base.run_id = run_id_;
    o.mpc.run_id = run_id_;
    o.mpc.num_states = 2 * m.num_dofs;
    if (const std::optional<std::size_t> k = FirstMpc(m)) {  // the first mpc controller's, as the tick's record
      const ControllerModel& c = m.controllers[*k];
      o.mpc.controller = c.name;
      o.mpc.num_knots = MpcKnotsOnWire(o.mpc.num_states, c.config.mpc.horizon);
    }
    o.mpc.status.reserve(32);  // every ToString(DdpStatus) fits: no allocation per plan
    o.mpc.knot_t.resize(static_cast<std::size_t>(o.mpc.num_knots));
    o.mpc.knot_x.assign(static_cast<std::size_t>(o.mpc.num_knots), std::vector<double>(2 * n));
    o.forces.run_id = run_id_;
    o.forces.num_dofs = m.num_dofs;
    for (auto* v : {&o.forces.gravity, &o.forces.coriolis, &o.forces.damping, &o.forces.friction, &o.forces.limits,
                    &o.forces.constraint, &o.forces.disturbance, &o.forces.tau_cmd, &o.forces.tau_applied}) {
      v->resize(n);
    }
    o.forces.contacts.reserve(kMaxContacts);  // a tick's contacts resize within it: no allocation
    out_.push_back(std::move(o));
    status_.instance_names.push_back(m.name());
    status_.instance_dofs.push_back(m.num_dofs);
    for (const std::string& joint : m.joint_names) status_.joint_names.push_back(Escape(joint, kMaxJointNameBytes));
  }
  status_.num_instances = static_cast<std::int32_t>(status_.instance_names.size());
  if (!StatusFits(status_.instance_names, status_.instance_dofs, status_.joint_names)) {
    spdlog::warn("the {} joint names do not fit in a {} status datagram: statuses carry none (num_joints = 0)",
                 status_.joint_names.size(), model_.status_channel);
    status_.joint_names.clear();
  }
  status_.num_joints = static_cast<std::int32_t>(status_.joint_names.size());
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
    if (r.publish_torque && !model_.instances[i].channels.torque_out.empty()) {
      PublishTorque(i, r, record.utime);  // first: the external plant waits for it
    }
    state_t& s = out_[i].state;
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
    s.controller = model_.instances[i].controllers[static_cast<std::size_t>(r.controller)].name;
    s.mode = static_cast<int8_t>(r.mode);
    bus_.PublishMessage(model_.instances[i].channels.state, s);
    ++states_published_;
    if (r.telemetry) PublishTelemetry(i, r, record);
    if (r.publish_forces) PublishForces(i, r, record);
    if (r.task) PublishTask(i, r, record);
    if (r.base) PublishBase(i, r, record);
    if (r.plan.taken) PublishMpc(i, r, record);
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
    last_.instances[i].mujoco_integrator = record.instances[i].mujoco_integrator;
    last_.instances[i].method = record.instances[i].method;
    last_.instances[i].effects = record.instances[i].effects;
    last_.instances[i].forces_on = record.instances[i].forces_on;
    last_.instances[i].residual_exceeded = record.instances[i].residual_exceeded;
    last_.instances[i].energy_residual = record.instances[i].energy_residual;
  }
  have_record_ = true;
  if ((record.tick + 1) % status_every_ == 0) PublishStatus(record);
}

// (record) => torque_t on an external plant's torque_channel.
void Publisher::PublishTorque(std::size_t i, const InstanceRecord& r, std::int64_t utime) {
  torque_t& t = out_[i].torque;
  t.utime = utime;
  ++t.sequence;
  t.state_tick = r.state_tick;
  std::copy_n(r.tau.data(), t.tau.size(), t.tau.data());
  bus_.PublishMessage(model_.instances[i].channels.torque_out, t);
}

// (record) => base_state_t: a floating base's pose, twist, centre of mass and momentum.
void Publisher::PublishBase(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  base_state_t& m = out_[i].base;
  m.utime = record.utime;
  m.tick = record.tick;
  m.t = r.t;
  std::copy_n(r.base_q.data(), 3, m.position);
  std::copy_n(r.base_q.data() + 3, 4, m.orientation);
  std::copy_n(r.base_v.data(), 3, m.linear_velocity);
  std::copy_n(r.base_v.data() + 3, 3, m.angular_velocity);
  std::copy_n(r.base_motion.com.data(), 3, m.com);
  std::copy_n(r.base_motion.linear.data(), 3, m.linear_momentum);
  std::copy_n(r.base_motion.angular.data(), 3, m.angular_momentum);
  bus_.PublishMessage(model_.instances[i].channels.base, m);
}

// (record) => task_state_t: the active task-space controller's frame, measured and commanded.
void Publisher::PublishTask(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  const ControllerModel& c = model_.instances[i].controllers[static_cast<std::size_t>(r.controller)];
  task_state_t& m = out_[i].task;
  m.utime = record.utime;
  m.tick = record.tick;
  m.t = r.t;
  m.frame = c.pose_rules.frame;
  m.controller = c.name;
  const auto put_pose = [](const Pose& pose, double* position, double* orientation) {
    std::copy_n(pose.position.data(), 3, position);
    orientation[0] = pose.orientation.w();
    orientation[1] = pose.orientation.x();
    orientation[2] = pose.orientation.y();
    orientation[3] = pose.orientation.z();
  };
  put_pose(r.task_pose, m.position, m.orientation);
  put_pose(r.task_commanded, m.position_des, m.orientation_des);
  std::copy_n(r.task_error.data(), 6, m.error);
  std::copy_n(r.task_twist.data(), 6, m.twist);
  bus_.PublishMessage(model_.instances[i].channels.task, m);
}

// (record) => mpc_t: the plan the tick took, its figures and knots; its age when taken.
void Publisher::PublishMpc(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  const PlanRecord& p = r.plan;
  mpc_t& m = out_[i].mpc;
  if (p.knot_t.size() != m.num_knots) return;  // not the plans this instance was built for: never sent malformed
  m.utime = record.utime;
  m.tick = record.tick;
  m.t = r.t;
  m.plan = p.sequence;
  m.start = p.start;
  m.age = r.t - p.start;
  m.solve_time = p.solve_time;
  m.iterations = p.iterations;
  m.cost_before = p.cost_before;
  m.cost = p.cost;
  m.status = ToString(p.status);
  m.followed = p.followed;
  m.dt = p.dt;
  m.horizon = p.horizon;
  for (std::size_t j = 0; j < m.knot_t.size(); ++j) {
    m.knot_t[j] = p.knot_t[static_cast<Eigen::Index>(j)];
    std::copy_n(p.knot_x.col(static_cast<Eigen::Index>(j)).data(), m.num_states, m.knot_x[j].data());
  }
  bus_.PublishMessage(model_.instances[i].channels.mpc, m);
}

// (record) => telemetry_t: the balance, the integrator's work, the instance's compute.
void Publisher::PublishTelemetry(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  telemetry_t& m = out_[i].telemetry;
  m.utime = record.utime;
  m.tick = record.tick;
  m.t = r.t;
  m.mode = static_cast<int8_t>(r.mode);
  m.energy = r.kinetic_energy + r.potential_energy;
  m.energy_residual = r.energy_residual;
  m.quadrature_bound = r.quadrature_bound;
  m.work = r.work;
  m.power = r.power;
  m.integrator = IntegratorName(r.integrator.type, r.external_plant, r.mujoco_integrator);
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
  bus_.PublishMessage(model_.instances[i].channels.telemetry, m);
}

// (record) => forces_t.
void Publisher::PublishForces(std::size_t i, const InstanceRecord& r, const TickRecord& record) {
  forces_t& f = out_[i].forces;
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
  f.constraint_on = e.constraint_on;
  const auto n = static_cast<std::size_t>(f.num_dofs);
  std::copy_n(e.gravity.data(), n, f.gravity.data());
  std::copy_n(e.coriolis.data(), n, f.coriolis.data());
  std::copy_n(e.damping.data(), n, f.damping.data());
  std::copy_n(e.friction.data(), n, f.friction.data());
  std::copy_n(e.limits.data(), n, f.limits.data());
  std::copy_n(e.constraint.data(), n, f.constraint.data());
  std::copy_n(e.disturbance.data(), n, f.disturbance.data());
  std::copy_n(e.tau_cmd.data(), n, f.tau_cmd.data());
  std::copy_n(e.tau_applied.data(), n, f.tau_applied.data());
  f.contacts_total = e.contacts_total;
  f.num_contacts = e.num_contacts;
  f.contacts.resize(static_cast<std::size_t>(e.num_contacts));
  for (std::size_t k = 0; k < f.contacts.size(); ++k) {
    const ContactWrench& w = e.contacts[k];
    contact_t& c = f.contacts[k];
    c.geom1 = w.geom1;
    c.geom2 = w.geom2;
    c.distance = w.distance;
    for (int a = 0; a < 3; ++a) {
      c.position[a] = w.position[a];
      c.normal[a] = w.normal[a];
      c.force[a] = w.force[a];
      c.torque[a] = w.torque[a];
    }
  }
  bus_.PublishMessage(model_.instances[i].channels.forces, f);
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
    if (v.work.budget_s > 0.0) reply_.reason += WorkFiguresText(v.work);
    bus_.PublishMessage(model_.instances[i].channels.reply, reply_);
  }
}

void Publisher::LogEvents(const TickRecord& record) {
  for (std::size_t i = 0; i < record.instances.size(); ++i) {
    const InstanceRecord& r = record.instances[i];
    if (r.fault)
      spdlog::error("{}: fault at t = {:.3f} s: {}; zero torque, state frozen until reset", model_.instances[i].name(),
                    r.t, r.fault);
    commands_applied_ += r.commands_accepted;
    if (r.commands_accepted > 0 && spdlog::should_log(spdlog::level::debug)) {
      spdlog::debug("{}: {} command(s) applied at t = {:.3f} s", model_.instances[i].name(), r.commands_accepted, r.t);
    }
    if (r.commands_rejected > 0) {
      commands_refused_by_tick_ += r.commands_rejected;
      // A work-bound refusal quotes its figures here too, as its reply does.
      std::string error = r.command_error;
      for (std::size_t k = r.num_verdicts; k-- > 0;) {
        const Verdict& v = r.verdicts[k];
        if (v.error == r.command_error && v.work.budget_s > 0.0) {
          error += WorkFiguresText(v.work);
          break;
        }
      }
      last_command_error_ = model_.instances[i].name() + ": " + error;
      std::int64_t suppressed = 0;
      if (refusal_throttle_.Allow(record.utime, suppressed)) {
        spdlog::warn(
            "{}: command refused: {}{}", model_.instances[i].name(), error,
            suppressed > 0 ? fmt::format(" ({} more refusals since the last line, not logged)", suppressed) : "");
      }
    }
    // The first record: an instance that starts in another mode than running
    // (an external controller waiting for its first torque) says so, rather
    // than "running -> hold" as though it had left a mode it was never in.
    const bool first = !out_[i].logged;
    out_[i].logged = true;
    if (first && (r.mode != Mode::kRunning || r.reason != nullptr)) {
      spdlog::info("{}: starts in {} at t = {:.3f} s{}", model_.instances[i].name(), ToString(r.mode), r.t,
                   r.reason ? fmt::format(" ({})", r.reason) : "");
      out_[i].mode = r.mode;
      out_[i].reason = r.reason;
    } else if (r.mode != out_[i].mode || r.reason != out_[i].reason) {
      const bool alarm = r.mode == Mode::kFault || r.mode == Mode::kEstop || r.mode == Mode::kStopped;
      const std::string why = r.reason ? fmt::format(" ({})", r.reason) : "";
      const auto level = alarm ? spdlog::level::warn : spdlog::level::info;
      if (r.mode != out_[i].mode) {
        spdlog::log(level, "{}: {} -> {} at t = {:.3f} s{}", model_.instances[i].name(), ToString(out_[i].mode),
                    ToString(r.mode), r.t, why);
      } else {  // the same mode for a new reason
        spdlog::log(level, "{}: still {} at t = {:.3f} s, now{}", model_.instances[i].name(), ToString(r.mode), r.t,
                    why);
      }
      out_[i].mode = r.mode;
      out_[i].reason = r.reason;
    }
    if (r.residual_exceeded != out_[i].residual_exceeded) {  // energy_balance with on_exceed: warn
      const double bound = model_.instances[i].residual_bound.bound;
      if (r.residual_exceeded)
        spdlog::warn("{}: the energy-balance residual |ε| = {:.3g} J exceeds energy_balance.bound = {:.3g} J at t = "
                     "{:.3f} s (on_exceed: warn: still {})",
                     model_.instances[i].name(), std::abs(r.energy_residual), bound, r.t, ToString(r.mode));
      else
        spdlog::info("{}: the energy-balance residual is back within energy_balance.bound at t = {:.3f} s",
                     model_.instances[i].name(), r.t);
      out_[i].residual_exceeded = r.residual_exceeded;
    }
  }
}

// The status's reason for an instance: why its mode is not running, and
// whether |ε| exceeds the scene's energy_balance bound (on_exceed: warn).
std::string Publisher::StatusReason(std::size_t i, const InstanceRecord& r) const {
  std::string reason = r.reason ? r.reason : "";
  if (!r.residual_exceeded) return reason;
  return reason + (reason.empty() ? "" : "; ") +
         fmt::format("|ε| = {:.3g} J exceeds energy_balance.bound = {:.3g} J", std::abs(r.energy_residual),
                     model_.instances[i].residual_bound.bound);
}

// (the last record, the receiver's counts, this window's timing) => status_t;
// the run's fixed fields (names, joint counts and names) are in status_ already.
void Publisher::PublishStatus(const TickRecord& last) {
  status_t& s = status_;
  s.utime = last.utime;
  s.ticks = last.tick + 1;
  s.ticks_in_window = static_cast<int32_t>(latencies_.size());
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
  s.bus_signed = stats_.bus_signed;
  s.datagrams_unauthenticated = stats_.datagrams_unauthenticated.load(std::memory_order_relaxed);
  s.unauthenticated_channels.clear();
  s.unauthenticated_counts.clear();
  for (std::size_t k = 0; k < stats_.channels.size(); ++k) {
    const std::int64_t n = stats_.unauthenticated[k].load(std::memory_order_relaxed);
    if (n == 0 || s.unauthenticated_channels.size() >= static_cast<std::size_t>(kMaxStatusChannels)) continue;
    s.unauthenticated_channels.push_back(stats_.channels[k]);
    s.unauthenticated_counts.push_back(n);
  }
  s.num_unauthenticated_channels = static_cast<std::int32_t>(s.unauthenticated_channels.size());
  s.instance_modes.clear();
  s.instance_reasons.clear();
  s.instance_integrators.clear();
  s.instance_methods.clear();
  s.instance_effects.clear();
  s.instance_forces.clear();
  for (const Outgoing& o : out_) s.instance_modes.push_back(static_cast<int8_t>(o.mode));
  for (std::size_t i = 0; i < last.instances.size(); ++i) {
    const InstanceRecord& r = last.instances[i];
    s.instance_reasons.push_back(StatusReason(i, r));
    s.instance_integrators.push_back(IntegratorDescription(r.integrator, r.external_plant, r.mujoco_integrator));
    s.instance_methods.emplace_back(ToString(r.method));
    s.instance_effects.push_back(EffectsDescription(r.effects));
    s.instance_forces.push_back(r.forces_on);
  }
  bus_.PublishMessage(model_.status_channel, s);
}

}  // namespace lagrange
