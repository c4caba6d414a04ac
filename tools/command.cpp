// lagrangectl command: switch controller, change gains, reset, pause, resume,
// emergency stop and clear it; confirmed by the daemon's status.

#include <lagrange/command_t.hpp>

#include "plant/plant_spec.hpp"
#include "tools/cli_support.hpp"
#include "tools/commands.hpp"
#include "tools/lcm_client.hpp"

namespace lagrange::cli {
namespace {

// "Kp=1,2,Kd=3,4" or "Kp=1,2 Kd=3,4" => (kp, kd).
std::pair<VectorXd, VectorXd> ParseGains(const std::vector<std::string>& words, int n) {
  std::string joined;
  for (const std::string& w : words) joined += (joined.empty() ? "" : ",") + w;
  std::string kp, kd, *current = nullptr;
  std::size_t start = 0;
  while (start <= joined.size()) {
    const std::size_t comma = joined.find(',', start);
    std::string item = joined.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (item.rfind("Kp=", 0) == 0 || item.rfind("kp=", 0) == 0) {
      current = &kp;
      item = item.substr(3);
    } else if (item.rfind("Kd=", 0) == 0 || item.rfind("kd=", 0) == 0) {
      current = &kd;
      item = item.substr(3);
    }
    if (current == nullptr) throw UsageError("gains: expected Kp=a,b,.. Kd=c,d,.., got '" + joined + "'");
    *current += (current->empty() ? "" : ",") + item;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (kp.empty() || kd.empty()) throw UsageError("gains: expected both Kp=.. and Kd=.., got '" + joined + "'");
  return {ParseNumberList("gains Kp", kp, n), ParseNumberList("gains Kd", kd, n)};
}

class CommandCommand final : public Command {
 public:
  explicit CommandCommand(CLI::App& parent)
      : Command(parent.add_subcommand(
            "command", "Command an instance: controller NAME | gains Kp=..,Kd=.. | reset | pause | resume | estop | clear")) {
    app_->add_option("instance", instance_, "Instance name (as in the scene)")->required();
    app_->add_option("action", action_, "controller NAME, gains Kp=..,Kd=.., reset, pause, resume, estop or clear")
        ->required()
        ->expected(1, -1);
    bus_.AddTo(*app_);
  }

  int Run(std::ostream& out, std::ostream&) override {
    command_t c;
    c.controller = "";
    c.num_gains = 0;
    const std::string& verb = action_[0];
    const std::vector<std::string> args(action_.begin() + 1, action_.end());
    static const std::pair<const char*, int8_t> kSimple[] = {
        {"reset", command_t::RESET}, {"pause", command_t::PAUSE}, {"resume", command_t::RESUME},
        {"estop", command_t::ESTOP}, {"clear", command_t::CLEAR_ESTOP}};
    bool known = false;
    for (const auto& [name, code] : kSimple) {
      if (verb != name) continue;
      if (!args.empty()) throw UsageError(verb + ": takes no arguments");
      c.command = code;
      known = true;
    }
    DaemonLink link(bus_, instance_);
    const int n = link.AwaitState().num_dofs;
    if (verb == "controller") {
      if (args.size() != 1) throw UsageError("controller: expected one controller name");
      c.command = command_t::SWITCH_CONTROLLER;
      c.controller = args[0];
      known = true;
    } else if (verb == "gains") {
      const auto [kp, kd] = ParseGains(args, n);
      c.command = command_t::SET_GAINS;
      c.num_gains = n;
      c.kp.assign(kp.data(), kp.data() + n);
      c.kd.assign(kd.data(), kd.data() + n);
      known = true;
    }
    if (!known) {
      throw UsageError("unknown action '" + verb + "' (expected controller, gains, reset, pause, resume, estop or clear)");
    }
    const status_t before = link.AwaitStatus();
    c.utime = WallMicros();
    link.lcm().publish(bus_.Channel(instance_, "_COMMAND"), &c);
    const bool answered = link.PumpUntil(
        [&] {
          const status_t& s = *link.status();
          return s.commands_accepted > before.commands_accepted || s.commands_rejected > before.commands_rejected;
        },
        bus_.wait);
    if (!answered) throw std::runtime_error("no answer from lagranged within " + FormatDouble(bus_.wait) + " s");
    const status_t& after = *link.status();
    if (after.commands_rejected > before.commands_rejected) throw std::runtime_error(after.last_command_error);
    link.PumpUntil([&] { return link.state()->utime > after.utime; }, 0.5);
    static const char* kModes[] = {"running", "hold", "fault", "paused", "estop"};
    const state_t& s = *link.state();
    out << instance_ << ": " << verb << (args.empty() || verb == "gains" ? "" : " " + args[0]) << " done; now "
        << (s.mode >= 0 && s.mode < 5 ? kModes[s.mode] : "?") << " with " << s.controller << "\n";
    return 0;
  }

 private:
  std::string instance_;
  std::vector<std::string> action_;
  BusOptions bus_;
};

}  // namespace

std::unique_ptr<Command> MakeCommandCommand(CLI::App& parent) { return std::make_unique<CommandCommand>(parent); }

}  // namespace lagrange::cli
