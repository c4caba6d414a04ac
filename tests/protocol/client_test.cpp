// The client's link to one lagranged run (protocol/client.hpp) over an
// in-process bus, where every message is one the test put there: it acts on
// one run only, names every run it saw when there are several, ignores what
// fails its wire check, and takes a reply only from that run for its own
// request; LinkOptions names the channels and refuses a malformed URL.

#include "protocol/client.hpp"

#include <gtest/gtest.h>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocol/channels.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

constexpr std::int64_t kRun = 0x1111;
constexpr std::int64_t kOtherRun = 0x2222;

LinkOptions InProcess(double wait = 0.05) {
  LinkOptions o;
  o.lcm_url = "inprocess://";
  o.wait = wait;
  return o;
}

state_t State(std::int64_t run_id, std::int64_t tick = 1) { return testing::MakeState(tick, run_id); }

reply_t Reply(std::int64_t run_id, std::int64_t request_id, const std::string& reason) {
  reply_t r{};
  r.run_id = run_id;
  r.request_id = request_id;
  r.accepted = reason.empty();
  r.reason = reason;
  return r;
}

status_t Status(std::int64_t run_id) {
  status_t s{};
  s.run_id = run_id;
  return s;
}

TEST(LinkOptions, NamesTheDaemonsChannelsUnderItsPrefix) {
  LinkOptions o = InProcess();
  o.channel_prefix = "LEFT_";
  EXPECT_EQ(o.Channel("arm", kStateSuffix), "LEFT_ARM_STATE");
  EXPECT_EQ(o.StatusChannel(), "LEFT_LAGRANGE_STATUS");
  EXPECT_EQ(o.Url(), "inprocess://");
}

TEST(LinkOptions, AMalformedUrlIsABusUrlErrorNamingWhatIsWrong) {
  for (const char* url : {"tcpq://127.0.0.1:7667", "udpm://239.255.76.67", "udpm://239.255.76.67:7667?ttl=300"}) {
    LinkOptions o;
    o.lcm_url = url;
    try {
      o.Open();
      FAIL() << url;
    } catch (const BusUrlError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string("LCM URL '") + url + "': ", 0), 0u) << e.what();
    }
  }
}

TEST(DaemonLink, TheOneRunPublishingTheInstanceIsTheOneItActsOn) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun, 1));
  link.bus().PublishMessage("CARTPOLE_STATE", State(kOtherRun));  // another instance's: not this link's business
  link.bus().PublishMessage("ARM_STATE", State(kRun, 2));
  EXPECT_EQ(link.AwaitOneRun(), kRun);
  EXPECT_EQ(link.state().tick, 2);
  EXPECT_EQ(link.states_received(), 2);
}

TEST(DaemonLink, TwoRunsOnOneInstanceAreNamedAndRefused) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun));
  link.bus().PublishMessage("ARM_STATE", State(kOtherRun));
  try {
    link.AwaitOneRun();
    FAIL() << "acted with two runs on the bus";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "two lagranged runs publish ARM_STATE (ids 0000000000001111 and 0000000000002222): refusing to act");
  }
}

TEST(DaemonLink, NoStateWithinTheWaitIsOneLineNamingTheChannelAndTheBus) {
  DaemonLink link(InProcess(0.05), "arm");
  std::vector<std::uint8_t> cut(64, 0);  // not a state: fails the wire check, so no run
  link.bus().Publish("ARM_STATE", cut.data(), cut.size());
  try {
    link.AwaitOneRun();
    FAIL() << "found a run in a packet that is not a state";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "no state from instance 'arm' on ARM_STATE within 0.05 s on inprocess://; heard ARM_STATE, but no "
              "valid state_t on it (not a lagranged?)");
  }
}

