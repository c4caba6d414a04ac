// lagrangectl command: switch controller, change gains, reset, pause, resume,
// emergency stop and clear it (clear also re-arms an external plant stopped
// by its watchdog); switch the integrator, an effect, the dynamics method, or
// the forces stream. Done only when lagranged says so: a reply_t from the one
// run publishing the instance's state, carrying this command's own request_id.
// An estop is the exception: it is never withheld, and goes to every run
// publishing the state, each run's verdict reported on a line of its own.

#include <lagrange/command_t.hpp>

#include <optional>

#include "controllers/factory.hpp"
#include "plant/effects.hpp"
#include "plant/escape.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/channels.hpp"
#include "protocol/client.hpp"
#include "protocol/clock.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

struct Action {
  const char* verb;
  std::int8_t code;
  int operands;          // words after the verb
  const char* expected;  // what they are, for messages
};

constexpr Action kActions[] = {{"controller", command_t::SWITCH_CONTROLLER, 1, "one controller name"},
                               {"gains", command_t::SET_GAINS, 0, ""},
                               {"reset", command_t::RESET, 0, ""},
                               {"pause", command_t::PAUSE, 0, ""},
                               {"resume", command_t::RESUME, 0, ""},
                               {"estop", command_t::ESTOP, 0, ""},
                               {"clear", command_t::CLEAR_ESTOP, 0, ""},
                               {"integrator", command_t::SET_INTEGRATOR, 1, "one integrator TYPE"},
                               {"effect", command_t::SET_EFFECT, 2, "an effect NAME and on or off"},
                               {"method", command_t::SET_METHOD, 1, "one method NAME"},
                               {"forces", command_t::SET_FORCES, 1, "on or off"}};

constexpr std::chrono::milliseconds kEstopResend{20};
// A refusal's reason is printed whole (a reply_t's reason passes the wire
// check at up to 4 KiB); Escape's default would cut a gain refusal's bounds.
constexpr std::size_t kMaxReasonShown = 2048;

std::string Verbs() {
  std::string verbs;
  constexpr std::size_t n = std::size(kActions);
  for (std::size_t i = 0; i < n; ++i) verbs += std::string(i == 0 ? "" : i + 1 == n ? " or " : ", ") + kActions[i].verb;
  return verbs;
}

// Throws a UsageError listing the known names unless `known`.
void RequireKnown(const std::string& what, const std::string& name, bool known, const std::string& names) {
  if (!known) throw UsageError("unknown " + what + " '" + Escape(name, 60) + "' (expected " + names + ")");
}

bool OnOff(const std::string& what, const std::string& word) {
  if (word != "on" && word != "off") throw UsageError(what + ": expected on or off, got '" + Escape(word, 60) + "'");
  return word == "on";
}

class CommandCommand final : public Command {
 public:
  explicit CommandCommand(CLI::App& parent)
      : Command(parent.add_subcommand("command",
                                      "Command an instance: controller NAME | gains --kp .. --kd .. | reset | pause | "
                                      "resume | estop | clear | integrator TYPE [--substeps N ..] | effect NAME on|off "
                                      "| method NAME | forces on|off")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    app_->add_option("action", action_,
                     "controller NAME, gains, reset, pause, resume, estop, clear (leaves an estop into hold, and "
                     "re-arms an external plant its watchdog stopped into waiting), integrator TYPE (" +
                         IntegratorTypeNames() + "), effect NAME (" + EffectKindNames() + ") on|off, method NAME (" +
                         MethodNames() + "), or forces on|off (publish <NAME>_FORCES)")
        ->required()
        ->expected(1, -1);
    app_->add_option("--kp", kp_,
                     "gains: proportional gains, one for every joint or one per joint (a or a,b,..); a task-space "
                     "controller's: one per task axis x, y, z, rx, ry, rz")
        ->delimiter(',')
        ->allow_extra_args(false)
        ->check(NonNegativeNumber());
    app_->add_option("--kd", kd_, "gains: derivative gains, one for every joint or one per joint (a or a,b,..)")
        ->delimiter(',')
        ->allow_extra_args(false)
        ->check(NonNegativeNumber());
    app_->add_option("--substeps", substeps_, "integrator: sub-steps per tick, 1..1000 (default 1)");
    app_->add_option("--rtol", rtol_, "integrator dopri5: relative tolerance (default 1e-8)");
    app_->add_option("--atol", atol_, "integrator dopri5: absolute tolerance (default 1e-10)");
    app_->add_option("--max-steps", max_steps_,
                     "integrator dopri5: internal steps per tick (default: the scene's, lowered to what fits the "
                     "period)");
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    command_t c = Parse();
    DaemonLink link(bus_, instance_);
    // An emergency stop is never withheld: it goes to every run publishing
    // the instance's state, and each run's verdict is reported.
    if (c.command == command_t::ESTOP) return Estop(link, c, out);
    const std::int64_t run = link.AwaitOneRun();
    if (c.command == command_t::SET_GAINS) {
      // One gain per joint, or per task axis (x, y, z, rx, ry, rz) for the active task-space controller.
      const std::optional<ControllerType> active = ParseControllerType(link.state().controller);
      const bool task = active && IsTaskSpace(*active);
      const int n = task ? kTaskDims : link.state().num_dofs;
      const VectorXd kp = JointValues("--kp", kp_, n, true, task);
      const VectorXd kd = JointValues("--kd", kd_, n, true, task);
      c.num_gains = n;
      c.kp.assign(kp.data(), kp.data() + n);
      c.kd.assign(kd.data(), kd.data() + n);
    }
    c.request_id = NewRequestId();
    link.ExpectReply(c.request_id);
    Send(link, c);
    // Other commands are sent once: a repeat could apply twice.
    if (!link.PumpUntil([&] { return link.reply().has_value(); }, bus_.wait)) {
      throw std::runtime_error("no verdict from lagranged (run " + RunIdText(run) + ") within " +
                               FormatDouble(bus_.wait) + " s");
    }
    link.RequireOneRun("refusing to trust the verdict");
    const reply_t& reply = *link.reply();
    if (!reply.accepted) throw std::runtime_error("refused: " + Escape(reply.reason, kMaxReasonShown));
    out << instance_ << ": " << Words() << " done; now " << StateAfterReply(link, run) << "\n";
    return 0;
  }

