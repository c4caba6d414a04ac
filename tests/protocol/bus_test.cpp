// The bus lagrange talks LCM through (protocol/bus.hpp): LCM's LC02 datagram
// format, every fragment (LC03) dropped, hostile datagrams counted without
// allocating, strict URLs, Escape for what the bus says; then real sockets on
// loopback multicast (ports 7900-7919), including the datagrams that crash
// LCM 1.3.1's reassembly (docs/lcm-fragment-bug.md) and interop with lcm::LCM.

#include <gtest/gtest.h>
#include <unistd.h>
#include <lcm/lcm-cpp.hpp>

#include <array>
#include <chrono>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "base/escape.hpp"
#include "protocol/bus.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/lcm_testing.hpp"
#include "tests/support/raw_udp.hpp"

namespace lagrange {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint32_t kShortMagic = 0x4c433032;

using testing::PutBigEndian32;

// LC02: magic, seqno, channel, NUL, payload.
Bytes ShortDatagram(const std::string& channel, const Bytes& payload, std::uint32_t seqno = 7) {
  Bytes out;
  PutBigEndian32(out, kShortMagic);
  PutBigEndian32(out, seqno);
  out.insert(out.end(), channel.begin(), channel.end());
  out.push_back(0);
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

// LC03 datagrams from one sender (tests/support/raw_udp.hpp lays them out).
constexpr std::uint32_t kAttackSeqno = 7;
constexpr std::uint32_t kAttackSize = 4096;
Bytes FragmentDatagram(std::uint32_t msg_size, std::uint32_t offset, std::uint16_t fragment_no, std::uint16_t fragments,
                       const std::string& channel, std::size_t data_size) {
  return testing::LcmFragment(kAttackSeqno, msg_size, offset, fragment_no, fragments, channel, data_size);
}

// The datagrams of docs/lcm-fragment-bug.md. LCM 1.3.1 keeps a fragment
// buffer per sender once a first fragment opened one; the next two then
// crash it (SIGSEGV), and the last makes it reserve 256 MiB.
Bytes FirstFragment() { return FragmentDatagram(kAttackSize, 0, 0, 2, "X", 16); }
// offset + size wraps in 32 bits: 0xFFFFFFF0 + 64 = 0x30 <= 4096.
Bytes WrappingFragment() { return FragmentDatagram(kAttackSize, 0xFFFFFFF0u, 1, 2, "", 64); }
// 18 bytes, shorter than the 20-byte header: frag_size = 18 - 20 wraps to
// 0xFFFFFFFE, and offset 2 + that wraps to 0.
Bytes ShortFragment() {
  Bytes out = FragmentDatagram(kAttackSize, 2, 1, 2, "", 0);
  out.resize(18);
  return out;
}
Bytes HugeFirstFragment() { return FragmentDatagram(256u << 20, 0, 0, 4097, "ARM_SETPOINT", 32); }

struct Received {
  std::string channel;
  Bytes payload;
};

Bus::Handler Recorder(std::vector<Received>& into) {
  return [&into](std::string_view channel, const std::uint8_t* data, std::size_t size) {
    into.push_back({std::string(channel), Bytes(data, data + size)});
  };
}

// ---------------------------------------------------------------- ParseDatagram

TEST(BusDatagram, ShortDatagramsAreMalformed) {
  const Bytes full = ShortDatagram("A", {});
  EXPECT_EQ(ParseDatagram(nullptr, 0).kind, Datagram::Kind::kMalformed);
  EXPECT_EQ(ParseDatagram(full.data(), 0).kind, Datagram::Kind::kMalformed);
  for (std::size_t n = 1; n <= 7; ++n) {
    EXPECT_EQ(ParseDatagram(full.data(), n).kind, Datagram::Kind::kMalformed) << n << " bytes";
  }
  // 8 bytes: a header and no channel terminator.
  EXPECT_EQ(ParseDatagram(full.data(), 8).kind, Datagram::Kind::kMalformed);
  EXPECT_EQ(ParseDatagram(full.data(), full.size()).kind, Datagram::Kind::kMessage);
}

TEST(BusDatagram, UnknownMagicIsMalformed) {
  Bytes d = ShortDatagram("ARM_SETPOINT", {1, 2, 3});
  d[3] = '1';  // "LC01"
  EXPECT_EQ(ParseDatagram(d.data(), d.size()).kind, Datagram::Kind::kMalformed);
  d[0] = 0;
  EXPECT_EQ(ParseDatagram(d.data(), d.size()).kind, Datagram::Kind::kMalformed);
}

TEST(BusDatagram, UnterminatedChannelIsMalformed) {
  Bytes d = ShortDatagram("ARM_SETPOINT", {});
  d.pop_back();  // the NUL
  EXPECT_EQ(ParseDatagram(d.data(), d.size()).kind, Datagram::Kind::kMalformed);
}

TEST(BusDatagram, ChannelOfSixtyThreeBytesIsAcceptedAndSixtyFourRefused) {
  const Bytes ok = ShortDatagram(std::string(63, 'c'), {9});
  const Datagram parsed = ParseDatagram(ok.data(), ok.size());
  ASSERT_EQ(parsed.kind, Datagram::Kind::kMessage);
  EXPECT_EQ(parsed.channel.size(), 63u);
  EXPECT_EQ(parsed.payload_size, 1u);
  for (const std::size_t n : {64u, 65u, 200u}) {
    const Bytes long_channel = ShortDatagram(std::string(n, 'c'), {9});
    EXPECT_EQ(ParseDatagram(long_channel.data(), long_channel.size()).kind, Datagram::Kind::kMalformed) << n;
  }
}

TEST(BusDatagram, EveryFragmentIsAFragmentWhateverItDeclares) {
  for (const Bytes& d : {FirstFragment(), WrappingFragment(), ShortFragment(), HugeFirstFragment(),
                         FragmentDatagram(0xFFFFFFFFu, 0xFFFFFFFFu, 0xFFFF, 0xFFFF, "", 0)}) {
    const Datagram parsed = ParseDatagram(d.data(), d.size());
    EXPECT_EQ(parsed.kind, Datagram::Kind::kFragment);
    EXPECT_TRUE(parsed.channel.empty());
    EXPECT_EQ(parsed.payload_size, 0u);
  }
  const Bytes magic_only = {0x4c, 0x43, 0x30, 0x33};
  EXPECT_EQ(ParseDatagram(magic_only.data(), magic_only.size()).kind, Datagram::Kind::kFragment);
}

TEST(BusDatagram, PayloadOverTheLimitIsOversized) {
  const Bytes at_limit = ShortDatagram("A", Bytes(kMaxMessageSize, 1));
  EXPECT_EQ(ParseDatagram(at_limit.data(), at_limit.size()).kind, Datagram::Kind::kMessage);
  const Bytes over = ShortDatagram("A", Bytes(kMaxMessageSize + 1, 1));
  EXPECT_EQ(ParseDatagram(over.data(), over.size()).kind, Datagram::Kind::kOversized);
  const Bytes udp_max = ShortDatagram("A", Bytes(65000, 1));
  EXPECT_EQ(ParseDatagram(udp_max.data(), udp_max.size()).kind, Datagram::Kind::kOversized);
}

TEST(BusDatagram, FormatThenParseRoundTrips) {
  std::mt19937 rng{42};
  Bytes out(kMaxMessageSize + 128);
  for (int trial = 0; trial < 500; ++trial) {
    const std::size_t channel_size = std::uniform_int_distribution<std::size_t>(0, 63)(rng);
    const std::size_t payload_size =
        trial == 0 ? kMaxMessageSize : std::uniform_int_distribution<std::size_t>(0, 2000)(rng);
    std::string channel(channel_size, ' ');
    for (char& c : channel) c = static_cast<char>(std::uniform_int_distribution<int>(1, 255)(rng));
    Bytes payload(payload_size);
    for (auto& b : payload) b = static_cast<std::uint8_t>(rng());
    std::size_t written = 0;
    ASSERT_TRUE(FormatDatagram(static_cast<std::uint32_t>(trial), channel, payload.data(), payload.size(), out.data(),
                               out.size(), written));
    EXPECT_EQ(written, 8 + channel_size + 1 + payload_size);
    const Datagram parsed = ParseDatagram(out.data(), written);
    ASSERT_EQ(parsed.kind, Datagram::Kind::kMessage);
    EXPECT_EQ(parsed.channel, channel);
    ASSERT_EQ(parsed.payload_size, payload_size);
    EXPECT_EQ(std::memcmp(parsed.payload, payload.data(), payload_size), 0);
  }
}

TEST(BusDatagram, FormatWritesLcmsShortHeader) {
  Bytes out(64);
  std::size_t written = 0;
  const std::uint8_t payload[] = {0xDE, 0xAD};
  ASSERT_TRUE(FormatDatagram(0x01020304, "AB", payload, sizeof payload, out.data(), out.size(), written));
  out.resize(written);
  EXPECT_EQ(out, (Bytes{'L', 'C', '0', '2', 1, 2, 3, 4, 'A', 'B', 0, 0xDE, 0xAD}));
}

TEST(BusDatagram, FormatRefusesWhatDoesNotFit) {
  Bytes out(32);
  std::size_t written = 99;
  const std::uint8_t payload[20] = {};
  EXPECT_FALSE(FormatDatagram(0, "CHANNEL", payload, sizeof payload, out.data(), out.size(), written));
  EXPECT_EQ(written, 0u);
  Bytes roomy(1000);
  EXPECT_FALSE(FormatDatagram(0, std::string(64, 'c'), payload, 0, roomy.data(), roomy.size(), written));
  EXPECT_FALSE(FormatDatagram(0, std::string_view("A\0B", 3), payload, 1, roomy.data(), roomy.size(), written));
  EXPECT_TRUE(FormatDatagram(0, "CHA", payload, sizeof payload, out.data(), out.size(), written));  // exactly fits
  EXPECT_EQ(written, out.size());
}

// ---------------------------------------------------------------- InProcessBus

TEST(BusInProcess, DeliversToExactChannelOnly) {
  InProcessBus bus;
  std::vector<Received> arm, arm_state;
  bus.Subscribe("ARM", Recorder(arm));
  bus.Subscribe("ARM_STATE", Recorder(arm_state));
  const std::uint8_t payload[] = {1, 2, 3};
  ASSERT_TRUE(bus.Publish("ARM_STATE", payload, sizeof payload));
  ASSERT_TRUE(bus.Publish("ARM_STATEX", payload, sizeof payload));
  ASSERT_TRUE(bus.Publish("AR", payload, sizeof payload));
  EXPECT_EQ(bus.Drain(), 3);
  EXPECT_TRUE(arm.empty());
  ASSERT_EQ(arm_state.size(), 1u);
  EXPECT_EQ(arm_state[0].payload, (Bytes{1, 2, 3}));
  const BusStats s = bus.stats();
  EXPECT_EQ(s.received, 3);
  EXPECT_EQ(s.delivered, 1);
  EXPECT_EQ(s.malformed, 0);
}

TEST(BusInProcess, PublishRefusesAndCountsOversizeAndLongChannels) {
  InProcessBus bus;
  std::vector<Received> got;
  bus.Subscribe(std::string(64, 'c'), Recorder(got));
  const Bytes big(kMaxMessageSize + 1, 0);
  EXPECT_FALSE(bus.Publish("A", big.data(), big.size()));
  EXPECT_FALSE(bus.Publish(std::string(64, 'c'), big.data(), 1));
  EXPECT_FALSE(bus.Publish("A", nullptr, kMaxMessageSize + 1));  // what PublishMessage sends for a too-large type
  EXPECT_TRUE(bus.Publish("A", big.data(), kMaxMessageSize));
  EXPECT_EQ(bus.stats().send_failures, 3);
  bus.Drain();
  EXPECT_TRUE(got.empty());
}

TEST(BusInProcess, DrainStopsAtMaxAndKeepsTheRest) {
  InProcessBus bus;
  std::vector<Received> got;
  bus.Subscribe("A", Recorder(got));
  const std::uint8_t b = 0;
  for (int i = 0; i < 5; ++i) bus.Publish("A", &b, 1);
  EXPECT_EQ(bus.Drain(2), 2);
  EXPECT_EQ(got.size(), 2u);
  EXPECT_EQ(bus.Handle(0), 3);
  EXPECT_EQ(got.size(), 5u);
  EXPECT_EQ(bus.Drain(), 0);
}

TEST(BusInProcess, HandlerMayPublishIntoTheSameBus) {
  InProcessBus bus;
  std::vector<Received> replies;
  bus.Subscribe("REQUEST", [&bus](std::string_view, const std::uint8_t* data, std::size_t size) {
    bus.Publish("REPLY", data, size);
  });
  bus.Subscribe("REPLY", Recorder(replies));
  const std::uint8_t b = 42;
  bus.Publish("REQUEST", &b, 1);
  EXPECT_EQ(bus.Drain(), 2);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].payload, (Bytes{42}));
}

