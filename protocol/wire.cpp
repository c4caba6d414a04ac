#include "protocol/wire.hpp"

#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <algorithm>

#include "base/vocabulary.hpp"
#include "protocol/big_endian.hpp"

namespace lagrange {
namespace {

std::int64_t ReadInt64(const std::uint8_t* p) { return static_cast<std::int64_t>(ReadBigEndian64(p)); }

std::int32_t ReadInt32(const std::uint8_t* p) { return static_cast<std::int32_t>(ReadBigEndian32(p)); }

constexpr std::size_t kHash = 8, kInt64 = 8, kInt32 = 4, kInt8 = 1, kDouble = 8;
constexpr std::size_t kContactBytes = 2 * kInt32 + 13 * kDouble;  // contact_t: geom1, geom2, distance, 4 vectors
constexpr std::int32_t kMaxString = 256;  // bytes, including the terminating NUL

}  // namespace

std::int64_t Fingerprint(const void* data, std::size_t size) {
  return size < kHash ? 0 : ReadInt64(static_cast<const std::uint8_t*>(data));
}

MessageType TypeOf(const void* data, std::size_t size) {
  const std::int64_t hash = Fingerprint(data, size);
  if (hash == state_t::getHash()) return MessageType::kState;
  if (hash == setpoint_t::getHash()) return MessageType::kSetpoint;
  if (hash == command_t::getHash()) return MessageType::kCommand;
  if (hash == reply_t::getHash()) return MessageType::kReply;
  if (hash == status_t::getHash()) return MessageType::kStatus;
  if (hash == torque_t::getHash()) return MessageType::kTorque;
  if (hash == telemetry_t::getHash()) return MessageType::kTelemetry;
  if (hash == forces_t::getHash()) return MessageType::kForces;
  if (hash == pose_setpoint_t::getHash()) return MessageType::kPoseSetpoint;
  if (hash == task_state_t::getHash()) return MessageType::kTaskState;
  if (hash == mpc_t::getHash()) return MessageType::kMpc;
  if (hash == base_state_t::getHash()) return MessageType::kBaseState;
  return MessageType::kUnknown;
}

const char* ToString(MessageType type) {
  switch (type) {
    case MessageType::kState: return "state_t";
    case MessageType::kSetpoint: return "setpoint_t";
    case MessageType::kCommand: return "command_t";
    case MessageType::kReply: return "reply_t";
    case MessageType::kStatus: return "status_t";
    case MessageType::kTorque: return "torque_t";
    case MessageType::kTelemetry: return "telemetry_t";
    case MessageType::kForces: return "forces_t";
    case MessageType::kPoseSetpoint: return "pose_setpoint_t";
    case MessageType::kTaskState: return "task_state_t";
    case MessageType::kMpc: return "mpc_t";
    case MessageType::kBaseState: return "base_state_t";
    case MessageType::kUnknown: break;
  }
  return "?";
}

std::optional<std::int64_t> RunIdOf(const void* data, std::size_t size) {
  switch (TypeOf(data, size)) {
    case MessageType::kUnknown:
    case MessageType::kSetpoint:
    case MessageType::kPoseSetpoint:
    case MessageType::kCommand: return std::nullopt;
    default: break;
  }
  if (size < kHash + 2 * kInt64) return std::nullopt;
  return ReadInt64(static_cast<const std::uint8_t*>(data) + kHash + kInt64);
}

const char* ToString(WireCheck check) {
  switch (check) {
    case WireCheck::kOk: return "ok";
    case WireCheck::kTooShort: return "packet too short";
    case WireCheck::kFingerprint: return "fingerprint mismatch (another type?)";
    case WireCheck::kBadLength: return "declared length out of range";
    case WireCheck::kSizeMismatch: return "packet size does not match its declared lengths";
  }
  return "?";
}

WireCheck CheckSetpointPacket(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  constexpr std::size_t header = kHash + kInt64 + kInt32;
  if (size < kHash) return WireCheck::kTooShort;
  if (ReadInt64(p) != setpoint_t::getHash()) return WireCheck::kFingerprint;
  if (size < header) return WireCheck::kTooShort;
  const std::int32_t n = ReadInt32(p + kHash + kInt64);
  if (n < 0 || n > kMaxDofs) return WireCheck::kBadLength;
  if (size != header + 3 * kDouble * static_cast<std::size_t>(n)) return WireCheck::kSizeMismatch;
  return WireCheck::kOk;
}

WireCheck CheckCommandPacket(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::size_t at = kHash + 2 * kInt64 + kInt8;  // fingerprint, utime, request_id, command
  if (size < kHash) return WireCheck::kTooShort;
  if (ReadInt64(p) != command_t::getHash()) return WireCheck::kFingerprint;
  if (size < at + kInt32) return WireCheck::kTooShort;
  const std::int32_t len = ReadInt32(p + at);  // string length including its NUL
  if (len < 1 || len > kMaxString) return WireCheck::kBadLength;
  at += kInt32 + static_cast<std::size_t>(len);
  if (size < at + kInt32) return WireCheck::kTooShort;
  if (p[at - 1] != 0) return WireCheck::kBadLength;  // the string must end in its NUL
  const std::int32_t g = ReadInt32(p + at);
  if (g < 0 || g > kMaxDofs) return WireCheck::kBadLength;
  at += kInt32 + 2 * kDouble * static_cast<std::size_t>(g);  // kp, kd
  if (size < at + kInt32) return WireCheck::kTooShort;
  const std::int32_t setting = ReadInt32(p + at);  // the setting's name, with its NUL
  if (setting < 1 || setting > kMaxString) return WireCheck::kBadLength;
  at += kInt32 + static_cast<std::size_t>(setting);
  if (size < at) return WireCheck::kTooShort;
  if (p[at - 1] != 0) return WireCheck::kBadLength;
  // substeps, rtol, atol, max_steps, on
  if (size != at + 2 * kInt32 + 2 * kDouble + kInt8) return WireCheck::kSizeMismatch;
  return WireCheck::kOk;
}

WireCheck CheckTorquePacket(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  constexpr std::size_t header = kHash + 4 * kInt64 + kInt32;
  if (size < kHash) return WireCheck::kTooShort;
  if (ReadInt64(p) != torque_t::getHash()) return WireCheck::kFingerprint;
  if (size < header) return WireCheck::kTooShort;
  const std::int32_t n = ReadInt32(p + kHash + 4 * kInt64);
  if (n < 0 || n > kMaxDofs) return WireCheck::kBadLength;
  if (size != header + kDouble * static_cast<std::size_t>(n)) return WireCheck::kSizeMismatch;
  return WireCheck::kOk;
}

// lagrangectl's side: packets the daemon publishes, walked field by field.
namespace {

constexpr std::int32_t kMaxStatusString = 4096;  // bytes with the NUL: reasons quote escaped input

// Reads a packet front to back, never past its end; the first failure sticks.
class PacketWalker {
 public:
  PacketWalker(const void* data, std::size_t size, std::int64_t hash)
      : p_(static_cast<const std::uint8_t*>(data)), size_(size) {
    if (size_ < kHash)
      result_ = WireCheck::kTooShort;
    else if (ReadInt64(p_) != hash)
      result_ = WireCheck::kFingerprint;
    else
      at_ = kHash;
  }
  void Skip(std::size_t bytes) {
    if (result_ != WireCheck::kOk) return;
    if (size_ - at_ < bytes)
      result_ = WireCheck::kTooShort;
    else
      at_ += bytes;
  }
  // An int32 length in [0, max]; 0 after a failure.
  std::int32_t Length(std::int32_t max) {
    if (result_ != WireCheck::kOk) return 0;
    if (size_ - at_ < kInt32) {
      result_ = WireCheck::kTooShort;
      return 0;
    }
    const std::int32_t n = ReadInt32(p_ + at_);
    at_ += kInt32;
    if (n < 0 || n > max) {
      result_ = WireCheck::kBadLength;
      return 0;
    }
    return n;
  }
  // An LCM string: int32 length including the NUL (1..max), the bytes, the NUL.
  void String(std::int32_t max) {
    const std::int32_t len = Length(max);
    if (result_ != WireCheck::kOk) return;
    if (len < 1) {
      result_ = WireCheck::kBadLength;
      return;
    }
    Skip(static_cast<std::size_t>(len));
    if (result_ == WireCheck::kOk && p_[at_ - 1] != 0) result_ = WireCheck::kBadLength;
  }
  // A length that breaks a rule between fields (their product, their parity): kBadLength, unless already failed.
  void Refuse() {
    if (result_ == WireCheck::kOk) result_ = WireCheck::kBadLength;
  }
  WireCheck Finish() const {
    if (result_ != WireCheck::kOk) return result_;
    return at_ == size_ ? WireCheck::kOk : WireCheck::kSizeMismatch;
  }

