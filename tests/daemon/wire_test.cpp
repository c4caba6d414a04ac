// Raw packet checks before decoding: exact sizes from declared lengths,
// fingerprints, and crafted lengths that would make a decoder allocate
// gigabytes.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>

#include <vector>

#include "daemon/wire.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using testing::Encode;

setpoint_t ValidSetpoint(int n) {
  setpoint_t s;
  s.utime = 123;
  s.num_dofs = n;
  s.q.assign(static_cast<std::size_t>(n), 0.5);
  s.qd.assign(static_cast<std::size_t>(n), 0.0);
  s.qdd.assign(static_cast<std::size_t>(n), 0.0);
  return s;
}

// Overwrites a big-endian int32 field inside an encoded packet.
void WriteInt32(std::vector<std::uint8_t>& buf, std::size_t at, std::int32_t v) {
  ASSERT_LE(at + 4, buf.size());
  const auto u = static_cast<std::uint32_t>(v);
  for (std::size_t i = 0; i < 4; ++i) buf.at(at + i) = static_cast<std::uint8_t>(u >> (24 - 8 * i));
}

TEST(Wire, AValidSetpointPassesAndEveryTruncationIsCaught) {
  const auto buf = Encode(ValidSetpoint(7));
  EXPECT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kOk);
  for (std::size_t len = 0; len < buf.size(); ++len) {
    EXPECT_NE(CheckSetpointPacket(buf.data(), len), WireCheck::kOk) << len;
  }
  auto longer = buf;
  longer.push_back(0);
  EXPECT_EQ(CheckSetpointPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
}

TEST(Wire, ACraftedArrayLengthIsRefusedBeforeAnythingIsAllocated) {
  auto buf = Encode(ValidSetpoint(2));
  WriteInt32(buf, 16, 0x7fffffff);  // num_dofs = 2³¹ − 1 in a 68-byte packet
  EXPECT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  WriteInt32(buf, 16, -1);
  EXPECT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  WriteInt32(buf, 16, 3);  // plausible, but the packet holds 2
  EXPECT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kSizeMismatch);
}

TEST(Wire, AnotherTypesPacketFailsTheFingerprint) {
  state_t s;
  s.num_dofs = 0;
  const auto buf = Encode(s);
  EXPECT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kFingerprint);
  EXPECT_EQ(CheckCommandPacket(buf.data(), buf.size()), WireCheck::kFingerprint);
  const auto sp = Encode(ValidSetpoint(2));
  EXPECT_EQ(CheckCommandPacket(sp.data(), sp.size()), WireCheck::kFingerprint);
}

TEST(Wire, CommandsAreCheckedThroughTheirStringAndArrays) {
  const auto buf = Encode(testing::MakeSetGainsCommand());
  EXPECT_EQ(CheckCommandPacket(buf.data(), buf.size()), WireCheck::kOk);
  for (std::size_t len = 0; len < buf.size(); ++len)
    EXPECT_NE(CheckCommandPacket(buf.data(), len), WireCheck::kOk) << len;
  auto huge_string = buf;
  WriteInt32(huge_string, 25, 0x7fffffff);  // after fingerprint, utime, request_id, command
  EXPECT_EQ(CheckCommandPacket(huge_string.data(), huge_string.size()), WireCheck::kBadLength);
  auto huge_gains = buf;
  WriteInt32(huge_gains, 25 + 4 + 3, 0x7fffffff);  // after "pd\0"
  EXPECT_EQ(CheckCommandPacket(huge_gains.data(), huge_gains.size()), WireCheck::kBadLength);
  auto unterminated = buf;
  unterminated[25 + 4 + 2] = 'x';  // the string's NUL
  EXPECT_EQ(CheckCommandPacket(unterminated.data(), unterminated.size()), WireCheck::kBadLength);
}

TEST(Wire, EveryPacketThatPassesDecodes) {
  for (int n : {0, 1, 2, 64}) {
    const auto buf = Encode(ValidSetpoint(n));
    ASSERT_EQ(CheckSetpointPacket(buf.data(), buf.size()), WireCheck::kOk);
    setpoint_t out;
    EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
    EXPECT_EQ(out.num_dofs, n);
  }
}

}  // namespace
}  // namespace lagrange
