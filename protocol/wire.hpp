#pragma once
// Checking LCM packets before decoding them. The generated decoders trust
// array lengths written in the packet; a crafted length could make them
// allocate gigabytes. These functions walk the wire layout of our types and
// accept a packet only if its fingerprint matches and its size is exactly
// what its own length fields imply, within kMaxDofs.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace lagrange {

enum class WireCheck : std::uint8_t { kOk, kTooShort, kFingerprint, kBadLength, kSizeMismatch };

// A packet's LCM fingerprint (its first 8 bytes, big-endian); 0 when shorter.
std::int64_t Fingerprint(const void* data, std::size_t size);

// lagrange's message types, told apart by their fingerprints.
enum class MessageType : std::uint8_t {
  kUnknown,  // another type's fingerprint, or shorter than one
  kState,
  kSetpoint,
  kCommand,
  kReply,
  kStatus,
  kTorque,
  kTelemetry,
  kForces,
  kPoseSetpoint,
  kTaskState,
  kMpc,
  kBaseState,
};
// A packet's type by its fingerprint alone: the layout is the Check*Packet functions' to check.
MessageType TypeOf(const void* data, std::size_t size);
// The LCM type's name ("state_t", ...); "?" for kUnknown.
const char* ToString(MessageType type);
// The run id of a state_t, status_t, reply_t, torque_t, task_state_t, base_state_t or mpc_t packet (each begins:
// fingerprint, utime, run_id); nullopt for another type or a short packet.
std::optional<std::int64_t> RunIdOf(const void* data, std::size_t size);
const char* ToString(WireCheck check);

// setpoint_t: fingerprint, utime, num_dofs, 3 × num_dofs doubles.
WireCheck CheckSetpointPacket(const void* data, std::size_t size);
// command_t: fingerprint, utime, request_id, command, controller (string), num_gains, 2 × num_gains doubles,
// setting (string), substeps, rtol, atol, max_steps, on.
WireCheck CheckCommandPacket(const void* data, std::size_t size);
// torque_t: fingerprint, utime, run_id, sequence, state_tick, num_dofs (<= kMaxDofs), num_dofs doubles.
WireCheck CheckTorquePacket(const void* data, std::size_t size);

// What a client (lagrangectl, protocol/client.hpp) receives, checked the same way before decoding.
// state_t: fingerprint, utime, run_id, tick, t, num_dofs (≤ kMaxDofs), 6 × num_dofs doubles, T, V, controller, mode.
WireCheck CheckStatePacket(const void* data, std::size_t size);
// status_t: every fixed field, its two strings, num_instances (≤ kMaxStatusInstances) names, modes and
// joint counts, reasons, integrators, methods, effects and forces flags, num_joints (≤ kMaxStatusJoints) joint names,
// bus_signed, datagrams_unauthenticated, num_unauthenticated_channels (≤ kMaxStatusChannels) channels and counts.
inline constexpr std::int32_t kMaxStatusInstances = 1024;
inline constexpr std::int32_t kMaxStatusJoints = 4096;
// status_t.unauthenticated_channels: at most this many channels are listed.
inline constexpr std::int32_t kMaxStatusChannels = 16;
WireCheck CheckStatusPacket(const void* data, std::size_t size);
// telemetry_t: every fixed field and its two strings.
WireCheck CheckTelemetryPacket(const void* data, std::size_t size);
// forces_t: the fixed fields, num_dofs (≤ kMaxDofs), 9 × num_dofs doubles, contacts_total, num_contacts (≤
// kMaxContacts) contact_t.
WireCheck CheckForcesPacket(const void* data, std::size_t size);
// The forces_t of lagrange before the constraint row and the contacts (its own fingerprint, which lcm-gen
// derives from the fields): seven flags, num_dofs (≤ kMaxDofs), 8 × num_dofs doubles. Only logs are read
// with it (protocol/log_records.hpp); a live one is another type.
inline constexpr std::int64_t kForcesV1Fingerprint = static_cast<std::int64_t>(0xbcdb73cfe7e9ba20ULL);
WireCheck CheckForcesV1Packet(const void* data, std::size_t size);
// reply_t: fingerprint, utime, run_id, request_id, command, accepted, reason.
WireCheck CheckReplyPacket(const void* data, std::size_t size);
// pose_setpoint_t: fingerprint, utime, frame (string), 14 doubles.
WireCheck CheckPoseSetpointPacket(const void* data, std::size_t size);
// task_state_t: fingerprint, utime, run_id, tick, t, frame and controller (strings), 26 doubles.
WireCheck CheckTaskStatePacket(const void* data, std::size_t size);
// base_state_t: fingerprint, utime, run_id, tick, t, 22 doubles.
WireCheck CheckBaseStatePacket(const void* data, std::size_t size);
// mpc_t: fingerprint, utime, run_id, tick, t, controller (string), plan, start, age, solve_time, iterations,
// cost_before, cost, status (string), followed, dt, horizon, num_states (even, <= 2 kMaxDofs), num_knots
// (<= mpc_t::MAX_KNOTS, and num_knots × (num_states + 1) <= kMaxMpcKnotValues), num_knots times,
// num_knots × num_states doubles.
inline constexpr std::int32_t kMaxMpcKnots = 16;         // mpc_t::MAX_KNOTS
inline constexpr std::int32_t kMaxMpcKnotValues = 1536;  // 12 KiB of knots: the message stays one datagram
WireCheck CheckMpcPacket(const void* data, std::size_t size);
// The knots an mpc_t carries of a plan of `horizon` knots (N + 1 states) of `num_states` each:
// min(kMaxMpcKnots, N + 1, kMaxMpcKnotValues / (num_states + 1)); 0 for no plan (horizon 0).
std::int32_t MpcKnotsOnWire(std::int32_t num_states, std::int32_t horizon);
// Knot j of `knots` evenly spaced over a plan's 0 .. horizon: round(j N / (knots − 1)) (0 for one knot).
std::int32_t MpcKnotOnWire(std::int32_t j, std::int32_t knots, std::int32_t horizon);

}  // namespace lagrange
