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
              "no state from instance 'arm' on ARM_STATE within 0.05 s (unknown instance, or no lagranged on "
              "inprocess://?)");
  }
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

TEST(DaemonLink, OnlyTheRunsStatusIsKept) {
  DaemonLink link(InProcess(), "arm");
  link.bus().PublishMessage("ARM_STATE", State(kRun));
  link.AwaitOneRun();
  link.bus().PublishMessage("LAGRANGE_STATUS", Status(kOtherRun));
  link.bus().PublishMessage("LAGRANGE_STATUS", Status(kRun));
  EXPECT_EQ(link.AwaitStatus().run_id, kRun);
  EXPECT_EQ(link.statuses_received(), 1);
}

}  // namespace
}  // namespace lagrange
