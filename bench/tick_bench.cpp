// The daemon's tick outside the daemon: Runtime::Tick on a scene, to set the
// loop benchmark's tick compute time beside what the same work costs with
// warm caches. Scenes:
//   default  config/default.yaml: 2-DOF arm under computed torque and
//            cart-pole under LQR, RK4, 1 kHz
//   panda    config/panda_minjerk.yaml: the 7-DOF Panda
//            (config/robots/panda.urdf) under computed torque tracking a
//            3 s minimum-jerk move, recursive dynamics, RK4, 1 kHz
//   panda-impedance  config/panda_cartesian_impedance.yaml: the Panda's
//            flange under Cartesian impedance (task-space: its pose,
//            Jacobian, J̇q̇, M, Λ and the posture projection every tick)
//   ur5-circle  config/ur5_circle.yaml: the UR5's tool under
//            operational-space control along a circle
//   panda-mujoco  config/panda_mujoco_minjerk.yaml: the panda scene with
//            MuJoCo as its plant (where MuJoCo was found)
//   panda-mujoco-table  config/panda_mujoco_table.yaml: the Panda on MuJoCo
//            pressing on a table (contact) under Cartesian impedance
//   a1-stand  config/quadruped_mujoco_stand.yaml: the A1 quadruped on
//            MuJoCo's ground (a floating base, four foot contacts) under pd
//            with stance gravity compensation (G, four foot Jacobians and
//            the 6 x 6 eigen-decomposition every tick)
//
//   tick/<scene>/hot          ticks back to back (caches and predictors warm),
//                             as shipped: the energy balance kept (telemetry on)
//   tick/<scene>/hot/telemetry-off  the same with every instance's telemetry
//                             off: what keeping the balance costs, by ratio
//   tick/<scene>/hot/forces-on  the same with every instance's forces on
//                             (<NAME>_FORCES): what computing them costs
//   tick/<scene>/after-sleep  one tick per absolute 1 ms deadline, timed from
//                             the wake to the end of the tick, as lagranged
//                             times its compute (daemon/loop.cpp: clock reads
//                             after the wake and after Runtime::Tick), but
//                             with no LCM threads beside it; its mean is the
//                             benchmark's time, and counters p50_ns, p99_ns
//                             and max_ns give the distribution of its ticks
//                             (nearest rank, as lagranged's status_t:
//                             bench/stats.hpp)

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "bench/stats.hpp"
#include "daemon/runtime.hpp"
#include "protocol/clock.hpp"
#include "sim/scene.hpp"

namespace lagrange::bench {
namespace {

constexpr Nanoseconds kPeriod = 1'000'000;  // 1 ms
constexpr int kSleptTicks = 2000;           // ticks per after-sleep run (2 s)

std::string ScenePath(const char* file) { return std::string(LAGRANGE_SOURCE_DIR) + "/config/" + file; }

// The scene at `path`, or nullopt after marking the benchmark skipped (a scene
// not there yet skips its benchmarks, not the program).
std::optional<Scene> LoadOrSkip(benchmark::State& bm, const std::string& path) {
  try {
    return LoadScene(path);
  } catch (const std::exception& e) {
    bm.SkipWithError(e.what());
    return std::nullopt;
  }
}

// A tick of a faulted instance does no work: such a figure would flatter the
// scene, so it is reported as an error instead.
void FailIfFaulted(benchmark::State& bm, const TickRecord& record) {
  for (const InstanceRecord& instance : record.instances) {
    if (instance.mode == Mode::kFault) {
      bm.SkipWithError((std::string("an instance faulted: ") + (instance.fault ? instance.fault : "?")).c_str());
      return;
    }
  }
}

enum class Variant : std::uint8_t { kAsShipped, kTelemetryOff, kForcesOn };

void TimeHot(benchmark::State& bm, const std::string& path, Variant variant) {
  std::optional<Scene> scene = LoadOrSkip(bm, path);
  if (!scene) return;
  for (InstanceConfig& c : scene->instances) {
    if (variant == Variant::kTelemetryOff) c.telemetry = false;
    if (variant == Variant::kForcesOn) c.forces = true;
  }
  Runtime runtime(std::move(*scene));
  TickRecord record = runtime.MakeRecord();
  Nanoseconds now = 0;
  for (auto _ : bm) {
    now += kPeriod;
    runtime.Tick(now, record);
    benchmark::ClobberMemory();
  }
  FailIfFaulted(bm, record);
}

void TimeAfterSleep(benchmark::State& bm, const std::string& path) {
  std::optional<Scene> scene = LoadOrSkip(bm, path);
  if (!scene) return;
  Runtime runtime(std::move(*scene));
  TickRecord record = runtime.MakeRecord();
  std::vector<double> compute_ns;
  compute_ns.reserve(kSleptTicks);
  MonotonicClock clock;
  Nanoseconds deadline = clock.Now();
  for (auto _ : bm) {
    deadline += kPeriod;
    clock.SleepUntil(deadline);
    const Nanoseconds start = clock.Now();
    runtime.Tick(start, record);
    const Nanoseconds compute = clock.Now() - start;
    bm.SetIterationTime(static_cast<double>(compute) * 1e-9);
    compute_ns.push_back(static_cast<double>(compute));
  }
  const Summary ticks = Summarize(std::move(compute_ns));
  bm.counters["p50_ns"] = ticks.p50;
  bm.counters["p99_ns"] = ticks.p99;
  bm.counters["max_ns"] = ticks.max;
  FailIfFaulted(bm, record);
}

void RegisterScene(const std::string& name, const std::string& scene) {
  benchmark::RegisterBenchmark(("tick/" + name + "/hot").c_str(),
                               [scene](benchmark::State& bm) { TimeHot(bm, scene, Variant::kAsShipped); });
  benchmark::RegisterBenchmark(("tick/" + name + "/hot/telemetry-off").c_str(),
                               [scene](benchmark::State& bm) { TimeHot(bm, scene, Variant::kTelemetryOff); });
  benchmark::RegisterBenchmark(("tick/" + name + "/hot/forces-on").c_str(),
                               [scene](benchmark::State& bm) { TimeHot(bm, scene, Variant::kForcesOn); });
  benchmark::RegisterBenchmark(("tick/" + name + "/after-sleep").c_str(),
                               [scene](benchmark::State& bm) { TimeAfterSleep(bm, scene); })
      ->UseManualTime()
      ->Iterations(kSleptTicks);
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  lagrange::bench::RegisterScene("default", lagrange::bench::ScenePath("default.yaml"));
  lagrange::bench::RegisterScene("panda", lagrange::bench::ScenePath("panda_minjerk.yaml"));
  lagrange::bench::RegisterScene("panda-impedance", lagrange::bench::ScenePath("panda_cartesian_impedance.yaml"));
  lagrange::bench::RegisterScene("ur5-circle", lagrange::bench::ScenePath("ur5_circle.yaml"));
#if LAGRANGE_HAVE_MUJOCO
  lagrange::bench::RegisterScene("panda-mujoco", lagrange::bench::ScenePath("panda_mujoco_minjerk.yaml"));
  lagrange::bench::RegisterScene("panda-mujoco-table", lagrange::bench::ScenePath("panda_mujoco_table.yaml"));
  lagrange::bench::RegisterScene("a1-stand", lagrange::bench::ScenePath("quadruped_mujoco_stand.yaml"));
#endif
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