// The error of a wait in vain for `instance` under `prefix`, after `publish` put messages on the bus.
template <class Publish>
std::string TimeoutError(const std::string& prefix, const std::string& instance, Publish publish) {
  LinkOptions options = InProcess(0.05);
  options.channel_prefix = prefix;
  DaemonLink link(options, instance);
  publish(link.bus());
  try {
    link.AwaitOneRun();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "found a run";
}

TEST(DaemonLink, AWaitInVainWithNothingOnTheBusSaysNoDaemonWasHeard) {
  EXPECT_EQ(TimeoutError("", "arm", [](Bus&) {}),
            "no state from instance 'arm' on ARM_STATE within 0.05 s on inprocess://; heard no lagranged there (is "
            "one running, on this LCM URL?)");
}

TEST(DaemonLink, AForgottenChannelPrefixIsNamed) {
  const std::string error = TimeoutError("", "arm", [](Bus& bus) {
    bus.PublishMessage("SIM_LAGRANGE_STATUS", Status(kRun));
    bus.PublishMessage("SIM_ARM_STATE", State(kRun));
    bus.PublishMessage("SIM_CARTPOLE_STATE", State(kRun));
  });
  EXPECT_EQ(error,
            "no state from instance 'arm' on ARM_STATE within 0.05 s on inprocess://; a lagranged publishes "
            "SIM_ARM_STATE: --channel-prefix SIM_?");
}

TEST(DaemonLink, APrefixTheDaemonDoesNotUseIsNamed) {
  const std::string error = TimeoutError("SIM_", "arm", [](Bus& bus) {
    bus.PublishMessage("LAGRANGE_STATUS", Status(kRun));
    bus.PublishMessage("ARM_STATE", State(kRun));
  });
  EXPECT_EQ(error,
            "no state from instance 'arm' on SIM_ARM_STATE within 0.05 s on inprocess://; a lagranged publishes "
            "ARM_STATE: without --channel-prefix?");
}

TEST(DaemonLink, AMistypedInstanceGetsTheNearestNameHeard) {
  const std::string error = TimeoutError("", "amr", [](Bus& bus) {
    bus.PublishMessage("LAGRANGE_STATUS", Status(kRun));
    bus.PublishMessage("CARTPOLE_STATE", State(kRun));
    bus.PublishMessage("ARM_STATE", State(kRun));
  });
  EXPECT_EQ(error,
            "no state from instance 'amr' on AMR_STATE within 0.05 s on inprocess://; state channels heard: "
            "ARM_STATE, CARTPOLE_STATE; did you mean 'arm'?");
}

TEST(DaemonLink, ChannelNamesHeardAreEscapedAndBounded) {
  const std::string error = TimeoutError("", "arm", [](Bus& bus) {
    for (int k = 0; k < 100; ++k) bus.PublishMessage("X" + std::to_string(k) + "\x1b[2J_STATE", State(kRun));
  });
  EXPECT_EQ(error.find('\x1b'), std::string::npos) << error;
  EXPECT_NE(error.find("\\x1b[2J_STATE"), std::string::npos) << error;
  std::size_t listed = 0;
  for (std::size_t at = error.find("_STATE"); at != std::string::npos; at = error.find("_STATE", at + 1)) ++listed;
  EXPECT_LE(listed, kMaxHeardChannels + 1) << error;  // + the channel waited on
}

TEST(HeardHint, SuggestsOnlyAPrefixAStatusConfirms) {
  // FARM_STATE ends in ARM_STATE, but no daemon runs with prefix F.
  EXPECT_EQ(HeardHint("", "arm", {"LAGRANGE_STATUS", "FARM_STATE"}),
            "state channels heard: FARM_STATE; did you mean 'farm'?");
}

// The README's two-daemon loop: arm_controller under CTRL_, the plant's arm without a prefix.
TEST(HeardHint, UnderAPrefixADaemonUsesTheNearestInstanceThereComesFirst) {
  EXPECT_EQ(
      HeardHint("CTRL_", "arm", {"LAGRANGE_STATUS", "CTRL_LAGRANGE_STATUS", "ARM_STATE", "CTRL_ARM_CONTROLLER_STATE"}),
      "state channels heard: ARM_STATE, CTRL_ARM_CONTROLLER_STATE; did you mean 'arm_controller'? (or a "
      "lagranged publishes ARM_STATE: without --channel-prefix?)");
}

TEST(SigningHint, EachReasonHeardIsAClauseAndNoneIsNothing) {
  EXPECT_EQ(SigningHint({}), "");
  EXPECT_EQ(SigningHint({.other_key = 1, .domain = {}}),
            "heard 1 message signed with another key or for another bus domain (their tags do not verify with this "
            "client's): give the daemon's key (--bus-key FILE or LAGRANGE_BUS_KEY_FILE), and its --bus-domain if it "
            "has one (or LAGRANGE_BUS_DOMAIN)");
  // With a key the client names its own domain; the format before domains is named apart.
  EXPECT_EQ(SigningHint({.other_key = 2, .old_format = 1, .domain = "udpm://239.255.76.67:8550"}),
            "heard 2 messages signed with another key or for another bus domain (this client's is "
            "udpm://239.255.76.67:8550; their tags do not verify with this client's): give the daemon's key "
            "(--bus-key FILE or LAGRANGE_BUS_KEY_FILE), and its --bus-domain if it has one (or LAGRANGE_BUS_DOMAIN); "
            "heard 1 signed message in lagrange's old format (LGS1, before bus domains), refused: update that "
            "lagranged");
  EXPECT_EQ(SigningHint({.unsigned_refused = 5, .out_of_window = 2, .domain = {}}),
            "heard 5 unsigned messages, which a client with a key refuses: the daemon runs without one (give it "
            "--bus-key FILE too, or run this client without a key); heard 2 signed messages stamped more than 2 s "
            "from this host's clock, or replayed: keep the hosts' clocks in step (chrony or NTP)");
  // What was heard for its signature explains the silence before any channel name does.
  EXPECT_EQ(WhatWasHeard({.signed_unreadable = 3, .domain = {}}, "", "arm", {"ARM_STATE"}),
            "heard 3 signed messages, which a client without a key cannot check: its states are signed; give the "
            "daemon's key (--bus-key FILE or LAGRANGE_BUS_KEY_FILE)");
  EXPECT_EQ(WhatWasHeard({}, "", "arm", {}), HeardHint("", "arm", {}));
}

TEST(DaemonLink, OnlyTheRunsReplyToItsOwnRequestCounts) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun));
  link.AwaitOneRun();
  link.ExpectReply(42);
  link.bus().PublishMessage("ARM_REPLY", Reply(kOtherRun, 42, "a spoofer's"));
  link.bus().PublishMessage("ARM_REPLY", Reply(kRun, 41, "someone else's request"));
  link.bus().PublishMessage("ARM_REPLY", Reply(kRun, 42, ""));
  link.bus().PublishMessage("ARM_REPLY", Reply(kRun, 42, "a second answer"));
  EXPECT_TRUE(link.PumpUntil([&] { return link.reply().has_value(); }, 1.0));
  link.Pump(0.01);
  ASSERT_TRUE(link.reply());
  EXPECT_TRUE(link.reply()->accepted);
  EXPECT_EQ(link.reply()->reason, "");
}