 private:
  const std::uint8_t* p_;
  std::size_t size_;
  std::size_t at_ = 0;
  WireCheck result_ = WireCheck::kOk;
};

}  // namespace

WireCheck CheckStatePacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, state_t::getHash());
  w.Skip(3 * kInt64 + kDouble);  // utime, run_id, tick, t
  const std::int32_t n = w.Length(kMaxDofs);
  w.Skip(6 * kDouble * static_cast<std::size_t>(n) + 2 * kDouble);  // q .. qd_des, T, V
  w.String(kMaxString);                                             // controller
  w.Skip(kInt8);                                                    // mode
  return w.Finish();
}

WireCheck CheckStatusPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, status_t::getHash());
  w.Skip(3 * kInt64 + kInt32 + 7 * kDouble +
         8 * kInt64);          // utime .. ticks_in_window, period .. compute_max, overruns .. measured_rejected
  w.String(kMaxStatusString);  // last_rejection
  w.Skip(2 * kInt64);          // commands_accepted, commands_rejected
  w.String(kMaxStatusString);  // last_command_error
  w.Skip(7 * kInt64);          // decode_errors .. replies_suppressed
  const std::int32_t n = w.Length(kMaxStatusInstances);
  for (std::int32_t i = 0; i < n; ++i) w.String(kMaxString);  // instance_names
  w.Skip(static_cast<std::size_t>(n) * kInt8);                // instance_modes
  w.Skip(static_cast<std::size_t>(n) * kInt32);               // instance_dofs
  for (std::int32_t i = 0; i < n; ++i) w.String(kMaxString);  // instance_reasons
  for (std::int32_t i = 0; i < n; ++i) w.String(kMaxString);  // instance_integrators
  for (std::int32_t i = 0; i < n; ++i) w.String(kMaxString);  // instance_methods
  for (std::int32_t i = 0; i < n; ++i) w.String(kMaxString);  // instance_effects
  w.Skip(static_cast<std::size_t>(n) * kInt8);                // instance_forces
  const std::int32_t j = w.Length(kMaxStatusJoints);          // num_joints
  for (std::int32_t i = 0; i < j; ++i) w.String(kMaxString);  // joint_names
  w.Skip(kInt8 + kInt64);                                     // bus_signed, datagrams_unauthenticated
  const std::int32_t c = w.Length(kMaxStatusChannels);        // num_unauthenticated_channels
  for (std::int32_t i = 0; i < c; ++i) w.String(kMaxString);  // unauthenticated_channels
  w.Skip(static_cast<std::size_t>(c) * kInt64);               // unauthenticated_counts
  return w.Finish();
}

