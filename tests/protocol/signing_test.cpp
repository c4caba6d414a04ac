// Signed traffic (protocol/signing.hpp) and a signed bus (protocol/bus.hpp):
// the key file's checks, the trailer's layout, every alteration and replay
// refused and counted on its channel, and signing that allocates nothing.
// Time is a fake wall clock; nothing here sleeps or measures time.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "protocol/big_endian.hpp"
#include "protocol/bus.hpp"
#include "protocol/signing.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

constexpr std::int64_t kNow = 1'700'000'000'000'000;  // µs since the epoch: the fake wall clock's start
constexpr const char* kDomain = "inprocess://";       // the in-process bus's own domain

BusKey TestKey(std::uint8_t seed = 1) {
  Bytes bytes(kBusKeyMinBytes);
  std::mt19937 rng{seed};
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
  return BusKey::FromBytes(bytes);
}

// A wall clock the test moves.
struct FakeWall {
  std::int64_t now = kNow;
  WallClockMicros Clock() {
    return [this] { return now; };
  }
};

// message ‖ trailer, as it follows the channel in a datagram.
Bytes SignedWire(Signer& signer, const std::string& channel, const Bytes& message) {
  Bytes wire(message);
  wire.resize(message.size() + kSignatureTrailerBytes);
  signer.Sign(channel, message.data(), message.size(), wire.data() + message.size());
  return wire;
}

SignatureVerdict VerifyWire(Verifier& verifier, const std::string& channel, const Bytes& wire) {
  std::size_t size = 0;
  return verifier.Verify(channel, wire.data(), wire.size(), size);
}

const Bytes kMessage = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};

// ---------------------------------------------------------------- the trailer

TEST(Signing, TrailerCarriesSenderStampTagAndMagicAfterTheMessage) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 0x0102030405060708ull, wall.Clock());
  const Bytes wire = SignedWire(signer, "ARM_STATE", kMessage);
  ASSERT_EQ(wire.size(), kMessage.size() + 36);
  EXPECT_TRUE(std::equal(kMessage.begin(), kMessage.end(), wire.begin())) << "the message comes first, unchanged";
  const std::uint8_t* trailer = wire.data() + kMessage.size();
  EXPECT_EQ(ReadBigEndian64(trailer), 0x0102030405060708ull);
  EXPECT_EQ(ReadBigEndian64(trailer + 8), static_cast<std::uint64_t>(kNow));
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(trailer + 32), 4), "LGS2");
}

TEST(Signing, StampsGrowStrictlyEvenWhenTheClockStandsStillOrStepsBack) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  std::uint64_t last = 0;
  for (int k = 0; k < 100; ++k) {
    if (k == 50) wall.now -= 1'000'000;  // the clock steps back a second
    const Bytes wire = SignedWire(signer, "A", kMessage);
    const std::uint64_t stamp = ReadBigEndian64(wire.data() + kMessage.size() + 8);
    EXPECT_GT(stamp, last) << k;
    last = stamp;
  }
}

TEST(Signing, RandomSenderIdsDiffer) {
  FakeWall wall;
  Signer a(TestKey(), kDomain, 0, wall.Clock()), b(TestKey(), kDomain, 0, wall.Clock());
  EXPECT_NE(a.sender_id(), 0u);
  EXPECT_NE(a.sender_id(), b.sender_id());
}

// ---------------------------------------------------------------- verification

TEST(Signing, VerifierAcceptsASignedMessageAndGivesItsSize) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  const Bytes wire = SignedWire(signer, "ARM_SETPOINT", kMessage);
  std::size_t size = 0;
  EXPECT_EQ(verifier.Verify("ARM_SETPOINT", wire.data(), wire.size(), size), SignatureVerdict::kOk);
  EXPECT_EQ(size, kMessage.size());
}

TEST(Signing, EveryAlteredByteOfMessageOrTrailerIsRefused) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  const Bytes wire = SignedWire(signer, "ARM_SETPOINT", kMessage);
  for (std::size_t i = 0; i < wire.size(); ++i) {
    Verifier verifier(TestKey(), kDomain, wall.Clock());  // fresh: a replay is not what refuses it
    Bytes altered = wire;
    altered[i] ^= 0x01;
    EXPECT_NE(VerifyWire(verifier, "ARM_SETPOINT", altered), SignatureVerdict::kOk) << "byte " << i;
  }
}

