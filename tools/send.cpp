// lagrangectl send: stream setpoints to an instance, a fixed one or a trajectory
// from the instance's current state. Success means the one lagranged run
// publishing the instance counted the setpoints as accepted and the instance
// was running them.

#include <lagrange/setpoint_t.hpp>

#include <cmath>
#include <memory>
#include <thread>

#include "controllers/trajectory.hpp"
#include "daemon/channels.hpp"
#include "daemon/clock.hpp"
#include "daemon/escape.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/daemon_link.hpp"
#include "tools/interrupt.hpp"

namespace lagrange::cli {
namespace {

// How long after the stream a state shows what the instance made of it.
constexpr double kSettle = 0.02;  // s

class SendCommand final : public Command {
 public:
  explicit SendCommand(CLI::App& parent)
      : Command(parent.add_subcommand("send", "Stream setpoints to an instance (fixed, step, sine or minimum jerk)")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    auto list = [&](const char* name, std::vector<double>& values, const char* help) {
      return AddNumberList(*app_, name, values, help);
    };
    list("--q", q_, "Target positions a,b,.. (rad or m); the sine's center if given");
    auto* qd = list("--qd", qd_, "Velocities (fixed setpoint only; default zeros)");
    auto* qdd = list("--qdd", qdd_, "Accelerations (fixed setpoint only; default zeros)");
    auto* step = app_->add_flag("--step", step_, "Jump to --q and hold it (the default)");
    auto* sine = list("--sine", sine_, "AMPLITUDE,FREQ: q_d = center + A sin(2π f t) on every joint");
    auto* jerk = app_->add_option("--min-jerk", min_jerk_, "SECONDS: minimum-jerk move from the current state to --q")
                     ->check(PositiveNumber());
    step->excludes(sine)->excludes(jerk);
    sine->excludes(jerk);
    app_->add_option("--rate", rate_, "Setpoints per second")->check(PositiveNumber(10000.0))->capture_default_str();
    app_->add_option("--for", for_, "Seconds to stream (default: 2, or the move's duration + 1, or 5 for a sine)")
        ->check(PositiveNumber());
    auto* once = app_->add_flag("--once", once_, "Send one setpoint and exit (fixed setpoint only)");
    once->excludes(sine)->excludes(jerk);
    qd_option_ = qd;
    qdd_option_ = qdd;
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    CheckArguments();
    DaemonLink link(bus_, instance_);
    link.AwaitOneRun();
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
    const auto ended = std::chrono::steady_clock::now();
    // What the instance made of them: its mode just after the stream (before any setpoint timeout).
    link.PumpUntil([&] { return link.state_received_at() > ended + std::chrono::duration<double>(kSettle); },
                   std::max(bus_.wait, 0.5));
    const state_t state = link.state();
    link.RequireOneRun("refusing to trust its counts");

    // The second status after the stream was made at least one status period
    // after the last setpoint arrived, so it counts all of them.
    const std::int64_t statuses_at_end = link.statuses_received();
    const bool counted =
        link.PumpUntil([&] { return link.statuses_received() >= statuses_at_end + 2; }, std::max(bus_.wait, 0.5));
    if (!counted) {
      throw std::runtime_error("sent " + std::to_string(sent) + " setpoints, but no status from lagranged (run " +
                               RunIdText(link.run_id()) + ") came within " + FormatDouble(std::max(bus_.wait, 0.5)) +
                               " s to count them");
    }
    const status_t& after = *link.status();
    const std::int64_t accepted = after.setpoints_accepted - before.setpoints_accepted;
    const std::int64_t rejected = after.setpoints_rejected - before.setpoints_rejected;
    if (rejected > 0) {
      throw std::runtime_error("lagranged rejected " + std::to_string(rejected) + " of " +
                               std::to_string(accepted + rejected) + " setpoints it received (" + std::to_string(sent) +
                               " sent): " + Escape(after.last_rejection));
    }
    if (accepted == 0) {
      throw std::runtime_error("lagranged (run " + RunIdText(link.run_id()) + ") received none of the " +
                               std::to_string(sent) + " setpoints sent on " + channel);
    }
    if (state.mode != state_t::MODE_RUNNING) {
      throw std::runtime_error(instance_ + " is in " + ModeName(state.mode) +
                               " mode, not running: lagranged accepted " + std::to_string(accepted) +
                               " setpoints but does not follow them" +
                               (state.mode == state_t::MODE_ESTOP    ? " (command " + instance_ + " clear)"
                                : state.mode == state_t::MODE_PAUSED ? " (command " + instance_ + " resume)"
                                : state.mode == state_t::MODE_FAULT  ? " (command " + instance_ + " reset)"
                                                                     : std::string()));
    }
    out << "sent " << sent << " setpoint" << (sent == 1 ? "" : "s") << " (" << what << ") to " << channel
        << "; lagranged accepted " << accepted << "\n";
    return 0;
  }

 private:
  // Combinations that make no sense, refused before anything goes on the bus.
  void CheckArguments() const {
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
      throw UsageError("--q is required");
    }
  }

  std::int64_t Stream(DaemonLink& link, const Trajectory& trajectory, int n, const std::string& channel,
                      double duration) {
    CatchInterrupt();
    MonotonicClock clock;
    Setpoint sp(n);
    setpoint_t msg;
    msg.num_dofs = n;
    const auto start = std::chrono::steady_clock::now();
    const auto period =
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(1.0 / rate_));
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

  std::string instance_;
  std::vector<double> q_, qd_, qdd_, sine_;
  std::optional<double> min_jerk_, for_;
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
