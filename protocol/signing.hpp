#pragma once
// Signed traffic: a shared secret key, and the trailer every datagram carries
// when a bus has one. Modelled on MAVLink 2 message signing (a per-link secret
// key, a truncated MAC, a timestamp that only grows per sender, a replay
// window, unsigned packets refused once signing is on).
//
// The trailer follows the LCM-encoded message inside the LC02 datagram, so
// LCM's decoders (lcm-spy, lcm-logger's readers, log2csv) read the message and
// ignore it; lcm-logger records it with the payload.
//
//   offset  bytes  field
//   0       8      sender id, u64 big-endian: random, chosen when the bus opens
//   8       8      stamp, u64 big-endian: µs since the Unix epoch, strictly
//                  increasing per sender (max(wall clock, previous + 1))
//   16      16     tag: keyed BLAKE2b-128 (libsodium crypto_generichash) of
//                  "LGS2" ‖ domain ‖ NUL ‖ channel ‖ NUL ‖ message ‖ sender id ‖ stamp
//   32      4      "LGS2": marks the trailer and its version (36 bytes in all)
//
// The domain binds a tag to one deployment: a message signed for one bus is
// refused on another that shares the key (a relay across buses is a replay
// the stamp window alone would let through). It is a name every program on
// the bus is given (--bus-domain, $LAGRANGE_BUS_DOMAIN, a scene's
// bus.domain), by default the bus itself: "udpm://GROUP:PORT" of its URL
// (protocol/bus_domain.hpp, the one definition, shared with the example
// clients). It is not secret and not sent: a receiver holding another domain
// computes another tag. LGS1, the format
// before domains, is refused as such (kOldFormat): a clean break.
//
// Accepted only when: the trailer is there, the stamp is within
// kStampWindowMicros of the receiver's wall clock and not before the receiver
// opened (a recording replayed later, or to a receiver started after it was
// made, is refused), the stamp is above the last one accepted from that
// sender (a datagram replayed while its sender is heard is refused), and the
// tag verifies (constant time). What is left: a datagram captured within the
// window and replayed to a receiver that was running but never heard its
// sender (another network segment) of the same domain, as with MAVLink. Why BLAKE2b and
// not MAVLink's HMAC-SHA256: bench/signing_bench.cpp measures both; see the
// README, "Signed traffic".
//
// What it does not do: encrypt (anyone on the network reads every message),
// keep a flood from filling the receive buffer (availability), or tell one key
// holder from another (a compromised holder can send anything).

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "protocol/bus_domain.hpp"

namespace lagrange {

// A key is a file of this many random bytes (lagrangectl keygen writes 32).
inline constexpr std::size_t kBusKeyMinBytes = 32;
inline constexpr std::size_t kBusKeyMaxBytes = 64;  // crypto_generichash_KEYBYTES_MAX
// Where a program finds the key when no --bus-key is given.
inline constexpr const char* kBusKeyEnv = "LAGRANGE_BUS_KEY_FILE";

inline constexpr std::size_t kSignatureTagBytes = 16;
inline constexpr std::size_t kSignatureTrailerBytes = 8 + 8 + kSignatureTagBytes + 4;
// How far a stamp may be from the receiver's wall clock, µs, either way.
// Hosts on one bus keep their clocks in step (NTP) to well within it.
inline constexpr std::int64_t kStampWindowMicros = 2'000'000;


class BusKey {
 public:
  // Reads `path`: a regular file (not a symbolic link: whoever can write the
  // link's directory could point it at another key) of
  // kBusKeyMinBytes..kBusKeyMaxBytes bytes, readable by its owner only (no
  // group or other permission bits), whose bytes are not all one value (an
  // all-zero file is a placeholder, not a key). Throws BusKeyError ("bus key
  // FILE: readable by group or others (mode 0644): chmod 600 FILE") otherwise.
  static BusKey FromFile(const std::string& path);
  // `bytes` as the key (tests); throws BusKeyError for a wrong size or bytes all of one value.
  static BusKey FromBytes(std::span<const std::uint8_t> bytes);

  std::span<const std::uint8_t> bytes() const { return {bytes_.data(), size_}; }

