#pragma once
// The ids on the wire. A run id names one run of a publisher (a lagranged,
// or one `lagrangectl send --tau` stream): state_t, status_t, reply_t,
// torque_t, telemetry_t and forces_t carry it, and a client acts only on
// what one run id published (protocol/client.hpp). A request id names one
// command (command_t.request_id), echoed in its reply_t.

#include <cstdint>
#include <string>

namespace lagrange {

// A random, non-zero 64-bit id for one run (getrandom); throws when the
// system has no randomness to give.
std::int64_t NewRunId();
// A fresh random non-zero id for a command (getrandom, as NewRunId).
std::int64_t NewRequestId();

// A run id or request id as lagrange prints it: 16 hex digits.
std::string RunIdText(std::int64_t id);

}  // namespace lagrange
