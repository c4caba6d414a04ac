// lagrangectl watch: a live terminal view of every instance and the loop's
// timing. Each daemon and instance is shown with its run id; one whose latest
// message is older than kStale is marked STALE, and every string from the bus
// is escaped. Per instance, the status's integrator, method and effects, and
// from <NAME>_TELEMETRY the latest energy residual ε and the cost per tick
// (evaluations, compute µs) averaged over the telemetry since the previous frame;
// from <NAME>_MPC (an mpc controller's plans) a line for its latest plan: its
// number, age when taken, solve time, iterations, cost before and after, and
// status (converged or why not; followed or fallen back); from <NAME>_BASE (a
// floating base) two lines: the base's position, quaternion and ω_b, the centre
// of mass and the momentum.

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <lagrange/base_state_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "base/escape.hpp"
#include "protocol/channels.hpp"
#include "protocol/client.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "protocol/observer.hpp"
#include "protocol/status.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"

namespace lagrange::cli {
namespace {

using SteadyTime = std::chrono::steady_clock::time_point;

constexpr double kStale = 0.5;             // s without a message: STALE (status is sent at 10 Hz, states at 1 kHz)
constexpr std::size_t kMaxRunsShown = 4;   // run ids kept per channel
constexpr std::size_t kMaxInstances = 64;  // instances followed
constexpr std::size_t kNameColumn = 24;    // joint names longer than this are cut

// Puts the terminal in non-canonical, no-echo mode while alive (only on a tty).
class RawTerminal {
 public:
  RawTerminal() : active_(isatty(STDIN_FILENO) == 1 && tcgetattr(STDIN_FILENO, &saved_) == 0) {
    if (!active_) return;
    termios raw = saved_;
    raw.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  }
  ~RawTerminal() {
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  // True when 'q' was pressed.
  bool QuitPressed() const {
    if (!active_) return false;
    pollfd fd{STDIN_FILENO, POLLIN, 0};
    char c = 0;
    while (poll(&fd, 1, 0) > 0 && read(STDIN_FILENO, &c, 1) == 1) {
      if (c == 'q' || c == 'Q') return true;
    }
    return false;
  }

 private:
  termios saved_{};
  bool active_;
};

std::string F(double x, int precision = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, x);
  return buf;
}

double Age(SteadyTime received, SteadyTime now) { return std::chrono::duration<double>(now - received).count(); }

// An instance's cost per tick, averaged over the telemetry received between
// two frames (evaluations vary from tick to tick under dopri5, compute time always).
struct CostWindow {
  double evaluations = 0.0, compute_us = 0.0;  // sums since the last frame
  int count = 0;
  double mean_evaluations = std::nan(""), mean_compute_us = std::nan("");  // over the last window that had any
  void Close() {
    if (count > 0) {
      mean_evaluations = evaluations / count;
      mean_compute_us = compute_us / count;
    }
    evaluations = compute_us = 0.0;
    count = 0;
  }
};

class WatchCommand final : public Command {
 public:
  explicit WatchCommand(CLI::App& parent)
      : Command(parent.add_subcommand("watch",
                                      "Live view of every instance (mode, integrator, energy residual, cost per tick) "
                                      "and the loop's timing (q or Ctrl-C quits)")) {
    app_->add_option("--instance", only_, "Show only these instances (repeatable)");
    app_->add_option("--rate", rate_, "Refreshes per second")->check(PositiveNumber(50.0))->capture_default_str();
    app_->add_option("--frames", frames_, "Draw this many frames and exit (default: until q or Ctrl-C)")
        ->check(CLI::PositiveNumber);
    app_->add_flag("--plain", plain_, "No screen clearing (the default when stdout is not a terminal)");
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    bus_handle_ = bus_.Open();
    const SigningCensus signing(*bus_handle_);  // for the error if no status comes: dropped for its signature?
    BusObserver::Hooks hooks;
    hooks.on_telemetry = [this](const std::string& name, const telemetry_t& m) {
      CostWindow& w = costs_[name][m.run_id];
      w.evaluations += m.evaluations;
      w.compute_us += m.compute_us;
      ++w.count;
    };
    observer_ = std::make_unique<BusObserver>(*bus_handle_, bus_.channel_prefix,
                                              ObserverLimits{kMaxRunsShown, kMaxInstances, only_.empty()}, hooks);
    for (const std::string& name : only_) observer_->Follow(name);
    // What else is on the bus, while waiting: for the hint if nothing comes.
    std::set<std::string> heard;
    bool waiting = true;
    bus_handle_->Subscribe(kEveryChannel, [&](std::string_view channel, const std::uint8_t*, std::size_t) {
      if (waiting && heard.size() < kMaxHeardChannels) heard.emplace(channel);
    });

    // Wait for the daemon (and any instance asked for by name).
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(bus_.wait);
    auto ready = [&] {
      if (observer_->statuses().empty()) return false;
      for (const std::string& name : only_) {
        if (Unheard(name)) return false;
      }
      return true;
    };
    while (!ready() && std::chrono::steady_clock::now() < give_up) Handle(10);
    waiting = false;
    if (observer_->statuses().empty()) {
      throw std::runtime_error("no " + bus_.StatusChannel() + " within " + FormatDouble(bus_.wait) + " s on " +
                               bus_.Url() + "; " + WhatWasHeard(signing.heard(), bus_.channel_prefix, "", heard));
    }
    for (const std::string& name : only_) {
      if (Unheard(name)) {
        throw std::runtime_error("no state from instance '" + name + "' on " + bus_.Channel(name, kStateSuffix) +
                                 " within " + FormatDouble(bus_.wait) + " s; " +
                                 HeardHint(bus_.channel_prefix, name, heard));
      }
    }

    CatchInterrupt();
    RawTerminal terminal;
    const bool clear = !plain_ && isatty(STDOUT_FILENO) == 1;
    const auto period = std::chrono::duration<double>(1.0 / rate_);
    for (int frame = 0; !frames_ || frame < *frames_; ++frame) {
      const auto next = std::chrono::steady_clock::now() + period;
      while (std::chrono::steady_clock::now() < next) {
        Handle(5);
        if (Interrupted() || terminal.QuitPressed()) return 0;
      }
      CloseCostWindows();
      out << (clear ? "\x1b[H\x1b[2J" : "") << Frame(std::chrono::steady_clock::now()) << (clear ? "" : "\n");
      out.flush();
    }
    return 0;
  }