TEST(Signing, AnotherChannelOrAnotherKeyIsRefused) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  const Bytes wire = SignedWire(signer, "ARM_SETPOINT", kMessage);
  Verifier same_key(TestKey(), kDomain, wall.Clock());
  EXPECT_EQ(VerifyWire(same_key, "ARM_SETPOINU", wire), SignatureVerdict::kBadTag);
  EXPECT_EQ(VerifyWire(same_key, "ARM_SETPOINT_", wire), SignatureVerdict::kBadTag);
  Verifier other_key(TestKey(2), kDomain, wall.Clock());
  EXPECT_EQ(VerifyWire(other_key, "ARM_SETPOINT", wire), SignatureVerdict::kBadTag);
}

// A relay: the same key on two buses, a datagram signed for one resent to
// the other at once (well within the stamp window). The domain is in the tag.
TEST(Signing, ADatagramSignedForOneBusDomainIsRefusedInAnother) {
  FakeWall wall;
  Signer signer(TestKey(), "udpm://239.255.76.67:7667", 7, wall.Clock());
  const Bytes wire = SignedWire(signer, "ARM_COMMAND", kMessage);
  for (const char* other : {"udpm://239.255.76.67:7668", "udpm://239.255.76.68:7667", "cell-2"}) {
    Verifier verifier(TestKey(), other, wall.Clock());
    EXPECT_EQ(VerifyWire(verifier, "ARM_COMMAND", wire), SignatureVerdict::kBadTag) << other;
  }
  Verifier same(TestKey(), "udpm://239.255.76.67:7667", wall.Clock());
  EXPECT_EQ(VerifyWire(same, "ARM_COMMAND", wire), SignatureVerdict::kOk);
}

// The format before domains ("LGS1") is told apart from an unsigned message, so it can be named.
TEST(Signing, AnOldFormatTrailerIsRefusedAsSuch) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  Bytes wire = SignedWire(signer, "A", kMessage);
  wire[wire.size() - 1] = '1';
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  EXPECT_EQ(VerifyWire(verifier, "A", wire), SignatureVerdict::kOldFormat);
  EXPECT_EQ(MessageSizeBeforeTrailer(wire.data(), wire.size()), kMessage.size()) << "log2csv still strips it";
}

TEST(BusDomain, TheDefaultIsTheBusGroupAndPortWhateverItsTtlOrBuffer) {
  EXPECT_EQ(BusDomainOf("udpm://239.255.76.67:7667?ttl=0"), "udpm://239.255.76.67:7667");
  EXPECT_EQ(BusDomainOf("udpm://239.255.76.67:7667?ttl=1&recv_buf_size=2097152"), "udpm://239.255.76.67:7667");
  EXPECT_EQ(BusDomainOf("udpm://239.255.76.67:7668"), "udpm://239.255.76.67:7668");
  EXPECT_EQ(BusDomainOf("inprocess://"), "inprocess://");
  EXPECT_THROW(BusDomainOf("tcpq://localhost:7700"), BusUrlError);
}

TEST(BusDomain, OptionWinsOverTheEnvironmentAndAnEmptyOrUnprintableOneIsRefused) {
  setenv(kBusDomainEnv, "cell-7", 1);
  EXPECT_EQ(ResolveBusDomain(std::string("cell-3")), "cell-3");
  EXPECT_EQ(ResolveBusDomain(std::nullopt), "cell-7");
  setenv(kBusDomainEnv, "", 1);
  EXPECT_THROW(ResolveBusDomain(std::nullopt), BusKeyError) << "set but empty: an unset variable";
  unsetenv(kBusDomainEnv);
  EXPECT_EQ(ResolveBusDomain(std::nullopt), "") << "none: the bus's own";
  for (const std::string& bad :
       {std::string(""), std::string(65, 'd'), std::string("a\nb"), std::string("caf\xc3\xa9")}) {
    EXPECT_THROW(ResolveBusDomain(bad), BusKeyError) << bad;
  }
}

TEST(Signing, AReplayedDatagramIsRefusedAndTheNextOneAccepted) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  const Bytes first = SignedWire(signer, "A", kMessage);
  const Bytes second = SignedWire(signer, "A", kMessage);
  EXPECT_EQ(VerifyWire(verifier, "A", first), SignatureVerdict::kOk);
  EXPECT_EQ(VerifyWire(verifier, "A", first), SignatureVerdict::kReplayed);
  EXPECT_EQ(VerifyWire(verifier, "A", second), SignatureVerdict::kOk);
  EXPECT_EQ(VerifyWire(verifier, "A", first), SignatureVerdict::kReplayed) << "an older one after a newer";
  EXPECT_EQ(VerifyWire(verifier, "A", second), SignatureVerdict::kReplayed);
}

