// The typed receive (protocol/receive.hpp): a message is decoded only when its
// type's check accepts exactly its bytes, and every drop says why; on a signed
// bus what fails its signature never reaches a typed subscriber and is counted
// by the bus under its reason.

#include <gtest/gtest.h>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "protocol/bus.hpp"
#include "protocol/receive.hpp"
#include "protocol/signing.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using Bytes = std::vector<std::uint8_t>;
using testing::Encode;
using testing::MakeState;

constexpr std::int64_t kNow = 1'700'000'000'000'000;  // µs since the epoch: the fake wall clock
constexpr const char* kChannel = "ARM_STATE";
constexpr std::size_t kNumDofsOffset = 8 + 8 + 8 + 8 + 8;  // fingerprint, utime, run_id, tick, t

BusKey Key(std::uint8_t seed) {
  Bytes bytes(kBusKeyMinBytes);
  std::mt19937 rng{seed};
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
  return BusKey::FromBytes(bytes);
}

WallClockMicros At(std::int64_t now) {
  return [now] { return now; };
}

// The state's bytes followed by a signature trailer of `key` for `domain`, stamped at `stamp`.
Bytes Signed(const Bytes& message, const BusKey& key, const std::string& domain, std::int64_t stamp) {
  Signer signer(key, domain, 7, At(stamp));
  Bytes wire(message);
  wire.resize(message.size() + kSignatureTrailerBytes);
  signer.Sign(kChannel, message.data(), message.size(), wire.data() + message.size());
  return wire;
}

TEST(Receive, AWellFormedStateIsDecodedWhole) {
  const state_t sent = MakeState(42, 0x77);
  const Bytes bytes = Encode(sent);
  const Received<state_t> r = Receive<state_t>(bytes.data(), bytes.size());
  ASSERT_TRUE(r) << ToString(r.drop);
  EXPECT_EQ(r.drop, Drop::kNone);
  EXPECT_EQ(r.message->tick, 42);
  EXPECT_EQ(r.message->run_id, 0x77);
  EXPECT_EQ(r.message->q, sent.q);
  EXPECT_EQ(r.message->controller, "pd");
}

TEST(Receive, ATruncatedStateIsDroppedAsTooShortOrSizeMismatchAtEveryLength) {
  const Bytes bytes = Encode(MakeState());
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const Drop d = Receive<state_t>(bytes.data(), n).drop;
    EXPECT_TRUE(d == Drop::kTooShort || d == Drop::kSizeMismatch) << n << ": " << ToString(d);
  }
  EXPECT_EQ(Receive<state_t>(bytes.data(), 8).drop, Drop::kTooShort);
  EXPECT_EQ(Receive<state_t>(nullptr, 0).drop, Drop::kTooShort);
}

TEST(Receive, ATrailingByteIsDroppedAsSizeMismatch) {
  Bytes bytes = Encode(MakeState());
  bytes.push_back(0);
  EXPECT_EQ(Receive<state_t>(bytes.data(), bytes.size()).drop, Drop::kSizeMismatch);
}

TEST(Receive, AnotherTypesMessageIsDroppedAsWrongType) {
  const Bytes bytes = Encode(MakeState());
  const Received<status_t> r = Receive<status_t>(bytes.data(), bytes.size());
  EXPECT_FALSE(r);
  EXPECT_EQ(r.drop, Drop::kWrongType);
}

TEST(Receive, AHugeDeclaredLengthIsDroppedAsBadLengthBeforeAnyDecode) {
  Bytes bytes = Encode(MakeState());
  for (std::size_t k = 0; k < 4; ++k) bytes.at(kNumDofsOffset + k) = k == 0 ? 0x7f : 0xff;  // num_dofs = 2^31 - 1
  EXPECT_EQ(Receive<state_t>(bytes.data(), bytes.size()).drop, Drop::kBadLength);
}

TEST(Receive, ASignedLiveMessageOnAReceiverWithoutTheKeyIsDroppedAsSignedWithoutKey) {
  const Bytes wire = Signed(Encode(MakeState()), Key(1), kInProcessUrl, kNow);
  EXPECT_EQ(Receive<state_t>(wire.data(), wire.size()).drop, Drop::kSignedWithoutKey);
  EXPECT_STREQ(ToString(Drop::kSignedWithoutKey), "signed message on a receiver without the bus key");
}