WireCheck CheckTelemetryPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, telemetry_t::getHash());
  w.Skip(3 * kInt64 + kDouble + kInt8 + 5 * kDouble);  // utime, run_id, tick, t, mode, energy .. power
  w.String(kMaxString);                                // integrator
  w.Skip(kInt32);                                      // substeps
  w.String(kMaxString);                                // method
  w.Skip(5 * kInt32 + 3 * kDouble);                    // evaluations .. failures, error_estimate, step, compute_us
  return w.Finish();
}

WireCheck CheckForcesPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, forces_t::getHash());
  w.Skip(3 * kInt64 + kDouble + 8 * kInt8);  // utime, run_id, tick, t, the eight *_on
  const std::int32_t n = w.Length(kMaxDofs);
  w.Skip(9 * kDouble * static_cast<std::size_t>(n));  // gravity .. tau_applied
  w.Skip(kInt32);                                     // contacts_total
  const std::int32_t c = w.Length(kMaxContacts);      // num_contacts
  w.Skip(kContactBytes * static_cast<std::size_t>(c));
  return w.Finish();
}

WireCheck CheckForcesV1Packet(const void* data, std::size_t size) {
  PacketWalker w(data, size, kForcesV1Fingerprint);
  w.Skip(3 * kInt64 + kDouble + 7 * kInt8);  // utime, run_id, tick, t, the seven *_on
  const std::int32_t n = w.Length(kMaxDofs);
  w.Skip(8 * kDouble * static_cast<std::size_t>(n));  // gravity .. tau_applied (no constraint)
  return w.Finish();
}

