#pragma once
// An instance's mode, as state_t.mode, telemetry_t.mode and
// status_t.instance_modes carry it (state_t.MODE_*). What each mode means and
// what moves an instance between them is the tick's (daemon/runtime.hpp).

#include <cstdint>
#include <string_view>

namespace lagrange {

enum class Mode : std::int8_t {
  kRunning = 0,
  kHold = 1,
  kFault = 2,
  kPaused = 3,
  kEstop = 4,
  kStopped = 5,  // external plant: the watchdog stopped commanding
  kWaiting = 6,  // external plant: armed, no measured state yet
};
std::string_view ToString(Mode mode);
// The name of a state_t.mode / status_t.instance_modes value as it came off
// the wire: ToString of the mode, or "?" out of range.
const char* ModeName(std::int8_t wire_mode);

}  // namespace lagrange
