// libFuzzer target: what the bus does with datagrams from the wire
// (protocol/bus.hpp), without a key and with one (protocol/signing.hpp).
//
// An input that does not begin with 'S' is one raw datagram for a bus without
// a key: ParseDatagram's classification, reformatting a parsed message byte
// for byte, and InProcessBus delivering it only to the subscribers of exactly
// its channel.
//
// An input that begins with 'S' is a script for an InProcessBus opened with a
// fixed test key on a fake wall clock. Each record after the 'S' starts with
// an op byte (op % 5):
//   0 sign:   channel (byte c: c < 0x80 one of kChannels, else c % 72 bytes),
//             sender id (byte + 1), stamp (byte k: odd, a u64; even, an i32 of
//             µs from the clock, taken modulo kStampReach + 1), message size
//             (u16 modulo kMaxScriptMessage + 1) and its bytes (zeros past
//             the input's end); a Signer of the key signs it.
//   1 keep:   as sign, but the datagram is kept for a resend, not sent (so
//             an altered copy can arrive before it, with its stamp still fresh).
//   2 raw:    size (u16) and the bytes: a datagram as it is.
//   3 resend: one of the last kHistory datagrams (byte), again unchanged (a
//             replay) or altered (byte % 5: none; one byte XORed, u16 offset
//             from the end and a mask; cut short, u16 bytes; u16 bytes of
//             input appended; another datagram appended, byte).
//   4 clock:  an i32 of µs added to the fake wall clock (it may step back).
// Integers are big-endian; past the input's end every byte reads as 0.
// Each datagram is drained alone and its fate checked against VerifierModel,
// the Verifier's rules written out again: exactly the predicted counter
// moves; a verified message reaches exactly the subscribers of its channel,
// its trailer stripped; what a Signer of the key wrote verifies, and a
// datagram altered after signing never does; refusals are counted on the
// channels that heard them.
//
// Run with --write-seeds DIR to write a valid LC02 datagram, the LC03
// fragments that crash LCM 1.3.1, and signed scripts as a starting corpus.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/big_endian.hpp"
#include "protocol/bus.hpp"
#include "protocol/signing.hpp"

