// lagrangectl watch: a live terminal view of every instance and the loop's timing.

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cstdio>
#include <map>
#include <regex>
#include <sstream>

#include "plant/plant_spec.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/interrupt.hpp"
#include "lcmtypes/subscribe.hpp"
#include "tools/lcm_client.hpp"

namespace lagrange::cli {
namespace {

const char* ModeName(int8_t mode) {
  static const char* kModes[] = {"running", "hold", "fault", "paused", "estop"};
  return mode >= 0 && mode < 5 ? kModes[mode] : "?";
}

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

class WatchCommand final : public Command {
 public:
  explicit WatchCommand(CLI::App& parent)
      : Command(parent.add_subcommand("watch", "Live view of every instance and the loop's timing (q or Ctrl-C quits)")) {
    app_->add_option("--instance", only_, "Show only these instances (repeatable)");
    app_->add_option("--rate", rate_, "Refreshes per second")->capture_default_str();
    app_->add_option("--frames", frames_, "Draw this many frames and exit (default: until q or Ctrl-C)");
    app_->add_flag("--plain", plain_, "No screen clearing (the default when stdout is not a terminal)");
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    const std::optional<double> rate = ParseFiniteNumber(rate_);
    if (!rate || *rate <= 0.0 || *rate > 50.0) throw UsageError("--rate: expected refreshes per second in (0, 50], got '" + rate_ + "'");
    if (frames_ && *frames_ < 1) throw UsageError("--frames: expected a whole number >= 1");
    lcm::LCM lcm(bus_.Url());
    if (!lcm.good()) throw std::runtime_error("cannot open LCM at " + bus_.Url());
    Subscribe<&WatchCommand::OnState>(
        lcm, std::regex_replace(bus_.channel_prefix, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") + ".*_STATE", this);
    Subscribe<&WatchCommand::OnStatus>(lcm, bus_.StatusChannel(), this);

    // Wait for the daemon (and any instance asked for by name).
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(bus_.wait);
    auto ready = [&] {
      if (!status_) return false;
      for (const std::string& name : only_) {
        if (!states_.count(bus_.Channel(name, "_STATE"))) return false;
      }
      return true;
    };
    while (!ready() && std::chrono::steady_clock::now() < give_up) lcm.handleTimeout(10);
    if (!status_) throw std::runtime_error("no " + bus_.StatusChannel() + " within " + FormatDouble(bus_.wait) + " s (no lagranged on " + bus_.Url() + "?)");
    for (const std::string& name : only_) {
      if (!states_.count(bus_.Channel(name, "_STATE"))) {
        throw std::runtime_error("no state from instance '" + name + "' on " + bus_.Channel(name, "_STATE") + " (unknown instance?)");
      }
    }

    CatchInterrupt();
    RawTerminal terminal;
    const bool clear = !plain_ && isatty(STDOUT_FILENO) == 1;
    const auto period = std::chrono::duration<double>(1.0 / *rate);
    for (int frame = 0; !frames_ || frame < *frames_; ++frame) {
      const auto next = std::chrono::steady_clock::now() + period;
      while (std::chrono::steady_clock::now() < next) {
        lcm.handleTimeout(5);
        if (Interrupted() || terminal.QuitPressed()) return 0;
      }
      out << (clear ? "\x1b[H\x1b[2J" : "") << Frame() << (clear ? "" : "\n");
      out.flush();
    }
    return 0;
  }

 private:
  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    state_t msg;
    if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) >= 0) states_[channel] = std::move(msg);
  }
  void OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    status_t msg;
    if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) >= 0) status_ = std::move(msg);
  }

  std::string Frame() const {
    std::ostringstream f;
    const status_t& s = *status_;
    f << "lagranged on " << bus_.Url() << "   ticks " << s.ticks << " at " << F(1.0 / s.period, 0) << " Hz   overruns "
      << s.overruns << "   state drops " << s.state_messages_dropped << "\n";
    f << "wake latency us  p50 " << F(s.wake_latency_p50, 1) << "  p99 " << F(s.wake_latency_p99, 1) << "  max "
      << F(s.wake_latency_max, 1) << "    compute us  p50 " << F(s.compute_p50, 1) << "  p99 " << F(s.compute_p99, 1)
      << "  max " << F(s.compute_max, 1) << "\n";
    f << "setpoints " << s.setpoints_accepted << " accepted, " << s.setpoints_rejected << " rejected"
      << (s.last_rejection.empty() ? "" : " (last: " + s.last_rejection + ")") << "\n";
    f << "commands  " << s.commands_accepted << " accepted, " << s.commands_rejected << " rejected"
      << (s.last_command_error.empty() ? "" : " (last: " + s.last_command_error + ")") << "   decode errors "
      << s.decode_errors << "\n";
    for (const auto& [channel, st] : states_) {
      if (!only_.empty()) {
        bool wanted = false;
        for (const std::string& name : only_) wanted = wanted || channel == bus_.Channel(name, "_STATE");
        if (!wanted) continue;
      }
      std::string name = channel.substr(bus_.channel_prefix.size(), channel.size() - bus_.channel_prefix.size() - 6);
      for (const std::string& n : s.instance_names) {
        if (bus_.Channel(n, "_STATE") == channel) name = n;  // the scene's spelling
      }
      f << "\n" << name << "   " << ModeName(st.mode) << "   " << st.controller << "   t " << F(st.t, 3) << " s   T "
        << F(st.kinetic_energy) << " J   V " << F(st.potential_energy) << " J   E "
        << F(st.kinetic_energy + st.potential_energy) << " J\n";
      f << "  joint          q        q_des          tau\n";
      for (int j = 0; j < st.num_dofs; ++j) {
        char line[128];
        std::snprintf(line, sizeof line, "  %5d %10.4f   %10.4f   %10.4f\n", j, st.q[j], st.q_des[j], st.tau[j]);
        f << line;
      }
    }
    return f.str();
  }

  std::vector<std::string> only_;
  std::string rate_ = "4";
  std::optional<int> frames_;
  bool plain_ = false;
  BusOptions bus_;
  std::map<std::string, state_t> states_;
  std::optional<status_t> status_;
};

}  // namespace

std::unique_ptr<Command> MakeWatchCommand(CLI::App& parent) { return std::make_unique<WatchCommand>(parent); }

}  // namespace lagrange::cli