TEST(DaemonLink, AfterAwaitRunsEveryRunsReplyToItsOwnRequestIsKept) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun));
  link.bus().PublishMessage("ARM_STATE", State(kOtherRun));
  EXPECT_EQ(link.AwaitRuns(), (std::vector<std::int64_t>{kRun, kOtherRun}));
  link.ExpectReply(42);
  link.bus().PublishMessage("ARM_REPLY", Reply(0x3333, 42, ""));  // a run that published no state
  link.bus().PublishMessage("ARM_REPLY", Reply(kOtherRun, 41, "someone else's request"));
  link.bus().PublishMessage("ARM_REPLY", Reply(kOtherRun, 42, "busy"));
  link.bus().PublishMessage("ARM_REPLY", Reply(kRun, 42, ""));
  link.bus().PublishMessage("ARM_REPLY", Reply(kOtherRun, 42, ""));  // a second answer
  EXPECT_TRUE(link.PumpUntil([&] { return link.reply(kRun) && link.reply(kOtherRun); }, 1.0));
  link.Pump(0.01);
  EXPECT_TRUE(link.reply(kRun)->accepted);
  EXPECT_FALSE(link.reply(kOtherRun)->accepted);
  EXPECT_EQ(link.reply(kOtherRun)->reason, "busy");
  EXPECT_FALSE(link.reply(0x3333));
  EXPECT_EQ(link.runs().size(), 2u);
}

