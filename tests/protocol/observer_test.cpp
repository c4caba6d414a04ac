// The multi-instance observer (protocol/observer.hpp) over the in-process bus:
// instances discovered from a status, runs kept apart, every bound held.

#include <gtest/gtest.h>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <chrono>
#include <string>
#include <vector>

#include "protocol/bus.hpp"
#include "protocol/channels.hpp"
#include "protocol/observer.hpp"
#include "tests/support/lcm_messages.hpp"

namespace lagrange {
namespace {

using testing::MakeState;

constexpr const char* kPrefix = "A_";

status_t StatusNaming(std::int64_t run_id, std::vector<std::string> names) {
  status_t s{};
  s.run_id = run_id;
  s.num_instances = static_cast<std::int32_t>(names.size());
  s.instance_names = std::move(names);
  s.instance_modes.assign(s.instance_names.size(), 0);
  s.instance_dofs.assign(s.instance_names.size(), 2);
  s.instance_reasons.assign(s.instance_names.size(), "");
  s.instance_integrators.assign(s.instance_names.size(), "rk4");
  s.instance_methods.assign(s.instance_names.size(), "closed_form");
  s.instance_effects.assign(s.instance_names.size(), "");
  s.instance_forces.assign(s.instance_names.size(), 0);
  return s;
}

void Send(InProcessBus& bus, const std::string& channel, const auto& message) {
  ASSERT_TRUE(bus.PublishMessage(channel, message));
  bus.Drain();
}

TEST(BusObserver, FollowsTheInstancesAStatusNamesOnlyWhenTheyAreInstanceNames) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix);
  Send(bus, StatusChannel(kPrefix), StatusNaming(7, {"arm", "Bad-Name", "9lives", "cartpole"}));
  ASSERT_EQ(observer.statuses().entries().size(), 1u);
  observer.Discover();
  EXPECT_EQ(observer.followed(), (std::vector<std::string>{"arm", "cartpole"}));
  Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(5, 7));
  const ObservedInstance* arm = observer.Find("arm");
  ASSERT_NE(arm, nullptr);
  ASSERT_NE(arm->states.Find(7), nullptr);
  EXPECT_EQ(arm->states.Find(7)->message.tick, 5);
  EXPECT_TRUE(observer.Find("cartpole")->states.empty());
}

TEST(BusObserver, KeepsTwoRunsOfOneInstanceApartAndForgetsTheLeastRecentlyHeardBeyondItsBound) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix, ObserverLimits{2, 8, true});
  ASSERT_TRUE(observer.Follow("arm"));
  for (std::int64_t run : {1, 2, 1, 3})
    Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(run * 10, run));
  const auto& states = observer.Find("arm")->states;
  EXPECT_EQ(states.entries().size(), 2u);
  EXPECT_EQ(states.Find(2), nullptr);  // heard before run 1's second state: forgotten first
  ASSERT_NE(states.Find(1), nullptr);
  EXPECT_EQ(states.Newest()->message.run_id, 3);
}

// A client that chose a run pins it: the least recently heard unpinned run is forgotten instead, a run is pinned
// before it is heard (a status still to come), and once every kept run is pinned a new one is not kept.
TEST(LatestByRun, APinnedRunIsNeverForgottenAndPinsAreBounded) {
  LatestByRun<state_t> states(2);
  const auto t0 = std::chrono::steady_clock::time_point{};
  const auto at = [&](int ms) { return t0 + std::chrono::milliseconds(ms); };
  ASSERT_NE(states.Add(MakeState(1, 1), at(1)), nullptr);
  ASSERT_TRUE(states.Pin(1));
  for (int run = 2; run < 50; ++run) ASSERT_NE(states.Add(MakeState(run, run), at(run)), nullptr);
  ASSERT_NE(states.Find(1), nullptr);
  EXPECT_EQ(states.Find(1)->message.tick, 1);
  EXPECT_EQ(states.Find(1)->count, 1);
  EXPECT_NE(states.Find(49), nullptr);
  EXPECT_EQ(states.entries().size(), 2u);
  ASSERT_TRUE(states.Pin(77));   // not heard yet
  EXPECT_FALSE(states.Pin(78));  // two pins of two runs: no more
  EXPECT_FALSE(states.pinned(78));
  ASSERT_NE(states.Add(MakeState(77, 77), at(100)), nullptr);  // forgets 49, the one unpinned run
  EXPECT_EQ(states.Find(49), nullptr);
  EXPECT_EQ(states.Add(MakeState(80, 80), at(101)), nullptr);  // every kept run pinned: not kept
  EXPECT_EQ(states.Find(80), nullptr);
  ASSERT_NE(states.Add(MakeState(2, 1), at(102)), nullptr);
  EXPECT_EQ(states.Find(1)->count, 2);
}