 private:
  void Send(DaemonLink& link, command_t& c) const {
    const std::string channel = bus_.Channel(instance_, kCommandSuffix);
    c.utime = MonotonicClock().WallMicros();
    if (!link.bus().PublishMessage(channel, c)) throw std::runtime_error("could not send the command on " + channel);
  }

  // One line per run publishing the instance's state (or the usual one line
  // when there is one run); throws, after printing them, unless every run
  // applied the estop. It is sent again every kEstopResend until every run
  // answered: under a flood the kernel may drop a datagram before lagranged
  // reads it, and a repeated estop is applied once (it is latest-wins).
  int Estop(DaemonLink& link, command_t& c, std::ostream& out) const {
    link.AwaitRuns();
    c.request_id = NewRequestId();
    link.ExpectReply(c.request_id);
    Send(link, c);
    auto next_send = std::chrono::steady_clock::now() + kEstopResend;
    auto all_answered = [&] {
      for (const std::int64_t run : link.runs())
        if (!link.reply(run)) return false;
      return true;
    };
    link.PumpUntil(
        [&] {
          if (std::chrono::steady_clock::now() >= next_send) {
            Send(link, c);
            next_send += kEstopResend;
          }
          return all_answered();
        },
        bus_.wait);
    const std::vector<std::int64_t> runs = link.runs();
    if (runs.size() == 1) {  // the one run's verdict, worded as every other command's
      const std::optional<reply_t>& reply = link.reply(runs[0]);
      if (!reply) {
        throw std::runtime_error("no verdict from lagranged (run " + RunIdText(runs[0]) + ") within " +
                                 FormatDouble(bus_.wait) + " s");
      }
      if (!reply->accepted) throw std::runtime_error("refused: " + Escape(reply->reason, kMaxReasonShown));
      out << instance_ << ": estop done; now " << StateAfterReply(link, runs[0]) << "\n";
      return 0;
    }
    std::size_t applied = 0;
    std::string ids;
    for (const std::int64_t run : runs) {
      const std::optional<reply_t>& reply = link.reply(run);
      const std::string id = RunIdText(run);
      ids += (ids.empty() ? "" : ", ") + id;
      out << instance_ << ": run " << id << ": estop ";
      if (!reply) {
        out << "no verdict within " << FormatDouble(bus_.wait) << " s\n";
      } else if (!reply->accepted) {
        out << "refused: " << Escape(reply->reason, kMaxReasonShown) << "\n";
      } else {
        ++applied;
        out << "done; now " << StateAfterReply(link, run) << "\n";
      }
    }
    out.flush();
    if (applied == runs.size()) return 0;
    throw std::runtime_error("estop applied by " + std::to_string(applied) + " of the " +
                             std::to_string(runs.size()) + " runs publishing " +
                             bus_.Channel(instance_, kStateSuffix) + " (ids " + ids + ")");
  }

  // "MODE with CONTROLLER" from the run's first state after its reply (the
  // tick applied the command before the reply went out), or its latest.
  static std::string StateAfterReply(DaemonLink& link, std::int64_t run) {
    const auto replied = std::chrono::steady_clock::now();
    link.PumpUntil([&] { return link.state_received_at(run) > replied; }, 0.5);
    const state_t& s = link.state(run);
    return std::string(ModeName(s.mode)) + " with " + Escape(s.controller);
  }

