// Instances built from the shipped scenes do what the scenes say; a step
// allocates nothing; controllers switch by name.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sim/instance.hpp"
#include "sim/offline.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<Instance> Load(const std::string& scene_file, double* period) {
  const Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/" + scene_file);
  *period = scene.period;
  std::vector<Instance> instances;
  for (const auto& c : scene.instances) instances.emplace_back(c);
  return instances;
}

double RunFor(std::vector<Instance>& instances, double period, double seconds, const StepObserver& observe = nullptr) {
  EXPECT_TRUE(RunOffline(
      instances, period, std::llround(seconds / period), observe ? observe : [](std::size_t, Instance&) {}));
  return seconds;
}

double OffUpright(const Instance& cartpole) { return std::abs(JointError(JointType::kRevolute, kPi, cartpole.q()[1])); }

TEST(ShippedScenes, DefaultArmHoldsItsPoseAndTheCartPoleBalances) {
  double period = 0;
  auto instances = Load("default.yaml", &period);
  ASSERT_EQ(instances.size(), 2u);
  const VectorXd arm_q0 = instances[0].q();
  double arm_drift = 0.0;
  RunFor(instances, period, 10.0, [&](std::size_t i, Instance& inst) {
    if (i == 0) arm_drift = std::max(arm_drift, (inst.q() - arm_q0).lpNorm<Eigen::Infinity>());
  });
  EXPECT_LT(arm_drift, 1e-9);
  EXPECT_EQ(instances[0].controller().name(), "computed-torque");
  EXPECT_EQ(instances[1].controller().name(), "lqr");
  EXPECT_LT(OffUpright(instances[1]), 1e-3);
  EXPECT_NEAR(instances[1].q()[0], 0.0, 0.05);
}

// One health rule for every offline stepper (lagrangectl simulate's scene controllers, lagrange.simulate's
// Python laws through a step function): a failed step stops that instance at its last healthy state, never
// observed again, and the others go on.
TEST(OfflineRun, AStepFunctionsFailureStopsItsInstanceAtItsLastHealthyState) {
  double period = 0;
  auto instances = Load("default.yaml", &period);
  std::vector<int> observed(2, 0);
  const std::vector<OfflineFault> faults = RunOfflineChecked(
      instances, period, 10, [&](std::size_t i, Instance&) { ++observed[i]; },
      [&](std::size_t i, Instance& inst) -> Instance::StepFailure {
        const Instance::StepFailure outcome = inst.Step(period);
        return i == 0 && inst.t() > 4.5 * period ? "injected" : outcome;
      });
  ASSERT_EQ(faults.size(), 1u);
  EXPECT_EQ(faults[0].index, 0u);
  EXPECT_STREQ(faults[0].reason, "injected");
  EXPECT_NEAR(faults[0].t, 5 * period, 1e-12);  // the time the failed step reached
  EXPECT_EQ(observed[0], 5);                    // t = 0 and its four healthy steps
  EXPECT_NEAR(instances[0].t(), 4 * period, 1e-12);
  EXPECT_EQ(observed[1], 11);
  EXPECT_NEAR(instances[1].t(), 10 * period, 1e-12);
}

