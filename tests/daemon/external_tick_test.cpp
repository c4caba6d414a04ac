// The tick of an external controller or an external plant on its own (Runtime::Tick,
// the mailboxes filled as the receiver would): timeouts of two ticks on an odd period,
// phase lock onto the measured states, and ticks that allocate nothing.

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "sim/yaml_reader.hpp"
#include "tests/daemon/external_support.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

using namespace external_test;

// ------------------------------------------------------------------ timeouts on odd periods

// A timeout of exactly two ticks at a period whose nanoseconds are not a
// whole double product: 0.00026 s × 1e9 = 259999.99999999997, and the tick
// (lagranged rounds the period: 130000 ns) must not see it as 259999 ns and
// time out after two ticks instead of after more than two.
constexpr double kOddPeriod = 0.00013;           // s
constexpr Nanoseconds kOddTick = 130'000;        // ns, llround(kOddPeriod × 1e9) as service.cpp
constexpr const char* kTwoOddTicks = "0.00026";  // s, = 2 × kOddPeriod in doubles

// The tick that takes a message at T, then ticks of kOddTick: running while
// now − T <= 260000 ns (the two-tick timeout), `after` at the first tick past it.
void ExpectTwoOddTicksThen(Runtime& runtime, TickRecord& record, Mode after) {
  Nanoseconds now = 0;
  runtime.Tick(now += kOddTick, record);  // takes it at T
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);  // now − T = 260000 ns: not more than the timeout
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.Tick(now += kOddTick, record);
  EXPECT_EQ(runtime.mode(0), after);
}

TEST(ExternalTimeouts, ATorqueTimeoutOfTwoTicksLastsTwoTicksWhateverTheRoundOff) {
  Runtime runtime(ParseScene(std::string(R"(
period: 0.00013
instances:
  - name: arm
    plant: {type: arm2}
    controller: {type: external, torque_timeout: )") +
                                 kTwoOddTicks + "}\n",
                             "inline"));
  ASSERT_NEAR(runtime.period(), kOddPeriod, 1e-18);
  TickRecord record = runtime.MakeRecord();
  runtime.channels(0).torques.back().tau << 1.0, 0.5;
  runtime.channels(0).torques.Publish();
  ExpectTwoOddTicksThen(runtime, record, Mode::kHold);
}

TEST(ExternalTimeouts, AStateTimeoutOfTwoTicksLastsTwoTicksWhateverTheRoundOff) {
  Runtime runtime(ParseScene(std::string(R"(
period: 0.00013
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: ARM_STATE, torque_channel: ARM_TORQUE, state_timeout: )") +
                                 kTwoOddTicks + R"(}
    controller: {type: pd, kp: 10, kd: 1}
)",
                             "inline"));
  TickRecord record = runtime.MakeRecord();
  PostMeasured(runtime, Vec({0.1, 0.2}), Vec({0.0, 0.0}), 1);
  ExpectTwoOddTicksThen(runtime, record, Mode::kStopped);
}

// ------------------------------------------------------------------ phase lock

// An external plant with phase_lock, fed states that arrive on their own 1 kHz
// grid at an arbitrary phase: the loop (as Loop::Run does it: the next deadline
// one period on, moved by PhaseShift) settles each tick phase_lag after its
// state arrived, moving at most kMaxPhaseStep a tick; without phase_lock it
// stays where it started.
std::vector<Nanoseconds> WaitsOfALoopFedOnAGrid(bool phase_lock) {
  const std::string scene = std::string(R"(
period: 0.001
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: ARM_STATE, torque_channel: ARM_TORQUE, state_timeout: 0.05, phase_lock: )") +
                            (phase_lock ? "true" : "false") + R"(}
    controller: {type: pd, kp: 10, kd: 1}
)";
  Runtime runtime(ParseScene(scene, "inline"));
  TickRecord record = runtime.MakeRecord();
  constexpr Nanoseconds kPeriod = 1'000'000;
  const Nanoseconds grid = 123'456;  // the plant's states arrive at grid + k·period
  std::vector<Nanoseconds> waits;
  Nanoseconds deadline = 50 * kPeriod;
  for (int k = 0; k < 200; ++k) {
    const Nanoseconds arrived = grid + ((deadline - grid) / kPeriod) * kPeriod;  // the latest state by now
    PostMeasured(runtime, Vec({0.1, 0.2}), Vec({0.0, 0.0}), k + 1, arrived);
    runtime.Tick(deadline, record);
    EXPECT_LE(std::abs(runtime.PhaseShift()), Runtime::kMaxPhaseStep);
    waits.push_back(deadline - arrived);
    deadline += kPeriod + runtime.PhaseShift();
  }
  EXPECT_EQ(runtime.mode(0), Mode::kRunning);
  return waits;
}

