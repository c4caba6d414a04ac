// The stance PD (controllers/stance_pd.hpp) on the Unitree A1 on its floating
// base (config/robots/a1.urdf): its gravity term is a static equilibrium
// over the feet in contact, G = Sᵀ tau_g + J_cᵀ λ, checked against the
// model's own G and foot Jacobians; in the air it adds nothing; its law
// allocates nothing.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "controllers/stance_pd.hpp"
#include "plant/floating_dynamics.hpp"
#include "plant/urdf.hpp"
#include "tests/support/alloc_counter.hpp"

namespace lagrange {
namespace {

constexpr int kJoints = 12;
constexpr double kEquilibriumTolerance = 1e-9;  // N or N·m, relative to m g (135 N)
const std::vector<std::string> kFourFeet = {"FR_foot", "FL_foot", "RR_foot", "RL_foot"};

std::shared_ptr<const FloatingDynamics> A1() {
  const UrdfRobot robot =
      LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/a1.urdf", UrdfOptions{.floating_base = true});
  return std::make_shared<const FloatingDynamics>(robot.tree);
}

VectorXd Posture() {
  VectorXd q(kJoints);
  for (int leg = 0; leg < 4; ++leg) q.segment<3>(3 * leg) << 0.0, 0.9, -1.8;
  return q;
}

// The base at `height` (m), turned by small roll, pitch, yaw (rad).
VectorXd Base(double height, double roll, double pitch, double yaw) {
  const Eigen::Quaterniond r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  VectorXd q(kFreeFlyerNq);
  q << 0.1, -0.2, height, r.x(), r.y(), r.z(), r.w();
  return q;
}

struct Stance {
  std::shared_ptr<const FloatingDynamics> model = A1();
  std::unique_ptr<StancePdController> controller;
  Setpoint setpoint{kJoints};
  VectorXd tau = VectorXd::Zero(kJoints);
  VectorXd base_v = VectorXd::Zero(kFreeFlyerNv), qd = VectorXd::Zero(kJoints);  // at rest

