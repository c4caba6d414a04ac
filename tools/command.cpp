// lagrangectl command: switch controller, change gains, reset, pause, resume,
// emergency stop and clear it (clear also re-arms an external plant stopped
// by its watchdog). Done only when lagranged says so: a reply_t
// from the one run publishing the instance's state, carrying this command's
// own request_id.

#include <lagrange/command_t.hpp>

#include "daemon/channels.hpp"
#include "daemon/clock.hpp"
#include "daemon/escape.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/daemon_link.hpp"

namespace lagrange::cli {
namespace {

struct Action {
  const char* verb;
  std::int8_t code;
  bool takes_name;  // controller NAME
};

constexpr Action kActions[] = {{"controller", command_t::SWITCH_CONTROLLER, true},
                               {"gains", command_t::SET_GAINS, false},
                               {"reset", command_t::RESET, false},
                               {"pause", command_t::PAUSE, false},
                               {"resume", command_t::RESUME, false},
                               {"estop", command_t::ESTOP, false},
                               {"clear", command_t::CLEAR_ESTOP, false}};

constexpr std::chrono::milliseconds kEstopResend{20};

class CommandCommand final : public Command {
 public:
  explicit CommandCommand(CLI::App& parent)
      : Command(parent.add_subcommand(
            "command",
            "Command an instance: controller NAME | gains --kp .. --kd .. | reset | pause | resume | estop | clear")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    app_->add_option("action", action_,
                     "controller NAME, gains, reset, pause, resume, estop or clear (leaves an estop into hold, and "
                     "re-arms an external plant its watchdog stopped into waiting)")
        ->required()
        ->expected(1, -1);
    app_->add_option("--kp", kp_, "gains: proportional gains, one for every joint or one per joint (a or a,b,..)")
        ->delimiter(',')
        ->allow_extra_args(false)
        ->check(NonNegativeNumber());
    app_->add_option("--kd", kd_, "gains: derivative gains, one for every joint or one per joint (a or a,b,..)")
        ->delimiter(',')
        ->allow_extra_args(false)
        ->check(NonNegativeNumber());
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    command_t c = Parse();
    DaemonLink link(bus_, instance_);
    const std::int64_t run = link.AwaitOneRun();
    if (c.command == command_t::SET_GAINS) {
      const int n = link.state().num_dofs;
      const VectorXd kp = JointValues("--kp", kp_, n, true);
      const VectorXd kd = JointValues("--kd", kd_, n, true);
      c.num_gains = n;
      c.kp.assign(kp.data(), kp.data() + n);
      c.kd.assign(kd.data(), kd.data() + n);
    }
    c.request_id = NewRequestId();
    link.ExpectReply(c.request_id);
    const std::string channel = bus_.Channel(instance_, kCommandSuffix);
    auto send = [&] {
      c.utime = MonotonicClock().WallMicros();
      if (!link.bus().PublishMessage(channel, c)) throw std::runtime_error("could not send the command on " + channel);
    };
    send();
    // An emergency stop is sent again every kEstopResend until its verdict
    // comes: under a flood the kernel may drop a datagram before lagranged
    // reads it, and a repeated estop is applied once (it is latest-wins).
    // Other commands are sent once: a repeat could apply twice.
    const bool resend = c.command == command_t::ESTOP;
    auto next_send = std::chrono::steady_clock::now() + kEstopResend;
    if (!link.PumpUntil(
            [&] {
              if (resend && std::chrono::steady_clock::now() >= next_send) {
                send();
                next_send += kEstopResend;
              }
              return link.reply().has_value();
            },
            bus_.wait)) {
      throw std::runtime_error("no verdict from lagranged (run " + RunIdText(run) + ") within " +
                               FormatDouble(bus_.wait) + " s");
    }
    link.RequireOneRun("refusing to trust the verdict");
    const reply_t& reply = *link.reply();
    if (!reply.accepted) throw std::runtime_error("refused: " + Escape(reply.reason));
    // The tick applied it before the reply went out: the next state shows the result.
    const auto replied = std::chrono::steady_clock::now();
    link.PumpUntil([&] { return link.state_received_at() > replied; }, 0.5);
    const state_t& s = link.state();
    out << instance_ << ": " << action_[0] << (action_[0] == "controller" ? " " + Escape(action_[1]) : "")
        << " done; now " << ModeName(s.mode) << " with " << Escape(s.controller) << "\n";
    return 0;
  }

 private:
  // The command from the arguments, before anything goes on the bus (gains
  // are sized once the instance's num_dofs is known).
  command_t Parse() const {
    const std::string& verb = action_[0];
    const Action* action = nullptr;
    for (const Action& a : kActions) action = verb == a.verb ? &a : action;
    if (!action) {
      throw UsageError("unknown action '" + verb +
                       "' (expected controller, gains, reset, pause, resume, estop or clear)");
    }
    const std::size_t args = action_.size() - 1;
    if (action->takes_name && args != 1) throw UsageError("controller: expected one controller name");
    if (!action->takes_name && args != 0) {
      if (verb == "gains") {
        throw UsageError(
            "gains: expected --kp A[,B..] --kd C[,D..] (one value for every joint, or one per joint), got '" +
            action_[1] + "'");
      }
      throw UsageError(verb + ": takes no arguments");
    }
    const bool gains = action->code == command_t::SET_GAINS;
    if (gains && (kp_.empty() || kd_.empty())) throw UsageError("gains: needs both --kp and --kd");
    if (!gains && (!kp_.empty() || !kd_.empty())) throw UsageError("--kp, --kd: only for gains");
    command_t c;
    c.command = action->code;
    c.controller = action->takes_name ? action_[1] : "";
    c.num_gains = 0;
    return c;
  }

  std::string instance_;
  std::vector<std::string> action_;
  std::vector<double> kp_, kd_;
  BusOptions bus_;
};

}  // namespace

std::unique_ptr<Command> MakeCommandCommand(CLI::App& parent) { return std::make_unique<CommandCommand>(parent); }

}  // namespace lagrange::cli
