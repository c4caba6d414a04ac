// The command session (protocol/command_session.hpp): what lagrangectl
// command and Python's Client.command both report, from the one place that
// words it. Over an in-process bus, where the test is the daemon: its reply
// decides the verdict, and the report is worded the same whether a client
// prints it (lines, then the failure) or returns it (Text).

#include "protocol/command_session.hpp"

#include <gtest/gtest.h>
#include <lagrange/command_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>

#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

constexpr std::int64_t kRun = 0x1111;
constexpr std::int64_t kOtherRun = 0x2222;

reply_t Reply(std::int64_t run_id, const std::string& reason) {
  reply_t r{};
  r.run_id = run_id;
  r.accepted = reason.empty();
  r.reason = reason;
  return r;
}

LinkOptions InProcess() {
  LinkOptions o;
  o.lcm_url = "inprocess://";
  o.wait = 0.5;
  return o;
}

TEST(CommandSession, GainsAreOnePerJointOrOnePerTaskAxisUnderATaskSpaceController) {
  state_t s = testing::MakeState(1, kRun);
  s.num_dofs = 7;
  s.controller = "pd";
  EXPECT_FALSE(GainsPerTaskAxis(s));
  EXPECT_EQ(GainCount(s), 7);
  for (const char* task : {"cartesian-impedance", "operational-space"}) {
    s.controller = task;
    EXPECT_TRUE(GainsPerTaskAxis(s)) << task;
    EXPECT_EQ(GainCount(s), 6) << task;
  }
  s.controller = "no such controller\n";  // a name off the bus that names no type: one per joint
  EXPECT_EQ(GainCount(s), 7);
}

TEST(CommandSession, ADoneCommandIsOneLineNamingItsWordsAndTheModeAfter) {
  const CommandReport r =
      ReportCommand("arm", CommandWordsText({"controller", "gc\x1b[2J"}), Reply(kRun, ""), "running with gc");
  EXPECT_TRUE(r.accepted);
  EXPECT_EQ(r.run_id, kRun);
  EXPECT_EQ(r.lines, (std::vector<std::string>{"arm: controller gc\\x1b[2J done; now running with gc"}));
  EXPECT_EQ(r.failure, "");
  EXPECT_EQ(r.Text(), "arm: controller gc\\x1b[2J done; now running with gc");
}

TEST(CommandSession, ARefusalShowsTheWholeReasonEscaped) {
  // A gain refusal names every bound: longer than Escape's default 200 bytes, and shown whole.
  const std::string reason = "gains for pd: kp[0] = 1e9 above " + std::string(300, 'b') + "\nforged line";
  const CommandReport r = ReportCommand("arm", "gains", Reply(kRun, reason), "");
  EXPECT_FALSE(r.accepted);
  EXPECT_TRUE(r.lines.empty());
  EXPECT_EQ(r.failure, "refused: gains for pd: kp[0] = 1e9 above " + std::string(300, 'b') + "\\nforged line");
  EXPECT_EQ(r.Text(), r.failure);
  // A reason longer than kMaxReasonShown is cut there.
  const CommandReport cut = ReportCommand("arm", "gains", Reply(kRun, std::string(4000, 'x')), "");
  EXPECT_EQ(cut.failure, "refused: " + std::string(kMaxReasonShown, 'x') + "...");
}

TEST(CommandSession, OneRunsEstopIsWordedAsEveryOtherCommand) {
  const std::string channel = "ARM_STATE";
  const CommandReport done = ReportEstop("arm", channel, 3.0, {{kRun, Reply(kRun, ""), "", "estop with pd"}});
  EXPECT_TRUE(done.accepted);
  EXPECT_EQ(done.run_id, kRun);
  EXPECT_EQ(done.Text(), "arm: estop done; now estop with pd");

  const CommandReport refused = ReportEstop("arm", channel, 3.0, {{kRun, Reply(kRun, "busy\n"), "", ""}});
  EXPECT_FALSE(refused.accepted);
  EXPECT_TRUE(refused.lines.empty());
  EXPECT_EQ(refused.failure, "refused: busy\\n");

  const CommandReport left =
      ReportEstop("arm", channel, 3.0, {{kRun, Reply(kRun, ""), "the estop did not stay: hold with pd", ""}});
  EXPECT_FALSE(left.accepted);
  EXPECT_EQ(left.failure, "estop applied, but the estop did not stay: hold with pd");

  try {
    ReportEstop("arm", channel, 2.5, {{kRun, std::nullopt, "", ""}});
    FAIL() << "no verdict from the one run is an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "no verdict from lagranged (run 0000000000001111) within 2.5 s");
  }
}

