#pragma once
// The scene's own setpoint source (an instance's `setpoint:`), a header of
// its own so that the scene (sim/scene.hpp) and the reader of its control
// parts (sim/scene_control.hpp) both use it without including each other.

#include <cstdint>
#include <optional>

#include "plant/types.hpp"

namespace lagrange {

// Used until (and unless) setpoints arrive over LCM. Times are from the
// start of the run.
struct TrajectoryConfig {
  enum class Type : std::uint8_t { kHold, kStep, kSine, kMinimumJerk } type = Type::kHold;
  std::optional<VectorXd> q;       // hold: the held position (default: the initial q)
  VectorXd target;                 // step, min-jerk
  double at = 0.0;                 // step: when, s
  VectorXd amplitude;              // sine, rad or m
  VectorXd frequency;              // sine, Hz
  std::optional<VectorXd> center;  // sine (default: the initial q)
  double duration = 1.0;           // min-jerk, s
};

}  // namespace lagrange