namespace {

using namespace lagrange;
using Bytes = std::vector<std::uint8_t>;

// The channels the target subscribes, in this order; a 63-byte name is an
// edge case, and kEveryChannel ("") hears every message; the others only
// their own.
const std::string kChannels[] = {"ARM_SETPOINT", "A", kEveryChannel, std::string(63, 'Z')};

constexpr std::uint8_t kSignedScript = 'S';
// µs since the epoch: the fake wall clock as the signed bus opens.
constexpr std::int64_t kOpened = 1'700'000'000'000'000;
// µs: a stamp relative to the clock reaches past the window either way.
constexpr std::int64_t kStampReach = kStampWindowMicros * 3 / 2;
// Bytes: a script signs oversized messages too.
constexpr std::size_t kMaxScriptMessage = kMaxMessageSize + 64;
// Datagrams sent that a resend picks from.
constexpr std::size_t kHistory = 256;

enum class Op : std::uint8_t { kSign, kKeep, kRaw, kResend, kClock, kCount };
enum class Alteration : std::uint8_t { kNone, kFlip, kCut, kAppend, kAppendSent, kCount };

// The layout of the trailer (protocol/signing.hpp), written out again for the model.
constexpr std::size_t kTrailerSender = 0, kTrailerStamp = 8, kTrailerTag = 16, kTrailerMagic = 32;
constexpr std::uint8_t kTrailerMagicBytes[4] = {'L', 'G', 'S', '2'};
constexpr std::uint8_t kOldTrailerMagicBytes[4] = {'L', 'G', 'S', '1'};  // before domains: refused as old
constexpr const char* kDomain = "inprocess://";                           // the in-process bus's own

void Put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

// Whether `n` bytes are equal, unseen by libFuzzer: it records the operands of
// every memcmp and comparison it instruments and pastes them into later
// inputs, and a tag it learnt so could make a datagram altered after signing
// verify.
__attribute__((no_sanitize("coverage"))) bool SameBytes(const std::uint8_t* a, const std::uint8_t* b, std::size_t n) {
  std::uint8_t diff = 0;
  for (std::size_t i = 0; i < n; ++i) diff |= static_cast<std::uint8_t>(a[i] ^ b[i]);
  return diff == 0;
}

BusKey TestKey() {
  std::uint8_t bytes[kBusKeyMinBytes];
  for (std::size_t i = 0; i < kBusKeyMinBytes; ++i) bytes[i] = static_cast<std::uint8_t>(0xA5 ^ (i * 37));
  return BusKey::FromBytes(bytes);
}

// Reads a script front to back; past its end every byte reads as 0.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool done() const { return at_ == size_; }
  std::uint8_t Byte() { return at_ < size_ ? data_[at_++] : 0; }
  std::uint64_t BigEndian(int bytes) {
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v = (v << 8) | Byte();
    return v;
  }
  std::uint16_t U16() { return static_cast<std::uint16_t>(BigEndian(2)); }
  std::int32_t I32() { return static_cast<std::int32_t>(static_cast<std::uint32_t>(BigEndian(4))); }
  // Up to `n` bytes, fewer at the end.
  Bytes Take(std::size_t n) {
    n = std::min(n, size_ - at_);
    Bytes out(data_ + at_, data_ + at_ + n);
    at_ += n;
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

// What the subscribers should hear from the next datagram, and how often they did.
struct Delivery {
  std::string_view channel;
  const std::uint8_t* message = nullptr;  // the message's bytes in the datagram as injected
  std::size_t size = 0;
  int calls = 0;
};

// The handler subscribed to `name`: what every delivery must be.
Bus::Handler Listener(const std::string& name, Delivery& delivery) {
  return [&delivery, name](std::string_view channel, const std::uint8_t* payload, std::size_t payload_size) {
    if ((name != kEveryChannel && channel != name) || payload_size > kMaxMessageSize ||
        (payload_size > 0 && payload == nullptr)) {
      __builtin_trap();
    }
    // The message itself: its channel, its bytes, no trailer.
    if (channel != delivery.channel || payload_size != delivery.size ||
        !SameBytes(payload, delivery.message, payload_size)) {
      __builtin_trap();
    }
    ++delivery.calls;
  };
}

void SubscribeAll(InProcessBus& bus, Delivery& delivery) {
  for (const std::string& name : kChannels) bus.Subscribe(name, Listener(name, delivery));
}

// How many of kChannels' subscribers hear `channel`.
int Hearers(std::string_view channel) {
  int n = 0;
  for (const std::string& name : kChannels) n += name == kEveryChannel || channel == name;
  return n;
}

// Every datagram read is counted once: delivered, refused for its signature, or dropped.
bool EveryDatagramCountedOnce(const BusStats& s) {
  return s.received == s.delivered + s.unauthenticated() + s.malformed + s.fragments_dropped + s.oversized &&
         s.kernel_drops == 0 && s.send_failures == 0;
}

// ---------------------------------------------------------------- without a key

void FuzzUnsignedDatagram(const std::uint8_t* data, std::size_t size) {
  // A copy of exactly `size` bytes, so AddressSanitizer catches a read past the end.
  const Bytes input(data, data + size);
  const std::uint8_t* begin = input.data();
  const Datagram d = ParseDatagram(begin, input.size());
  if (d.kind == Datagram::Kind::kMessage) {
    const auto* channel = reinterpret_cast<const std::uint8_t*>(d.channel.data());
    if (d.channel.size() > 63 || d.payload_size > kMaxMessageSize) __builtin_trap();
    if (channel != begin + 8 || d.payload != channel + d.channel.size() + 1) __builtin_trap();
    if (d.payload + d.payload_size != begin + input.size()) __builtin_trap();
    if (std::memchr(channel, 0, d.channel.size()) != nullptr) __builtin_trap();
    // Reformatting gives the same bytes (the seqno is carried, not checked).
    Bytes again(input.size());
    std::size_t written = 0;
    const std::uint32_t seqno =
        (std::uint32_t{begin[4]} << 24) | (std::uint32_t{begin[5]} << 16) | (std::uint32_t{begin[6]} << 8) | begin[7];
    if (!FormatDatagram(seqno, d.channel, d.payload, d.payload_size, again.data(), again.size(), written) ||
        written != input.size() || again != input) {
      __builtin_trap();
    }
  } else if (d.payload != nullptr || d.payload_size != 0 || !d.channel.empty()) {
    __builtin_trap();
  }

  InProcessBus bus;
  Delivery delivery{d.channel, d.payload, d.payload_size, 0};
  SubscribeAll(bus, delivery);
  bus.InjectDatagram(input.data(), input.size());
  if (bus.Drain() != 1) __builtin_trap();
  const BusStats s = bus.stats();
  if (s.received != 1 || s.malformed + s.fragments_dropped + s.oversized + (d.kind == Datagram::Kind::kMessage) != 1) {
    __builtin_trap();
  }
  if (s.delivered != (delivery.calls > 0 ? 1 : 0)) __builtin_trap();
  if (delivery.calls != (d.kind == Datagram::Kind::kMessage ? Hearers(d.channel) : 0)) __builtin_trap();
  // Without a key nothing is checked, so nothing is refused for its signature.
  if (bus.signs() || s.unauthenticated() != 0 || !EveryDatagramCountedOnce(s)) __builtin_trap();
  for (const std::string& name : kChannels) {
    if (bus.unauthenticated_on(name) != 0) __builtin_trap();
  }
}

// ---------------------------------------------------------------- with a key

// Which counter one datagram moves on the signed bus.
enum class Fate : std::uint8_t {
  kDelivered, kUnsigned, kOldFormat, kStale, kReplayed, kBadTag, kMalformed, kFragment, kOversized
};

bool IsRefusal(Fate f) {
  return f == Fate::kUnsigned || f == Fate::kOldFormat || f == Fate::kStale || f == Fate::kReplayed ||
         f == Fate::kBadTag;
}

// `s` with one more datagram received, counted as `fate`.
BusStats Counted(BusStats s, Fate fate) {
  ++s.received;
  switch (fate) {
    case Fate::kDelivered: ++s.delivered; break;
    case Fate::kUnsigned: ++s.unsigned_dropped; break;
    case Fate::kOldFormat: ++s.old_format; break;
    case Fate::kStale: ++s.stale; break;
    case Fate::kReplayed: ++s.replayed; break;
    case Fate::kBadTag: ++s.bad_tags; break;
    case Fate::kMalformed: ++s.malformed; break;
    case Fate::kFragment: ++s.fragments_dropped; break;
    case Fate::kOversized: ++s.oversized; break;
  }
  return s;
}

bool SameStats(const BusStats& a, const BusStats& b) {
  return a.received == b.received && a.delivered == b.delivered && a.fragments_dropped == b.fragments_dropped &&
         a.malformed == b.malformed && a.oversized == b.oversized && a.kernel_drops == b.kernel_drops &&
         a.send_failures == b.send_failures && a.unsigned_dropped == b.unsigned_dropped &&
         a.old_format == b.old_format && a.stale == b.stale &&
         a.replayed == b.replayed && a.bad_tags == b.bad_tags;
}

// A message whose payload ends in what looks like a signature trailer of `magic`.
bool EndsIn(const Datagram& d, const std::uint8_t (&magic)[4]) {
  return d.kind == Datagram::Kind::kMessage && d.payload_size >= kSignatureTrailerBytes &&
         std::memcmp(d.payload + d.payload_size - kSignatureTrailerBytes + kTrailerMagic, magic, 4) == 0;
}
bool HasTrailer(const Datagram& d) { return EndsIn(d, kTrailerMagicBytes); }

// The Verifier's rules (protocol/signing.hpp), written out again to predict
// each datagram's fate: no trailer, unsigned; a stamp outside the window of
// the clock or before the bus opened, stale; a stamp not above the last one
// verified from its sender, replayed; a tag that is not the key's, bad; and
// the last stamps of the Verifier::kMaxSenders senders most recently verified.
class VerifierModel {
 public:
  explicit VerifierModel(const KeyedMac& mac) : mac_(mac) {}

  // Whether the trailer's tag is the key's tag for the datagram's channel,
  // message, sender and stamp (KeyedMac: the one definition of the tag).
  bool TagVerifies(const Datagram& d) const {
    if (!HasTrailer(d)) return false;
    const std::uint8_t* trailer = d.payload + d.payload_size - kSignatureTrailerBytes;
    std::uint8_t expected[kSignatureTagBytes];
    mac_.Tag(d.channel, d.payload, d.payload_size - kSignatureTrailerBytes, ReadBigEndian64(trailer + kTrailerSender),
             ReadBigEndian64(trailer + kTrailerStamp), expected);
    return SameBytes(expected, trailer + kTrailerTag, kSignatureTagBytes);
  }

  // The fate of `d` at wall-clock time `now`; a delivered one is remembered.
  Fate Predict(const Datagram& d, bool tag_verifies, std::int64_t now) {
    switch (d.kind) {
      case Datagram::Kind::kMessage: break;
      case Datagram::Kind::kFragment: return Fate::kFragment;
      case Datagram::Kind::kMalformed: return Fate::kMalformed;
      case Datagram::Kind::kOversized: return Fate::kOversized;
    }
    if (!HasTrailer(d)) return EndsIn(d, kOldTrailerMagicBytes) ? Fate::kOldFormat : Fate::kUnsigned;
    const std::uint8_t* trailer = d.payload + d.payload_size - kSignatureTrailerBytes;
    const std::uint64_t sender = ReadBigEndian64(trailer + kTrailerSender);
    const std::uint64_t stamp = ReadBigEndian64(trailer + kTrailerStamp);
    const auto signed_stamp = static_cast<std::int64_t>(stamp);
    if (stamp > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()) ||
        signed_stamp < now - kStampWindowMicros || signed_stamp > now + kStampWindowMicros || signed_stamp < kOpened) {
      return Fate::kStale;
    }
    const auto known = std::find_if(senders_.begin(), senders_.end(), [&](const auto& s) { return s.first == sender; });
    if (known != senders_.end() && stamp <= known->second) return Fate::kReplayed;
    if (!tag_verifies) return Fate::kBadTag;
    if (known != senders_.end()) {
      senders_.erase(known);
    } else if (senders_.size() == Verifier::kMaxSenders) {
      senders_.erase(senders_.begin());
    }
    senders_.emplace_back(sender, stamp);
    return Fate::kDelivered;
  }

 private:
  const KeyedMac& mac_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> senders_;  // (id, last stamp), least recently verified first
};

// Where a datagram's bytes after its seqno came from.
enum class Origin : std::uint8_t {
  kSigner,   // exactly as a Signer of the key wrote them: they verify
  kAltered,  // a kSigner datagram changed once after signing: they never verify
  kOther,    // the input's bytes, or a kAltered datagram changed again (perhaps back)
};

struct Sent {
  Bytes bytes;
  Origin origin = Origin::kOther;
};

// A datagram on `channel` whose message a Signer of `key` signed for
// `sender_id` at `stamp`; empty when the channel cannot be sent.
Bytes SignedDatagram(const BusKey& key, std::string_view channel, const Bytes& message, std::uint64_t sender_id,
                     std::uint64_t stamp, std::uint32_t seqno) {
  Bytes out(8 + channel.size() + 1 + message.size() + kSignatureTrailerBytes);
  std::size_t written = 0;
  if (!FormatDatagram(seqno, channel, message.data(), message.size(), out.data(), out.size(), written)) return {};
  // A new Signer's first stamp is its clock's reading, so any stamp can be had, an old one too.
  Signer signer(key, kDomain, sender_id, [stamp] { return static_cast<std::int64_t>(stamp); });
  signer.Sign(channel, out.data() + written - message.size(), message.size(), out.data() + written);
  return out;
}

// One signed-bus run: the fake wall clock, the bus, the model, what was sent.
class SignedRun {
 public:
  SignedRun(const BusKey& key, const KeyedMac& mac) : key_(key), bus_(&key, [this] { return now_; }), model_(mac) {
    if (!bus_.signs()) __builtin_trap();
    SubscribeAll(bus_, delivery_);
  }

