// Stiff hard cases at the tick: explicit integrators that go unstable at 1 ms
// are detected and faulted (never a silent NaN), while sub-stepping or the
// variational integrator stays stable.

#include <gtest/gtest.h>

#include <algorithm>
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
    integrator: )" +
         integrator + "\n";
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
    integrator: )" +
         integrator + "\n";
}

// The energy E = T + V, where V is the stop's spring energy ½ k (q − limit)² (gravity is off):
// in contact the stop stores part of T in V, and the stop's damper takes some out (3.6 % over
// the bounce). So an integrator's energy error is measured against the energy of the exact
// motion, E_ref(t) from dopri5 at rtol 1e-12, tick by tick, not against E(0).
struct StopRun {
  double deepest = 0.0;        // rad past the stop, over the whole run
  double worst_energy = 0.0;   // max over every tick of |E − E_ref| / E(0)
  double worst_after = 0.0;    // the same over the ticks after the bounce, out of contact
  double final_q = 0.0;        // the elbow at the end, rad
  std::vector<double> energy;  // E at each tick, J
};

StopRun RunIntoTheStop(const char* integrator, const std::vector<double>& reference = {}) {
  Runtime runtime(ParseScene(LimitScene(integrator), "inline"));
  TickRecord record = runtime.MakeRecord();
  Instance& arm = runtime.instance(0);
  const double e0 = arm.KineticEnergy() + arm.PotentialEnergy();  // 120 J at t = 0
  StopRun run;
  bool touched = false;
  for (int k = 0; k < 200; ++k) {
    runtime.Tick((k + 1) * kMs, record);
    const InstanceRecord& r = record.instances[0];
    EXPECT_EQ(r.mode, Mode::kRunning) << integrator << " at tick " << k << ": " << (r.fault ? r.fault : "");
    if (r.mode != Mode::kRunning) break;
    const double past = std::abs(r.q[1]) - 1.0;
    const double energy = r.kinetic_energy + r.potential_energy;
    run.energy.push_back(energy);
    const double gain = reference.empty() ? 0.0 : std::abs(energy - reference[static_cast<std::size_t>(k)]) / e0;
    touched = touched || past > 0.0;
    run.deepest = std::max(run.deepest, past);
    run.worst_energy = std::max(run.worst_energy, gain);
    if (touched && past < 0.0) run.worst_after = std::max(run.worst_after, gain);
  }
  EXPECT_TRUE(touched) << integrator;
  run.final_q = record.instances[0].q[1];
  return run;
}

// Bounds on |E − E_ref| / E(0) (measured values below, in the test).
constexpr double kRk4StopTol = 5e-3, kRk4StopAfterTol = 1e-3;
constexpr double kDopri5StopTol = 2e-5, kDopri5StopAfterTol = 2e-6;
constexpr double kVariationalStopTol = 0.1, kVariationalStopAfterTol = 0.08;

TEST(StiffCases, AJointLimitStopHitAtHighSpeedBouncesBackWithFiniteState) {
  struct Case {
    const char* integrator;
    double energy_gain;  // bound on |E − E_ref| / E(0) at every tick
    double gain_after;   // the same after the bounce
  };
  // Measured over the 200 ticks, |E − E_ref| / E(0), the largest in contact and after the bounce:
  // RK4 × 10 2.5e-3 and 3.6e-4, dopri5 6.5e-6 and 4.4e-7; the variational integrator × 4
  // (h·ω ≈ 1 in contact) is symplectic, not dissipative: its energy error is bounded but not
  // signed, 6.5 % in contact and 5.2 % after the bounce.
  const std::vector<double> exact = RunIntoTheStop("{type: dopri5, rtol: 1.0e-12, atol: 1.0e-12}").energy;
  ASSERT_EQ(exact.size(), 200u);
  for (const Case& c : {Case{"{type: rk4, substeps: 10}", kRk4StopTol, kRk4StopAfterTol},
                        Case{"{type: dopri5}", kDopri5StopTol, kDopri5StopAfterTol},
                        Case{"{type: variational, substeps: 4}", kVariationalStopTol, kVariationalStopAfterTol}}) {
    const StopRun run = RunIntoTheStop(c.integrator, exact);
    EXPECT_LT(run.deepest, 0.1) << c.integrator;                 // the stop held: at most 0.1 rad into it
    EXPECT_LE(run.worst_energy, c.energy_gain) << c.integrator;  // at every tick, not only the last
    EXPECT_LE(run.worst_after, c.gain_after) << c.integrator;
    EXPECT_LT(std::abs(run.final_q), 1.0 + 1e-3) << c.integrator;  // bounced back out
  }
}

TEST(StiffCases, TheSameStopIsFaultedWithRk4AtOneMillisecond) {
  const Outcome o = RunScene(LimitScene("{type: rk4}"), 200);
  EXPECT_TRUE(o.faulted);
  EXPECT_TRUE(o.always_finite);
}

}  // namespace
}  // namespace lagrange
