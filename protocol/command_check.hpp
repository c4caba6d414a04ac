#pragma once
// A command packet from the wire to a verdict, without LCM or threads: the
// raw layout check (wire.hpp), decoding, then what does not change while the
// daemon runs (the command code, controller names, gain sizes and each
// controller's gain bounds, Controller::gain_bounds()).
// What depends on the instance's mode is the tick's to decide.

#include <lagrange/command_t.hpp>

#include <string>
#include <vector>

#include "controllers/factory.hpp"
#include "plant/effects.hpp"
#include "plant/integrators.hpp"
#include "plant/types.hpp"
#include "protocol/command_kind.hpp"

namespace lagrange {

struct CommandRules {
  std::string instance;                  // for messages
  int n = 0;                             // the instance's num_dofs
  std::vector<std::string> controllers;  // names, by index
  std::vector<ControllerType> controller_types;
  std::vector<GainBounds> gain_bounds;  // what each controller can use at the scene's period
  IntegratorConfig integrator;          // the scene's: set-integrator keeps its Newton settings
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
