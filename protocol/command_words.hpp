#pragma once
// A command from the words lagrangectl command takes ("estop", "controller
// pd", "effect damping on", "integrator rk4"): the one table of verbs, their
// operands and what each operand must be, for the CLI (tools/command.cpp) and
// the Python client (python/bus.cpp).

#include <lagrange/command_t.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace lagrange {

// A word that is not a command, or the wrong number of operands: one line
// naming what was expected ("unknown action 'x' (expected controller, gains, ..)").
struct CommandWordsError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// "controller, gains, reset, ... or forces": every verb, for messages.
std::string CommandVerbs();

// command_t for `words` (the verb, then its operands), every other field zero
// (gains: num_gains, kp and kd are the caller's; integrator: substeps and
// tolerances 0, the daemon's defaults). Names are checked as the daemon
// checks them (controller names excepted: only the daemon knows the scene's).
// Throws CommandWordsError.
command_t CommandFromWords(const std::vector<std::string>& words);

}  // namespace lagrange
