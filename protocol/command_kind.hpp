#pragma once
// What a command asks, as command_t.command and reply_t.command carry it
// (command_t.SWITCH_CONTROLLER ...).

#include <cstdint>

namespace lagrange {

enum class CommandKind : std::int8_t {
  kSwitchController = 1,
  kSetGains = 2,
  kReset = 3,
  kPause = 4,
  kResume = 5,
  kEstop = 6,
  kClearEstop = 7,
  kSetIntegrator = 8,
  kSetEffect = 9,
  kSetMethod = 10,
  kSetForces = 11,
};

}  // namespace lagrange
