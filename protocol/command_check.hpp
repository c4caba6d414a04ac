#pragma once
// A command packet from the wire to a verdict, without LCM or threads: the
// raw layout check (wire.hpp), decoding, then what does not change while the
// daemon runs (the command code, controller names, gain sizes and each
// controller's gain bounds). The bounds are the instance model's
// (Controller::gain_bounds()): the simulator, which builds that model, gives
// the check of them (CommandRules::check_gains), so the protocol needs no
// dynamics. What depends on the instance's mode is the tick's to decide.

#include <lagrange/command_t.hpp>

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/vocabulary.hpp"
#include "protocol/command_kind.hpp"

namespace lagrange {

struct CommandRules {
  std::string instance;                  // for messages
  int n = 0;                             // the instance's num_dofs
  std::vector<std::string> controllers;  // names, by index
  // How many gains each controller takes: one per joint, or kTaskDims with
  // gains_per_task_axis (a task-space controller's: x, y, z, rx, ry, rz).
  std::vector<int> gain_counts;
  std::vector<bool> gains_per_task_axis;
  // Why gains of the right count cannot be used by controller `c` (kp and kd,
  // gain_counts[c] each) at the scene's period: "kp[1]: expected ...", or
  // nullopt. Empty: any count-sized gains are taken.
  std::function<std::optional<std::string>(std::size_t c, std::span<const double> kp, std::span<const double> kd)>
      check_gains;
  IntegratorConfig integrator;  // the scene's: set-integrator keeps its Newton settings
};

struct CommandVerdict {
  enum class Kind : std::uint8_t { kAccepted, kRejected, kUndecodable } kind = Kind::kUndecodable;
  std::string reason;  // why, for kRejected and kUndecodable; bus text in it is escaped
  CommandKind command = CommandKind::kReset;
  int controller = -1;  // switch: the target; set-gains: the controller the gains are for
  // set-integrator, set-effect, set-method, set-forces, parsed and checked (CommandMessage's fields).
  IntegratorConfig integrator;
  bool default_max_steps = false;
  EffectKind effect = EffectKind::kGravity;
  Method method = Method::kClosedForm;
  bool on = false;
};

// Checks `data` (size bytes) as a command_t for an instance with `rules`,
// decoding it into `out` (whose vectors keep their capacity). `active` is
// the instance's active controller (set-gains with no name means it).
// Integrator, effect and method names are parsed here and the integrator's
// numbers checked (CheckIntegratorConfig; 0 means the default); whether the
// instance can take them now is the tick's to decide (Instance::Set*).
CommandVerdict CheckCommand(const void* data, std::size_t size, const CommandRules& rules, int active, command_t& out);

}  // namespace lagrange