WireCheck CheckPoseSetpointPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, pose_setpoint_t::getHash());
  w.Skip(kInt64);                  // utime
  w.String(kMaxString);            // frame
  w.Skip((3 + 4 + 6 + 1) * kDouble);  // position, orientation, twist, duration
  return w.Finish();
}

WireCheck CheckTaskStatePacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, task_state_t::getHash());
  w.Skip(3 * kInt64 + kDouble);  // utime, run_id, tick, t
  w.String(kMaxString);          // frame
  w.String(kMaxString);          // controller
  w.Skip((3 + 4 + 3 + 4 + 6 + 6) * kDouble);  // position .. twist
  return w.Finish();
}

WireCheck CheckBaseStatePacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, base_state_t::getHash());
  w.Skip(3 * kInt64 + kDouble);                    // utime, run_id, tick, t
  w.Skip((3 + 4 + 3 + 3 + 3 + 3 + 3) * kDouble);  // position .. angular_momentum
  return w.Finish();
}

static_assert(kMaxMpcKnots == mpc_t::MAX_KNOTS);

std::int32_t MpcKnotsOnWire(std::int32_t num_states, std::int32_t horizon) {
  if (horizon <= 0 || num_states < 0) return 0;
  return std::min({kMaxMpcKnots, horizon + 1, kMaxMpcKnotValues / (num_states + 1)});
}

std::int32_t MpcKnotOnWire(std::int32_t j, std::int32_t knots, std::int32_t horizon) {
  if (knots <= 1) return 0;
  return static_cast<std::int32_t>((static_cast<std::int64_t>(j) * horizon * 2 + (knots - 1)) / (2 * (knots - 1)));
}

WireCheck CheckMpcPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, mpc_t::getHash());
  w.Skip(3 * kInt64 + kDouble);                        // utime, run_id, tick, t
  w.String(kMaxString);                                 // controller
  w.Skip(kInt64 + 3 * kDouble + kInt32 + 2 * kDouble);  // plan, start, age, solve_time, iterations, cost_before,
                                                        // cost
  w.String(kMaxString);                                 // status
  w.Skip(kInt8 + kDouble + kInt32);                     // followed, dt, horizon
  const std::int32_t states = w.Length(2 * kMaxDofs);
  const std::int32_t knots = w.Length(mpc_t::MAX_KNOTS);
  if (states % 2 != 0 || knots * (states + 1) > kMaxMpcKnotValues) w.Refuse();  // q and qd; one datagram
  w.Skip(kDouble * static_cast<std::size_t>(knots) * static_cast<std::size_t>(states + 1));  // knot_t, knot_x
  return w.Finish();
}

WireCheck CheckReplyPacket(const void* data, std::size_t size) {
  PacketWalker w(data, size, reply_t::getHash());
  w.Skip(3 * kInt64 + 2 * kInt8);  // utime, run_id, request_id, command, accepted
  w.String(kMaxStatusString);      // reason
  return w.Finish();
}

}  // namespace lagrange
