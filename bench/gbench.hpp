#pragma once
// What the Google Benchmark programs share: the machine baseline every
// per-call figure is quoted against, and their main.

#include <benchmark/benchmark.h>

#include <cmath>

namespace lagrange::bench {

// calib/sincos, the machine baseline: one sin and one cos of a changing argument.
inline void TimeSinCos(benchmark::State& bm) {
  double x = 0.1;
  for (auto _ : bm) {
    benchmark::DoNotOptimize(std::sin(x) + std::cos(x));
    x += 0.37;
    if (x > 6.0) x -= 6.0;
  }
}

// Registers calib/sincos, then the program's own benchmarks, and runs them
// with Google Benchmark's command line.
inline int RunBenchmarks(int argc, char** argv, void (*register_benchmarks)()) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RegisterBenchmark("calib/sincos", TimeSinCos);
  register_benchmarks();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace lagrange::bench