TEST(BusObserver, APinnedRunIsKeptOnEveryChannelThroughAFloodOfForgedRunIds) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix, ObserverLimits{2, 8, false});
  ASSERT_TRUE(observer.Pin(7));  // before the instance is followed: it is pinned there too
  ASSERT_TRUE(observer.Follow("arm"));
  Send(bus, StatusChannel(kPrefix), StatusNaming(7, {"arm"}));
  Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(1, 7));
  for (std::int64_t forged = 100; forged < 200; ++forged) {
    Send(bus, StatusChannel(kPrefix), StatusNaming(forged, {"arm"}));
    Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(2, forged));
  }
  EXPECT_NE(observer.statuses().Find(7), nullptr);
  ASSERT_NE(observer.Find("arm")->states.Find(7), nullptr);
  EXPECT_EQ(observer.Find("arm")->states.Find(7)->message.tick, 1);
  EXPECT_NE(observer.Find("arm")->states.Find(199), nullptr);  // the others still come and go
  EXPECT_TRUE(observer.Pin(8));
  EXPECT_FALSE(observer.Pin(9));  // limits.runs pins at most
}

TEST(BusObserver, FollowsNoMoreInstancesThanItsBound) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix, ObserverLimits{4, 2, true});
  Send(bus, StatusChannel(kPrefix), StatusNaming(7, {"a", "b", "c"}));
  observer.Discover();
  EXPECT_EQ(observer.followed().size(), 2u);
  EXPECT_FALSE(observer.Follow("d"));
}

TEST(BusObserver, DoesNotDiscoverWhenToldNotTo) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix, ObserverLimits{4, 8, false});
  Send(bus, StatusChannel(kPrefix), StatusNaming(7, {"arm"}));
  observer.Discover();
  EXPECT_TRUE(observer.followed().empty());
}

TEST(BusObserver, AStateHookSeesTheInstanceBeforeTheNewStateIsKept) {
  InProcessBus bus;
  std::vector<std::int64_t> previous_ticks;
  BusObserver* self = nullptr;
  BusObserver::Hooks hooks;
  hooks.on_state = [&](const std::string& name, const state_t&) {
    const auto* newest = self->Find(name)->states.Newest();
    previous_ticks.push_back(newest == nullptr ? -1 : newest->message.tick);
  };
  BusObserver observer(bus, kPrefix, {}, hooks);
  self = &observer;
  observer.Follow("arm");
  Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(1));
  Send(bus, InstanceChannel(kPrefix, "arm", kStateSuffix), MakeState(2));
  EXPECT_EQ(previous_ticks, (std::vector<std::int64_t>{-1, 1}));
}

TEST(BusObserver, AStatusHookSeesEveryStatusBeforeItIsKept) {
  InProcessBus bus;
  std::vector<std::int64_t> heard;  // (run id, statuses of it kept before)
  BusObserver* self = nullptr;
  BusObserver::Hooks hooks;
  hooks.on_status = [&](const status_t& s) {
    const auto* kept = self->statuses().Find(s.run_id);
    heard.push_back(s.run_id);
    heard.push_back(kept == nullptr ? 0 : kept->count);
  };
  BusObserver observer(bus, kPrefix, {}, hooks);
  self = &observer;
  for (std::int64_t run : {7, 7, 8}) Send(bus, StatusChannel(kPrefix), StatusNaming(run, {"arm"}));
  EXPECT_EQ(heard, (std::vector<std::int64_t>{7, 0, 7, 1, 8, 0}));
}

TEST(BusObserver, AMalformedStateIsNotKept) {
  InProcessBus bus;
  BusObserver observer(bus, kPrefix);
  observer.Follow("arm");
  const std::vector<std::uint8_t> bytes = testing::Encode(MakeState());
  ASSERT_TRUE(bus.Publish(InstanceChannel(kPrefix, "arm", kStateSuffix), bytes.data(), bytes.size() - 1));
  bus.Drain();
  EXPECT_TRUE(observer.Find("arm")->states.empty());
}

}  // namespace
}  // namespace lagrange