 private:
  std::array<std::uint8_t, kBusKeyMaxBytes> bytes_{};
  std::size_t size_ = 0;
};

// The key file: `option` when given (--bus-key), else $LAGRANGE_BUS_KEY_FILE
// when set, else "" (no key: unsigned). An empty path given either way (an
// unset variable in a unit or script) throws BusKeyError, never runs unsigned.
std::string ResolveBusKeyFile(const std::optional<std::string>& option);
// The bus domain (ResolveBusDomain, BusDomainProblem, BusKeyError): protocol/bus_domain.hpp.
// Writes a new key of kBusKeyMinBytes from libsodium's randombytes to `path`,
// mode 0600; never overwrites. Throws BusKeyError naming the file and why.
void WriteNewBusKey(const std::string& path);

// The MAC with the key and the domain absorbed once (BLAKE2b's key block,
// then "LGS2" ‖ domain ‖ NUL), copied per tag: the one definition of the tag,
// shared by Signer and Verifier.
class KeyedMac {
 public:
  // `domain`: a non-empty domain (BusDomainProblem); throws BusKeyError otherwise.
  KeyedMac(const BusKey& key, std::string_view domain);
  // The tag of (channel, message, sender id, stamp), kSignatureTagBytes to `tag`. Allocates nothing.
  void Tag(std::string_view channel, const std::uint8_t* message, std::size_t size, std::uint64_t sender_id,
           std::uint64_t stamp, std::uint8_t* tag) const;

 private:
  alignas(64) std::array<unsigned char, 384> state_{};  // crypto_generichash_state
};

// Wall-clock µs since the Unix epoch; injectable for tests.
using WallClockMicros = std::function<std::int64_t()>;
std::int64_t SystemWallMicros();

// Signs one sender's datagrams. Allocates nothing.
class Signer {
 public:
  // Signs for `domain`; `sender_id` 0 picks a random one.
  Signer(const BusKey& key, std::string_view domain, std::uint64_t sender_id = 0,
         WallClockMicros clock = SystemWallMicros);
  // Writes the trailer for (channel, message) to `trailer`
  // (kSignatureTrailerBytes); every call takes a new stamp.
  void Sign(std::string_view channel, const std::uint8_t* message, std::size_t size, std::uint8_t* trailer);
  std::uint64_t sender_id() const { return sender_id_; }

 private:
  KeyedMac mac_;
  std::uint64_t sender_id_;
  std::uint64_t last_stamp_ = 0;
  WallClockMicros clock_;
};

enum class SignatureVerdict : std::uint8_t {
  kOk,
  kUnsigned,   // shorter than a trailer, or no "LGS2" (nor "LGS1") at its end
  kOldFormat,  // an "LGS1" trailer: signed before domains, by a sender to update
  kStale,      // stamp outside kStampWindowMicros of the receiver's clock, or before the receiver opened
  kReplayed,   // stamp not above the last accepted from that sender
  kBadTag,     // the tag does not verify: forged, altered, another key or another domain
};

// The size of the message before what looks like a signature trailer (ends in
// "LGS2", or the old "LGS1"), `size` when there is none. Says nothing about
// the tag: for readers of recordings (log2csv), which have no key to check it with.
std::size_t MessageSizeBeforeTrailer(const std::uint8_t* wire, std::size_t size);

// Checks one receiver's datagrams. Remembers the last stamp of up to
// kMaxSenders senders whose tags verified (a forger cannot fill it); beyond
// that the least recently heard is forgotten. Allocates nothing.
class Verifier {
 public:
  static constexpr std::size_t kMaxSenders = 64;
  // Takes what was signed for `domain`.
  Verifier(const BusKey& key, std::string_view domain, WallClockMicros clock = SystemWallMicros);
  // `wire` is what followed the channel's NUL: message then trailer. On kOk,
  // `message_size` is the message's length (wire_size − the trailer).
  SignatureVerdict Verify(std::string_view channel, const std::uint8_t* wire, std::size_t wire_size,
                          std::size_t& message_size);

 private:
  struct Sender {
    std::uint64_t id = 0;
    std::uint64_t last_stamp = 0;
    std::uint64_t heard = 0;  // Verify's call number when last accepted
    bool used = false;
  };
  Sender* Find(std::uint64_t id);
  Sender& Admit(std::uint64_t id);

  KeyedMac mac_;
  WallClockMicros clock_;
  std::int64_t opened_;  // µs: nothing stamped earlier was sent to this receiver
  std::array<Sender, kMaxSenders> senders_{};
  std::uint64_t calls_ = 0;
};

}  // namespace lagrange