TEST(DaemonLink, OnlyTheRunsStatusIsKept) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun));
  link.AwaitOneRun();
  link.bus().PublishMessage("LAGRANGE_STATUS", Status(kOtherRun));
  link.bus().PublishMessage("LAGRANGE_STATUS", Status(kRun));
  EXPECT_EQ(link.AwaitStatus().run_id, kRun);
  EXPECT_EQ(link.statuses_received(), 1);
}

// Every identity on the bus is copyable: a spoofer cycling forged run ids on the instance's state and the status
// channels fills the link's bounded memory of runs, which forgets the least recently heard. The run the client chose
// is pinned: never forgotten, so its state, count and status stay readable (state() never throws), and the link
// still names the runs it hears, refusing to act beside them.
TEST(DaemonLink, AFloodOfForgedRunIdsNeverEvictsTheRunAClientChose) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun, 1));
  ASSERT_EQ(link.AwaitOneRun(), kRun);
  link.bus().PublishMessage("LAGRANGE_STATUS", Status(kRun));
  constexpr std::int64_t kForged = 0x5000;
  constexpr int kFlood = 100;  // run ids, far beyond kMaxLinkRuns
  for (int k = 0; k < kFlood; ++k) {
    link.bus().PublishMessage("ARM_STATE", State(kForged + k, 1000 + k));
    link.bus().PublishMessage("LAGRANGE_STATUS", Status(kForged + k));
  }
  link.Pump(0.02);
  EXPECT_EQ(link.state().tick, 1);
  EXPECT_EQ(link.states_received(), 1);
  ASSERT_NE(link.status(), nullptr);
  EXPECT_EQ(link.status()->run_id, kRun);
  EXPECT_EQ(link.statuses_received(), 1);
  link.bus().PublishMessage("ARM_STATE", State(kRun, 2));
  link.Pump(0.02);
  EXPECT_EQ(link.state().tick, 2);
  EXPECT_EQ(link.states_received(), 2);
  // The runs it saw: the chosen one and the forged ones heard last, bounded.
  const std::vector<std::int64_t> runs = link.runs();
  EXPECT_EQ(runs.size(), kMaxLinkRuns);
  EXPECT_EQ(runs.front(), kRun);
  EXPECT_EQ(runs.back(), kForged + kFlood - 1);
  try {
    link.RequireOneRun("refusing to act");
    FAIL() << "acted beside forged runs";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "several lagranged runs publish ARM_STATE (ids 0000000000001111, "
              "0000000000005061, 0000000000005062 and 0000000000005063): refusing to act");
  }
}

// A wait is bounded as inf and nan are refused (issue 32: Client.state(timeout=1e9) and --wait 1e9 held the
// caller for 32 years): one rule for lagrangectl --wait and Python's Client, and the link refuses what it breaks.
TEST(CheckWait, AWaitIsAPositiveNumberOfSecondsUpToADay) {
  for (const double ok : {1e-3, 3.0, kMaxWaitSeconds}) EXPECT_EQ(CheckWait(ok), "") << ok;
  EXPECT_EQ(CheckWait(1e9), "expected a positive number of seconds up to 86400 (a day), got 1e+09");
  EXPECT_EQ(CheckWait(-1.0), "expected a positive number of seconds up to 86400 (a day), got -1");
  for (const double bad : {0.0, 86400.5, std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_NE(CheckWait(bad), "") << bad;
  }
  EXPECT_EQ(CheckWait(std::numeric_limits<double>::quiet_NaN(), "forever"),
            "expected a positive number of seconds up to 86400 (a day), got forever");
  try {
    DaemonLink link(InProcess(1e9), "arm");
    FAIL() << "a link that waits 32 years";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "wait: expected a positive number of seconds up to 86400 (a day), got 1e+09");
  }
}

}  // namespace
}  // namespace lagrange
