#include "protocol/mode.hpp"

namespace lagrange {

std::string_view ToString(Mode mode) {
  switch (mode) {
    case Mode::kRunning: return "running";
    case Mode::kHold: return "hold";
    case Mode::kFault: return "fault";
    case Mode::kPaused: return "paused";
    case Mode::kEstop: return "estop";
    case Mode::kStopped: return "stopped";
    case Mode::kWaiting: return "waiting";
  }
  return "?";
}

const char* ModeName(std::int8_t wire_mode) {
  if (wire_mode < static_cast<std::int8_t>(Mode::kRunning) || wire_mode > static_cast<std::int8_t>(Mode::kWaiting))
    return "?";
  return ToString(static_cast<Mode>(wire_mode)).data();  // the names are string literals
}

}  // namespace lagrange