TEST(ExternalPhaseLock, TheLoopSettlesPhaseLagAfterEachMeasuredState) {
  const std::vector<Nanoseconds> locked = WaitsOfALoopFedOnAGrid(true);
  EXPECT_GT(locked.front(), 800'000);  // started 876.5 µs after the state
  for (std::size_t k = 100; k < locked.size(); ++k) EXPECT_NEAR(locked[k], 200'000, 1'000) << k;
  const std::vector<Nanoseconds> free = WaitsOfALoopFedOnAGrid(false);
  for (const Nanoseconds w : free) EXPECT_EQ(w, free.front());
}

TEST(ExternalPhaseLock, APhaseLagOfAPeriodOrMoreIsRefused) {
  EXPECT_THROW(ParseScene(R"(
period: 0.001
instances:
  - name: arm_controller
    plant: {type: external, model: {type: arm2}, state_channel: S, torque_channel: T, phase_lock: true, phase_lag: 0.001}
    controller: {type: pd, kp: 10, kd: 1}
)",
                          "inline"),
               ConfigError);
}

// ------------------------------------------------------------------ the ticks allocate nothing

// Heap allocations of `ticks` ticks of `runtime`, 1 ms apart from `now`,
// after `before_each` (the receiver's part, not counted) each time.
template <class F>
std::int64_t TickAllocations(Runtime& runtime, TickRecord& record, Nanoseconds& now, int ticks, F before_each) {
  std::int64_t total = 0;
  for (int k = 0; k < ticks; ++k) {
    before_each(k);
    testing::AllocationCounter counter;
    runtime.Tick(now += kMs, record);
    total += counter.count();
  }
  return total;
}

TEST(ExternalTickAllocation, APlantTickAllocatesNothingRunningOnTorquesOrHoldingOnItsFallback) {
  const auto none = [](int) {};
  for (const Scene& scene : {LoadScene(Config("arm_external_plant.yaml")),
                             ArmScene("{type: external, torque_timeout: 0.05, fallback: brake}"),
                             LoadScene(Config("arm_impedance_client.yaml"))}) {
    Runtime runtime(scene);
    {  // the counter sees this binary's allocations, so the zero below means something
      testing::AllocationCounter counter;
      const TickRecord probe = runtime.MakeRecord();
      ASSERT_GT(counter.count(), 0);
    }
    TickRecord record = runtime.MakeRecord();
    Nanoseconds now = 0;
    std::int64_t allocations = TickAllocations(runtime, record, now, 20, none);  // hold: no torque yet
    ASSERT_EQ(runtime.mode(0), Mode::kHold);
    allocations += TickAllocations(runtime, record, now, 100, [&](int k) {
      runtime.channels(0).torques.back().tau << 0.01 * k, -0.005 * k;
      runtime.channels(0).torques.Publish();
    });
    ASSERT_EQ(runtime.mode(0), Mode::kRunning);
    allocations += TickAllocations(runtime, record, now, 100, none);  // timed out: the fallback holds
    ASSERT_EQ(runtime.mode(0), Mode::kHold);
    EXPECT_EQ(allocations, 0) << scene.instances[0].controller.external.fallback.value_or("(default)");
  }
}

TEST(ExternalTickAllocation, AControllerTickAllocatesNothingRunningOrStopped) {
  Runtime runtime(LoadScene(Config("arm_external_controller.yaml")));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  const auto none = [](int) {};
  const VectorXd qd = Vec({0.2, -0.1});
  VectorXd q = Vec({0.8, 0.1});
  const auto measure = [&](int k) {
    q[0] = 0.8 + 0.001 * k;
    PostMeasured(runtime, q, qd, k);
  };
  std::int64_t allocations = TickAllocations(runtime, record, now, 20, none);  // waiting
  ASSERT_EQ(runtime.mode(0), Mode::kWaiting);
  allocations += TickAllocations(runtime, record, now, 100, measure);
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  ASSERT_TRUE(record.instances[0].publish_torque);
  allocations += TickAllocations(runtime, record, now, 100, none);  // timed out: stopped
  ASSERT_EQ(runtime.mode(0), Mode::kStopped);
  runtime.PostUrgent(0, Urgent::kClearEstop, 1);
  allocations += TickAllocations(runtime, record, now, 50, measure);  // re-armed, running
  ASSERT_EQ(runtime.mode(0), Mode::kRunning);
  runtime.channels(0).measured_problem.store(static_cast<std::uint8_t>(MeasuredProblem::kNotFinite));
  allocations += TickAllocations(runtime, record, now, 50, measure);  // tripped: stopped
  ASSERT_EQ(runtime.mode(0), Mode::kStopped);
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace lagrange
