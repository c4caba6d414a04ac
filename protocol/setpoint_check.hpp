#pragma once
// A setpoint packet from the wire to a verdict, without LCM or threads: the
// raw layout check (wire.hpp), decoding, then the content rules. Its age is
// judged by the receiver, which knows the clocks.

#include <lagrange/setpoint_t.hpp>

#include <string>

#include "plant/types.hpp"

namespace lagrange {

struct SetpointRules {
  int n = 0;              // the instance's num_dofs
  VectorXd lower, upper;  // setpoint limits on q (n), ±inf for none
};

struct SetpointVerdict {
  enum class Kind : std::uint8_t { kAccepted, kRejected, kUndecodable } kind = Kind::kUndecodable;
  std::string reason;  // why, for kRejected and kUndecodable
};

// |q|, |qd|, |qdd| above this are refused as mistakes (rad, m and their rates).
inline constexpr double kMaxSetpointMagnitude = 1e6;

// Checks `data` (size bytes) as a setpoint_t for an instance with `rules`,
// decoding it into `out` (whose vectors keep their capacity).
SetpointVerdict CheckSetpoint(const void* data, std::size_t size, const SetpointRules& rules, setpoint_t& out);

}  // namespace lagrange