 private:
  // Handles messages, then follows the instances a status named (never from inside a handler).
  void Handle(int timeout_ms) {
    bus_handle_->Handle(timeout_ms);
    observer_->Discover();
  }

  // No state yet from instance `name`.
  bool Unheard(const std::string& name) const {
    const ObservedInstance* seen = observer_->Find(name);
    return seen == nullptr || seen->states.empty();
  }

  // Ends a frame's cost windows; forgets those of runs the observer forgot.
  void CloseCostWindows() {
    for (auto& [name, runs] : costs_) {
      const ObservedInstance* seen = observer_->Find(name);
      std::erase_if(runs, [&](const auto& run) { return seen == nullptr || !seen->telemetry.Find(run.first); });
      for (auto& [run, w] : runs) w.Close();
    }
  }

  CostWindow CostOf(const std::string& instance, std::int64_t run_id) const {
    const auto it = costs_.find(instance);
    if (it == costs_.end()) return {};
    const auto w = it->second.find(run_id);
    return w == it->second.end() ? CostWindow{} : w->second;
  }

  void DaemonLines(std::ostream& f, const status_t& s, double age) const {
    f << "lagranged run " << RunIdText(s.run_id) << " on " << Escape(bus_.Url()) << "   ";
    if (age > kStale) f << "STALE: no status for " << F(age, 1) << " s (stopped?)   ";
    f << "ticks " << s.ticks << " at " << F(s.period > 0.0 ? 1.0 / s.period : 0.0, 0) << " Hz   overruns " << s.overruns
      << "   state drops " << s.state_messages_dropped << "\n";
    f << "wake latency us  p50 " << F(s.wake_latency_p50, 1) << "  p99 " << F(s.wake_latency_p99, 1) << "  max "
      << F(s.wake_latency_max, 1) << "    compute us  p50 " << F(s.compute_p50, 1) << "  p99 " << F(s.compute_p99, 1)
      << "  max " << F(s.compute_max, 1) << "\n";
    f << "inputs    setpoints " << s.setpoints_accepted << " accepted, " << s.setpoints_rejected
      << " rejected   torques " << s.torques_accepted << " accepted, " << s.torques_rejected
      << " rejected   measured states " << s.measured_accepted << " accepted, " << s.measured_rejected << " rejected\n";
    if (!s.last_rejection.empty()) f << "          last input rejected: " << Escape(s.last_rejection) << "\n";
    f << "commands  " << s.commands_accepted << " accepted, " << s.commands_rejected << " rejected"
      << (s.last_command_error.empty() ? "" : " (last: " + Escape(s.last_command_error) + ")") << "   decode errors "
      << s.decode_errors << "\n";
    f << "bus       kernel drops " << s.datagrams_dropped_kernel << "   malformed " << s.datagrams_malformed
      << "   fragments dropped " << s.fragments_dropped << "   foreign messages " << s.foreign_messages
      << (s.foreign_messages > 0 ? " (last from run " + RunIdText(s.last_foreign_run_id) + ")" : "")
      << "   replies suppressed " << s.replies_suppressed << "\n";
    if (s.bus_signed) {  // a signed bus: what it refused for its signature, in total and where
      f << "signed    refused " << s.datagrams_unauthenticated;
      for (std::size_t k = 0; k < s.unauthenticated_channels.size() && k < s.unauthenticated_counts.size(); ++k) {
        f << (k == 0 ? " (" : ", ") << Escape(s.unauthenticated_channels[k]) << " " << s.unauthenticated_counts[k];
      }
      f << (s.unauthenticated_channels.empty() ? "" : ")") << "\n";
    }
  }

