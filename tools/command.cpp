// lagrangectl command: switch controller, change gains, reset, pause, resume,
// emergency stop and clear it (clear also re-arms an external plant stopped
// by its watchdog); switch the integrator, an effect, the dynamics method, or
// the forces stream. Done only when lagranged says so: a reply_t from the one
// run publishing the instance's state, carrying this command's own request_id.
// An estop is the exception: it is never withheld, and goes to every run
// publishing the state, each run's verdict reported on a line of its own.

#include <lagrange/command_t.hpp>

#include <map>
#include <optional>

#include "controllers/factory.hpp"
#include "plant/effects.hpp"
#include "plant/escape.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/channels.hpp"
#include "protocol/client.hpp"
#include "protocol/command_words.hpp"
#include "protocol/format.hpp"
#include "protocol/ids.hpp"
#include "protocol/mode.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

// A refusal's reason is printed whole (a reply_t's reason passes the wire
// check at up to 4 KiB); Escape's default would cut a gain refusal's bounds.
constexpr std::size_t kMaxReasonShown = 2048;

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
    const reply_t reply = link.Command(c);  // sent once: a repeat could apply twice
    if (!reply.accepted) throw std::runtime_error("refused: " + Escape(reply.reason, kMaxReasonShown));
    out << instance_ << ": " << Words() << " done; now " << StateAfterReply(link, run) << "\n";
    return 0;
  }

 private:
  // One line per run publishing the instance's state (or the usual one line
  // when there is one run); throws, after printing them, unless every run
  // applied the estop (DaemonLink::Estop resends it until every run answered)
  // and kept it while its states were watched (DaemonLink::EstopDidNotStay).
  int Estop(DaemonLink& link, command_t& c, std::ostream& out) const {
    link.AwaitRuns();
    const std::map<std::int64_t, std::optional<reply_t>> verdicts = link.Estop(c);
    const auto reply_of = [&](std::int64_t run) -> const std::optional<reply_t>& { return verdicts.at(run); };
    std::vector<std::int64_t> runs;
    for (const auto& [run, reply] : verdicts) runs.push_back(run);
    if (runs.size() == 1) {  // the one run's verdict, worded as every other command's
      const std::optional<reply_t>& reply = reply_of(runs[0]);
      if (!reply) {
        throw std::runtime_error("no verdict from lagranged (run " + RunIdText(runs[0]) + ") within " +
                                 FormatDouble(bus_.wait) + " s");
      }
      if (!reply->accepted) throw std::runtime_error("refused: " + Escape(reply->reason, kMaxReasonShown));
      if (const std::string left = link.EstopDidNotStay(runs[0]); !left.empty()) {
        throw std::runtime_error("estop applied, but " + left);
      }
      out << instance_ << ": estop done; now " << StateAfterReply(link, runs[0]) << "\n";
      return 0;
    }
    std::size_t applied = 0;
    std::string ids;
    for (const std::int64_t run : runs) {
      const std::optional<reply_t>& reply = reply_of(run);
      const std::string id = RunIdText(run);
      ids += (ids.empty() ? "" : ", ") + id;
      out << instance_ << ": run " << id << ": estop ";
      if (!reply) {
        out << "no verdict within " << FormatDouble(bus_.wait) << " s\n";
      } else if (!reply->accepted) {
        out << "refused: " << Escape(reply->reason, kMaxReasonShown) << "\n";
      } else if (const std::string left = link.EstopDidNotStay(run); !left.empty()) {
        out << "applied, but " << left << "\n";
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

  static std::string StateAfterReply(DaemonLink& link, std::int64_t run) { return link.ModeAfterReply(run); }

  std::string Words() const {
    std::string words;
    for (const std::string& w : action_) words += (words.empty() ? "" : " ") + Escape(w);
    return words;
  }

  // The command from the arguments, before anything goes on the bus (gains
  // are sized once the instance's num_dofs is known).
  command_t Parse() const {
    if (action_[0] == "gains" && action_.size() > 1) {
      throw UsageError("gains: expected --kp A[,B..] --kd C[,D..] (one value for every joint, or one per joint), got '" +
                       Escape(action_[1], 60) + "'");
    }
    command_t c;
    try {
      c = CommandFromWords(action_);
    } catch (const CommandWordsError& e) {
      throw UsageError(e.what());
    }
    const bool gains = c.command == command_t::SET_GAINS;
    if (gains && (kp_.empty() || kd_.empty())) throw UsageError("gains: needs both --kp and --kd");
    if (!gains && (!kp_.empty() || !kd_.empty())) throw UsageError("--kp, --kd: only for gains");
    const bool integrator = c.command == command_t::SET_INTEGRATOR;
    if (!integrator && (substeps_ || rtol_ || atol_ || max_steps_)) {
      throw UsageError("--substeps, --rtol, --atol, --max-steps: only for integrator");
    }
    if (integrator) SetIntegratorNumbers(*ParseIntegratorType(c.setting), c);
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
