// lagrangectl send: stream setpoints to an instance, a fixed one or a trajectory
// from the instance's current state; or stream a fixed torque (torque_t) to an
// instance running its external controller. Success means the one lagranged
// run publishing the instance counted what was sent as accepted, rejected
// none, and the instance was running it.

#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/torque_t.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <thread>

#include "base/escape.hpp"
#include "controllers/factory.hpp"
#include "controllers/trajectory.hpp"
#include "protocol/channels.hpp"
#include "protocol/client.hpp"
#include "protocol/clock.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/setpoint_check.hpp"
#include "protocol/status.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"

namespace lagrange::cli {
namespace {

// How long after the stream a state shows what the instance made of it
// (well within any setpoint or torque timeout).
constexpr double kSettle = 0.02;  // s
// After a pose target, how long the frame is given to get there (beyond a
// timed move's duration) before its distance is reported.
constexpr double kPoseSettle = 0.5;  // s
// --pose's quaternion as typed (0.7071,0.7071,0,0): within this of unit it is
// normalised before it is sent (lagranged takes 1e-6); beyond, refused.
constexpr double kQuaternionTypingTolerance = 1e-3;

// What lagranged made of a stream: the instance's state just after it, and
// the daemon's counters in a status that counts every message of it.
struct Outcome {
  state_t state;
  status_t status;
};

// A distance as a reading: three significant digits ("0.0539").
std::string ThreeDigits(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

// "1 torque", "3 torques".
std::string Count(std::int64_t n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

// The command that leaves a mode ("" when there is none to give).
std::string LeaveCommand(const std::string& instance, std::int8_t mode) {
  switch (mode) {
    case state_t::MODE_ESTOP: return "command " + instance + " clear";
    case state_t::MODE_STOPPED: return "command " + instance + " clear";  // re-arms an external plant
    case state_t::MODE_PAUSED: return "command " + instance + " resume";
    case state_t::MODE_FAULT: return "command " + instance + " reset";
    default: return "";
  }
}

class SendCommand final : public Command {
 public:
  explicit SendCommand(CLI::App& parent)
      : Command(parent.add_subcommand("send",
                                      "Stream setpoints to an instance (fixed, step, sine or minimum jerk), or a "
                                      "fixed torque to its external controller (--tau)")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    auto list = [&](const char* name, std::vector<double>& values, const char* help) {
      return AddNumberList(*app_, name, values, help);
    };
    auto* q = list("--q", q_, "Target positions a,b,.. (rad or m); the sine's center if given");
    auto* qd = list("--qd", qd_, "Velocities (fixed setpoint only; default zeros)");
    auto* qdd = list("--qdd", qdd_, "Accelerations (fixed setpoint only; default zeros)");
    auto* step = app_->add_flag("--step", step_, "Jump to --q and hold it (the default)");
    auto* sine = list("--sine", sine_, "AMPLITUDE,FREQ: q_d = center + A sin(2π f t) on every joint");
    auto* jerk = app_->add_option("--min-jerk", min_jerk_, "SECONDS: minimum-jerk move from the current state to --q")
                     ->check(PositiveNumber());
    auto* tau =
        list("--tau", tau_, "Torques a or a,b,.. (N·m or N): a torque_t stream to the instance's external controller");
    auto* pose = list("--pose", pose_,
                      "X,Y,Z[,QW,QX,QY,QZ]: a pose target (m; unit quaternion) for the instance's task-space "
                      "controller, world frame; without a quaternion the orientation of its current target is kept; "
                      "with --min-jerk, a move there from the measured pose");
    auto* frame = app_->add_option("--frame", frame_, "--pose: the frame it is for (refused unless the controller's)")
                      ->needs(pose);
    step->excludes(sine)->excludes(jerk);
    sine->excludes(jerk);
    for (CLI::Option* setpoint : {q, qd, qdd, step, sine, jerk}) tau->excludes(setpoint);
    for (CLI::Option* joint : {q, qd, qdd, step, sine, tau}) pose->excludes(joint);
    (void)frame;
    app_->add_option("--torque-channel", torque_channel_,
                     "--tau: the channel to send on (default: <PREFIX><INSTANCE>_TORQUE; a scene may name another)")
        ->needs(tau);
    app_->add_option("--rate", rate_, "Setpoints or torques per second")
        ->check(PositiveNumber(10000.0))
        ->capture_default_str();
    app_->add_option("--for", for_, "Seconds to stream (default: 2, or the move's duration + 1, or 5 for a sine)")
        ->check(PositiveNumber());
    auto* once = app_->add_flag("--once", once_, "Send one setpoint or torque and exit (not with a trajectory)");
    once->excludes(sine)->excludes(jerk);
    qd_option_ = qd;
    qdd_option_ = qdd;
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    CheckArguments();
    DaemonLink link(bus_, instance_);
    link.AwaitOneRun();
    if (!pose_.empty()) return SendPose(link, out);
    return tau_.empty() ? SendSetpoints(link, out) : SendTorques(link, out);
  }

 private:
  // Combinations that make no sense, refused before anything goes on the bus.
  void CheckArguments() const {
    if (torque_channel_) {
      if (const std::string why = CheckChannelName(*torque_channel_); !why.empty()) {
        throw UsageError("--torque-channel: " + why);
      }
    }
    if (!pose_.empty()) {
      if (pose_.size() != 3 && pose_.size() != 7) {
        throw UsageError("--pose: expected X,Y,Z or X,Y,Z,QW,QX,QY,QZ (3 or 7 numbers), got " +
                         std::to_string(pose_.size()));
      }
      if (pose_.size() == 7) {
        const double norm = Eigen::Map<const Eigen::Vector4d>(pose_.data() + 3).norm();
        if (!(std::abs(norm - 1.0) <= kQuaternionTypingTolerance)) {
          throw UsageError("--pose: expected a unit quaternion QW,QX,QY,QZ, got norm " + FormatDouble(norm));
        }
      }
      if (once_ || for_) throw UsageError("--pose: sends one target (not with --once or --for)");
      return;
    }
    if (!tau_.empty()) return;  // CLI11 refused every setpoint option beside --tau
    const bool moving = !sine_.empty() || min_jerk_;
    if (moving && (qd_option_->count() > 0 || qdd_option_->count() > 0)) {
      throw UsageError(std::string(qd_option_->count() > 0 ? "--qd" : "--qdd") + ": only for a fixed setpoint (" +
                       (sine_.empty() ? "--min-jerk" : "--sine") + " sets its own velocities and accelerations)");
    }
    if (!sine_.empty()) {
      if (sine_.size() != 2) {
        throw UsageError("--sine: expected AMPLITUDE,FREQ (2 numbers, the same for every joint), got " +
                         std::to_string(sine_.size()));
      }
      if (sine_[1] < 0.0) throw UsageError("--sine: expected a frequency >= 0 Hz, got " + FormatDouble(sine_[1]));
    } else if (min_jerk_) {
      if (q_.empty()) throw UsageError("--min-jerk: needs the target --q");
    } else if (q_.empty()) {
      throw UsageError("--q or --tau is required");
    }
  }

  int SendSetpoints(DaemonLink& link, std::ostream& out) {
    const state_t now = link.state();
    const int n = now.num_dofs;
    const VectorXd q_now = Eigen::Map<const VectorXd>(now.q.data(), n);
    const VectorXd qd_now = Eigen::Map<const VectorXd>(now.qd.data(), n);

    std::unique_ptr<Trajectory> trajectory;
    std::string what;
    double duration = 2.0;
    fixed_qd_.resize(0);
    if (!sine_.empty()) {
      const VectorXd center = q_.empty() ? q_now : JointValues("--q", q_, n);
      trajectory = MakeSine(center, VectorXd::Constant(n, sine_[0]), VectorXd::Constant(n, sine_[1]));
      what = "sine " + FormatDouble(sine_[0]) + " at " + FormatDouble(sine_[1]) + " Hz";
      duration = 5.0;
    } else if (min_jerk_) {
      trajectory = MakeMinimumJerk(q_now, qd_now, VectorXd::Zero(n), JointValues("--q", q_, n), *min_jerk_);
      what = "minimum-jerk move in " + FormatDouble(*min_jerk_) + " s";
      duration = *min_jerk_ + 1.0;
    } else {
      const VectorXd q = JointValues("--q", q_, n);
      fixed_qd_ = qd_.empty() ? VectorXd::Zero(n) : JointValues("--qd", qd_, n);
      fixed_qdd_ = qdd_.empty() ? VectorXd::Zero(n) : JointValues("--qdd", qdd_, n);
      trajectory = MakeHold(q);
      what = "setpoint";
    }
    if (for_) duration = *for_;

    const status_t before = link.AwaitStatus();
    const std::string channel = bus_.Channel(instance_, kSetpointSuffix);
    const std::int64_t sent = Stream(link, *trajectory, n, channel, once_ ? 0.0 : duration);
    const Outcome o = AwaitOutcome(link, sent, "setpoint");
    const std::int64_t accepted = o.status.setpoints_accepted - before.setpoints_accepted;
    const std::int64_t rejected = o.status.setpoints_rejected - before.setpoints_rejected;
    if (rejected > 0) {
      throw std::runtime_error("lagranged rejected " + std::to_string(rejected) + " of " +
                               Count(accepted + rejected, "setpoint") + " it received (" + std::to_string(sent) +
                               " sent): " + Escape(o.status.last_rejection));
    }
    if (accepted == 0) {
      throw std::runtime_error("lagranged (run " + RunIdText(link.run_id()) + ") received none of the " +
                               Count(sent, "setpoint") + " sent on " + channel);
    }
    RequireRunning(o, Count(accepted, "setpoint"), "does not follow them");
    out << "sent " << Count(sent, "setpoint") << " (" << what << ") to " << channel << "; lagranged accepted "
        << accepted << "\n";
    return 0;
  }

  // One pose target (pose_setpoint_t) for the instance's task-space
  // controller: at once, or with --min-jerk a move over that time, after which
  // the frame's distance from it is reported from the instance's task state.
  int SendPose(DaemonLink& link, std::ostream& out) {
    const std::string task_channel = bus_.Channel(instance_, kTaskSuffix);
    const double wait = std::max(bus_.wait, 0.5);
    if (!link.PumpUntil([&] { return link.task_state() != nullptr; }, wait)) {
      throw std::runtime_error(instance_ + " publishes no task state on " + task_channel + ": it runs " +
                               Escape(link.state().controller) +
                               ", not a task-space controller (cartesian-impedance, operational-space)");
    }
    const task_state_t current = *link.task_state();
    pose_setpoint_t msg{};
    msg.frame = frame_.value_or("");
    std::copy(pose_.begin(), pose_.begin() + 3, msg.position);
    if (pose_.size() == 7) {
      const Eigen::Vector4d q = Eigen::Map<const Eigen::Vector4d>(pose_.data() + 3).normalized();
      std::copy(q.data(), q.data() + 4, msg.orientation);
    } else {
      std::copy(current.orientation_des, current.orientation_des + 4, msg.orientation);
    }
    msg.duration = min_jerk_.value_or(0.0);
    const status_t before = link.AwaitStatus();
    const std::string channel = bus_.Channel(instance_, kPoseSuffix);
    MonotonicClock clock;
    msg.utime = clock.WallMicros();
    const std::int64_t sent = link.bus().PublishMessage(channel, msg) ? 1 : 0;
    const Outcome o = AwaitOutcome(link, sent, "pose");
    const std::int64_t accepted = o.status.setpoints_accepted - before.setpoints_accepted;
    const std::int64_t rejected = o.status.setpoints_rejected - before.setpoints_rejected;
    if (rejected > 0) throw std::runtime_error("lagranged rejected the pose: " + Escape(o.status.last_rejection));
    if (accepted == 0) {
      throw std::runtime_error("lagranged (run " + RunIdText(link.run_id()) + ") received none of the " +
                               Count(sent, "pose") + " sent on " + channel);
    }
    RequireRunning(o, "the pose", "does not follow it");
    std::string what = "pose (" + FormatDouble(msg.position[0]) + ", " + FormatDouble(msg.position[1]) + ", " +
                       FormatDouble(msg.position[2]) + " m; " + FormatDouble(msg.orientation[0]) + ", " +
                       FormatDouble(msg.orientation[1]) + ", " + FormatDouble(msg.orientation[2]) + ", " +
                       FormatDouble(msg.orientation[3]) + ")";
    if (min_jerk_) what += " over " + FormatDouble(*min_jerk_) + " s, minimum jerk";
    out << "sent " << what << " to " << channel << "; lagranged accepted it";
    // Where the frame is once the move is done: the task state after it.
    CatchInterrupt();
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(msg.duration + kPoseSettle);
    link.PumpUntil([&] { return Interrupted() || std::chrono::steady_clock::now() >= until; },
                   msg.duration + kPoseSettle + 1.0);
    if (const task_state_t* t = link.task_state()) {
      const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(t->position) - Eigen::Map<const Eigen::Vector3d>(msg.position);
      // The rotation error is the task state's: the commanded orientation is the sent one once a move ends.
      out << "; " << Escape(t->frame) << " is " << ThreeDigits(1e3 * p.norm()) << " mm and "
          << ThreeDigits(1e3 * Eigen::Map<const Eigen::Vector3d>(t->error + 3).norm()) << " mrad from it";
    }
    out << "\n";
    return 0;
  }

  // A fixed torque for `--for` seconds (or once), as one sender: a fresh
  // run_id, the sequence growing from 1, no measured state (state_tick -1).
  int SendTorques(DaemonLink& link, std::ostream& out) {
    const int n = link.state().num_dofs;
    const VectorXd tau = JointValues("--tau", tau_, n, true);
    std::string what;
    for (int j = 0; j < n; ++j) what += (j ? "," : "") + FormatDouble(tau[j]);

    const status_t before = link.AwaitStatus();
    const std::string channel = torque_channel_.value_or(bus_.Channel(instance_, kTorqueSuffix));
    const std::int64_t sent = StreamTorque(link, tau, channel, once_ ? 0.0 : for_.value_or(2.0));
    const Outcome o = AwaitOutcome(link, sent, "torque");
    saw_running_ = saw_running_ || (o.state.mode == state_t::MODE_RUNNING && link.state_received_at() > first_sent_);
    const std::int64_t accepted = o.status.torques_accepted - before.torques_accepted;
    const std::int64_t rejected = o.status.torques_rejected - before.torques_rejected;
    const std::string external(ToString(ControllerType::kExternal));
    const bool external_active = o.state.controller == external;
    const std::string switch_hint =
        external_active ? "" : "; switch with `lagrangectl command " + instance_ + " controller " + external + "`";
    if (rejected > 0) {
      throw std::runtime_error("lagranged rejected " + std::to_string(rejected) + " of " +
                               Count(accepted + rejected, "torque") + " it received (" + std::to_string(sent) +
                               " sent): " + Escape(o.status.last_rejection) + switch_hint);
    }
    if (accepted == 0) {
      // Only an instance whose scene lists an external controller listens for torques.
      throw std::runtime_error(
          "lagranged (run " + RunIdText(link.run_id()) + ") counted none of the " + Count(sent, "torque") +
          " sent on " + channel + ": " +
          (external_active ? "does the scene name another torque channel? (--torque-channel)"
                           : "no " + external + " controller of " + instance_ + " listens there (" + instance_ +
                                 " runs " + Escape(o.state.controller) + "; its scene lists no " + external +
                                 " controller, or names another torque channel: --torque-channel)"));
    }
    // Running under them at some point after the first arrived: once the
    // stream ends the instance holds after torque_timeout, which may be
    // shorter than any wait here, so the state after the stream proves nothing.
    if (!saw_running_) RequireRunning(o, Count(accepted, "torque"), "does not apply them");
    out << "sent " << Count(sent, "torque") << " (tau " << what << ") to " << channel << "; lagranged accepted "
        << accepted << "\n";
    return 0;
  }

  // The state kSettle after the stream (before any timeout sends the instance
  // to hold) and the second status after it, which was made at least one
  // status period after the last message arrived, so it counts all of them.
  Outcome AwaitOutcome(DaemonLink& link, std::int64_t sent, const std::string& what) {
    const auto ended = std::chrono::steady_clock::now();
    const double wait = std::max(bus_.wait, 0.5);
    link.PumpUntil([&] { return link.state_received_at() > ended + std::chrono::duration<double>(kSettle); }, wait);
    const state_t state = link.state();
    link.RequireOneRun("refusing to trust its counts");
    const std::int64_t statuses_at_end = link.statuses_received();
    if (!link.PumpUntil([&] { return link.statuses_received() >= statuses_at_end + 2; }, wait)) {
      throw std::runtime_error("sent " + Count(sent, what) + ", but no status from lagranged (run " +
                               RunIdText(link.run_id()) + ") came within " + FormatDouble(wait) + " s to count them");
    }
    return {state, *link.status()};
  }

  // `accepted`: "3 setpoints"; `consequence`: what the instance does not do with them.
  void RequireRunning(const Outcome& o, const std::string& accepted, const char* consequence) const {
    if (o.state.mode == state_t::MODE_RUNNING) return;
    // (REASON; command NAME ACTION), with what of the two there is.
    const std::string why = ModeReasonIn(o.status, instance_, o.state.mode);
    const std::string leave = LeaveCommand(instance_, o.state.mode);
    const std::string notes = why + (!why.empty() && !leave.empty() ? "; " : "") + leave;
    throw std::runtime_error(instance_ + " is in " + ModeName(o.state.mode) +
                             " mode, not running: lagranged accepted " + accepted + " but " + consequence +
                             (notes.empty() ? "" : " (" + notes + ")"));
  }

  std::int64_t Stream(DaemonLink& link, const Trajectory& trajectory, int n, const std::string& channel,
                      double duration) {
    CatchInterrupt();
    MonotonicClock clock;
    Setpoint sp(n);
    setpoint_t msg;
    msg.num_dofs = n;
    const auto start = std::chrono::steady_clock::now();
    const auto period = Period();
    std::int64_t sent = 0;
    for (auto next = start; !Interrupted(); next += period) {
      const double t = std::chrono::duration<double>(next - start).count();
      if (t > duration + 1e-9 && sent > 0) break;
      trajectory.Sample(t, sp);
      if (fixed_qd_.size() == n) {
        sp.qd = fixed_qd_;
        sp.qdd = fixed_qdd_;
      }
      msg.utime = clock.WallMicros();
      msg.q.assign(sp.q.data(), sp.q.data() + n);
      msg.qd.assign(sp.qd.data(), sp.qd.data() + n);
      msg.qdd.assign(sp.qdd.data(), sp.qdd.data() + n);
      sent += link.bus().PublishMessage(channel, msg) ? 1 : 0;
      std::this_thread::sleep_until(next + period);
      link.bus().Drain();  // keep the status and state current without blocking
    }
    // lagranged holds the last setpoint as sent: a moving trajectory ends with one at rest where it stopped.
    const std::vector<double> zeros(static_cast<std::size_t>(n), 0.0);
    if (fixed_qd_.size() != n && (msg.qd != zeros || msg.qdd != zeros)) {
      msg.utime = clock.WallMicros();
      msg.qd = zeros;
      msg.qdd = zeros;
      sent += link.bus().PublishMessage(channel, msg) ? 1 : 0;
    }
    return sent;
  }

  std::int64_t StreamTorque(DaemonLink& link, const VectorXd& tau, const std::string& channel, double duration) {
    CatchInterrupt();
    MonotonicClock clock;
    torque_t msg;
    msg.run_id = NewRunId();
    msg.sequence = 0;
    msg.state_tick = -1;
    msg.num_dofs = static_cast<std::int32_t>(tau.size());
    msg.tau.assign(tau.data(), tau.data() + tau.size());
    const auto start = std::chrono::steady_clock::now();
    const auto period = Period();
    first_sent_ = start;
    saw_running_ = false;
    std::int64_t sent = 0;
    for (auto next = start; !Interrupted(); next += period) {
      if (std::chrono::duration<double>(next - start).count() > duration + 1e-9 && sent > 0) break;
      ++msg.sequence;  // grows even when a publish fails: lagranged sees a gap, not a repeat
      msg.utime = clock.WallMicros();
      sent += link.bus().PublishMessage(channel, msg) ? 1 : 0;
      std::this_thread::sleep_until(next + period);
      link.bus().Drain();
      saw_running_ =
          saw_running_ || (link.state().mode == state_t::MODE_RUNNING && link.state_received_at() > first_sent_);
    }
    return sent;
  }

  std::chrono::steady_clock::duration Period() const {
    return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(1.0 / rate_));
  }

  std::string instance_;
  std::vector<double> q_, qd_, qdd_, sine_, tau_, pose_;
  std::optional<std::string> frame_;
  std::optional<double> min_jerk_, for_;
  std::optional<std::string> torque_channel_;
  // --tau: when the stream began, and whether a state after it showed the instance running.
  std::chrono::steady_clock::time_point first_sent_;
  bool saw_running_ = false;
  bool step_ = false, once_ = false;
  double rate_ = 1000.0;  // the loop's rate: no staircase in a moving setpoint
  BusOptions bus_;
  CLI::Option* qd_option_ = nullptr;
  CLI::Option* qdd_option_ = nullptr;
  VectorXd fixed_qd_, fixed_qdd_;
};

}  // namespace

std::unique_ptr<Command> MakeSendCommand(CLI::App& parent) { return std::make_unique<SendCommand>(parent); }

}  // namespace lagrange::cli