  void Play(Reader& in) {
    while (!in.done()) {
      Sent sent;
      if (Next(in, sent)) Send(std::move(sent));
    }
    const BusStats s = bus_.stats();
    if (!EveryDatagramCountedOnce(s)) __builtin_trap();
  }

 private:
  // The next record's datagram; false for one kept, a clock step or a channel that cannot be sent.
  bool Next(Reader& in, Sent& sent) {
    switch (static_cast<Op>(in.Byte() % static_cast<int>(Op::kCount))) {
      case Op::kSign: return Sign(in, sent);
      case Op::kKeep:
        if (Sign(in, sent)) Remember(std::move(sent));
        return false;
      case Op::kRaw: sent = {in.Take(in.U16()), Origin::kOther}; return true;
      case Op::kResend: return Resend(in, sent);
      case Op::kClock: now_ += in.I32(); return false;
      case Op::kCount: break;
    }
    return false;
  }

  bool Sign(Reader& in, Sent& sent) {
    const std::uint8_t c = in.Byte();
    std::string channel = kChannels[c % 4];
    if (c >= 0x80) {
      const Bytes name = in.Take(c % 72);
      channel.assign(name.begin(), name.end());
    }
    const std::uint64_t sender_id = std::uint64_t{in.Byte()} + 1;
    const std::uint64_t stamp =
        in.Byte() % 2 == 1 ? in.BigEndian(8) : static_cast<std::uint64_t>(now_ + in.I32() % (kStampReach + 1));
    const std::size_t size = in.U16() % (kMaxScriptMessage + 1);
    Bytes message = in.Take(size);
    message.resize(size);
    sent = {SignedDatagram(key_, channel, message, sender_id, stamp, static_cast<std::uint32_t>(sent_)),
            Origin::kSigner};
    return !sent.bytes.empty();
  }