TEST(BusInProcess, CountsHostileDatagramsDeliversNothingAndAllocatesNothing) {
  const std::vector<std::pair<Bytes, std::int64_t BusStats::*>> hostile = {
      {{}, &BusStats::malformed},
      {{'L'}, &BusStats::malformed},
      {{'L', 'C', '0', '2', 0, 0, 0}, &BusStats::malformed},
      {ShortDatagram(std::string(64, 'A'), {1}), &BusStats::malformed},
      {[] {
         Bytes d = ShortDatagram("ARM_SETPOINT", {});
         d.pop_back();
         return d;
       }(),
       &BusStats::malformed},
      {FirstFragment(), &BusStats::fragments_dropped},
      {WrappingFragment(), &BusStats::fragments_dropped},
      {ShortFragment(), &BusStats::fragments_dropped},
      {HugeFirstFragment(), &BusStats::fragments_dropped},
      {ShortDatagram("ARM_SETPOINT", Bytes(65000, 1)), &BusStats::oversized},
  };
  for (const auto& [bytes, counter] : hostile) {
    InProcessBus bus;
    std::vector<Received> got;
    got.reserve(4);
    bus.Subscribe("ARM_SETPOINT", Recorder(got));
    bus.Subscribe("", Recorder(got));
    bus.InjectDatagram(bytes.data(), bytes.size());
    int read = 0;
    std::int64_t allocations = 0;
    {
      testing::AllocationCounter counter_scope;
      read = bus.Drain();
      allocations = counter_scope.count();
    }
    const BusStats s = bus.stats();
    EXPECT_EQ(read, 1) << bytes.size() << " bytes";
    EXPECT_EQ(allocations, 0) << bytes.size() << " bytes";
    EXPECT_TRUE(got.empty()) << bytes.size() << " bytes";
    EXPECT_EQ(s.*counter, 1) << bytes.size() << " bytes";
    EXPECT_EQ(s.received, 1);
    EXPECT_EQ(s.delivered, 0);
    EXPECT_EQ(s.malformed + s.fragments_dropped + s.oversized, 1);
  }
}

