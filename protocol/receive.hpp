#pragma once
// The one typed receive: a message's bytes as a subscriber or a log reader has
// them => the decoded message, or the reason it was dropped. The check is the
// message type's (kCheckOf below: its Check*Packet), then a decode that must
// consume every byte; nothing is decoded that its check refused (the generated
// decoders trust the lengths a packet states).
//
// What comes before it: on a signed bus the bus itself verifies every
// datagram's signature (key, domain, stamp window, replay: protocol/bus.hpp,
// protocol/signing.hpp) and hands on only the message, its trailer stripped;
// refusals are counted there by reason (BusStats). What reaches Receive is
// then either a verified message or, on a bus without a key, whatever was sent.
//
// Framing: a live message (kLive) must be exactly the message. A message that
// still carries a signature trailer reached a receiver without the key: it is
// dropped as kSignedWithoutKey (never trusted: nothing checked its tag). A
// recording (kRecorded: lcm-logger keeps the trailer with the payload) is read
// with or without the trailer, which is not checked (a reader of a file has no
// key and no clock to check it against).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "protocol/bus.hpp"
#include "protocol/signing.hpp"
#include "protocol/wire.hpp"

namespace lagrange {

class state_t;
class setpoint_t;
class command_t;
class reply_t;
class status_t;
class torque_t;
class telemetry_t;
class forces_t;
class pose_setpoint_t;
class task_state_t;
class base_state_t;
class mpc_t;

// Why a message was dropped; kNone when it was decoded.
enum class Drop : std::uint8_t {
  kNone,
  kTooShort,          // shorter than its type's fixed fields
  kWrongType,         // another type's fingerprint
  kBadLength,         // a declared length out of range
  kSizeMismatch,      // its size is not what its declared lengths make it
  kSignedWithoutKey,  // a signed message (a trailer) on a receiver without the key
  kUndecodable,       // the generated decoder did not consume exactly its bytes
};
// "packet too short", ... (the wire checks' own words for theirs).
const char* ToString(Drop drop);

enum class Framing : std::uint8_t {
  kLive,      // what a Bus handler gets: exactly the message
  kRecorded,  // a log record: the message, maybe followed by an unverified signature trailer
};

// The check each message type calls for (protocol/wire.hpp).
using PacketCheck = WireCheck (*)(const void*, std::size_t);
// Only the types below have one: any other type is refused where it is named
// (a dependent static_assert: comparing a function's address with nullptr is
// not a constant expression in the sanitizer builds, so the check cannot be
// "kCheckOf<M> != nullptr").
template <class>
inline constexpr bool kNotAMessageType = false;
template <class Message>
inline constexpr PacketCheck kCheckOf = [] {
  static_assert(kNotAMessageType<Message>, "not a lagrange message type");
  return PacketCheck{nullptr};
}();
template <>
inline constexpr PacketCheck kCheckOf<state_t> = &CheckStatePacket;
template <>
inline constexpr PacketCheck kCheckOf<setpoint_t> = &CheckSetpointPacket;
template <>
inline constexpr PacketCheck kCheckOf<command_t> = &CheckCommandPacket;
template <>
inline constexpr PacketCheck kCheckOf<reply_t> = &CheckReplyPacket;
template <>
inline constexpr PacketCheck kCheckOf<status_t> = &CheckStatusPacket;
template <>
inline constexpr PacketCheck kCheckOf<torque_t> = &CheckTorquePacket;
template <>
inline constexpr PacketCheck kCheckOf<telemetry_t> = &CheckTelemetryPacket;
template <>
inline constexpr PacketCheck kCheckOf<forces_t> = &CheckForcesPacket;
template <>
inline constexpr PacketCheck kCheckOf<pose_setpoint_t> = &CheckPoseSetpointPacket;
template <>
inline constexpr PacketCheck kCheckOf<task_state_t> = &CheckTaskStatePacket;
template <>
inline constexpr PacketCheck kCheckOf<base_state_t> = &CheckBaseStatePacket;
template <>
inline constexpr PacketCheck kCheckOf<mpc_t> = &CheckMpcPacket;

// A wire check's verdict as a Drop.
Drop DropOf(WireCheck check);
// `check` applied as `framing` says (see the header): the message's size on kNone.
Drop CheckFramed(PacketCheck check, Framing framing, const std::uint8_t* data, std::size_t size,
                 std::size_t& message_size);

// Decodes `size` bytes at `data` into `out` after its type's check. `out` is
// left unspecified on a drop. Reusing one `out` reuses its vectors' storage
// (the daemon's receive thread).
template <class Message>
Drop ReceiveInto(Message& out, const void* data, std::size_t size, Framing framing = Framing::kLive) {
  if (data == nullptr) return Drop::kTooShort;
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::size_t n = 0;
  if (const Drop d = CheckFramed(kCheckOf<Message>, framing, p, size, n); d != Drop::kNone) return d;
  return out.decode(p, 0, static_cast<int>(n)) == static_cast<int>(n) ? Drop::kNone : Drop::kUndecodable;
}

// The decoded message, or why it was dropped.
template <class Message>
struct Received {
  std::optional<Message> message;
  Drop drop = Drop::kNone;
  explicit operator bool() const { return message.has_value(); }
};

template <class Message>
Received<Message> Receive(const void* data, std::size_t size, Framing framing = Framing::kLive) {
  Received<Message> r;
  Message m;
  r.drop = ReceiveInto(m, data, size, framing);
  if (r.drop == Drop::kNone) r.message = std::move(m);
  return r;
}

// Subscribes `on_message(Message&&)` to `channel` of `bus`: every live message
// Receive accepts; the others are dropped (a subscriber that counts or reports
// drops calls ReceiveInto itself).
template <class Message, class OnMessage>
void SubscribeMessages(Bus& bus, const std::string& channel, OnMessage on_message) {
  bus.Subscribe(channel, [on = std::move(on_message)](std::string_view, const std::uint8_t* data, std::size_t size) {
    Message m;
    if (ReceiveInto(m, data, size) == Drop::kNone) on(std::move(m));
  });
}

}  // namespace lagrange
