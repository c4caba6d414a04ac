// mpc_t on the wire (<NAME>_MPC): its check walks the two counts of its knots
// and refuses every hostile shape before the generated decoder (which trusts
// them) allocates anything; the typed receive drops such a plan with the
// check's reason, and the knots a daemon sends of a plan are evenly spaced and
// always fit one datagram.

#include <gtest/gtest.h>
#include <lagrange/mpc_t.hpp>

#include <cstdint>
#include <optional>
#include <vector>

#include "base/vocabulary.hpp"
#include "protocol/bus.hpp"
#include "protocol/receive.hpp"
#include "protocol/wire.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using Bytes = std::vector<std::uint8_t>;
using testing::Encode;

// A plan of a cart-pole (4 states) with `knots` knots, from run 7.
mpc_t ValidPlan(int knots = 16, int states = 4) {
  mpc_t m{};
  m.utime = 1;
  m.run_id = 7;
  m.tick = 40;
  m.t = 0.04;
  m.controller = "mpc";
  m.plan = 2;
  m.start = 0.04;
  m.solve_time = 0.003;
  m.iterations = 2;
  m.cost_before = 12.0;
  m.cost = 10.0;
  m.status = "max-iterations";
  m.followed = true;
  m.dt = 0.02;
  m.horizon = 100;
  m.num_states = states;
  m.num_knots = knots;
  for (int j = 0; j < knots; ++j) {
    m.knot_t.push_back(0.04 + 0.02 * j);
    m.knot_x.emplace_back(static_cast<std::size_t>(states), 0.5);
  }
  return m;
}

// Where num_states is in an encoded plan: just before num_knots and the knots' doubles.
std::size_t NumStatesAt(const Bytes& buf, int knots, int states) {
  return buf.size() - 8 * static_cast<std::size_t>(knots) * static_cast<std::size_t>(states + 1) - 8;
}

void WriteInt32(Bytes& buf, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (std::size_t i = 0; i < 4; ++i) buf.at(at + i) = static_cast<std::uint8_t>(u >> (24 - 8 * i));
}

TEST(MpcWire, APlanPassesForEveryShapeWithinTheBoundsAndEveryTruncationOrExtraByteIsCaught) {
  for (const auto& [knots, states] : {std::pair{0, 4}, std::pair{1, 2}, std::pair{16, 4}, std::pair{16, 14},
                                      std::pair{2, 2 * kMaxDofs}}) {
    const Bytes buf = Encode(ValidPlan(knots, states));
    ASSERT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kOk) << knots << " x " << states;
    EXPECT_LE(buf.size(), kMaxMessageSize);
    EXPECT_EQ(TypeOf(buf.data(), buf.size()), MessageType::kMpc);
    EXPECT_EQ(RunIdOf(buf.data(), buf.size()), std::optional<std::int64_t>(7));
  }
  const Bytes buf = Encode(ValidPlan());
  for (std::size_t len = 0; len < buf.size(); ++len) EXPECT_NE(CheckMpcPacket(buf.data(), len), WireCheck::kOk) << len;
  Bytes longer = buf;
  longer.push_back(0);
  EXPECT_EQ(CheckMpcPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  const Bytes state = Encode(testing::MakeState());
  EXPECT_EQ(CheckMpcPacket(state.data(), state.size()), WireCheck::kFingerprint);
}

TEST(MpcWire, APlanClaimingMoreKnotsThanMaxKnotsOrNegativeIsRefusedBeforeDecoding) {
  for (const std::int32_t knots : {mpc_t::MAX_KNOTS + 1, 0x7fffffff, -1}) {
    Bytes buf = Encode(ValidPlan());
    WriteInt32(buf, NumStatesAt(buf, 16, 4) + 4, knots);
    EXPECT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kBadLength) << knots;
  }
}

TEST(MpcWire, APlanWithAnOddNegativeOrOversizedStateCountIsRefused) {
  for (const std::int32_t states : {3, -2, 2 * kMaxDofs + 2, 0x7fffffff}) {
    Bytes buf = Encode(ValidPlan());
    WriteInt32(buf, NumStatesAt(buf, 16, 4), states);
    EXPECT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kBadLength) << states;
  }
}