TEST(BusInProcess, DeliveringAWellFormedMessageAllocatesNothingInTheBus) {
  InProcessBus bus;
  int calls = 0;
  bus.Subscribe("ARM_SETPOINT", [&calls](std::string_view, const std::uint8_t*, std::size_t) { ++calls; });
  const Bytes d = ShortDatagram("ARM_SETPOINT", Bytes(200, 3));
  bus.InjectDatagram(d.data(), d.size());
  testing::AllocationCounter counter;
  EXPECT_EQ(bus.Drain(), 1);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_EQ(calls, 1);
}

// Random bytes, and near-valid datagrams mutated at random, never reach a
// handler under a channel it did not subscribe, and every datagram is counted once.
TEST(BusInProcess, RandomDatagramsNeverReachTheWrongHandler) {
  std::mt19937 rng{42};
  InProcessBus bus;
  const std::array<std::string, 3> channels = {"ARM_SETPOINT", "ARM_COMMAND", "LAGRANGE_CONTROL"};
  std::int64_t wrong = 0, delivered = 0;
  for (const std::string& name : channels) {
    bus.Subscribe(name, [&, name](std::string_view channel, const std::uint8_t* data, std::size_t size) {
      ++delivered;
      if (channel != name || size > kMaxMessageSize || (size > 0 && data == nullptr)) ++wrong;
    });
  }
  constexpr int kDatagrams = 100000;
  Bytes d;
  for (int i = 0; i < kDatagrams; ++i) {
    const int shape = std::uniform_int_distribution<int>(0, 3)(rng);
    if (shape == 0) {  // pure noise
      d.resize(std::uniform_int_distribution<std::size_t>(0, 96)(rng));
      for (auto& b : d) b = static_cast<std::uint8_t>(rng());
    } else {  // a valid datagram, then a few bytes flipped, cut or an LC03 magic
      const std::string& name = channels[std::uniform_int_distribution<std::size_t>(0, 2)(rng)];
      d = ShortDatagram(name, Bytes(std::uniform_int_distribution<std::size_t>(0, 64)(rng), 0x5A));
      const int flips = std::uniform_int_distribution<int>(0, 3)(rng);
      for (int f = 0; f < flips; ++f) d[std::uniform_int_distribution<std::size_t>(0, d.size() - 1)(rng)] ^= rng();
      if (shape == 2) d.resize(std::uniform_int_distribution<std::size_t>(0, d.size())(rng));
      if (shape == 3 && rng() % 4 == 0) d[3] = '3';
    }
    bus.InjectDatagram(d.data(), d.size());
    if (i % 1000 == 999) bus.Drain(1000);
  }
  bus.Drain();
  const BusStats s = bus.stats();
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(s.received, kDatagrams);
  EXPECT_EQ(s.delivered, delivered);
  EXPECT_GT(s.delivered, 0);
  EXPECT_GT(s.malformed, 0);
  EXPECT_GT(s.fragments_dropped, 0);
  EXPECT_LE(s.delivered + s.malformed + s.fragments_dropped + s.oversized, s.received);
}

