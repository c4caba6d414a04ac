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
#include "daemon/runtime.hpp"

namespace lagrange {

struct CommandRules {
  std::string instance;                  // for messages
  int n = 0;                             // the instance's num_dofs
  std::vector<std::string> controllers;  // names, by index
  std::vector<ControllerType> controller_types;
  std::vector<GainBounds> gain_bounds;  // what each controller can use at the scene's period
};

struct CommandVerdict {
  enum class Kind : std::uint8_t { kAccepted, kRejected, kUndecodable } kind = Kind::kUndecodable;
  std::string reason;  // why, for kRejected and kUndecodable; bus text in it is escaped
  CommandKind command = CommandKind::kReset;
  int controller = -1;  // switch: the target; set-gains: the controller the gains are for
};

// Checks `data` (size bytes) as a command_t for an instance with `rules`,
// decoding it into `out` (whose vectors keep their capacity). `active` is
// the instance's active controller (set-gains with no name means it).
CommandVerdict CheckCommand(const void* data, std::size_t size, const CommandRules& rules, int active, command_t& out);

}  // namespace lagrange
