// lagrangectl send: stream setpoints to an instance, a fixed one or a trajectory
// from the instance's current state.

#include <lagrange/setpoint_t.hpp>

#include <cmath>
#include <memory>
#include <thread>

#include "controllers/setpoint.hpp"
#include "plant/plant_spec.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"
#include "tools/lcm_client.hpp"

namespace lagrange::cli {
namespace {

class SendCommand final : public Command {
 public:
  explicit SendCommand(CLI::App& parent)
      : Command(parent.add_subcommand("send", "Stream setpoints to an instance (fixed, step, sine or minimum jerk)")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    app_->add_option("--q", q_, "Target positions a,b,.. (rad or m); the sine's center if given");
    app_->add_option("--qd", qd_, "Velocities (fixed setpoint only; default zeros)");
    app_->add_option("--qdd", qdd_, "Accelerations (fixed setpoint only; default zeros)");
    auto* step = app_->add_flag("--step", step_, "Jump to --q and hold it (the default)");
    auto* sine = app_->add_option("--sine", sine_, "AMPLITUDE,FREQ: q_d = center + A sin(2π f t) on every joint");
    auto* jerk = app_->add_option("--min-jerk", min_jerk_, "SECONDS: minimum-jerk move from the current state to --q");
    step->excludes(sine)->excludes(jerk);
    sine->excludes(jerk);
    app_->add_option("--rate", rate_, "Setpoints per second")->capture_default_str();
    app_->add_option("--for", for_, "Seconds to stream (default: 2, or the move's duration + 1, or 5 for a sine)");
    app_->add_flag("--once", once_, "Send one setpoint and exit (fixed setpoint only)");
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    const std::optional<double> rate = ParseFiniteNumber(rate_);
    if (!rate || *rate <= 0.0 || *rate > 10000.0) throw UsageError("--rate: expected setpoints per second in (0, 10000], got '" + rate_ + "'");
    std::optional<double> duration;
    if (for_) {
      duration = ParseFiniteNumber(*for_);
      if (!duration || *duration <= 0.0) throw UsageError("--for: expected a positive number of seconds, got '" + *for_ + "'");
    }
    DaemonLink link(bus_, instance_);
    const state_t now = link.AwaitState();
    const int n = now.num_dofs;
    const VectorXd q_now = Eigen::Map<const VectorXd>(now.q.data(), n);
    const VectorXd qd_now = Eigen::Map<const VectorXd>(now.qd.data(), n);

    std::unique_ptr<Trajectory> trajectory;
    std::string what;
    if (sine_) {
      const VectorXd af = ParseNumberList("--sine", *sine_, 2);
      if (af[1] < 0.0) throw UsageError("--sine: expected a frequency >= 0 Hz, got " + FormatDouble(af[1]));
      const VectorXd center = q_ ? ParseNumberList("--q", *q_, n) : q_now;
      trajectory = MakeSine(center, VectorXd::Constant(n, af[0]), VectorXd::Constant(n, af[1]));
      what = "sine " + FormatDouble(af[0]) + " at " + FormatDouble(af[1]) + " Hz";
      if (!duration) duration = 5.0;
    } else if (min_jerk_) {
      const std::optional<double> seconds = ParseFiniteNumber(*min_jerk_);
      if (!seconds || *seconds <= 0.0) throw UsageError("--min-jerk: expected a positive number of seconds, got '" + *min_jerk_ + "'");
      if (!q_) throw UsageError("--min-jerk: needs the target --q");
      trajectory = MakeMinimumJerk(q_now, qd_now, VectorXd::Zero(n), ParseNumberList("--q", *q_, n), *seconds);
      what = "minimum-jerk move in " + FormatDouble(*seconds) + " s";
      if (!duration) duration = *seconds + 1.0;
    } else {
      if (!q_) throw UsageError("--q is required");
      Setpoint fixed(n);
      fixed.q = ParseNumberList("--q", *q_, n);
      if (qd_) fixed.qd = ParseNumberList("--qd", *qd_, n);
      if (qdd_) fixed.qdd = ParseNumberList("--qdd", *qdd_, n);
      trajectory = MakeHold(fixed.q);
      fixed_qd_ = fixed.qd;
      fixed_qdd_ = fixed.qdd;
      what = "setpoint";
      if (!duration) duration = 2.0;
    }
    if (once_ && (sine_ || min_jerk_)) throw UsageError("--once: only for a fixed setpoint");

    const std::int64_t rejected_before = link.AwaitStatus().setpoints_rejected;
    const std::string channel = bus_.Channel(instance_, "_SETPOINT");
    const std::int64_t sent = Stream(link, *trajectory, n, channel, once_ ? 0.0 : *duration, *rate);
    // Give the daemon a status period to report on what it received.
    link.PumpUntil([&] { return link.statuses_received() >= 3; }, 0.35);
    const status_t& status = *link.status();
    if (status.setpoints_rejected > rejected_before) {
      throw std::runtime_error("lagranged rejected " + std::to_string(status.setpoints_rejected - rejected_before) +
                               " of " + std::to_string(sent) + " setpoints: " + status.last_rejection);
    }
    out << "sent " << sent << " setpoint" << (sent == 1 ? "" : "s") << " (" << what << ") to " << channel << "\n";
    return 0;
  }

 private:
  std::int64_t Stream(DaemonLink& link, const Trajectory& trajectory, int n, const std::string& channel,
                      double duration, double rate) {
    CatchInterrupt();
    Setpoint sp(n);
    setpoint_t msg;
    msg.num_dofs = n;
    const auto start = std::chrono::steady_clock::now();
    const auto period = std::chrono::duration<double>(1.0 / rate);
    std::int64_t sent = 0;
    for (auto next = start; !Interrupted(); next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period)) {
      const double t = std::chrono::duration<double>(next - start).count();
      if (t > duration + 1e-9 && sent > 0) break;
      trajectory.Sample(t, sp);
      if (fixed_qd_.size() == n) {
        sp.qd = fixed_qd_;
        sp.qdd = fixed_qdd_;
      }
      msg.utime = WallMicros();
      msg.q.assign(sp.q.data(), sp.q.data() + n);
      msg.qd.assign(sp.qd.data(), sp.qd.data() + n);
      msg.qdd.assign(sp.qdd.data(), sp.qdd.data() + n);
      link.lcm().publish(channel, &msg);
      ++sent;
      std::this_thread::sleep_until(next + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period));
      link.Pump(0.0);  // keep the status current without blocking
    }
    // lagranged holds the last setpoint as sent: a moving trajectory ends with one at rest where it stopped.
    if (fixed_qd_.size() != n && (msg.qd != std::vector<double>(static_cast<std::size_t>(n), 0.0) ||
                                  msg.qdd != std::vector<double>(static_cast<std::size_t>(n), 0.0))) {
      msg.utime = WallMicros();
      msg.qd.assign(static_cast<std::size_t>(n), 0.0);
      msg.qdd.assign(static_cast<std::size_t>(n), 0.0);
      link.lcm().publish(channel, &msg);
      ++sent;
    }
    return sent;
  }

  std::string instance_;
  std::optional<std::string> q_, qd_, qdd_, sine_, min_jerk_, for_;
  bool step_ = false, once_ = false;
  std::string rate_ = "1000";  // the loop's rate: no staircase in a moving setpoint
  BusOptions bus_;
  VectorXd fixed_qd_, fixed_qdd_;
};

}  // namespace

std::unique_ptr<Command> MakeSendCommand(CLI::App& parent) { return std::make_unique<SendCommand>(parent); }

}  // namespace lagrange::cli