TEST(Receive, ARecordedSignedMessageIsDecodedWithoutItsTrailer) {
  const Bytes wire = Signed(Encode(MakeState(9)), Key(1), kInProcessUrl, kNow);
  const Received<state_t> r = Receive<state_t>(wire.data(), wire.size(), Framing::kRecorded);
  ASSERT_TRUE(r) << ToString(r.drop);
  EXPECT_EQ(r.message->tick, 9);
  // A recording is not a licence for anything else: a truncated one is still dropped.
  EXPECT_EQ(Receive<state_t>(wire.data(), wire.size() - 1, Framing::kRecorded).drop, Drop::kSizeMismatch);
}

TEST(Receive, ReceiveIntoReusesTheMessageAndReportsTheSameDrops) {
  state_t out;
  const Bytes good = Encode(MakeState(3));
  EXPECT_EQ(ReceiveInto(out, good.data(), good.size()), Drop::kNone);
  EXPECT_EQ(out.tick, 3);
  Bytes longer = good;
  longer.push_back(0);
  EXPECT_EQ(ReceiveInto(out, longer.data(), longer.size()), Drop::kSizeMismatch);
  EXPECT_EQ(ReceiveInto(out, good.data(), 8), Drop::kTooShort);
}

// A signed in-process bus that receives `payload` on kChannel as a datagram from the wire.
struct SignedReceiver {
  explicit SignedReceiver(const std::string& domain = "") : key(Key(1)), bus(&key, At(kNow), domain) {
    SubscribeMessages<state_t>(bus, kChannel, [this](state_t&& s) { received.push_back(std::move(s)); });
  }
  void Deliver(const Bytes& payload) {
    Bytes datagram(payload.size() + 128);
    std::size_t written = 0;
    ASSERT_TRUE(
        FormatDatagram(seqno++, kChannel, payload.data(), payload.size(), datagram.data(), datagram.size(), written));
    bus.InjectDatagram(datagram.data(), written);
    bus.Drain();
  }
  BusKey key;
  InProcessBus bus;
  std::vector<state_t> received;
  std::uint32_t seqno = 0;
};

TEST(SignedReceive, AStateSignedWithTheKeyForTheBusesDomainReachesTheTypedSubscriber) {
  SignedReceiver r;
  r.Deliver(Signed(Encode(MakeState(5)), Key(1), kInProcessUrl, kNow));
  ASSERT_EQ(r.received.size(), 1u);
  EXPECT_EQ(r.received[0].tick, 5);
  EXPECT_EQ(r.bus.stats().unauthenticated(), 0);
}

TEST(SignedReceive, AStateSignedWithAnotherKeyIsDroppedAsABadTag) {
  SignedReceiver r;
  r.Deliver(Signed(Encode(MakeState()), Key(2), kInProcessUrl, kNow));
  EXPECT_TRUE(r.received.empty());
  EXPECT_EQ(r.bus.stats().bad_tags, 1);
  EXPECT_EQ(r.bus.unauthenticated_on(kChannel), 1);
}

TEST(SignedReceive, AnUnsignedStateOnASignedBusIsDroppedAsUnsigned) {
  SignedReceiver r;
  r.Deliver(Encode(MakeState()));
  EXPECT_TRUE(r.received.empty());
  EXPECT_EQ(r.bus.stats().unsigned_dropped, 1);
}

TEST(SignedReceive, AStateStampedOutsideTheWindowIsDroppedAsStale) {
  SignedReceiver r;
  r.Deliver(Signed(Encode(MakeState()), Key(1), kInProcessUrl, kNow - 2 * kStampWindowMicros));
  EXPECT_TRUE(r.received.empty());
  EXPECT_EQ(r.bus.stats().stale, 1);
}

TEST(SignedReceive, AStateSignedForAnotherDomainIsDroppedAsABadTag) {
  SignedReceiver r("udpm://239.255.76.67:8771");
  r.Deliver(Signed(Encode(MakeState()), Key(1), "udpm://239.255.76.67:8772", kNow));
  EXPECT_TRUE(r.received.empty());
  EXPECT_EQ(r.bus.stats().bad_tags, 1);
}

}  // namespace
}  // namespace lagrange
