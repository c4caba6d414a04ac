// The daemon's tick outside the daemon: Runtime::Tick on the default scene
// (config/default.yaml), to set the loop benchmark's tick compute time beside
// what the same work costs with warm caches.
//
//   tick/default/hot          ticks back to back (caches and predictors warm)
//   tick/default/after-sleep  one tick per absolute 1 ms deadline, timed from
//                             the wake to the end of the tick, as lagranged
//                             times it (but with no LCM threads beside it)

#include <benchmark/benchmark.h>

#include <chrono>
#include <string>

#include "daemon/clock.hpp"
#include "daemon/runtime.hpp"
#include "daemon/scene.hpp"

namespace lagrange::bench {
namespace {

constexpr Nanoseconds kPeriod = 1'000'000;  // 1 ms

const std::string kDefaultScene = std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml";

void TimeHot(benchmark::State& bm) {
  Runtime runtime(LoadScene(kDefaultScene));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  for (auto _ : bm) {
    now += kPeriod;
    runtime.Tick(now, record);
    benchmark::ClobberMemory();
  }
}

void TimeAfterSleep(benchmark::State& bm) {
  Runtime runtime(LoadScene(kDefaultScene));
  TickRecord record = runtime.MakeRecord();
  MonotonicClock clock;
  Nanoseconds deadline = clock.Now();
  for (auto _ : bm) {
    deadline += kPeriod;
    clock.SleepUntil(deadline);
    const Nanoseconds start = clock.Now();
    runtime.Tick(start, record);
    bm.SetIterationTime(static_cast<double>(clock.Now() - start) * 1e-9);
  }
}

}  // namespace
}  // namespace lagrange::bench

BENCHMARK(lagrange::bench::TimeHot)->Name("tick/default/hot");
BENCHMARK(lagrange::bench::TimeAfterSleep)->Name("tick/default/after-sleep")->UseManualTime()->Iterations(2000);

BENCHMARK_MAIN();