  std::string Words() const {
    std::string words;
    for (const std::string& w : action_) words += (words.empty() ? "" : " ") + Escape(w);
    return words;
  }

  // The command from the arguments, before anything goes on the bus (gains
  // are sized once the instance's num_dofs is known).
  command_t Parse() const {
    const std::string& verb = action_[0];
    const Action* action = nullptr;
    for (const Action& a : kActions) action = verb == a.verb ? &a : action;
    if (!action) throw UsageError("unknown action '" + Escape(verb, 60) + "' (expected " + Verbs() + ")");
    const std::vector<std::string> args(action_.begin() + 1, action_.end());
    if (static_cast<int>(args.size()) != action->operands) {
      if (verb == "gains") {
        throw UsageError(
            "gains: expected --kp A[,B..] --kd C[,D..] (one value for every joint, or one per joint), got '" +
            Escape(args[0], 60) + "'");
      }
      if (action->operands == 0) throw UsageError(verb + ": takes no arguments");
      throw UsageError(verb + ": expected " + action->expected + ", got " + std::to_string(args.size()) +
                       (args.size() == 1 ? " word" : " words"));
    }
    const bool gains = action->code == command_t::SET_GAINS;
    if (gains && (kp_.empty() || kd_.empty())) throw UsageError("gains: needs both --kp and --kd");
    if (!gains && (!kp_.empty() || !kd_.empty())) throw UsageError("--kp, --kd: only for gains");
    const bool integrator = action->code == command_t::SET_INTEGRATOR;
    if (!integrator && (substeps_ || rtol_ || atol_ || max_steps_)) {
      throw UsageError("--substeps, --rtol, --atol, --max-steps: only for integrator");
    }
    command_t c{};  // every field zero: "the default" for the integrator's numbers
    c.command = action->code;
    switch (action->code) {
      case command_t::SWITCH_CONTROLLER: c.controller = args[0]; break;
      case command_t::SET_INTEGRATOR: {
        const std::optional<IntegratorType> type = ParseIntegratorType(args[0]);
        RequireKnown("integrator", args[0], type.has_value(), IntegratorTypeNames());
        c.setting = args[0];
        SetIntegratorNumbers(*type, c);
        break;
      }
      case command_t::SET_EFFECT:
        RequireKnown("effect", args[0], ParseEffectKind(args[0]).has_value(), EffectKindNames());
        c.setting = args[0];
        c.on = OnOff("effect " + args[0], args[1]);
        break;
      case command_t::SET_METHOD:
        RequireKnown("method", args[0], ParseMethod(args[0]).has_value(), MethodNames());
        c.setting = args[0];
        break;
      case command_t::SET_FORCES: c.on = OnOff("forces", args[0]); break;
      default: break;
    }
    return c;
  }

  // The numbers given, each checked as the daemon checks them
  // (CheckIntegratorConfig, with the others at their defaults); those not
  // given stay 0, which the daemon reads as its default.
  void SetIntegratorNumbers(IntegratorType type, command_t& c) const {
    if (type != IntegratorType::kDormandPrince && (rtol_ || atol_ || max_steps_))
      throw UsageError("--rtol, --atol, --max-steps: only for dopri5");
    auto check = [](const char* option, const std::string& value, auto set) {
      IntegratorConfig config;
      set(config);
      if (const char* why = CheckIntegratorConfig(config)) {
        std::string reason = why;  // "integrator.substeps: expected 1 to 1000": the option names the key here
        if (reason.rfind("integrator.", 0) == 0 && reason.find(": ") != std::string::npos)
          reason = reason.substr(reason.find(": ") + 2);
        throw UsageError(std::string(option) + " " + value + ": " + reason);
      }
    };
    if (substeps_) {
      check("--substeps", std::to_string(*substeps_), [&](IntegratorConfig& k) { k.substeps = *substeps_; });
      c.substeps = *substeps_;
    }
    if (rtol_) {
      check("--rtol", FormatDouble(*rtol_), [&](IntegratorConfig& k) { k.rtol = *rtol_; });
      c.rtol = *rtol_;
    }
    if (atol_) {
      check("--atol", FormatDouble(*atol_), [&](IntegratorConfig& k) { k.atol = *atol_; });
      c.atol = *atol_;
    }
    if (max_steps_) {
      check("--max-steps", std::to_string(*max_steps_), [&](IntegratorConfig& k) { k.max_steps = *max_steps_; });
      c.max_steps = *max_steps_;
    }
  }

  std::string instance_;
  std::vector<std::string> action_;
  std::vector<double> kp_, kd_;
  std::optional<int> substeps_, max_steps_;
  std::optional<double> rtol_, atol_;
  BusOptions bus_;
};

}  // namespace

std::unique_ptr<Command> MakeCommandCommand(CLI::App& parent) { return std::make_unique<CommandCommand>(parent); }

}  // namespace lagrange::cli