TEST(ShippedScenes, TheArticlesGravityCompensationHoldsTheArm) {
  double period = 0;
  auto instances = Load("gravity_compensation.yaml", &period);
  const VectorXd q0 = instances[0].q();
  RunFor(instances, period, 3.0);
  EXPECT_LT((instances[0].q() - q0).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(ShippedScenes, CartPoleExerciseAndSwingUpEndUpright) {
  for (const char* file : {"cartpole_pd.yaml", "cartpole_swingup.yaml"}) {
    double period = 0;
    auto instances = Load(file, &period);
    RunFor(instances, period, 20.0);
    EXPECT_LT(OffUpright(instances[0]), 0.05) << file;
  }
}

TEST(ShippedScenes, SevenLinkChainTracksItsMinimumJerkMove) {
  double period = 0;
  auto instances = Load("chain7_minjerk.yaml", &period);
  Setpoint sp(7);
  double worst = 0.0;
  RunFor(instances, period, 4.0, [&](std::size_t, Instance& inst) {
    worst = std::max(worst, (inst.q_des() - inst.q()).lpNorm<Eigen::Infinity>());
  });
  instances[0].SampleTrajectory(sp);
  EXPECT_LT((sp.q - instances[0].q()).lpNorm<Eigen::Infinity>(), 1e-4);  // arrived
  EXPECT_LT(worst, 1e-2);                                                // and tracked on the way
  EXPECT_GT((sp.q - instances[0].config().q0).norm(), 1.0);              // it really moved
}

TEST(Instance, StepsAllocateNothingForEveryShippedScene) {
  for (const char* file : {"default.yaml", "gravity_compensation.yaml", "cartpole_swingup.yaml", "chain7_minjerk.yaml",
                           "pendulum.yaml", "effects_demo.yaml", "cartpole_pd.yaml"}) {
    double period = 0;
    auto instances = Load(file, &period);
    for (Instance& inst : instances) {
      Setpoint sp(inst.num_dofs());
      inst.Step(period);  // first step outside: nothing is lazily allocated, but be fair to warm caches
      testing::AllocationCounter counter;
      for (int k = 0; k < 100; ++k) {
        inst.SampleTrajectory(sp);
        inst.Step(period, sp);
      }
      inst.Reset();
      inst.Step(period);
      EXPECT_EQ(counter.count(), 0) << file << " " << inst.name();
    }
  }
}

TEST(Instance, SwitchesBetweenItsConfiguredControllersByName) {
  double period = 0;
  auto instances = Load("default.yaml", &period);
  Instance& arm = instances[0];
  EXPECT_EQ(arm.controller_names(),
            (std::vector<std::string>{"computed-torque", "pd", "gravity-compensation", "none"}));
  EXPECT_FALSE(arm.SelectController("pd"));
  EXPECT_EQ(arm.controller().name(), "pd");
  const auto err = arm.SelectController("lqr");
  ASSERT_TRUE(err);
  EXPECT_EQ(*err, "unknown controller 'lqr' for arm (available: computed-torque, pd, gravity-compensation, none)");
  EXPECT_EQ(arm.controller().name(), "pd");
  arm.Reset();
  EXPECT_EQ(arm.controller().name(), "computed-torque");
}

TEST(Instance, ResetReturnsToTheInitialStateAtTimeZero) {
  double period = 0;
  auto instances = Load("cartpole_swingup.yaml", &period);
  Instance& cp = instances[0];
  for (int k = 0; k < 500; ++k) cp.Step(period);
  EXPECT_GT(cp.q().norm(), 0.01);
  cp.Reset();
  EXPECT_EQ(cp.t(), 0.0);
  EXPECT_EQ(cp.q(), cp.config().q0);
  EXPECT_EQ(cp.qd(), cp.config().qd0);
}

// A state set from outside (Python's Instance.q = ...) is where the next step
// starts: the free pendulum set at (0.3, 0.5) moves as one that started
// there; ε runs on through the jump in energy (no work was done); nothing is
// allocated.
TEST(Instance, SetStateStartsTheNextStepThereAndTheEnergyBalanceRunsOn) {
  double period = 0;
  auto moved = Load("pendulum.yaml", &period);
  InstanceConfig config = moved[0].config();
  config.q0 = VectorXd::Constant(1, 0.3);
  config.qd0 = VectorXd::Constant(1, 0.5);
  Instance started(config);
  Instance& inst = moved[0];
  const VectorXd q = VectorXd::Constant(1, 0.3), qd = VectorXd::Constant(1, 0.5);
  {
    testing::AllocationCounter counter;
    inst.SetState(q, qd);
    EXPECT_EQ(counter.count(), 0);
  }
  EXPECT_EQ(inst.qdd(), started.qdd());
  for (int k = 0; k < 200; ++k) {
    inst.Step(period);
    started.Step(period);
  }
  EXPECT_EQ(inst.q(), started.q());
  EXPECT_EQ(inst.qd(), started.qd());
  // Mid-run: a jump of about 1 J in E, and ε where it was.
  for (int k = 0; k < 50; ++k) inst.Step(period);
  const double before = inst.energy_balance().residual();
  inst.SetState(inst.q().array() + 0.4, inst.qd().array() + 1.0);
  EXPECT_NEAR(inst.energy_balance().residual(), before, 1e-12);  // to rounding in E(0)'s move by the jump
  for (int k = 0; k < 50; ++k) inst.Step(period);
  EXPECT_NEAR(inst.energy_balance().residual(), before, 1e-6);
}

// A scene's arm under PD with the given integrator and `continuous` flag.
Instance ArmUnderPd(const std::string& integrator, bool continuous) {
  const std::string yaml =
      "period: 0.001\ninstances:\n  - name: arm\n    plant: {type: arm2}\n"
      "    integrator: {type: " +
      integrator +
      "}\n"
      "    controller: {type: pd, kp: [50, 50], kd: [5, 5], continuous: " +
      (continuous ? "true" : "false") + "}\n";
  const Scene scene = ParseScene(yaml, "test");
  return Instance(scene.instances.at(0));
}

TEST(Instance, AFaultNamesTheControllerWhenItsOutputWasNotFinite) {
  // A non-finite setpoint makes the law non-finite; dopri5 then also fails its
  // tolerance, but the cause reported is the controller, where it began.
  for (const char* integrator : {"rk4", "dopri5"}) {
    for (const bool continuous : {false, true}) {
      Instance arm = ArmUnderPd(integrator, continuous);
      Setpoint sp(2);
      sp.q << std::nan(""), 0.0;
      EXPECT_STREQ(arm.Step(0.001, sp), Instance::kControllerNotFinite) << integrator << " continuous " << continuous;
    }
  }
}

TEST(Instance, ContinuousControlAllocatesNothing) {
  for (const char* integrator : {"explicit-euler", "semi-implicit-euler", "rk4", "dopri5", "variational"}) {
    Instance arm = ArmUnderPd(integrator, true);
    Setpoint sp(2);
    sp.q << 0.1, -0.1;
    arm.Step(0.001, sp);
    int failures = 0;
    testing::AllocationCounter counter;
    for (int k = 0; k < 100; ++k) failures += arm.Step(0.001, sp) != nullptr;
    EXPECT_EQ(counter.count(), 0) << integrator;
    EXPECT_EQ(failures, 0) << integrator;
  }
}

TEST(Instance, AHealthyStepReportsNoFailure) {
  Instance arm = ArmUnderPd("dopri5", false);
  Setpoint sp(2);
  sp.q << 0.1, -0.1;
  EXPECT_EQ(arm.Step(0.001, sp), nullptr);
}

TEST(Instance, ResetRestoresTheScenesGainsChangedAtRunTime) {
  Instance arm = ArmUnderPd("rk4", false);
  const Gains scene = arm.controller().gains();
  Gains changed = scene;
  changed.kp *= 2.0;
  changed.kd *= 3.0;
  ASSERT_TRUE(arm.controller().SetGains(changed));
  ASSERT_NE(arm.controller().gains().kp, scene.kp);
  arm.Reset();
  EXPECT_EQ(arm.controller().gains().kp, scene.kp);
  EXPECT_EQ(arm.controller().gains().kd, scene.kd);
}

}  // namespace
}  // namespace lagrange