  void InstanceLines(std::ostream& f, const std::string& name, const ObservedInstance& view, SteadyTime now) const {
    const auto latest = view.states.Latest();
    std::vector<std::string> live;
    for (const auto* e : latest) {
      if (Age(e->received, now) <= kStale) live.push_back(RunIdText(e->message.run_id));
    }
    if (live.size() > 1) {
      f << "\n" << bus_.Channel(name, kStateSuffix) << ": " << live.size() << " lagranged runs publish it (ids";
      for (const std::string& id : live) f << " " << id;
      f << "): which is which cannot be told\n";
    }
    for (const auto* e : latest) {
      const state_t& st = e->message;
      const double age = Age(e->received, now);
      if (age > kStale && e != latest.front()) continue;  // an old run superseded by another
      f << "\n" << Escape(name) << "   ";
      if (age > kStale)
        f << "STALE (no state for " << F(age, 1) << " s; was " << ModeName(st.mode) << ")";
      else
        f << ModeName(st.mode) << ReasonOf(name, st);
      f << "   " << Escape(st.controller) << "   t " << F(st.t, 3) << " s   T " << F(st.kinetic_energy) << " J   V "
        << F(st.potential_energy) << " J   E " << F(st.kinetic_energy + st.potential_energy) << " J   run "
        << RunIdText(st.run_id) << "\n";
      SettingsAndTelemetryLines(f, name, st.run_id, view.telemetry.Find(st.run_id), now);
      if (const auto* plan = view.plans.Find(st.run_id)) PlanLine(f, plan->message, Age(plan->received, now));
      if (const auto* base = view.bases.Find(st.run_id)) BaseLine(f, base->message);
      // Joint names from this run's status (URDF names, or q1.. for planar plants), cut to one column.
      const std::vector<std::string> joints = JointNamesOf(name, st.run_id, st.num_dofs);
      int width = 4;
      for (const std::string& j : joints) width = std::max(width, static_cast<int>(std::min(j.size(), kNameColumn)));
      char line[192];
      std::snprintf(line, sizeof line, "  %5s  %-*s %10s   %10s   %10s\n", "joint", width, "name", "q", "q_des", "tau");
      f << line;
      for (int j = 0; j < st.num_dofs; ++j) {
        const auto k = static_cast<std::size_t>(j);
        std::string joint = joints.empty() ? std::string("?") : joints[k];
        if (joint.size() > kNameColumn) joint = joint.substr(0, kNameColumn - 3) + "...";
        std::snprintf(line, sizeof line, "  %5d  %-*s %10.4f   %10.4f   %10.4f\n", j, width, joint.c_str(), st.q[k],
                      st.q_des[k], st.tau[k]);
        f << line;
      }
    }
  }