TEST(MpcWire, APlanWhoseKnotsWouldNotFitOneDatagramIsRefusedWhateverItsSize) {
  // 16 knots of a 256-joint state: each count within its own bound, their product over kMaxMpcKnotValues.
  const Bytes buf = Encode(ValidPlan(16, 2 * kMaxDofs));
  EXPECT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  Bytes lying = Encode(ValidPlan(2, 4));
  WriteInt32(lying, NumStatesAt(lying, 2, 4) + 4, 16);  // 16 knots declared, 2 sent
  WriteInt32(lying, NumStatesAt(lying, 2, 4), 2 * kMaxDofs);
  EXPECT_EQ(CheckMpcPacket(lying.data(), lying.size()), WireCheck::kBadLength);
}

TEST(MpcWire, APlanWithACraftedOrOversizedStringIsRefused) {
  mpc_t m = ValidPlan();
  m.status.assign(256, 'x');  // 257 bytes with its NUL
  const Bytes over = Encode(m);
  EXPECT_EQ(CheckMpcPacket(over.data(), over.size()), WireCheck::kBadLength);
  for (const std::int32_t length : {0x7fffffff, -1, 0, 257}) {
    Bytes buf = Encode(ValidPlan());
    WriteInt32(buf, 8 + 3 * 8 + 8, length);  // the controller's length: after fingerprint, utime, run_id, tick, t
    EXPECT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kBadLength) << length;
  }
}

TEST(MpcReceive, AHostilePlanIsDroppedWithTheChecksReasonAndAValidOneDecodesWhole) {
  const mpc_t sent = ValidPlan(5, 4);
  const Bytes buf = Encode(sent);
  const Received<mpc_t> got = Receive<mpc_t>(buf.data(), buf.size());
  ASSERT_TRUE(got) << ToString(got.drop);
  EXPECT_EQ(got.message->num_knots, 5);
  EXPECT_EQ(got.message->knot_x.size(), 5u);
  EXPECT_EQ(got.message->knot_x[4].size(), 4u);
  EXPECT_EQ(got.message->status, "max-iterations");
  Bytes hostile = buf;
  WriteInt32(hostile, NumStatesAt(hostile, 5, 4) + 4, 0x7fffffff);
  EXPECT_EQ(Receive<mpc_t>(hostile.data(), hostile.size()).drop, Drop::kBadLength);
  hostile = buf;
  WriteInt32(hostile, NumStatesAt(hostile, 5, 4), 5);
  EXPECT_EQ(Receive<mpc_t>(hostile.data(), hostile.size()).drop, Drop::kBadLength);
}

TEST(MpcWire, TheKnotsSentOfAPlanRunEvenlyFromItsFirstToItsLastAndFitOneDatagram) {
  EXPECT_EQ(MpcKnotsOnWire(4, 0), 0);  // no plan
  EXPECT_EQ(MpcKnotsOnWire(4, 100), mpc_t::MAX_KNOTS);
  EXPECT_EQ(MpcKnotsOnWire(4, 5), 6);  // a short horizon: every knot, 0 .. N
  EXPECT_EQ(MpcKnotOnWire(0, 16, 100), 0);
  EXPECT_EQ(MpcKnotOnWire(15, 16, 100), 100);
  for (int j = 1; j < 16; ++j) EXPECT_GT(MpcKnotOnWire(j, 16, 100), MpcKnotOnWire(j - 1, 16, 100)) << j;
  for (const int states : {2, 14, 64, 2 * kMaxDofs}) {
    const int knots = MpcKnotsOnWire(states, 10000);
    EXPECT_GE(knots, 2) << states;
    const Bytes buf = Encode(ValidPlan(knots, states));
    EXPECT_EQ(CheckMpcPacket(buf.data(), buf.size()), WireCheck::kOk) << states;
  }
}

}  // namespace
}  // namespace lagrange