  bool Resend(Reader& in, Sent& sent) {
    if (history_.empty()) return false;
    const Sent& source = history_[in.Byte() % history_.size()];
    sent = source;
    Bytes& b = sent.bytes;
    bool changed = false;  // beyond the seqno, which no check covers
    switch (static_cast<Alteration>(in.Byte() % static_cast<int>(Alteration::kCount))) {
      case Alteration::kNone: break;
      case Alteration::kFlip: {  // counted from the end, where the trailer is
        const std::size_t from_end = in.U16();
        const std::uint8_t mask = in.Byte();
        if (b.empty()) break;
        const std::size_t at = b.size() - 1 - from_end % b.size();
        b[at] ^= mask != 0 ? mask : 0x80;
        changed = at < 4 || at >= 8;
        break;
      }
      case Alteration::kCut: {
        const std::size_t cut = in.U16() % (b.size() + 1);
        b.resize(b.size() - cut);
        changed = cut > 0;
        break;
      }
      case Alteration::kAppend: {
        const Bytes more = in.Take(in.U16());
        b.insert(b.end(), more.begin(), more.end());
        changed = !more.empty();
        break;
      }
      case Alteration::kAppendSent: {
        const Bytes& more = history_[in.Byte() % history_.size()].bytes;
        b.insert(b.end(), more.begin(), more.end());
        changed = !more.empty();
        break;
      }
      case Alteration::kCount: break;
    }
    if (changed) sent.origin = source.origin == Origin::kSigner ? Origin::kAltered : Origin::kOther;
    return true;
  }

