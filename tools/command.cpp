// lagrangectl command: switch controller, change gains, reset, pause, resume,
// emergency stop and clear it (clear also re-arms an external plant stopped
// by its watchdog); switch the integrator, an effect, the dynamics method, or
// the forces stream. Done only when lagranged says so: a reply_t from the one
// run publishing the instance's state, carrying this command's own request_id.
// An estop is the exception: it is never withheld, and goes to every run
// publishing the state, each run's verdict reported on a line of its own.

#include <lagrange/command_t.hpp>

#include <optional>

#include "base/escape.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/client.hpp"
#include "protocol/command_session.hpp"
#include "protocol/command_words.hpp"
#include "protocol/format.hpp"
#include "tools/bus_options.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"

namespace lagrange::cli {
namespace {

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
    if (c.command == command_t::ESTOP) return Report(RunEstop(link, instance_, c), out);
    link.AwaitOneRun();
    if (c.command == command_t::SET_GAINS) {
      const bool task = GainsPerTaskAxis(link.state());
      const int n = GainCount(link.state());
      const VectorXd kp = JointValues("--kp", kp_, n, true, task);
      const VectorXd kd = JointValues("--kd", kd_, n, true, task);
      c.num_gains = n;
      c.kp.assign(kp.data(), kp.data() + n);
      c.kd.assign(kd.data(), kd.data() + n);
    }
    return Report(RunCommand(link, instance_, CommandWordsText(action_), c), out);
  }

 private:
  // The report's lines, then (a command not done) its failure as the error.
  static int Report(const CommandReport& report, std::ostream& out) {
    for (const std::string& line : report.lines) out << line << "\n";
    out.flush();
    if (!report.accepted) throw std::runtime_error(report.failure);
    return 0;
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
