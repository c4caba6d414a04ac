#pragma once
// What the Google Benchmark programs share: the machine baseline every
// per-call figure is quoted against, their own flags, and their main.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <string_view>
#include <vector>

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

// Removes `prefix`VALUE (e.g. "--agreement_csv=FILE") from the command line,
// since Google Benchmark refuses flags it does not know, and returns VALUE
// ("" when absent; the last one when repeated).
inline std::string TakeFlag(int& argc, char** argv, std::string_view prefix) {
  std::string value;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg.starts_with(prefix)) {
      value = std::string(arg.substr(prefix.size()));
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  return value;
}

// "GROUP/ROBOT/LIBRARY/TERM": the name of a peer benchmark (kdl_bench, kinematics_bench).
inline std::string PeerBenchmarkName(std::string_view group, std::string_view robot, std::string_view library,
                                     std::string_view term) {
  std::string name(group);
  for (std::string_view part : {robot, library, term}) name.append("/").append(part);
  return name;
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

// Google Benchmark's console table, and each run's CPU time per call kept by
// name (the median when there are repetitions) for a program's summary.
class Collector final : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      const std::string name = run.run_name.str();
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name != "median") continue;
      if (run.run_type == Run::RT_Iteration && medians_.count(name) != 0) continue;  // aggregates win
      if (run.run_type == Run::RT_Aggregate) {
        medians_[name] = run.GetAdjustedCPUTime();
      } else {
        times_[name].push_back(run.GetAdjustedCPUTime());
      }
    }
  }
  // ns per call: the median of the repetitions.
  double Time(const std::string& name) const {
    if (auto it = medians_.find(name); it != medians_.end()) return it->second;
    auto it = times_.find(name);
    if (it == times_.end() || it->second.empty()) return 0.0;
    std::vector<double> t = it->second;
    std::nth_element(t.begin(), t.begin() + static_cast<long>(t.size() / 2), t.end());
    return t[t.size() / 2];
  }

 private:
  std::map<std::string, double> medians_;
  std::map<std::string, std::vector<double>> times_;
};

// RunBenchmarks, then `summary` over the times the run kept (a program that
// prints ratios measured in the same run: derivatives_bench, ddp_bench).
inline int RunBenchmarks(int argc, char** argv, void (*register_benchmarks)(), void (*summary)(const Collector&)) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RegisterBenchmark("calib/sincos", TimeSinCos);
  register_benchmarks();
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();
  summary(collector);
  std::printf("calib/sincos %.1f ns\n", collector.Time("calib/sincos"));
  return 0;
}

}  // namespace lagrange::bench
