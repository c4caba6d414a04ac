// Raw packet checks before decoding: exact sizes from declared lengths,
// fingerprints, and crafted lengths that would make a decoder allocate
// gigabytes.

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/pose_setpoint_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/base_state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <optional>
#include <string>
#include <vector>

#include "plant/types.hpp"
#include "protocol/wire.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using testing::Encode;
using testing::MakeState;

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

void WriteInt64(std::vector<std::uint8_t>& buf, std::size_t at, std::uint64_t v) {
  WriteInt32(buf, at, static_cast<std::int32_t>(v >> 32));
  WriteInt32(buf, at + 4, static_cast<std::int32_t>(v & 0xffffffffu));
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

// ------------------------------------------------------------------ issue 14: the switch commands' layout

// Every field of command_t in use: set-gains' string and arrays, then the
// switch fields. Byte offsets: controller's length at 25 ("pd\0" to 32),
// num_gains at 32, kp and kd to 68, setting's length at 68 ("dopri5\0" to 79),
// substeps at 79, rtol, atol, max_steps at 99, on at 103; 104 bytes.
command_t FullCommand() {
  command_t c = testing::MakeSetGainsCommand();
  c.command = command_t::SET_INTEGRATOR;
  c.setting = "dopri5";
  c.substeps = 4;
  c.rtol = 1e-6;
  c.atol = 1e-9;
  c.max_steps = 200;
  c.on = true;
  return c;
}
constexpr std::size_t kSettingLengthAt = 68, kSettingNulAt = 78, kFullCommandSize = 104;

TEST(Wire, AFullSwitchCommandPassesAndDecodesToItsFields) {
  const auto buf = Encode(FullCommand());
  ASSERT_EQ(buf.size(), kFullCommandSize);
  ASSERT_EQ(CheckCommandPacket(buf.data(), buf.size()), WireCheck::kOk);
  command_t out;
  ASSERT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(out.setting, "dopri5");
  EXPECT_EQ(out.substeps, 4);
  EXPECT_EQ(out.max_steps, 200);
  EXPECT_TRUE(out.on);
  for (std::size_t len = 0; len < buf.size(); ++len) {
    EXPECT_NE(CheckCommandPacket(buf.data(), len), WireCheck::kOk) << len;
  }
}

// A sender built against command_t before issue 14 stops after kd: another
// layout, refused before decoding (its fingerprint differs too, but the size
// alone must not pass).
TEST(Wire, ACommandEndingAfterItsGainsIsRefused) {
  const auto buf = Encode(FullCommand());
  EXPECT_EQ(CheckCommandPacket(buf.data(), kSettingLengthAt), WireCheck::kTooShort);
}

TEST(Wire, ASettingOfLengthZeroOrOver256BytesIsRefused) {
  auto zero = Encode(FullCommand());
  WriteInt32(zero, kSettingLengthAt, 0);  // not even the NUL
  EXPECT_EQ(CheckCommandPacket(zero.data(), zero.size()), WireCheck::kBadLength);
  auto negative = Encode(FullCommand());
  WriteInt32(negative, kSettingLengthAt, -1);
  EXPECT_EQ(CheckCommandPacket(negative.data(), negative.size()), WireCheck::kBadLength);
  auto crafted = Encode(FullCommand());
  WriteInt32(crafted, kSettingLengthAt, 0x7fffffff);
  EXPECT_EQ(CheckCommandPacket(crafted.data(), crafted.size()), WireCheck::kBadLength);
  // Real strings around the bound: 255 bytes and the NUL pass, 256 and the NUL do not.
  command_t longest = FullCommand();
  longest.setting.assign(255, 'x');
  const auto fits = Encode(longest);
  EXPECT_EQ(CheckCommandPacket(fits.data(), fits.size()), WireCheck::kOk);
  longest.setting.assign(256, 'x');
  const auto over = Encode(longest);
  EXPECT_EQ(CheckCommandPacket(over.data(), over.size()), WireCheck::kBadLength);
}

TEST(Wire, ASettingWithoutItsNulIsRefused) {
  auto buf = Encode(FullCommand());
  ASSERT_EQ(buf.at(kSettingNulAt), 0);
  buf[kSettingNulAt] = 'x';
  EXPECT_EQ(CheckCommandPacket(buf.data(), buf.size()), WireCheck::kBadLength);
}

TEST(Wire, ACommandWithTrailingBytesOrWithoutItsOnByteIsRefused) {
  auto longer = Encode(FullCommand());
  longer.push_back(0);
  EXPECT_EQ(CheckCommandPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  const auto buf = Encode(FullCommand());
  EXPECT_EQ(CheckCommandPacket(buf.data(), buf.size() - 1), WireCheck::kSizeMismatch);
}

// ------------------------------------------------------------------ telemetry_t and forces_t

telemetry_t ValidTelemetry() {
  telemetry_t m{};
  m.utime = 1;
  m.run_id = 0x1234;
  m.tick = 7;
  m.t = 0.007;
  m.energy = 1.5;
  m.energy_residual = 1e-12;
  m.integrator = "dopri5";
  m.substeps = 2;
  m.method = "closed-form";
  m.evaluations = 19;
  m.error_estimate = 0.3;
  m.step = 5e-4;
  return m;
}
// The integrator's length: after fingerprint, utime, run_id, tick, t, mode, energy .. power.
constexpr std::size_t kTelemetryStringAt = 8 + 3 * 8 + 8 + 1 + 5 * 8;

forces_t ValidForces(int n, int contacts = 0) {
  forces_t f{};
  f.utime = 1;
  f.run_id = 0x5678;
  f.tick = 7;
  f.gravity_on = f.coriolis_on = true;
  f.num_dofs = n;
  for (auto* v : {&f.gravity, &f.coriolis, &f.damping, &f.friction, &f.limits, &f.constraint, &f.disturbance,
                  &f.tau_cmd, &f.tau_applied}) {
    v->assign(static_cast<std::size_t>(n), 0.25);
  }
  f.contacts_total = f.num_contacts = contacts;
  f.contacts.resize(static_cast<std::size_t>(contacts));
  for (contact_t& c : f.contacts) {
    c.geom2 = 1;
    c.normal[2] = 1.0;
    c.force[2] = 30.0;
  }
  return f;
}
// num_dofs: after fingerprint, utime, run_id, tick, t and the eight flags.
constexpr std::size_t kForcesDofsAt = 8 + 3 * 8 + 8 + 8;
// num_contacts of a forces_t on n joints: after num_dofs, the nine rows and contacts_total.
std::size_t ForcesContactsAt(int n) { return kForcesDofsAt + 4 + 9 * 8 * static_cast<std::size_t>(n) + 4; }

TEST(Wire, ATelemetryPassesAndEveryTruncationOrExtraByteIsCaught) {
  const auto buf = Encode(ValidTelemetry());
  ASSERT_EQ(CheckTelemetryPacket(buf.data(), buf.size()), WireCheck::kOk);
  telemetry_t out;
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  for (std::size_t len = 0; len < buf.size(); ++len) {
    EXPECT_NE(CheckTelemetryPacket(buf.data(), len), WireCheck::kOk) << len;
  }
  auto longer = buf;
  longer.push_back(0);
  EXPECT_EQ(CheckTelemetryPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  const auto forces = Encode(ValidForces(2));
  EXPECT_EQ(CheckTelemetryPacket(forces.data(), forces.size()), WireCheck::kFingerprint);
}

pose_setpoint_t ValidPose() {
  pose_setpoint_t m{};
  m.utime = 1;
  m.frame = "panda_hand_tcp";
  m.orientation[0] = 1.0;
  m.duration = 2.0;
  return m;
}
task_state_t ValidTaskState() {
  task_state_t m{};
  m.run_id = 7;
  m.frame = "tool0";
  m.controller = "operational-space";
  m.orientation[0] = m.orientation_des[0] = 1.0;
  return m;
}

// A floating base's state (fixed size): its type and run, every truncation and an extra byte caught.
TEST(Wire, BaseStatesPassAndEveryTruncationOrExtraByteIsCaught) {
  base_state_t m{};
  m.run_id = 9;
  m.orientation[3] = 1.0;
  const auto base = Encode(m);
  ASSERT_EQ(CheckBaseStatePacket(base.data(), base.size()), WireCheck::kOk);
  EXPECT_EQ(TypeOf(base.data(), base.size()), MessageType::kBaseState);
  EXPECT_STREQ(ToString(MessageType::kBaseState), "base_state_t");
  EXPECT_EQ(RunIdOf(base.data(), base.size()), std::optional<std::int64_t>(9));
  for (std::size_t len = 0; len < base.size(); ++len) EXPECT_NE(CheckBaseStatePacket(base.data(), len), WireCheck::kOk);
  auto longer = base;
  longer.push_back(0);
  EXPECT_EQ(CheckBaseStatePacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  const auto task = Encode(ValidTaskState());
  EXPECT_EQ(CheckBaseStatePacket(task.data(), task.size()), WireCheck::kFingerprint);
}

TEST(Wire, PoseSetpointsAndTaskStatesPassAndEveryTruncationOrExtraByteIsCaught) {
  const auto pose = Encode(ValidPose());
  const auto task = Encode(ValidTaskState());
  ASSERT_EQ(CheckPoseSetpointPacket(pose.data(), pose.size()), WireCheck::kOk);
  ASSERT_EQ(CheckTaskStatePacket(task.data(), task.size()), WireCheck::kOk);
  EXPECT_EQ(TypeOf(pose.data(), pose.size()), MessageType::kPoseSetpoint);
  EXPECT_EQ(TypeOf(task.data(), task.size()), MessageType::kTaskState);
  EXPECT_EQ(RunIdOf(task.data(), task.size()), std::optional<std::int64_t>(7));
  EXPECT_EQ(RunIdOf(pose.data(), pose.size()), std::nullopt);  // a client's message carries no run
  for (std::size_t len = 0; len < pose.size(); ++len) EXPECT_NE(CheckPoseSetpointPacket(pose.data(), len), WireCheck::kOk);
  for (std::size_t len = 0; len < task.size(); ++len) EXPECT_NE(CheckTaskStatePacket(task.data(), len), WireCheck::kOk);
  auto longer = pose;
  longer.push_back(0);
  EXPECT_EQ(CheckPoseSetpointPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  EXPECT_EQ(CheckPoseSetpointPacket(task.data(), task.size()), WireCheck::kFingerprint);
  // A frame name of a crafted length: refused before decoding.
  for (const std::int32_t length : {0x7fffffff, -1, 0, 257}) {
    auto buf = pose;
    WriteInt32(buf, 16, length);  // after the fingerprint and utime
    EXPECT_EQ(CheckPoseSetpointPacket(buf.data(), buf.size()), WireCheck::kBadLength) << length;
  }
}

TEST(Wire, ATelemetryWithACraftedOrOversizedStringIsRefused) {
  for (const std::int32_t length : {0x7fffffff, -1, 0, 257}) {
    auto buf = Encode(ValidTelemetry());
    WriteInt32(buf, kTelemetryStringAt, length);
    EXPECT_EQ(CheckTelemetryPacket(buf.data(), buf.size()), WireCheck::kBadLength) << length;
  }
  telemetry_t m = ValidTelemetry();
  m.method.assign(256, 'x');  // 257 bytes with its NUL
  const auto over = Encode(m);
  EXPECT_EQ(CheckTelemetryPacket(over.data(), over.size()), WireCheck::kBadLength);
}

TEST(Wire, ForcesPassForEverySizeUpToTheBoundAndEveryTruncationIsCaught) {
  for (int n : {0, 1, 2, kMaxDofs}) {
    for (int contacts : {0, 1, kMaxContacts}) {
      const auto buf = Encode(ValidForces(n, contacts));
      ASSERT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kOk) << n << " " << contacts;
      forces_t out;
      EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
      EXPECT_EQ(out.num_dofs, n);
      EXPECT_EQ(out.num_contacts, contacts);
    }
  }
  const auto buf = Encode(ValidForces(2, 2));
  for (std::size_t len = 0; len < buf.size(); ++len) {
    EXPECT_NE(CheckForcesPacket(buf.data(), len), WireCheck::kOk) << len;
  }
  auto longer = buf;
  longer.push_back(0);
  EXPECT_EQ(CheckForcesPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
}

TEST(Wire, ForcesOverKMaxDofsOrNegativeOrMiscountedAreRefused) {
  const auto over = Encode(ValidForces(kMaxDofs + 1));  // really that long
  EXPECT_EQ(CheckForcesPacket(over.data(), over.size()), WireCheck::kBadLength);
  auto buf = Encode(ValidForces(2));
  WriteInt32(buf, kForcesDofsAt, -1);
  EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  WriteInt32(buf, kForcesDofsAt, 0x7fffffff);
  EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  WriteInt32(buf, kForcesDofsAt, 3);  // plausible, but the packet holds 2
  EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kTooShort);
  WriteInt32(buf, kForcesDofsAt, 1);
  EXPECT_NE(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kOk);
}

// The contacts' count is bounded (kMaxContacts) and must match the packet,
// before anything is decoded.
TEST(Wire, ForcesWithMoreContactsThanTheBoundOrAMiscountAreRefused) {
  const auto over = Encode(ValidForces(2, kMaxContacts + 1));  // really that many
  EXPECT_EQ(CheckForcesPacket(over.data(), over.size()), WireCheck::kBadLength);
  auto buf = Encode(ValidForces(2, 2));
  for (const std::int32_t count : {-1, 0x7fffffff, kMaxContacts + 1}) {
    WriteInt32(buf, ForcesContactsAt(2), count);
    EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kBadLength) << count;
  }
  WriteInt32(buf, ForcesContactsAt(2), 3);  // plausible, but the packet holds 2
  EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kTooShort);
  WriteInt32(buf, ForcesContactsAt(2), 1);
  EXPECT_EQ(CheckForcesPacket(buf.data(), buf.size()), WireCheck::kSizeMismatch);
}

// An earlier lagrange's forces_t (no constraint row, no contacts: its own
// fingerprint) is another type live, and its own layout's check takes it.
TEST(Wire, AnEarlierForcesLayoutIsToldApartByItsFingerprint) {
  std::vector<std::uint8_t> v1(8 + 3 * 8 + 8 + 7 + 4 + 8 * 8 * 2, 0);
  WriteInt64(v1, 0, static_cast<std::uint64_t>(kForcesV1Fingerprint));
  WriteInt32(v1, 8 + 3 * 8 + 8 + 7, 2);
  EXPECT_EQ(CheckForcesV1Packet(v1.data(), v1.size()), WireCheck::kOk);
  EXPECT_EQ(CheckForcesPacket(v1.data(), v1.size()), WireCheck::kFingerprint);
  EXPECT_EQ(TypeOf(v1.data(), v1.size()), MessageType::kUnknown);
  for (std::size_t len = 0; len < v1.size(); ++len) EXPECT_NE(CheckForcesV1Packet(v1.data(), len), WireCheck::kOk);
  const auto now = Encode(ValidForces(2));
  EXPECT_EQ(CheckForcesV1Packet(now.data(), now.size()), WireCheck::kFingerprint);
  EXPECT_NE(forces_t::getHash(), kForcesV1Fingerprint);
}

// ------------------------------------------------------------------ status_t with the switch fields

status_t StatusWithSwitchFields() {
  status_t s{};
  s.run_id = 0x9abc;
  s.num_instances = 2;
  s.instance_names = {"arm", "cartpole"};
  s.instance_modes = {0, 1};
  s.instance_dofs = {2, 2};
  s.instance_reasons = {"", "setpoints timed out"};
  s.instance_integrators = {"rk4 x4", "dopri5 rtol=1e-08 atol=1e-10 max_steps=200"};
  s.instance_methods = {"closed-form", "recursive"};
  s.instance_effects = {"gravity,coriolis", ""};
  s.instance_forces = {true, false};
  s.num_joints = 4;
  s.joint_names = {"q1", "q2", "x", "theta"};
  return s;
}

TEST(Wire, AStatusWithTheSwitchFieldsPassesAndEveryTruncationIsCaught) {
  const auto buf = Encode(StatusWithSwitchFields());
  ASSERT_EQ(CheckStatusPacket(buf.data(), buf.size()), WireCheck::kOk);
  status_t out;
  ASSERT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(out.instance_integrators[1], "dopri5 rtol=1e-08 atol=1e-10 max_steps=200");
  EXPECT_EQ(out.instance_forces, (std::vector<std::int8_t>{1, 0}));
  for (std::size_t len = 0; len < buf.size(); ++len) {
    EXPECT_NE(CheckStatusPacket(buf.data(), len), WireCheck::kOk) << len;
  }
  auto longer = buf;
  longer.push_back(0);
  EXPECT_EQ(CheckStatusPacket(longer.data(), longer.size()), WireCheck::kSizeMismatch);
}

TEST(Wire, AStatusWhoseSwitchStringsExceedTheBoundIsRefused) {
  for (auto field : {&status_t::instance_integrators, &status_t::instance_methods, &status_t::instance_effects}) {
    status_t s = StatusWithSwitchFields();
    (s.*field)[1].assign(256, 'x');
    const auto buf = Encode(s);
    EXPECT_EQ(CheckStatusPacket(buf.data(), buf.size()), WireCheck::kBadLength);
  }
}

// What lagrangectl (a client) decodes from the bus or a log passes these checks first.
TEST(Wire, WhatAClientDecodesIsAcceptedAndTruncationsAndLyingLengthsAreRefused) {
  status_t status = StatusWithSwitchFields();
  status.last_rejection = "why";
  status.last_command_error = "";
  reply_t reply{};
  reply.reason = "not paused";
  const std::vector<std::pair<std::vector<std::uint8_t>, WireCheck (*)(const void*, std::size_t)>> packets = {
      {Encode(MakeState()), CheckStatePacket},
      {Encode(status), CheckStatusPacket},
      {Encode(reply), CheckReplyPacket},
      {Encode(ValidTelemetry()), CheckTelemetryPacket},
      {Encode(ValidForces(2)), CheckForcesPacket}};
  for (const auto& [bytes, check] : packets) {
    EXPECT_EQ(check(bytes.data(), bytes.size()), WireCheck::kOk);
    for (std::size_t size = 0; size < bytes.size(); ++size)
      ASSERT_NE(check(bytes.data(), size), WireCheck::kOk) << size;
    std::vector<std::uint8_t> longer = bytes;
    longer.push_back(0);
    EXPECT_EQ(check(longer.data(), longer.size()), WireCheck::kSizeMismatch);
  }
  EXPECT_EQ(CheckStatePacket(packets[1].first.data(), packets[1].first.size()), WireCheck::kFingerprint);

  // A state declaring 2^31 - 1 joints, a negative string length, a status declaring 2^31 - 1 instances.
  std::vector<std::uint8_t> state = Encode(MakeState());
  const std::size_t num_dofs_at = 8 + 4 * 8;
  WriteInt32(state, num_dofs_at, 0x7fffffff);
  EXPECT_EQ(CheckStatePacket(state.data(), state.size()), WireCheck::kBadLength);
  state = Encode(MakeState());
  WriteInt32(state, state.size() - 1 - 3 - 4, -5);  // the controller's length ("pd" + NUL, then mode)
  EXPECT_EQ(CheckStatePacket(state.data(), state.size()), WireCheck::kBadLength);
  // num_instances follows the fixed fields (156 bytes with the fingerprint), last_rejection "why" (4 + 4),
  // the two command counts (16), last_command_error "" (4 + 1) and seven counters (56).
  const std::size_t names_at = 156 + 8 + 16 + 5 + 56;
  std::vector<std::uint8_t> lying = Encode(status);
  WriteInt32(lying, names_at, 0x7fffffff);
  EXPECT_EQ(CheckStatusPacket(lying.data(), lying.size()), WireCheck::kBadLength);
  lying = Encode(status);  // a status declaring 2^31 - 1 joint names (the tail: num_joints, then the names)
  const std::size_t joint_names = (4 + 3) + (4 + 3) + (4 + 2) + (4 + 6);
  WriteInt32(lying, lying.size() - joint_names - 4, 0x7fffffff);
  EXPECT_EQ(CheckStatusPacket(lying.data(), lying.size()), WireCheck::kBadLength);
  // Forces declaring 2^31 - 1 joints (num_dofs after utime, run_id, tick, t and the seven flags).
  lying = Encode(ValidForces(2));
  WriteInt32(lying, 8 + 4 * 8 + 7, 0x7fffffff);
  EXPECT_EQ(CheckForcesPacket(lying.data(), lying.size()), WireCheck::kBadLength);
}

TEST(Wire, TheRunIdOfATelemetryOrForcesIsReadAndACommandHasNone) {
  const auto telemetry = Encode(ValidTelemetry());
  EXPECT_EQ(RunIdOf(telemetry.data(), telemetry.size()), std::optional<std::int64_t>(0x1234));
  const auto forces = Encode(ValidForces(2));
  EXPECT_EQ(RunIdOf(forces.data(), forces.size()), std::optional<std::int64_t>(0x5678));
  const auto command = Encode(FullCommand());
  EXPECT_EQ(RunIdOf(command.data(), command.size()), std::nullopt);
  EXPECT_EQ(RunIdOf(telemetry.data(), 8 + 8 + 7), std::nullopt);  // too short to hold it
}

}  // namespace
}  // namespace lagrange