  // Injects one datagram, drains it, and checks its fate against the model.
  void Send(Sent sent) {
    const Datagram d = ParseDatagram(sent.bytes.data(), sent.bytes.size(), kMaxSignedPayload);
    if (d.kind == Datagram::Kind::kMessage && d.payload_size > kMaxSignedPayload) __builtin_trap();
    const bool verifies = model_.TagVerifies(d);
    if (sent.origin == Origin::kSigner && d.kind == Datagram::Kind::kMessage && !verifies) __builtin_trap();
    if (sent.origin == Origin::kAltered && verifies) __builtin_trap();
    const Fate fate = model_.Predict(d, verifies, now_);
    const BusStats before = bus_.stats();
    delivery_ = {d.channel, d.payload, HasTrailer(d) ? d.payload_size - kSignatureTrailerBytes : 0, 0};
    bus_.InjectDatagram(sent.bytes.data(), sent.bytes.size());
    if (bus_.Drain() != 1) __builtin_trap();
    if (!SameStats(bus_.stats(), Counted(before, fate))) __builtin_trap();
    if (delivery_.calls != (fate == Fate::kDelivered ? Hearers(d.channel) : 0)) __builtin_trap();
    if (IsRefusal(fate)) CountRefusal(d.channel);
    Remember(std::move(sent));
  }

