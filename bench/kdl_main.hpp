#pragma once
// The main of a benchmark that runs Orocos KDL beside lagrange (kdl_bench,
// kinematics_bench): check that the two agree first, time only if they do.

#include <kdl/config.h>

#include <cstdio>
#include <exception>
#include <string>

#include "bench/gbench.hpp"

namespace lagrange::bench {

// `agree(csv)` (the agreement table, and its CSV to --agreement_csv=FILE when
// given) must hold, else exit 1 without timing; then the benchmarks that
// `register_benchmarks` adds, with KDL's version in the context.
inline int RunAfterAgreement(int argc, char** argv, const char* program, bool (*agree)(const std::string&),
                             void (*register_benchmarks)()) {
  const std::string csv = TakeFlag(argc, argv, "--agreement_csv=");
  try {
    if (!agree(csv)) {
      std::fprintf(stderr, "%s: lagrange and KDL disagree; not timing\n", program);
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 1;
  }
  benchmark::AddCustomContext("kdl_version", KDL_VERSION_STRING);
  return RunBenchmarks(argc, argv, register_benchmarks);
}

}  // namespace lagrange::bench
