// A command from the wire to a verdict (protocol/command_check.hpp): what
// does not change while the daemon runs is decided here (the command code,
// controller names, gain sizes and bounds, integrator, effect and method
// names and the integrator's numbers); each refusal names what was expected
// and escapes what the bus sent.

#include "protocol/command_check.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using Kind = CommandVerdict::Kind;

CommandRules ArmRules() {
  CommandRules rules;
  rules.instance = "arm";
  rules.n = 2;
  rules.controllers = {"pd", "computed-torque"};
  rules.gain_counts = {2, 2};
  rules.gains_per_task_axis = {false, false};
  rules.integrator.max_steps = 200;  // the scene's
  return rules;
}

CommandVerdict Check(const command_t& c, int active = 0) {
  const std::vector<std::uint8_t> bytes = testing::Encode(c);
  command_t out;
  return CheckCommand(bytes.data(), bytes.size(), ArmRules(), active, out);
}

command_t Setting(int8_t kind, const std::string& setting) {
  command_t c = testing::MakeCommand(kind, 1, 1);
  c.setting = setting;
  return c;
}

TEST(CommandCheck, ASwitchToAConfiguredControllerIsAcceptedWithItsIndex) {
  const CommandVerdict v = Check(testing::MakeCommand(command_t::SWITCH_CONTROLLER, 1, 1, "computed-torque"));
  EXPECT_EQ(v.kind, Kind::kAccepted) << v.reason;
  EXPECT_EQ(v.command, CommandKind::kSwitchController);
  EXPECT_EQ(v.controller, 1);
}

TEST(CommandCheck, AnUnknownControllerIsRejectedEscapedWithTheOnesThereAre) {
  const CommandVerdict v = Check(testing::MakeCommand(command_t::SWITCH_CONTROLLER, 1, 1, "x\x1b[2J"));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "unknown controller 'x\\x1b[2J' for arm (available: pd, computed-torque)");
}

TEST(CommandCheck, GainsWithoutANameAreForTheActiveControllerAndMustBeOnePerJoint) {
  CommandVerdict v = Check(testing::MakeCommand(command_t::SET_GAINS, 1, 1, "", {10.0, 20.0}, {1.0, 2.0}), 1);
  EXPECT_EQ(v.kind, Kind::kAccepted) << v.reason;
  EXPECT_EQ(v.controller, 1);
  v = Check(testing::MakeCommand(command_t::SET_GAINS, 1, 1, "pd", {1.0, 2.0, 3.0}, {1.0, 2.0, 3.0}));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "gains: num_gains is 3, expected 2");
}

// The bounds are the instance model's: the rules' check_gains (the simulator's CheckGains) decides, once the count
// is right, on the gains the command carried, and its reason is the refusal's, naming the controller.
TEST(CommandCheck, GainsOfTheRightCountGoToTheRulesBoundsCheck) {
  CommandRules rules = ArmRules();
  std::vector<std::size_t> asked;
  rules.check_gains = [&](std::size_t c, std::span<const double> kp,
                          std::span<const double> kd) -> std::optional<std::string> {
    asked.push_back(c);
    if (kp.size() != 2 || kd.size() != 2) return "wrong sizes";
    if (kp[1] > 100.0) return "kp[1]: expected |gain| <= 100, got " + std::to_string(static_cast<int>(kp[1]));
    return std::nullopt;
  };
  const auto check = [&](const command_t& c) {
    const std::vector<std::uint8_t> bytes = testing::Encode(c);
    command_t out;
    return CheckCommand(bytes.data(), bytes.size(), rules, 0, out);
  };
  CommandVerdict v =
      check(testing::MakeCommand(command_t::SET_GAINS, 1, 1, "computed-torque", {1.0, 200.0}, {1.0, 2.0}));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "gains for computed-torque: kp[1]: expected |gain| <= 100, got 200");
  v = check(testing::MakeCommand(command_t::SET_GAINS, 1, 1, "pd", {1.0, 50.0}, {1.0, 2.0}));
  EXPECT_EQ(v.kind, Kind::kAccepted) << v.reason;
  // A wrong count is refused before the bounds are asked.
  v = check(testing::MakeCommand(command_t::SET_GAINS, 1, 1, "pd", {1.0}, {1.0}));
  EXPECT_EQ(v.reason, "gains: num_gains is 1, expected 2");
  EXPECT_EQ(asked, (std::vector<std::size_t>{1, 0}));
}

TEST(CommandCheck, AnUnknownCommandCodeIsRejected) {
  const CommandVerdict v = Check(testing::MakeCommand(99, 1, 1));
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason, "unknown command 99");
}

TEST(CommandCheck, AnIntegratorsZerosAreItsDefaultsAndTheScenesMaxSteps) {
  const CommandVerdict v = Check(Setting(command_t::SET_INTEGRATOR, "dopri5"));
  ASSERT_EQ(v.kind, Kind::kAccepted) << v.reason;
  const IntegratorConfig defaults;
  EXPECT_EQ(v.integrator.type, IntegratorType::kDormandPrince);
  EXPECT_EQ(v.integrator.substeps, defaults.substeps);
  EXPECT_EQ(v.integrator.rtol, defaults.rtol);
  EXPECT_EQ(v.integrator.atol, defaults.atol);
  EXPECT_EQ(v.integrator.max_steps, 200);
  EXPECT_TRUE(v.default_max_steps);
}

TEST(CommandCheck, BadSettingsAreRejectedNamingWhatWasExpected) {
  command_t too_many = Setting(command_t::SET_INTEGRATOR, "rk4");
  too_many.substeps = 1001;
  CommandVerdict v = Check(too_many);
  EXPECT_EQ(v.kind, Kind::kRejected);
  EXPECT_EQ(v.reason.rfind("integrator: ", 0), 0u) << v.reason;
  v = Check(Setting(command_t::SET_INTEGRATOR, "euler\n"));
  EXPECT_EQ(v.reason, "unknown integrator 'euler\\n' (expected " + IntegratorTypeNames() + ")");
  v = Check(Setting(command_t::SET_EFFECT, "magic"));
  EXPECT_EQ(v.reason, "unknown effect 'magic' (expected " + EffectKindNames() + ")");
  v = Check(Setting(command_t::SET_METHOD, "guess"));
  EXPECT_EQ(v.reason, "unknown method 'guess' (expected " + MethodNames() + ")");
}

TEST(CommandCheck, AnEffectAndAMethodAreParsed) {
  command_t on = Setting(command_t::SET_EFFECT, "friction");
  on.on = true;
  CommandVerdict v = Check(on);
  ASSERT_EQ(v.kind, Kind::kAccepted) << v.reason;
  EXPECT_EQ(v.effect, EffectKind::kFriction);
  EXPECT_TRUE(v.on);
  v = Check(Setting(command_t::SET_METHOD, "recursive"));
  ASSERT_EQ(v.kind, Kind::kAccepted) << v.reason;
  EXPECT_EQ(v.method, Method::kRecursive);
}

}  // namespace
}  // namespace lagrange
