// What a status says and how much of it fits (protocol/status.hpp): joint
// names from a status, each instance's share of status_t.joint_names, or none
// at all when the counts do not add up (never misattributed); an instance's
// reason for its mode, only for the mode it is given with; the descriptions
// lagranged writes; the size bound that keeps a status in one datagram.

#include "protocol/status.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include "plant/effects.hpp"
#include "plant/integrators.hpp"

namespace lagrange {
namespace {

status_t Status(std::vector<std::string> instances, std::vector<std::int32_t> dofs, std::vector<std::string> joints) {
  status_t s{};
  s.num_instances = static_cast<std::int32_t>(instances.size());
  s.instance_names = std::move(instances);
  s.instance_modes.assign(s.instance_names.size(), 0);
  s.instance_dofs = std::move(dofs);
  s.instance_reasons.assign(s.instance_names.size(), "");
  s.num_joints = static_cast<std::int32_t>(joints.size());
  s.joint_names = std::move(joints);
  return s;
}

TEST(JointNames, EachInstanceGetsItsShareInOrder) {
  const status_t s = Status({"arm", "pole"}, {2, 1}, {"shoulder", "elbow", "hinge"});
  EXPECT_EQ(JointNamesByInstance(s), (std::vector<std::vector<std::string>>{{"shoulder", "elbow"}, {"hinge"}}));
  EXPECT_EQ(JointNamesIn(s, "pole"), std::vector<std::string>{"hinge"});
  EXPECT_TRUE(JointNamesIn(s, "other").empty());
}

// Σ instance_dofs ≠ num_joints: which names belong to which instance is not
// known, so none are given (rather than the first instance's taking them).
TEST(JointNames, CountsThatDoNotAddUpAttributeNoNames) {
  EXPECT_TRUE(JointNamesByInstance(Status({"arm", "pole"}, {2, 1}, {"a", "b", "c", "d"})).empty());
  EXPECT_TRUE(JointNamesByInstance(Status({"arm", "pole"}, {2, 2}, {"a", "b", "c"})).empty());
  EXPECT_TRUE(JointNamesIn(Status({"arm", "pole"}, {1, 1}, {"a", "b", "c"}), "arm").empty());
  EXPECT_TRUE(JointNamesByInstance(Status({"arm"}, {-1}, {})).empty());
  status_t wrong_count = Status({"arm"}, {1}, {"a"});
  wrong_count.num_joints = 2;
  EXPECT_TRUE(JointNamesByInstance(wrong_count).empty());
}

TEST(JointNames, NamesAreEscapedForPrinting) {
  EXPECT_EQ(JointNamesIn(Status({"arm"}, {1}, {"bad\nname"}), "arm"), std::vector<std::string>{"bad\\nname"});
}

// A status is sent at 10 Hz, a state every tick: a reason is shown only
// beside the mode the status gives it for, and escaped.
TEST(ModeReasons, AReasonIsGivenOnlyForItsOwnModeAndEscaped) {
  status_t s = Status({"arm", "plant"}, {2, 2}, {});
  s.instance_modes = {state_t::MODE_HOLD, state_t::MODE_STOPPED};
  s.instance_reasons = {"streamed torques timed out (torque_timeout)", "late\x1b[2J"};
  EXPECT_EQ(ModeReasonIn(s, "arm", state_t::MODE_HOLD), "streamed torques timed out (torque_timeout)");
  EXPECT_EQ(ModeReasonIn(s, "arm", state_t::MODE_RUNNING), "");  // the state has moved on
  EXPECT_EQ(ModeReasonIn(s, "plant", state_t::MODE_STOPPED), "late\\x1b[2J");
  EXPECT_EQ(ModeReasonIn(s, "other", state_t::MODE_HOLD), "");
  s.instance_reasons.pop_back();  // fewer reasons than instances: none made up
  EXPECT_EQ(ModeReasonIn(s, "plant", state_t::MODE_STOPPED), "");
}

// A status lists every instance in one datagram, so lagranged refuses a
// scene with more instances than fit (service.cpp), and joint names are left
// out before that.
TEST(StatusSize, AStatusOfTwentyInstancesFitsAndOneOfAThousandDoesNot) {
  const auto names = [](int n) {
    std::vector<std::string> v;
    for (int i = 0; i < n; ++i) v.push_back("instance_" + std::to_string(i));
    return v;
  };
  EXPECT_TRUE(StatusFits(names(20), std::vector<std::int32_t>(20, 7), {}));
  EXPECT_FALSE(StatusFits(names(1000), std::vector<std::int32_t>(1000, 2), {}));
}

// The descriptions lagranged writes in a status (and lagrangectl watch shows).
TEST(StatusDescriptions, AnIntegratorIsDescribedByItsNameAndWhatItWasGiven) {
  IntegratorConfig c;
  EXPECT_EQ(IntegratorDescription(c, false), "rk4");
  c.substeps = 4;
  EXPECT_EQ(IntegratorDescription(c, false), "rk4 x4");
  c = IntegratorConfig{};
  c.type = IntegratorType::kDormandPrince;
  c.max_steps = 200;
  EXPECT_EQ(IntegratorDescription(c, false), "dopri5 rtol=1e-08 atol=1e-10 max_steps=200");
  c.rtol = 1.5e-6;
  c.substeps = 2;
  EXPECT_EQ(IntegratorDescription(c, false), "dopri5 rtol=1.5e-06 atol=1e-10 max_steps=200 x2");
  EXPECT_EQ(IntegratorDescription(c, true), "none");  // an external plant integrates nothing
}

// A plant MuJoCo steps: MuJoCo's integrator by its own name, whatever
// lagrange's nearest (which never runs) is; semi-implicit Euler is not
// called rk4, nor MuJoCo's implicit.
TEST(StatusDescriptions, AMujocoPlantsIntegratorIsMujocosByName) {
  IntegratorConfig c;  // rk4: what the scene loader sets for MuJoCo's implicit
  EXPECT_EQ(IntegratorDescription(c, false, MujocoIntegrator::kImplicit), "mujoco-implicit");
  EXPECT_EQ(IntegratorName(c.type, false, MujocoIntegrator::kImplicit), "mujoco-implicit");
  c.type = IntegratorType::kSemiImplicitEuler;
  c.substeps = 4;
  EXPECT_EQ(IntegratorDescription(c, false, MujocoIntegrator::kEuler), "mujoco-euler x4");
  EXPECT_EQ(IntegratorName(c.type, false, MujocoIntegrator::kEuler), "mujoco-euler");
  EXPECT_EQ(IntegratorName(IntegratorType::kRk4, false, MujocoIntegrator::kRk4), "mujoco-rk4");
  EXPECT_EQ(IntegratorName(IntegratorType::kRk4, false), "rk4");  // lagrange's own
  EXPECT_EQ(IntegratorName(IntegratorType::kRk4, true), "none");
}

TEST(StatusDescriptions, TheEffectsOnAreListedInTheirOrder) {
  EffectFlags flags;
  EXPECT_EQ(EffectsDescription(flags), "");
  flags.friction = true;
  flags.gravity = true;
  EXPECT_EQ(EffectsDescription(flags), "gravity,friction");
}

TEST(Status, PercentilesAreNearestRankSamplesNeverInterpolations) {
  std::vector<double> v = {5.0, 1.0, 4.0, 2.0, 3.0};
  EXPECT_EQ(NearestRankPercentile(v, 0.5), 3.0);   // the 3rd smallest of 5
  EXPECT_EQ(NearestRankPercentile(v, 0.99), 5.0);  // ceil(4.95) = 5th
  EXPECT_EQ(NearestRankPercentile(v, 0.01), 1.0);  // below 1/n: the smallest
  std::vector<double> none;
  EXPECT_TRUE(std::isnan(NearestRankPercentile(none, 0.5)));
}

}  // namespace
}  // namespace lagrange