// ---------------------------------------------------------------- URLs

TEST(BusUrl, AcceptsStrictUdpmUrls) {
  UdpmUrl u = ParseUdpmUrl("udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(u.group, "239.255.76.67");
  EXPECT_EQ(u.port, 7667);
  EXPECT_EQ(u.ttl, 0);
  EXPECT_EQ(u.recv_buf_size, 0);
  u = ParseUdpmUrl("udpm://224.0.0.1:1?ttl=255&recv_buf_size=2097152");
  EXPECT_EQ(u.port, 1);
  EXPECT_EQ(u.ttl, 255);
  EXPECT_EQ(u.recv_buf_size, 2097152);
  u = ParseUdpmUrl("udpm://239.0.0.9:65535?recv_buf_size=1&ttl=1");
  EXPECT_EQ(u.port, 65535);
  EXPECT_EQ(u.ttl, 1);
  u = ParseUdpmUrl("udpm://239.255.76.67:7667");
  EXPECT_EQ(u.ttl, 0);  // LCM's default
}

TEST(BusUrl, ADefaultReceiveBufferIsAskedOnlyOfAUdpmUrlThatNamesNone) {
  EXPECT_EQ(WithDefaultReceiveBuffer("udpm://239.255.76.67:7667?ttl=0", 2097152),
            "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152");
  EXPECT_EQ(WithDefaultReceiveBuffer("udpm://239.255.76.67:7667", 4096), "udpm://239.255.76.67:7667?recv_buf_size=4096");
  // The user's size wins; other providers and an empty query (refused when opened) are left as they are.
  EXPECT_EQ(WithDefaultReceiveBuffer("udpm://239.255.76.67:7667?recv_buf_size=1&ttl=0", 2097152),
            "udpm://239.255.76.67:7667?recv_buf_size=1&ttl=0");
  EXPECT_EQ(WithDefaultReceiveBuffer("inprocess://", 2097152), "inprocess://");
  EXPECT_EQ(WithDefaultReceiveBuffer("udpm://239.255.76.67:7667?", 2097152), "udpm://239.255.76.67:7667?");
  EXPECT_EQ(ParseUdpmUrl(WithDefaultReceiveBuffer("udpm://239.255.76.67:7667?ttl=1", 65536)).recv_buf_size, 65536);
}

TEST(BusUrl, RefusesMalformedUrlsNamingThem) {
  for (const std::string url : {
           "",
           "udpm://",
           "udp://239.255.76.67:7667?ttl=0",
           "udpm://239.255.76.67?ttl=0",
           "udpm://239.255.76.67:?ttl=0",
           "udpm://239.255.76.67:0?ttl=0",
           "udpm://239.255.76.67:65536?ttl=0",
           "udpm://239.255.76.67:+7667?ttl=0",
           "udpm://239.255.76.67:7667x?ttl=0",
           "udpm://192.168.1.1:7667?ttl=0",
           "udpm://240.0.0.1:7667?ttl=0",
           "udpm://223.255.255.255:7667?ttl=0",
           "udpm://239.255.76:7667?ttl=0",
           "udpm://239.255.76.67.1:7667?ttl=0",
           "udpm://239.256.76.67:7667?ttl=0",
           "udpm://239..76.67:7667?ttl=0",
           "udpm://localhost:7667?ttl=0",
           "udpm://239.255.76.67:7667?",
           "udpm://239.255.76.67:7667?ttl=",
           "udpm://239.255.76.67:7667?ttl=abc",
           "udpm://239.255.76.67:7667?ttl=300",
           "udpm://239.255.76.67:7667?ttl=-1",
           "udpm://239.255.76.67:7667?ttl=1.5",
           "udpm://239.255.76.67:7667?ttl= 1",
           "udpm://239.255.76.67:7667?ttl=0&ttl=1",
           "udpm://239.255.76.67:7667?ttl=0&",
           "udpm://239.255.76.67:7667?ttl",
           "udpm://239.255.76.67:7667?ttl=0&color=red",
           "udpm://239.255.76.67:7667?recv_buf_size=0",
           "udpm://239.255.76.67:7667?recv_buf_size=99999999999",
           "udpm://239.255.76.67:7667?ttl=99999999999999999999",
       }) {
    try {
      ParseUdpmUrl(url);
      ADD_FAILURE() << "accepted '" << url << "'";
    } catch (const BusError& e) {
      EXPECT_NE(std::string(e.what()).find("'" + url + "'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("udpm://GROUP:PORT"), std::string::npos) << e.what();
    }
  }
}

TEST(BusUrl, OpenBusRefusesOtherLcmProviders) {
  for (const std::string url : {"tcpq://localhost:7700", "memq://", "file:///tmp/x.lcm?mode=r", "", "inprocess"}) {
    try {
      OpenBus(url);
      ADD_FAILURE() << "opened '" << url << "'";
    } catch (const BusError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("'" + url + "'"), std::string::npos) << what;
      EXPECT_NE(what.find("udpm://"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
  EXPECT_THROW(OpenBus("udpm://10.0.0.1:7667?ttl=0"), BusError);
}

TEST(BusUrl, OpenBusGivesAnInProcessBus) {
  const std::unique_ptr<Bus> bus = OpenBus("inprocess://");
  ASSERT_NE(dynamic_cast<InProcessBus*>(bus.get()), nullptr);
  EXPECT_EQ(bus->fd(), -1);
}

// ---------------------------------------------------------------- Escape

TEST(BusEscape, EscapesControlsBackslashAndDel) {
  EXPECT_EQ(Escape("plain text"), "plain text");
  EXPECT_EQ(Escape("a\nb"), "a\\nb");
  EXPECT_EQ(Escape("a\r\tb"), "a\\r\\tb");
  EXPECT_EQ(Escape("back\\slash"), "back\\\\slash");
  EXPECT_EQ(Escape("\x1b[31mred"), "\\x1b[31mred");
  EXPECT_EQ(Escape("\x1b]0;title\x07"), "\\x1b]0;title\\x07");  // OSC: set the terminal title
  EXPECT_EQ(Escape("del\x7f"), "del\\x7f");
  EXPECT_EQ(Escape(std::string_view("nul\0x", 5)), "nul\\x00x");
  EXPECT_EQ(Escape("caf\xc3\xa9"), "caf\xc3\xa9");  // UTF-8 passes
}

// A cut at max_bytes that would fall inside a multi-byte character falls
// before it: "é" is 2 bytes, "€" 3, "😀" 4; the result is whole characters.
TEST(BusEscape, CutsOnACharacterBoundarySoUtf8StaysValid) {
  EXPECT_EQ(Escape("ab\xc3\xa9"
                   "cd",
                   3),
            "ab...");  // inside é: before it
  EXPECT_EQ(Escape("ab\xc3\xa9"
                   "cd",
                   4),
            "ab\xc3\xa9...");                     // after é: kept whole
  EXPECT_EQ(Escape("a\xe2\x82\xac", 2), "a...");  // inside €
  EXPECT_EQ(Escape("a\xe2\x82\xac", 3), "a...");
  EXPECT_EQ(Escape("\xf0\x9f\x98\x80\xf0\x9f\x98\x80", 6), "\xf0\x9f\x98\x80...");  // inside the second 😀
  // A joint name of 2-byte characters cut at the status's 60 bytes: 30 whole characters.
  std::string name;
  for (int i = 0; i < 40; ++i) name += "\xc3\xa9";
  std::string expected;
  for (int i = 0; i < 30; ++i) expected += "\xc3\xa9";
  EXPECT_EQ(Escape(name, 60), expected + "...");
  std::string odd = "x" + name;  // shifted by a byte: the cut falls inside the 30th é, so 29 are kept
  EXPECT_EQ(Escape(odd, 60), "x" + expected.substr(0, 58) + "...");
}

TEST(BusEscape, TruncatesLongTextWithAnEllipsis) {
  EXPECT_EQ(Escape(std::string(300, 'x')), std::string(200, 'x') + "...");
  EXPECT_EQ(Escape(std::string(200, 'x')), std::string(200, 'x'));
  EXPECT_EQ(Escape("abcdef", 3), "abc...");
  const std::string escaped = Escape(std::string(1000, '\n'), 10);
  EXPECT_EQ(escaped, std::string() + "\\n\\n\\n\\n\\n\\n\\n\\n\\n\\n...");
}

// ---------------------------------------------------------------- real sockets

constexpr const char* kGroup = "239.255.76.67";

class BusUdpm : public ::testing::Test {
 protected:
  static std::string Url(int port) { return testing::TestLcmUrl(port); }
  static void Prepare(int port) { ASSERT_EQ(testing::PrepareLoopbackMulticast(port), ""); }
};

// Polls `bus` until `done` or about 2 s of 10 ms waits.
template <class Done>
bool PollUntil(Bus& bus, Done done, int tries = 200) {
  for (int i = 0; i < tries && !done(); ++i) bus.Handle(10);
  return done();
}

TEST_F(BusUdpm, PublishOnlyBusHasNoReceiveSocket) {
  const std::unique_ptr<Bus> bus = OpenBus(Url(7900));
  EXPECT_EQ(bus->fd(), -1);
  EXPECT_EQ(bus->Drain(), 0);
  std::vector<Received> got;
  bus->Subscribe("X", Recorder(got));
  EXPECT_GE(bus->fd(), 0);
}

TEST_F(BusUdpm, SubscriberReceivesWhatAnotherBusPublishes) {
  Prepare(7901);
  const std::unique_ptr<Bus> receiver = OpenBus(Url(7901));
  const std::unique_ptr<Bus> sender = OpenBus(Url(7901));
  std::vector<Received> got;
  receiver->Subscribe("BUS_TEST", Recorder(got));
  const Bytes payload = {1, 2, 3, 4, 5};
  ASSERT_TRUE(PollUntil(*receiver, [&] {
    sender->Publish("BUS_TEST", payload.data(), payload.size());
    return !got.empty();
  }));
  EXPECT_EQ(got[0].channel, "BUS_TEST");
  EXPECT_EQ(got[0].payload, payload);
  EXPECT_EQ(sender->stats().send_failures, 0);
  EXPECT_GE(receiver->stats().delivered, 1);
  EXPECT_EQ(receiver->stats().malformed, 0);
}

TEST_F(BusUdpm, SurvivesTheDatagramsThatCrashLcmAndCountsThem) {
  Prepare(7902);
  const std::unique_ptr<Bus> bus = OpenBus(Url(7902));
  std::vector<Received> got;
  got.reserve(256);
  bus->Subscribe("ARM_SETPOINT", Recorder(got));
  testing::RawUdpSender raw(kGroup, 7902);
  for (const Bytes& d : {FirstFragment(), WrappingFragment(), FirstFragment(), ShortFragment(), HugeFirstFragment()}) {
    ASSERT_TRUE(raw.Send(d));
  }
  ASSERT_TRUE(raw.Send(ShortDatagram("ARM_SETPOINT", Bytes(65000 - 21, 0xEE))));
  ASSERT_TRUE(raw.Send(ShortDatagram(std::string(80, 'A'), {1})));
  // From one socket to one receiver on loopback the order holds, but any
  // datagram may be lost: send the valid one until it arrives.
  const Bytes valid = {7, 7, 7};
  ASSERT_TRUE(PollUntil(*bus, [&] {
    raw.Send(ShortDatagram("ARM_SETPOINT", valid));
    return !got.empty();
  }));
  for (const Received& r : got) {
    EXPECT_EQ(r.channel, "ARM_SETPOINT");
    EXPECT_EQ(r.payload, valid);  // never the oversized one
  }
  const BusStats s = bus->stats();
  EXPECT_GE(s.fragments_dropped, 1);
  EXPECT_GE(s.oversized, 1);
  EXPECT_GE(s.malformed, 1);
  EXPECT_GE(s.delivered, 1);
  EXPECT_GE(s.received, s.delivered + s.fragments_dropped + s.oversized + s.malformed);
}

// SO_RCVBUF(7): the kernel keeps twice the size set, capped at
// net.core.rmem_max without CAP_NET_ADMIN; with it, the bus's SO_RCVBUFFORCE
// goes beyond the cap.
TEST_F(BusUdpm, TheReceiveBufferAskedIsGrantedUpToTheKernelsCap) {
  std::ifstream rmem("/proc/sys/net/core/rmem_max");
  long long rmem_max = 0;
  ASSERT_TRUE(rmem >> rmem_max);
  const int asked = static_cast<int>(std::min<long long>(rmem_max + 65536, 64LL << 20));
  const std::unique_ptr<Bus> bus = OpenBus(Url(7905) + "&recv_buf_size=" + std::to_string(asked));
  EXPECT_EQ(bus->receive_buffer_bytes(), 0);  // no socket before a subscription
  std::vector<Received> got;
  bus->Subscribe("X", Recorder(got));
  const bool privileged = geteuid() == 0;  // root: CAP_NET_ADMIN (the tests run unconfined)
  const long long expected = 2 * (privileged ? asked : std::min<long long>(asked, rmem_max));
  EXPECT_EQ(bus->receive_buffer_bytes(), expected) << "asked " << asked << ", rmem_max " << rmem_max;
  EXPECT_EQ(OpenBus("inprocess://")->receive_buffer_bytes(), 0);
}

// Drain reads in batches (recvmmsg) yet never reads more than `max`, and hands
// on every datagram it read: the datagrams it reports are the ones delivered.
TEST_F(BusUdpm, DrainReadsAtMostItsMaxAndDeliversWhatItRead) {
  Prepare(7906);
  const std::unique_ptr<Bus> bus = OpenBus(Url(7906) + "&recv_buf_size=1048576");
  std::vector<Received> got;
  got.reserve(64);
  bus->Subscribe("BATCH", Recorder(got));
  testing::RawUdpSender raw(kGroup, 7906);
  // Loopback multicast queues a datagram at the receiver within sendto: all 40 wait (any may be lost).
  for (std::uint8_t k = 0; k < 40; ++k) ASSERT_TRUE(raw.Send(ShortDatagram("BATCH", {k})));
  const int first = bus->Drain(5);
  EXPECT_LE(first, 5);  // not a whole batch of 16
  EXPECT_EQ(got.size(), static_cast<std::size_t>(first));
  const int rest = bus->Drain(1024);
  EXPECT_LE(first + rest, 40);
  EXPECT_EQ(got.size(), static_cast<std::size_t>(first + rest));
  for (std::size_t k = 1; k < got.size(); ++k) EXPECT_LT(got[k - 1].payload[0], got[k].payload[0]);  // in order
  EXPECT_EQ(bus->stats().delivered, static_cast<std::int64_t>(got.size()));
  EXPECT_EQ(bus->stats().received, static_cast<std::int64_t>(got.size()));
}

TEST_F(BusUdpm, ReceivesWhatLcmPublishes) {
  Prepare(7903);
  const std::unique_ptr<Bus> bus = OpenBus(Url(7903));
  std::vector<Received> got;
  bus->Subscribe("FROM_LCM", Recorder(got));
  lcm::LCM lcm(Url(7903));
  ASSERT_TRUE(lcm.good());
  const Bytes payload(300, 0x42);
  ASSERT_TRUE(PollUntil(*bus, [&] {
    lcm.publish("FROM_LCM", payload.data(), static_cast<unsigned>(payload.size()));
    return !got.empty();
  }));
  EXPECT_EQ(got[0].channel, "FROM_LCM");
  EXPECT_EQ(got[0].payload, payload);
}

TEST_F(BusUdpm, LcmReceivesWhatTheBusPublishes) {
  Prepare(7904);
  const std::unique_ptr<Bus> bus = OpenBus(Url(7904));
  lcm::LCM lcm(Url(7904));
  ASSERT_TRUE(lcm.good());
  std::vector<Received> got;
  lcm.subscribeFunction(
      "FROM_BUS",
      +[](const lcm::ReceiveBuffer* rbuf, const std::string& channel, std::vector<Received>* into) {
        const auto* p = static_cast<const std::uint8_t*>(rbuf->data);
        into->push_back({channel, Bytes(p, p + rbuf->data_size)});
      },
      &got);
  const Bytes payload = {9, 8, 7, 6};
  for (int i = 0; i < 200 && got.empty(); ++i) {
    ASSERT_TRUE(bus->Publish("FROM_BUS", payload.data(), payload.size()));
    lcm.handleTimeout(10);
  }
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got[0].channel, "FROM_BUS");
  EXPECT_EQ(got[0].payload, payload);
}

}  // namespace
}  // namespace lagrange
