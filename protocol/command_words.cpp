#include "protocol/command_words.hpp"

#include <iterator>
#include <optional>

#include "base/escape.hpp"
#include "base/vocabulary.hpp"

namespace lagrange {
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

// Throws listing the known names unless `known`.
void RequireKnown(const std::string& what, const std::string& name, bool known, const std::string& names) {
  if (!known) throw CommandWordsError("unknown " + what + " '" + Escape(name, 60) + "' (expected " + names + ")");
}

bool OnOff(const std::string& what, const std::string& word) {
  if (word != "on" && word != "off") {
    throw CommandWordsError(what + ": expected on or off, got '" + Escape(word, 60) + "'");
  }
  return word == "on";
}

}  // namespace

std::string CommandVerbs() {
  std::string verbs;
  constexpr std::size_t n = std::size(kActions);
  for (std::size_t i = 0; i < n; ++i) verbs += std::string(i == 0 ? "" : i + 1 == n ? " or " : ", ") + kActions[i].verb;
  return verbs;
}

command_t CommandFromWords(const std::vector<std::string>& words) {
  if (words.empty()) throw CommandWordsError("no action (expected " + CommandVerbs() + ")");
  const std::string& verb = words[0];
  const Action* action = nullptr;
  for (const Action& a : kActions) action = verb == a.verb ? &a : action;
  if (!action) throw CommandWordsError("unknown action '" + Escape(verb, 60) + "' (expected " + CommandVerbs() + ")");
  const std::vector<std::string> args(words.begin() + 1, words.end());
  if (static_cast<int>(args.size()) != action->operands) {
    if (action->operands == 0) throw CommandWordsError(verb + ": takes no arguments");
    throw CommandWordsError(verb + ": expected " + action->expected + ", got " + std::to_string(args.size()) +
                            (args.size() == 1 ? " word" : " words"));
  }
  command_t c{};  // every field zero: "the default" for the integrator's numbers
  c.command = action->code;
  switch (action->code) {
    case command_t::SWITCH_CONTROLLER: c.controller = args[0]; break;
    case command_t::SET_INTEGRATOR:
      RequireKnown("integrator", args[0], ParseIntegratorType(args[0]).has_value(), IntegratorTypeNames());
      c.setting = args[0];
      break;
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

}  // namespace lagrange
