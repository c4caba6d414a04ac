// Stiff hard cases at the tick: explicit integrators that go unstable at 1 ms
// are detected and faulted (never a silent NaN), while sub-stepping or the
// variational integrator stays stable.

#include <gtest/gtest.h>

#include <cmath>

#include "daemon/runtime.hpp"

namespace lagrange {
namespace {

constexpr Nanoseconds kMs = 1'000'000;

struct Outcome {
  bool faulted = false;
  const char* reason = nullptr;
  bool always_finite = true;
  InstanceRecord last;
};

Outcome RunScene(const std::string& yaml, int ticks) {
  Runtime runtime(ParseScene(yaml, "inline"));
  TickRecord record = runtime.MakeRecord();
  Outcome out;
  for (int k = 0; k < ticks; ++k) {
    runtime.Tick((k + 1) * kMs, record);
    const InstanceRecord& r = record.instances[0];
    out.always_finite = out.always_finite && r.q.allFinite() && r.qd.allFinite() && r.qdd.allFinite() &&
                        r.tau.allFinite() && std::isfinite(r.kinetic_energy + r.potential_energy);
    if (r.fault && !out.faulted) {
      out.faulted = true;
      out.reason = r.fault;
    }
  }
  out.last = record.instances[0];
  return out;
}

// A PD evaluated at every integrator stage (continuous: true) with Kp = 2e5:
// the arm's fastest closed-loop mode has ω ≈ 3.5e3 rad/s, so h·ω ≈ 3.5 at 1 ms,
// beyond the stability limits of explicit Euler, semi-implicit Euler (2) and RK4 (2.8).
std::string StiffPdScene(const std::string& integrator) {
  return R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.5, 0.3]}
    controller: {type: pd, kp: 2.0e5, kd: 20, continuous: true}
    setpoint: {q: [0.6, 0.2]}
    integrator: )" + integrator + "\n";
}

TEST(StiffCases, StiffContinuousPdFaultsExplicitIntegratorsAtOneMillisecond) {
  for (const char* integrator : {"{type: explicit-euler}", "{type: semi-implicit-euler}", "{type: rk4}"}) {
    const Outcome o = RunScene(StiffPdScene(integrator), 1000);
    EXPECT_TRUE(o.faulted) << integrator;
    EXPECT_TRUE(o.always_finite) << integrator;  // detected and reported, never published as NaN
    EXPECT_EQ(o.last.mode, Mode::kFault) << integrator;
    ASSERT_NE(o.reason, nullptr);
    EXPECT_TRUE(std::string(o.reason) == "the energy left its bound (max_energy)" ||
                std::string(o.reason) == "the state became non-finite")
        << o.reason;
  }
}

TEST(StiffCases, SubSteppingOrTheVariationalIntegratorKeepTheStiffPdStable) {
  for (const char* integrator : {"{type: rk4, substeps: 4}", "{type: semi-implicit-euler, substeps: 8}",
                                 "{type: variational}", "{type: dopri5}"}) {
    const Outcome o = RunScene(StiffPdScene(integrator), 1000);
    EXPECT_FALSE(o.faulted) << integrator << ": " << (o.reason ? o.reason : "");
    EXPECT_EQ(o.last.mode, Mode::kRunning) << integrator;
    // At rest on the setpoint, up to the small offset gravity leaves against Kp = 2e5.
    EXPECT_NEAR(o.last.q[0], 0.6, 1e-3) << integrator;
    EXPECT_NEAR(o.last.q[1], 0.2, 1e-3) << integrator;
  }
}

// The arm's elbow swung at 60 rad/s (120 J) into a stiff stop (k = 1e6 N·m/rad, d = 20): plain
// RK4 at 1 ms is unstable in contact (measured: 6 kJ and rising), RK4 with 10 sub-steps
// holds even k = 1e7.
std::string LimitScene(const std::string& integrator) {
  return R"(
instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0.0, 0.0], qd: [0.0, 60.0]}
    effects: {gravity: false, limits: {lower: [-10, -1.0], upper: [10, 1.0], stiffness: 1.0e6, damping: 20}}
    integrator: )" + integrator + "\n";
}

TEST(StiffCases, AJointLimitStopHitAtHighSpeedBouncesBackWithFiniteState) {
  for (const char* integrator : {"{type: rk4, substeps: 10}", "{type: dopri5}", "{type: variational, substeps: 4}"}) {
    Runtime runtime(ParseScene(LimitScene(integrator), "inline"));
    TickRecord record = runtime.MakeRecord();
    runtime.Tick(kMs, record);
    const double e0 = record.instances[0].kinetic_energy + record.instances[0].potential_energy;
    double deepest = 0.0, energy = e0;
    for (int k = 1; k < 200; ++k) {
      runtime.Tick((k + 1) * kMs, record);
      const InstanceRecord& r = record.instances[0];
      ASSERT_EQ(r.mode, Mode::kRunning) << integrator << " at tick " << k << ": " << (r.fault ? r.fault : "");
      deepest = std::max(deepest, std::abs(r.q[1]) - 1.0);
      energy = r.kinetic_energy + r.potential_energy;
    }
    EXPECT_LT(deepest, 0.1) << integrator;        // the stop held: at most 0.1 rad into it
    EXPECT_LE(energy, e0 * (1.0 + 1e-6)) << integrator;  // and took energy out (its damper), never added
    EXPECT_LT(std::abs(record.instances[0].q[1]), 1.0 + 1e-3) << integrator;  // bounced back out
  }
}

TEST(StiffCases, TheSameStopIsFaultedWithRk4AtOneMillisecond) {
  const Outcome o = RunScene(LimitScene("{type: rk4}"), 200);
  EXPECT_TRUE(o.faulted);
  EXPECT_TRUE(o.always_finite);
}

}  // namespace
}  // namespace lagrange