TEST(Signing, AStampOutsideTheWindowIsRefusedEitherWay) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  const Bytes recorded = SignedWire(signer, "A", kMessage);
  Verifier later(TestKey(), kDomain, wall.Clock());
  wall.now += kStampWindowMicros + 1;  // replayed a little over the window later (lcm-logplayer)
  EXPECT_EQ(VerifyWire(later, "A", recorded), SignatureVerdict::kStale);
  wall.now = kNow - kStampWindowMicros - 1;  // the receiver's clock behind the sender's
  EXPECT_EQ(VerifyWire(later, "A", recorded), SignatureVerdict::kStale);
  wall.now = kNow + kStampWindowMicros;  // at the edge
  EXPECT_EQ(VerifyWire(later, "A", recorded), SignatureVerdict::kOk);
}

TEST(Signing, AnythingStampedBeforeTheReceiverOpenedIsStale) {
  // A recording made before a receiver started, replayed to it at once (within the window).
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  const Bytes recorded = SignedWire(signer, "A", kMessage);
  wall.now += 1000;
  Verifier started_after(TestKey(), kDomain, wall.Clock());
  EXPECT_EQ(VerifyWire(started_after, "A", recorded), SignatureVerdict::kStale);
  EXPECT_EQ(VerifyWire(started_after, "A", SignedWire(signer, "A", kMessage)), SignatureVerdict::kOk);
}

TEST(Signing, UnsignedAndShortMessagesAreRefusedAsUnsigned) {
  FakeWall wall;
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  EXPECT_EQ(VerifyWire(verifier, "A", kMessage), SignatureVerdict::kUnsigned);
  EXPECT_EQ(VerifyWire(verifier, "A", Bytes{}), SignatureVerdict::kUnsigned);
  EXPECT_EQ(VerifyWire(verifier, "A", Bytes(kSignatureTrailerBytes, 0)), SignatureVerdict::kUnsigned);
  std::size_t size = 1;
  EXPECT_EQ(verifier.Verify("A", nullptr, 0, size), SignatureVerdict::kUnsigned);
  EXPECT_EQ(size, 0u);
}

TEST(Signing, ForgedSendersCannotEvictARealOneFromTheReplayWindow) {
  FakeWall wall;
  Signer real(TestKey(), kDomain, 7, wall.Clock());
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  const Bytes first = SignedWire(real, "A", kMessage);
  ASSERT_EQ(VerifyWire(verifier, "A", first), SignatureVerdict::kOk);
  for (std::size_t k = 0; k < 4 * Verifier::kMaxSenders; ++k) {
    Signer cycling(TestKey(9), kDomain, 1000 + k, wall.Clock());  // a new sender id each time, without the key
    EXPECT_EQ(VerifyWire(verifier, "A", SignedWire(cycling, "A", kMessage)), SignatureVerdict::kBadTag);
  }
  EXPECT_EQ(VerifyWire(verifier, "A", first), SignatureVerdict::kReplayed);
}

TEST(Signing, SigningAndVerifyingAllocateNothing) {
  FakeWall wall;
  Signer signer(TestKey(), kDomain, 7, wall.Clock());
  Verifier verifier(TestKey(), kDomain, wall.Clock());
  Bytes wire(kMessage.size() + kSignatureTrailerBytes);
  std::copy(kMessage.begin(), kMessage.end(), wire.begin());
  testing::AllocationCounter allocations;
  for (int k = 0; k < 100; ++k) {
    signer.Sign("A", wire.data(), kMessage.size(), wire.data() + kMessage.size());
    std::size_t size = 0;
    if (verifier.Verify("A", wire.data(), wire.size(), size) != SignatureVerdict::kOk) ADD_FAILURE() << k;
  }
  EXPECT_EQ(allocations.count(), 0);
}

// ---------------------------------------------------------------- the key file

class BusKeyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lagrange_key_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, std::size_t bytes, mode_t mode) {
    const fs::path p = dir_ / name;
    std::string content(bytes, 'k');
    for (std::size_t i = 0; i < bytes; ++i) content[i] = static_cast<char>('a' + i % 26);  // not all one value
    std::ofstream(p, std::ios::binary) << content;
    chmod(p.c_str(), mode);
    return p.string();
  }
  static std::string Refusal(const std::string& path) {
    try {
      BusKey::FromFile(path);
    } catch (const BusKeyError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(BusKeyFile, AcceptsAnOwnerOnlyFileOfThirtyTwoToSixtyFourBytes) {
  EXPECT_EQ(Refusal(Write("32", 32, 0600)), "");
  EXPECT_EQ(Refusal(Write("64", 64, 0400)), "");
}

TEST_F(BusKeyFile, RefusesAGroupOrWorldReadableFileNamingItAndTheMode) {
  for (const mode_t mode : {0640, 0604, 0644, 0660, 0610}) {
    const std::string path = Write("k" + std::to_string(mode), 32, mode);
    const std::string why = Refusal(path);
    EXPECT_NE(why.find("bus key " + path + ": readable by group or others"), std::string::npos) << why;
    EXPECT_NE(why.find("chmod 600"), std::string::npos) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << "one line";
  }
}

TEST_F(BusKeyFile, RefusesTheWrongSizeNamingTheFile) {
  for (const std::size_t bytes : {0, 16, 31, 65, 4096}) {
    const std::string path = Write("s" + std::to_string(bytes), bytes, 0600);
    const std::string why = Refusal(path);
    EXPECT_NE(why.find("bus key " + path + ": " + std::to_string(bytes) + " bytes"), std::string::npos) << why;
  }
}

TEST_F(BusKeyFile, RefusesAMissingFileADirectoryAndASymlink) {
  EXPECT_NE(Refusal((dir_ / "missing").string()).find("No such file"), std::string::npos);
  EXPECT_NE(Refusal(dir_.string()).find("bus key " + dir_.string() + ": "), std::string::npos);
  const std::string target = Write("target", 32, 0600);
  fs::create_symlink(target, dir_ / "link");
  const std::string why = Refusal((dir_ / "link").string());
  EXPECT_NE(why.find("a symbolic link (to " + target + ")"), std::string::npos) << why;
  EXPECT_NE(why.find("name the key file itself (" + fs::canonical(target).string() + ")"), std::string::npos) << why;
  EXPECT_EQ(why.find("Too many levels"), std::string::npos) << why;
}

TEST_F(BusKeyFile, RefusesAKeyWhoseBytesAreAllOneValue) {
  for (const char fill : {'\0', '\xff', 'k'}) {
    const fs::path p = dir_ / ("fill" + std::to_string(static_cast<unsigned char>(fill)));
    std::ofstream(p, std::ios::binary) << std::string(32, fill);
    chmod(p.c_str(), 0600);
    const std::string why = Refusal(p.string());
    EXPECT_NE(why.find("bus key " + p.string() + ": every byte is 0x"), std::string::npos) << why;
    EXPECT_NE(why.find("not a random key"), std::string::npos) << why;
  }
  EXPECT_THROW(BusKey::FromBytes(Bytes(kBusKeyMinBytes, 0)), BusKeyError);
}

TEST_F(BusKeyFile, KeygenWritesAnOwnerOnlyKeyThatLoadsAndNeverOverwrites) {
  const std::string path = (dir_ / "new.key").string();
  const mode_t old_mask = umask(0);  // whatever the umask, the file is 0600
  WriteNewBusKey(path);
  umask(old_mask);
  struct stat st {};
  ASSERT_EQ(stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(st.st_size, static_cast<off_t>(kBusKeyMinBytes));
  EXPECT_EQ(Refusal(path), "");
  EXPECT_THROW(WriteNewBusKey(path), BusKeyError);
  const std::string other = (dir_ / "other.key").string();
  WriteNewBusKey(other);
  std::ifstream a(path, std::ios::binary), b(other, std::ios::binary);
  EXPECT_NE(std::string(std::istreambuf_iterator<char>(a), {}), std::string(std::istreambuf_iterator<char>(b), {}));
}

TEST(BusKeyEnv, AnEmptyPathGivenOrAnEmptyVariableIsRefusedNeverUnsigned) {
  EXPECT_THROW(ResolveBusKeyFile(std::string()), BusKeyError);
  setenv(kBusKeyEnv, "", 1);
  EXPECT_THROW(ResolveBusKeyFile(std::nullopt), BusKeyError);
  unsetenv(kBusKeyEnv);
}

TEST(BusKeyEnv, OptionWinsOverTheEnvironment) {
  setenv(kBusKeyEnv, "/from/env", 1);
  EXPECT_EQ(ResolveBusKeyFile("/from/option"), "/from/option");
  EXPECT_EQ(ResolveBusKeyFile(std::nullopt), "/from/env");
  unsetenv(kBusKeyEnv);
  EXPECT_EQ(ResolveBusKeyFile(std::nullopt), "");
}

// ---------------------------------------------------------------- a signed bus

struct Seen {
  std::string channel;
  Bytes message;
};

Bus::Handler Recorder(std::vector<Seen>& into) {
  return [&into](std::string_view channel, const std::uint8_t* data, std::size_t size) {
    into.push_back({std::string(channel), Bytes(data, data + size)});
  };
}

TEST(SignedBus, DeliversASignedMessageWithoutItsTrailer) {
  const BusKey key = TestKey();
  InProcessBus bus(&key);
  EXPECT_TRUE(bus.signs());
  std::vector<Seen> got;
  bus.Subscribe("ARM_SETPOINT", Recorder(got));
  bus.Publish("ARM_SETPOINT", kMessage.data(), kMessage.size());
  bus.Drain();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].message, kMessage);
  EXPECT_EQ(bus.stats().unauthenticated(), 0);
}

// A raw LC02 datagram: magic, seqno, channel, NUL, payload.
Bytes Lc02(const std::string& channel, const Bytes& payload) {
  Bytes out = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 1};
  out.insert(out.end(), channel.begin(), channel.end());
  out.push_back(0);
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

TEST(SignedBus, RefusesUnsignedForgedReplayedAndStaleDatagramsCountingEachOnItsChannel) {
  const BusKey key = TestKey();
  FakeWall wall;
  InProcessBus bus(&key, wall.Clock());
  std::vector<Seen> got;
  bus.Subscribe("ARM_SETPOINT", Recorder(got));
  bus.Subscribe("ARM_COMMAND", Recorder(got));
  Signer holder(key, kDomain, 42, wall.Clock());
  Signer forger(TestKey(3), kDomain, 43, wall.Clock());
  const Bytes good = SignedWire(holder, "ARM_SETPOINT", kMessage);

  const Bytes unsigned_setpoint = Lc02("ARM_SETPOINT", kMessage);
  bus.InjectDatagram(unsigned_setpoint.data(), unsigned_setpoint.size());
  const Bytes unsigned_command = Lc02("ARM_COMMAND", kMessage);
  bus.InjectDatagram(unsigned_command.data(), unsigned_command.size());
  const Bytes forged = Lc02("ARM_COMMAND", SignedWire(forger, "ARM_COMMAND", kMessage));
  bus.InjectDatagram(forged.data(), forged.size());
  const Bytes real = Lc02("ARM_SETPOINT", good);
  bus.InjectDatagram(real.data(), real.size());
  bus.InjectDatagram(real.data(), real.size());                                         // replayed
  Bytes tampered = Lc02("ARM_SETPOINT", SignedWire(holder, "ARM_SETPOINT", kMessage));  // newer than `real`
  tampered[tampered.size() - kSignatureTrailerBytes - 1] ^= 0x80;                       // the message's last byte
  bus.InjectDatagram(tampered.data(), tampered.size());
  const Bytes old = Lc02("ARM_SETPOINT", SignedWire(holder, "ARM_SETPOINT", kMessage));
  const Bytes other_channel = Lc02("NOT_OURS", Bytes{1, 2, 3});  // not subscribed: not counted
  bus.InjectDatagram(other_channel.data(), other_channel.size());
  bus.Drain();
  wall.now += 2 * kStampWindowMicros;
  bus.InjectDatagram(old.data(), old.size());  // stale
  bus.Drain();

  ASSERT_EQ(got.size(), 1u) << "only the one genuine datagram";
  EXPECT_EQ(got[0].message, kMessage);
  const BusStats s = bus.stats();
  EXPECT_EQ(s.unsigned_dropped, 2);
  EXPECT_EQ(s.bad_tags, 2);
  EXPECT_EQ(s.replayed, 1);
  EXPECT_EQ(s.stale, 1);
  EXPECT_EQ(s.unauthenticated(), 6);
  EXPECT_EQ(bus.unauthenticated_on("ARM_SETPOINT"), 4);
  EXPECT_EQ(bus.unauthenticated_on("ARM_COMMAND"), 2);
  EXPECT_EQ(bus.unauthenticated_on("NOT_OURS"), 0);
}

// A client that hears every channel and also subscribes to some: a refusal on
// one of those is counted on it, not on the every-channel subscription.
TEST(SignedBus, ARefusalIsCountedOnItsOwnChannelAfterAnEveryChannelSubscription) {
  const BusKey key = TestKey();
  InProcessBus bus(&key);
  std::vector<Seen> got;
  bus.Subscribe(kEveryChannel, Recorder(got));
  bus.Subscribe("ARM_STATE", Recorder(got));
  for (const char* channel : {"ARM_STATE", "ARM_STATE", "OTHER"}) {
    const Bytes unsigned_datagram = Lc02(channel, kMessage);
    bus.InjectDatagram(unsigned_datagram.data(), unsigned_datagram.size());
  }
  bus.Drain();
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(bus.unauthenticated_on("ARM_STATE"), 2);
  EXPECT_EQ(bus.unauthenticated_on(kEveryChannel), 1);  // OTHER: heard only by the every-channel subscription
  EXPECT_EQ(bus.stats().unsigned_dropped, 3);
}

TEST(SignedBus, AnUnsignedBusReceivesTheMessageFollowedByTheTrailer) {
  // What lcm-logger records and LCM's decoders read: the message first, then 36 bytes they ignore.
  std::vector<Seen> raw;
  InProcessBus plain;
  plain.Subscribe("A", Recorder(raw));
  Signer signer(TestKey(), kDomain);
  const Bytes datagram = Lc02("A", SignedWire(signer, "A", kMessage));
  plain.InjectDatagram(datagram.data(), datagram.size());
  plain.Drain();
  ASSERT_EQ(raw.size(), 1u);
  EXPECT_EQ(raw[0].message.size(), kMessage.size() + kSignatureTrailerBytes);
  EXPECT_TRUE(std::equal(kMessage.begin(), kMessage.end(), raw[0].message.begin()));
}

TEST(SignedBus, TheLargestMessageStillFitsWithItsTrailer) {
  const BusKey key = TestKey();
  InProcessBus bus(&key);
  std::vector<Seen> got;
  bus.Subscribe("A", Recorder(got));
  const Bytes largest(kMaxMessageSize, 0x5a);
  EXPECT_TRUE(bus.Publish("A", largest.data(), largest.size()));
  const Bytes over(kMaxMessageSize + 1, 0x5a);
  EXPECT_FALSE(bus.Publish("A", over.data(), over.size()));
  bus.Drain();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].message.size(), kMaxMessageSize);
}