  // The status's integrator, method and effects for the instance; then from
  // its telemetry the latest energy residual ε with the quadrature's own error
  // bound, and the cost per tick averaged since the previous frame.
  void SettingsAndTelemetryLines(std::ostream& f, const std::string& instance, std::int64_t run_id,
                                 const LatestByRun<telemetry_t>::Entry* telemetry, SteadyTime now) const {
    for (const auto* e : observer_->statuses().Latest()) {
      if (e->message.run_id != run_id) continue;
      if (const std::optional<InstanceSettings> s = SettingsIn(e->message, instance)) {
        f << "  integrator " << s->integrator << "   method " << s->method << "   effects "
          << (s->effects.empty() ? std::string("none") : s->effects) << "   forces " << (s->forces ? "on" : "off")
          << "\n";
      }
      break;
    }
    if (!telemetry) {
      f << "  no telemetry\n";
      return;
    }
    const telemetry_t& t = telemetry->message;
    const CostWindow cost = CostOf(instance, run_id);
    char line[192];
    std::snprintf(line, sizeof line,
                  "  ε %10.3e J (quadrature bound %.1e J)   evaluations %.4g/tick   compute %.1f us/tick",
                  t.energy_residual, t.quadrature_bound, cost.mean_evaluations, cost.mean_compute_us);
    f << line;
    const double age = Age(telemetry->received, now);
    if (age > kStale) f << "   STALE (no telemetry for " << F(age, 1) << " s)";
    f << "\n";
  }

  // A floating base's latest state (base_state_t): where the base is and how it turns, the centre of mass
  // and the momentum.
  static void BaseLine(std::ostream& f, const base_state_t& b) {
    const auto vec = [](const double* v) { return "(" + F(v[0], 3) + ", " + F(v[1], 3) + ", " + F(v[2], 3) + ")"; };
    f << "  base p " << vec(b.position) << " m   quat (x y z w) (" << F(b.orientation[0], 3) << ", "
      << F(b.orientation[1], 3) << ", " << F(b.orientation[2], 3) << ", " << F(b.orientation[3], 3) << ")   ω_b "
      << vec(b.angular_velocity) << " rad/s\n";
    f << "  com " << vec(b.com) << " m   momentum " << vec(b.linear_momentum) << " N·s   about com "
      << vec(b.angular_momentum) << " N·m·s\n";
  }

  // An mpc controller's latest plan (mpc_t): what the optimiser did and whether the tick follows it.
  static void PlanLine(std::ostream& f, const mpc_t& m, double received_age) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "  mpc plan %lld   age %.1f ms   solve %.2f ms   iterations %d   cost %.4g -> %.4g   ",
                  static_cast<long long>(m.plan), m.age * 1e3, m.solve_time * 1e3, m.iterations, m.cost_before,
                  m.cost);
    f << line << Escape(m.status, 32) << (m.followed ? " (followed)" : " (not followed: the fallback holds)");
    if (received_age > kStale) f << "   STALE (no plan for " << F(received_age, 1) << " s)";
    f << "\n";
  }

  // " (why)" when the latest status of the state's run gives a reason for the
  // instance in the state's mode ("" when running, or when the two disagree).
  std::string ReasonOf(const std::string& instance, const state_t& st) const {
    for (const auto* e : observer_->statuses().Latest()) {
      if (e->message.run_id != st.run_id) continue;
      const std::string why = ModeReasonIn(e->message, instance, st.mode);
      return why.empty() ? "" : " (" + why + ")";
    }
    return "";
  }

  // An instance's joint names from the latest status of run `run_id`, if it gives n of them.
  std::vector<std::string> JointNamesOf(const std::string& instance, std::int64_t run_id, int n) const {
    for (const auto* e : observer_->statuses().Latest()) {
      if (e->message.run_id != run_id) continue;
      std::vector<std::string> names = JointNamesIn(e->message, instance);
      if (static_cast<int>(names.size()) == n) return names;
    }
    return {};
  }

  std::string Frame(SteadyTime now) const {
    std::ostringstream f;
    const auto statuses = observer_->statuses().Latest();
    for (const auto* e : statuses) {
      const double age = Age(e->received, now);
      if (age > kStale && e != statuses.front())
        continue;  // a dead run after a restart: shown only while nothing newer speaks
      DaemonLines(f, e->message, age);
    }
    for (const auto& [name, view] : observer_->instances()) {
      if (view.states.empty()) continue;
      if (!only_.empty() && std::find(only_.begin(), only_.end(), name) == only_.end()) continue;
      InstanceLines(f, name, view, now);
    }
    return f.str();
  }

  std::vector<std::string> only_;
  double rate_ = 4.0;
  std::optional<int> frames_;
  bool plain_ = false;
  BusOptions bus_;
  std::unique_ptr<Bus> bus_handle_;
  std::unique_ptr<BusObserver> observer_;
  std::map<std::string, std::map<std::int64_t, CostWindow>> costs_;  // by instance, by run: of the runs observed
};

}  // namespace

std::unique_ptr<Command> MakeWatchCommand(CLI::App& parent) { return std::make_unique<WatchCommand>(parent); }

}  // namespace lagrange::cli