  // A refusal is counted on one channel that heard it: ARM_SETPOINT and A,
  // subscribed before kEveryChannel, on their own; the rest on kEveryChannel's
  // or (for the 63-byte name, subscribed after it) on either.
  void CountRefusal(std::string_view channel) {
    ++refused_[channel == kChannels[0] ? 0 : channel == kChannels[1] ? 1 : 2];
    if (bus_.unauthenticated_on(kChannels[0]) != refused_[0] || bus_.unauthenticated_on(kChannels[1]) != refused_[1] ||
        bus_.unauthenticated_on(kChannels[2]) + bus_.unauthenticated_on(kChannels[3]) != refused_[2]) {
      __builtin_trap();
    }
  }

  // Keeps the last kHistory datagrams sent or kept, overwriting the oldest.
  void Remember(Sent sent) {
    if (history_.size() < kHistory) {
      history_.push_back(std::move(sent));
    } else {
      history_[sent_ % kHistory] = std::move(sent);
    }
    ++sent_;
  }

  const BusKey& key_;
  std::int64_t now_ = kOpened;  // µs since the epoch: the fake wall clock, read by the bus's Verifier
  InProcessBus bus_;
  VerifierModel model_;
  Delivery delivery_;
  std::vector<Sent> history_;  // a ring of the last kHistory datagrams sent
  std::size_t sent_ = 0;       // datagrams sent or kept; the next one's seqno
  std::int64_t refused_[3] = {0, 0, 0};
};

void FuzzSignedScript(const std::uint8_t* data, std::size_t size) {
  static const BusKey key = TestKey();
  static const KeyedMac mac(key, kDomain);
  Reader in(data, size);
  SignedRun run(key, mac);
  run.Play(in);
}

// ---------------------------------------------------------------- seeds

void WriteSeed(const std::string& path, const Bytes& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// A signed script, record by record (the layout at the top of this file).
struct Script {
  Bytes bytes{kSignedScript};
  // A message of `size` bytes of `fill`, stamped `offset` µs from the clock; `op` kSign or kKeep.
  void Sign(std::uint8_t channel, std::uint8_t sender, std::int32_t offset, std::uint16_t size, std::uint8_t fill,
            Op op = Op::kSign) {
    SignZeros(channel, sender, offset, size, op);
    bytes.insert(bytes.end(), size, fill);
  }
  // The same with the message left out: zeros, as the script ends (the last record only).
  void SignZeros(std::uint8_t channel, std::uint8_t sender, std::int32_t offset, std::uint16_t size,
                 Op op = Op::kSign) {
    bytes.insert(bytes.end(), {static_cast<std::uint8_t>(op), channel, sender, 0});
    Put32(bytes, static_cast<std::uint32_t>(offset));
    bytes.insert(bytes.end(), {static_cast<std::uint8_t>(size >> 8), static_cast<std::uint8_t>(size)});
  }
  void Raw(const Bytes& datagram) {
    bytes.insert(bytes.end(), {static_cast<std::uint8_t>(Op::kRaw), static_cast<std::uint8_t>(datagram.size() >> 8),
                               static_cast<std::uint8_t>(datagram.size())});
    bytes.insert(bytes.end(), datagram.begin(), datagram.end());
  }
  void Resend(std::uint8_t which) {
    bytes.insert(bytes.end(),
                 {static_cast<std::uint8_t>(Op::kResend), which, static_cast<std::uint8_t>(Alteration::kNone)});
  }
  void ResendFlipped(std::uint8_t which, std::uint16_t from_end) {
    bytes.insert(bytes.end(),
                 {static_cast<std::uint8_t>(Op::kResend), which, static_cast<std::uint8_t>(Alteration::kFlip),
                  static_cast<std::uint8_t>(from_end >> 8), static_cast<std::uint8_t>(from_end), 0x01});
  }
  void Clock(std::int32_t micros) {
    bytes.push_back(static_cast<std::uint8_t>(Op::kClock));
    Put32(bytes, static_cast<std::uint32_t>(micros));
  }
};

void WriteSignedSeeds(const std::string& dir, const Bytes& unsigned_message) {
  // Delivered, replayed; stale, then (in the window) with its tag's last byte
  // altered, and as signed; kept, its tag's first byte altered, as signed;
  // unsigned; stamped before the bus opened.
  Script sequence;
  constexpr std::uint16_t kSize = 40;
  // The tag's first and last bytes, counted from the datagram's end (0: its last byte).
  constexpr std::uint16_t kTagFirstFromEnd = kSignatureTrailerBytes - kTrailerTag - 1;
  constexpr std::uint16_t kTagLastFromEnd = kSignatureTrailerBytes - kTrailerMagic;
  sequence.Sign(0, 1, 0, kSize, 0x11);
  sequence.Resend(0);
  sequence.Sign(0, 2, 2'500'000, kSize, 0x22);
  sequence.Clock(1'000'000);
  sequence.ResendFlipped(2, kTagLastFromEnd);
  sequence.Resend(2);
  sequence.Sign(1, 5, 0, kSize, 0x55, Op::kKeep);
  sequence.ResendFlipped(5, kTagFirstFromEnd);
  sequence.Resend(5);
  sequence.Raw(unsigned_message);
  sequence.Clock(-10'000'000);
  sequence.Sign(1, 3, 0, kSize, 0x33);
  WriteSeed(dir + "/signed_sequence", sequence.bytes);
  // Stamps on the window's edges, either way, and on the bus's opening.
  Script window;
  constexpr auto kWindow = static_cast<std::int32_t>(kStampWindowMicros);
  window.Sign(0, 10, kWindow, kSize, 0x66);
  window.Sign(0, 11, kWindow + 1, kSize, 0x66);
  window.Clock(2 * kWindow);
  window.Sign(0, 12, -kWindow, kSize, 0x66);
  window.Sign(0, 13, -kWindow - 1, kSize, 0x66);
  window.Clock(-2 * kWindow);
  window.Sign(0, 14, -1, kSize, 0x66);
  window.Sign(0, 15, 0, kSize, 0x66);
  WriteSeed(dir + "/signed_window", window.bytes);
  // More senders than the Verifier remembers, then the first one's datagram again.
  Script senders;
  for (std::size_t i = 0; i < Verifier::kMaxSenders + 6; ++i) senders.Sign(1, static_cast<std::uint8_t>(i), 0, 4, 0x44);
  senders.Resend(0);
  WriteSeed(dir + "/signed_senders", senders.bytes);
  // The largest message that fits with its trailer, and one byte more (oversized).
  for (const std::size_t size : {kMaxMessageSize, kMaxMessageSize + 1}) {
    Script large;
    large.SignZeros(0, 1, 0, static_cast<std::uint16_t>(size));
    WriteSeed(dir + "/signed_" + std::to_string(size), large.bytes);
  }
}

void WriteSeeds(const std::string& dir) {
  Bytes message;
  Put32(message, 0x4c433032);
  Put32(message, 1);
  for (const char c : std::string("ARM_SETPOINT")) message.push_back(static_cast<std::uint8_t>(c));
  message.push_back(0);
  message.insert(message.end(), 40, 0x11);
  WriteSeed(dir + "/lc02", message);
  // LC03: magic, msg_seqno, msg_size, fragment_offset, fragment_no (u16), fragments_in_msg (u16).
  Bytes wrapping;
  for (const std::uint32_t v : {0x4c433033u, 1u, 4096u, 0xFFFFFFF0u}) Put32(wrapping, v);
  Put32(wrapping, 0x00010002);
  wrapping.insert(wrapping.end(), 64, 0xAB);
  WriteSeed(dir + "/lc03_wrap", wrapping);
  WriteSeed(dir + "/lc03_short", Bytes(wrapping.begin(), wrapping.begin() + 18));  // shorter than its header
  Bytes huge;
  for (const std::uint32_t v : {0x4c433033u, 1u, 256u << 20, 0u}) Put32(huge, v);
  Put32(huge, 0x00000002);
  huge.insert(huge.end(), {'A', 0, 1, 2, 3});
  WriteSeed(dir + "/lc03_huge", huge);
  WriteSignedSeeds(dir, message);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seeds") == 0) {
      WriteSeeds((*argv)[i + 1]);
      std::exit(0);
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 0 && data[0] == kSignedScript) {
    FuzzSignedScript(data + 1, size - 1);
  } else {
    FuzzUnsignedDatagram(data, size);
  }
  return 0;
}