TEST(SignedBus, SigningOnAUdpmBusAndVerifyingOnReceiptAllocateNothing) {
  const BusKey key = TestKey();
  // Publish-only: no receive socket, the datagrams go to a private port (8111) and are not read.
  const std::unique_ptr<Bus> udpm = OpenBus("udpm://239.255.76.67:8111?ttl=0", &key);
  ASSERT_TRUE(udpm->signs());
  const Bytes state(200, 0x25);
  {
    testing::AllocationCounter allocations;
    for (int k = 0; k < 100; ++k) udpm->Publish("ARM_STATE", state.data(), state.size());
    EXPECT_EQ(allocations.count(), 0) << "the publish thread signs in the bus's send buffer";
  }
  InProcessBus bus(&key);
  int delivered = 0;
  bus.Subscribe("ARM_SETPOINT", [&](std::string_view, const std::uint8_t*, std::size_t) { ++delivered; });
  Signer sender(key, kDomain);
  for (int k = 0; k < 100; ++k) {
    const Bytes d = Lc02("ARM_SETPOINT", SignedWire(sender, "ARM_SETPOINT", kMessage));
    bus.InjectDatagram(d.data(), d.size());
  }
  testing::AllocationCounter allocations;
  bus.Drain();
  EXPECT_EQ(allocations.count(), 0) << "the receive thread verifies without allocating";
  EXPECT_EQ(delivered, 100);
}

TEST(SignedBus, WithoutAKeyNothingIsSignedOrChecked) {
  InProcessBus bus;
  EXPECT_FALSE(bus.signs());
  std::vector<Seen> got;
  bus.Subscribe("A", Recorder(got));
  const Bytes datagram = Lc02("A", kMessage);
  bus.InjectDatagram(datagram.data(), datagram.size());
  bus.Publish("A", kMessage.data(), kMessage.size());
  bus.Drain();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[1].message, kMessage) << "no trailer appended";
  EXPECT_EQ(bus.stats().unauthenticated(), 0);
}

}  // namespace
}  // namespace lagrange