  explicit Stance(std::vector<std::string> feet, double kp = 0.0, double kd = 0.0) {
    StanceOptions options;
    options.on = true;
    options.feet = std::move(feet);
    controller = std::make_unique<StancePdController>(
        std::vector<JointType>(kJoints, JointType::kRevolute),
        VectorXd::Constant(kJoints, std::numeric_limits<double>::infinity()),
        Gains{VectorXd::Constant(kJoints, kp), VectorXd::Constant(kJoints, kd)}, true, options, model);
    setpoint.q = Posture();
  }
  bool Compute(const VectorXd& base_q, const VectorXd& q) {
    return controller->Compute(0.0, base_q, base_v, q, qd, setpoint, tau);
  }
  // G − Sᵀ tau − J_cᵀ λ (nv) at (base_q, q), with λ the controller's on `feet` (those in contact).
  VectorXd Residual(const VectorXd& base_q, const VectorXd& q, const std::vector<std::string>& feet) const {
    const std::unique_ptr<FloatingData> data = model->MakeData();
    VectorXd fq(model->num_q()), zero = VectorXd::Zero(model->num_v()), r(model->num_v());
    fq << base_q, q;
    model->ComputeInverseDynamics(*data, fq, zero, zero, DynamicsTerms{.gravity = true, .coriolis = false}, r);
    r.tail(kJoints) -= tau;
    const std::vector<std::string> frames = model->tree().frame_names();
    Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model->num_v());
    for (std::size_t i = 0; i < feet.size(); ++i) {
      const int f = static_cast<int>(std::find(frames.begin(), frames.end(), feet[i]) - frames.begin());
      model->ComputeFrameJacobian(*data, fq, f, J);
      r -= J.topRows<3>().transpose() * controller->contact_forces().segment<3>(3 * static_cast<Eigen::Index>(i));
    }
    return r;
  }
};

TEST(StancePd, FourFeetOnTheGroundCarryTheWeightInStaticEquilibrium) {
  Stance s(kFourFeet);
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> tilt(-0.05, 0.05);
  // Standing: the trunk 2 × 0.2 cos(0.9) + 0.02 m up, so the foot spheres' centres are 0.02 m up (within 0.03).
  const double height = 2 * 0.2 * std::cos(0.9) + 0.02;
  for (int trial = 0; trial < 10; ++trial) {
    const VectorXd base = Base(height, 0.1 * tilt(rng), 0.1 * tilt(rng), 10 * tilt(rng));
    VectorXd q = Posture();
    for (int j = 0; j < kJoints; ++j) q[j] += tilt(rng);
    ASSERT_TRUE(s.Compute(base, q));
    ASSERT_EQ(s.controller->contact_count(), 4);
    EXPECT_LT(s.Residual(base, q, kFourFeet).cwiseAbs().maxCoeff(), kEquilibriumTolerance);
    double weight = 0.0;
    for (int f = 0; f < 4; ++f) weight += s.controller->contact_forces()[3 * f + 2];
    EXPECT_NEAR(weight, 13.74 * 9.81, kEquilibriumTolerance);  // Σ λ_z = m g
  }
}

TEST(StancePd, TwoDiagonalFeetGiveTheLeastSquaresBalance) {
  const std::vector<std::string> feet = {"FR_foot", "RL_foot"};
  Stance s(feet);
  const double height = 2 * 0.2 * std::cos(0.9) + 0.02;
  const VectorXd base = Base(height, 0.02, -0.03, 0.3);
  ASSERT_TRUE(s.Compute(base, Posture()));
  ASSERT_EQ(s.controller->contact_count(), 2);
  // The joints' rows hold exactly; the base's residual is orthogonal to what the two feet can push (J_c,base λ's
  // range).
  const VectorXd r = s.Residual(base, Posture(), feet);
  EXPECT_LT(r.tail(kJoints).cwiseAbs().maxCoeff(), kEquilibriumTolerance);
  const std::unique_ptr<FloatingData> data = s.model->MakeData();
  VectorXd fq(s.model->num_q());
  fq << base, Posture();
  const std::vector<std::string> frames = s.model->tree().frame_names();
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, s.model->num_v());
  for (const std::string& foot : feet) {
    s.model->ComputeFrameJacobian(*data, fq,
                                  static_cast<int>(std::find(frames.begin(), frames.end(), foot) - frames.begin()), J);
    const Eigen::Vector3d along = J.topRows<3>().leftCols<kFreeFlyerNv>() * r.head<kFreeFlyerNv>();
    EXPECT_LT(along.cwiseAbs().maxCoeff(), kEquilibriumTolerance) << foot;
  }
}

TEST(StancePd, InTheAirOnlyThePdActs) {
  Stance s(kFourFeet, 50.0, 1.0);
  VectorXd q = Posture();
  q[1] += 0.1;  // an error of −0.1 rad on FR's thigh
  ASSERT_TRUE(s.Compute(Base(1.0, 0.0, 0.0, 0.0), q));
  EXPECT_EQ(s.controller->contact_count(), 0);
  VectorXd expected = VectorXd::Zero(kJoints);
  expected[1] = -50.0 * 0.1;
  EXPECT_LT((s.tau - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(StancePd, RefusesAnUnknownFootNamingTheRobotsFrames) {
  try {
    Stance s({"FR_foot", "paw"});
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("feet: expected frames of the robot (", 0), 0u) << what;
    EXPECT_NE(what.find("RL_foot"), std::string::npos) << what;
    EXPECT_NE(what.find("got 'paw'"), std::string::npos) << what;
  }
}

TEST(StancePd, TheLawAllocatesNothing) {
  Stance s(kFourFeet, 60.0, 2.0);
  const VectorXd base = Base(2 * 0.2 * std::cos(0.9) + 0.02, 0.01, 0.0, 0.0), air = Base(1.0, 0.0, 0.0, 0.0);
  const VectorXd q = Posture();
  testing::AllocationCounter counter;
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(s.Compute(k % 2 == 0 ? base : air, q));
  }
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace lagrange