TEST(CommandSession, AnEstopToSeveralRunsIsALinePerRunThenHowManyAppliedIt) {
  const std::vector<EstopRun> runs = {{kRun, Reply(kRun, ""), "", "estop with pd"},
                                      {kOtherRun, std::nullopt, "", ""},
                                      {0x3333, Reply(0x3333, "busy"), "", ""},
                                      {0x4444, Reply(0x4444, ""), "the estop did not stay: hold with pd", ""}};
  const CommandReport r = ReportEstop("arm", "ARM_STATE", 3.0, runs);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.run_id, 0);
  EXPECT_EQ(r.lines, (std::vector<std::string>{
                         "arm: run 0000000000001111: estop done; now estop with pd",
                         "arm: run 0000000000002222: estop no verdict within 3 s",
                         "arm: run 0000000000003333: estop refused: busy",
                         "arm: run 0000000000004444: estop applied, but the estop did not stay: hold with pd",
                     }));
  EXPECT_EQ(r.failure,
            "estop applied by 1 of the 4 runs publishing ARM_STATE (ids 0000000000001111, 0000000000002222, "
            "0000000000003333, 0000000000004444)");
  EXPECT_EQ(r.Text(), r.lines[0] + "\n" + r.lines[1] + "\n" + r.lines[2] + "\n" + r.lines[3] + "\n" + r.failure);

  const CommandReport all =
      ReportEstop("arm", "ARM_STATE", 3.0, {runs[0], {kOtherRun, Reply(kOtherRun, ""), "", "estop with gc"}});
  EXPECT_TRUE(all.accepted);
  EXPECT_EQ(all.failure, "");
  EXPECT_EQ(all.lines.size(), 2u);
}

// The session over a link: the test answers the command as lagranged would, and the report is its verdict.
TEST(CommandSession, ACommandOverTheLinkIsReportedFromTheRunsReplyToItsOwnRequest) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", testing::MakeState(1, kRun));
  link.AwaitOneRun();
  std::string answer = "unknown controller 'fly' for arm (available: pd, gc)";
  link.bus().Subscribe("ARM_COMMAND", [&](std::string_view, const std::uint8_t* data, std::size_t size) {
    command_t c;
    ASSERT_GE(c.decode(data, 0, static_cast<int>(size)), 0);
    reply_t r = Reply(kRun, answer);
    r.request_id = c.request_id;
    link.bus().PublishMessage("ARM_REPLY", r);
    link.bus().PublishMessage("ARM_STATE", testing::MakeState(2, kRun));
  });
  command_t c = testing::MakeCommand(command_t::SWITCH_CONTROLLER, 0, 0);
  c.controller = "fly";
  const CommandReport refused = RunCommand(link, "arm", CommandWordsText({"controller", "fly"}), c);
  EXPECT_FALSE(refused.accepted);
  EXPECT_EQ(refused.failure, "refused: unknown controller 'fly' for arm (available: pd, gc)");

  answer = "";
  c.controller = "gc";
  const CommandReport done = RunCommand(link, "arm", CommandWordsText({"controller", "gc"}), c);
  EXPECT_TRUE(done.accepted);
  EXPECT_EQ(done.run_id, kRun);
  EXPECT_EQ(done.Text(), "arm: controller gc done; now running with pd");
}

}  // namespace
}  // namespace lagrange
