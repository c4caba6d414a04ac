#include "protocol/command_check.hpp"

#include <algorithm>

#include "base/escape.hpp"
#include "protocol/receive.hpp"
#include "protocol/wire.hpp"

namespace lagrange {
namespace {

CommandVerdict MakeVerdict(CommandVerdict::Kind kind, std::string why) {
  CommandVerdict v;
  v.kind = kind;
  v.reason = std::move(why);
  return v;
}

CommandVerdict Reject(std::string why) { return MakeVerdict(CommandVerdict::Kind::kRejected, std::move(why)); }

int FindController(const CommandRules& rules, const std::string& name) {
  const auto it = std::find(rules.controllers.begin(), rules.controllers.end(), name);
  return it == rules.controllers.end() ? -1 : static_cast<int>(it - rules.controllers.begin());
}

std::string Unknown(const CommandRules& rules, const std::string& name) {
  std::string list;
  for (const std::string& c : rules.controllers) list += (list.empty() ? "" : ", ") + c;
  return "unknown controller '" + Escape(name, 64) + "' for " + rules.instance + " (available: " + list + ")";
}

}  // namespace

CommandVerdict CheckCommand(const void* data, std::size_t size, const CommandRules& rules, int active, command_t& out) {
  if (const Drop d = ReceiveInto(out, data, size); d != Drop::kNone) {
    return MakeVerdict(CommandVerdict::Kind::kUndecodable, ToString(d));
  }
  if (out.command < command_t::SWITCH_CONTROLLER || out.command > command_t::SET_FORCES) {
    return Reject("unknown command " + std::to_string(out.command));
  }
  CommandVerdict v = MakeVerdict(CommandVerdict::Kind::kAccepted, "");
  v.command = static_cast<CommandKind>(out.command);
  if (v.command == CommandKind::kSwitchController) {
    v.controller = FindController(rules, out.controller);
    if (v.controller < 0) return Reject(Unknown(rules, out.controller));
  }
  if (v.command == CommandKind::kSetGains) {
    v.controller = out.controller.empty() ? active : FindController(rules, out.controller);
    if (v.controller < 0) return Reject(Unknown(rules, out.controller));
    const auto c = static_cast<std::size_t>(v.controller);
    // One gain per joint, or per task axis (6) for a task-space controller.
    const int count = rules.gain_counts[c];
    if (out.num_gains != count) {
      return Reject("gains: num_gains is " + std::to_string(out.num_gains) + ", expected " + std::to_string(count) +
                    (rules.gains_per_task_axis[c] ? " (one per task axis: x, y, z, rx, ry, rz)" : ""));
    }
    const auto n = static_cast<std::size_t>(count);
    if (rules.check_gains) {
      if (auto err = rules.check_gains(c, std::span<const double>(out.kp.data(), n),
                                       std::span<const double>(out.kd.data(), n))) {
        return Reject("gains for " + rules.controllers[c] + ": " + *err);
      }
    }
  }
  v.on = out.on;
  const std::string setting = Escape(out.setting, 64);
  if (v.command == CommandKind::kSetIntegrator) {
    const std::optional<IntegratorType> type = ParseIntegratorType(out.setting);
    if (!type) return Reject("unknown integrator '" + setting + "' (expected " + IntegratorTypeNames() + ")");
    IntegratorConfig c = rules.integrator;  // its Newton settings
    const IntegratorConfig defaults;
    c.type = *type;
    c.substeps = out.substeps == 0 ? defaults.substeps : out.substeps;
    c.rtol = out.rtol == 0.0 ? defaults.rtol : out.rtol;
    c.atol = out.atol == 0.0 ? defaults.atol : out.atol;
    v.default_max_steps = out.max_steps == 0;
    c.max_steps = v.default_max_steps ? rules.integrator.max_steps : out.max_steps;
    if (const char* why = CheckIntegratorConfig(c)) return Reject(std::string("integrator: ") + why);
    v.integrator = c;
  }
  if (v.command == CommandKind::kSetEffect) {
    const std::optional<EffectKind> effect = ParseEffectKind(out.setting);
    if (!effect) return Reject("unknown effect '" + setting + "' (expected " + EffectKindNames() + ")");
    v.effect = *effect;
  }
  if (v.command == CommandKind::kSetMethod) {
    const std::optional<Method> method = ParseMethod(out.setting);
    if (!method) return Reject("unknown method '" + setting + "' (expected " + MethodNames() + ")");
    v.method = *method;
  }
  return v;
}

}  // namespace lagrange
