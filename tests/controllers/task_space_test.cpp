// The task-space controllers (controllers/task_space.hpp) on the shipped
// robots (config/robots/): the operational-space identities (J J̄ = I, the
// null-space projector annihilates task forces and does not accelerate the
// frame), the operational-space law gives the frame the acceleration it
// commands (by finite differences of the frame's twist), Cartesian impedance
// settles the Panda's hand at its target pose, the posture task holds the
// elbow while the hand is held, the UR5 follows a Cartesian circle and passes
// through its wrist singularity finite and within its torque limits, the gain
// bounds refuse too-stiff gains as the joint controllers do, and Compute
// allocates nothing.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "controllers/factory.hpp"
#include "plant/eigenvalues.hpp"
#include "plant/urdf.hpp"
#include "tests/controllers/closed_loop.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/plant_cases.hpp"

namespace lagrange {
namespace {

using testing::ClosedLoop;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTick = 1e-3;
constexpr double kIdentity = 1e-9;  // J J̄ = I and friends, relative to their terms' size

PlantSpec Robot(const std::string& name) {
  return UrdfPlantSpec(std::make_shared<const UrdfRobot>(
      LoadUrdf(std::string(LAGRANGE_SOURCE_DIR) + "/config/robots/" + name + ".urdf")));
}

// Poses well inside each robot's limits, away from singular configurations.
VectorXd PandaPose() { return (VectorXd(7) << 0.3, -0.5, -0.2, -2.0, 0.1, 1.6, 0.6).finished(); }
VectorXd Ur5Pose() { return (VectorXd(6) << 0.2, -1.3, 1.4, -1.6, -1.5, 0.3).finished(); }

VectorXd Unlimited(int n) { return VectorXd::Constant(n, kInf); }

// A task-space config with gains per task axis: translational then rotational.
ControllerConfig TaskConfig(ControllerType type, const VectorXd& q0, double kp_lin, double kp_ang, double kd_lin,
                            double kd_ang) {
  ControllerConfig c;
  c.type = type;
  c.q0 = q0;
  c.period = kTick;
  c.gains.kp = (VectorXd(6) << kp_lin, kp_lin, kp_lin, kp_ang, kp_ang, kp_ang).finished();
  if (kd_lin >= 0.0) c.gains.kd = (VectorXd(6) << kd_lin, kd_lin, kd_lin, kd_ang, kd_ang, kd_ang).finished();
  return c;
}

TaskSpaceController& TaskOf(Controller& c) { return dynamic_cast<TaskSpaceController&>(c); }

// The frame's pose at q (n), computed apart from any controller.
Pose FramePose(const PlantSpec& plant, const std::string& frame, const VectorXd& q) {
  const Kinematics kin(MakeRigidTree(plant));
  const std::unique_ptr<KinematicsData> data = kin.MakeData();
  kin.ComputeFrameKinematics(*data, q, VectorXd::Zero(q.size()));
  const int k = *FindTaskFrame(kin, frame);
  return Pose{data->position(k), Eigen::Quaterniond(data->rotation(k))};
}

// Position error (m) and orientation error (rad) of a pose against another.
double PositionError(const Pose& a, const Pose& b) { return PoseError(a, b).head<3>().norm(); }
double AngleError(const Pose& a, const Pose& b) { return PoseError(a, b).tail<3>().norm(); }

// The operational-space quantities at seeded random Panda states (n = 7, so
// the null space is one-dimensional): J J̄ = I (the dynamically consistent
// pseudo-inverse is a right inverse), Λ = (J M⁻¹ Jᵀ)⁻¹, P Jᵀ F = 0 (no task
// force survives the projector), and J M⁻¹ P τ0 = 0 (a projected torque does
// not accelerate the frame), for random F and τ0.
TEST(TaskSpace, OperationalSpaceIdentitiesHoldAwayFromSingularities) {
  const PlantSpec panda = Robot("panda");
  const auto dynamics = MakeDynamics(panda, Method::kRecursive);
  const Kinematics kin(MakeRigidTree(panda));
  const auto kdata = kin.MakeData();
  const auto ddata = dynamics->MakeData();
  const int n = 7, frame = kin.num_frames() - 1;
  OperationalSpace os(n, SingularityDamping{});
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  MatrixXd M(n, n);
  for (int k = 0; k < 20; ++k) {
    VectorXd q = PandaPose();
    for (int i = 0; i < n; ++i) q[i] += u(rng);
    kin.ComputeFrameKinematics(*kdata, q, VectorXd::Zero(n));
    dynamics->ComputeMassMatrix(*ddata, q, M);
    const Matrix6Xd& J = kdata->jacobian(frame, FrameAxes::kWorldAligned);
    ASSERT_TRUE(os.Compute(M, J));
    ASSERT_GT(os.smallest_singular_value(), SingularityDamping{}.threshold);
    EXPECT_EQ(os.damping(), 0.0);
    const MatrixXd Jbar = os.DynamicallyConsistentInverse();
    EXPECT_LE((J * Jbar - Matrix6d::Identity()).norm(), kIdentity);
    const Matrix6d A = J * M.inverse() * J.transpose();
    EXPECT_LE((os.inertia() * A - Matrix6d::Identity()).norm(), kIdentity);
    Vector6d F;
    VectorXd tau0(n), out(n);
    for (int i = 0; i < 6; ++i) F[i] = 100.0 * u(rng);
    for (int i = 0; i < n; ++i) tau0[i] = 100.0 * u(rng);
    const VectorXd task = J.transpose() * F;
    os.ProjectToNullSpace(J, task, out);
    EXPECT_LE(out.norm(), kIdentity * task.norm());
    os.ProjectToNullSpace(J, tau0, out);
    EXPECT_LE((J * M.inverse() * out).norm(), kIdentity * (J * M.inverse() * tau0).norm());
    EXPECT_GT(out.norm(), 1e-3 * tau0.norm());  // and the null space is there (n = 7)
  }
}

// With an exact model (and no torque limits) the operational-space law makes
// the frame accelerate as commanded, ẍ = ẍ_d + Kd ė + Kp e: checked against
// the frame's twist differenced along the plant's own motion,
// ẍ ≈ (J(q₊) q̇₊ − J(q₋) q̇₋)/2δ with (q±, q̇±) = (q ± δ q̇ + ½δ² q̈, q̇ ± δ q̈),
// q̈ the plant's forward dynamics under the law's torque. Not just J q̈: this
// also checks the bias J̇ q̇ the law subtracts.
TEST(TaskSpace, OperationalSpaceLawGivesTheFrameTheAccelerationItCommands) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  ControllerConfig c = TaskConfig(ControllerType::kOperationalSpace, PandaPose(), 100.0, 80.0, 20.0, 18.0);
  auto controller = MakeController(c, panda, Unlimited(n));
  TaskSpaceController& task = TaskOf(*controller);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto dynamics = MakeDynamics(panda, Method::kRecursive);
  const auto ddata = dynamics->MakeData();
  const Kinematics kin(MakeRigidTree(panda));
  const auto kdata = kin.MakeData();
  const int frame = task.frame();
  auto twist = [&](const VectorXd& q, const VectorXd& qd) -> Vector6d {
    kin.ComputeFrameKinematics(*kdata, q, qd);
    return kdata->jacobian(frame, FrameAxes::kWorldAligned) * qd;
  };
  for (int k = 0; k < 5; ++k) {
    VectorXd q = PandaPose(), qd(n), tau(n), qdd(n);
    for (int i = 0; i < n; ++i) {
      q[i] += 0.1 * u(rng);
      qd[i] = 0.5 * u(rng);
    }
    // A target off the measured pose, moving, accelerating.
    PoseSetpoint target;
    target.pose = FramePose(panda, "", PandaPose());
    for (int i = 0; i < 6; ++i) {
      target.twist[i] = 0.2 * u(rng);
      target.acceleration[i] = u(rng);
    }
    task.SetPoseTarget(target);
    ASSERT_TRUE(controller->Compute(0.0, q, qd, Setpoint(n), tau));
    dynamics->ComputeForwardDynamics(*ddata, q, qd, tau, DynamicsTerms{}, qdd);
    const double d = 1e-5;
    const Vector6d xdd =
        (twist(q + d * qd + 0.5 * d * d * qdd, qd + d * qdd) - twist(q - d * qd + 0.5 * d * d * qdd, qd - d * qdd)) /
        (2.0 * d);
    const Vector6d commanded = target.acceleration + c.gains.kd.cwiseProduct(task.commanded().twist - twist(q, qd)) +
                               c.gains.kp.cwiseProduct(task.pose_error());
    EXPECT_LE((xdd - commanded).norm(), 1e-5 * commanded.norm())
        << "xdd " << xdd.transpose() << "\ncommanded " << commanded.transpose();
  }
}

// At rest on its target, with the posture task off, the impedance law is
// gravity compensation; displaced from it, the law adds Jᵀ K e; and the
// default target holds the pose the frame has when the controller starts.
TEST(TaskSpace, ImpedanceAtRestIsGravityPlusTheSpringsForceThroughJTranspose) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  const VectorXd q0 = PandaPose(), zero = VectorXd::Zero(n);
  auto controller =
      MakeController(TaskConfig(ControllerType::kCartesianImpedance, q0, 500.0, 40.0, -1, -1), panda, Unlimited(n));
  TaskSpaceController& task = TaskOf(*controller);
  EXPECT_EQ(task.frame_name(), "panda_link8");  // the last frame: the default
  VectorXd tau(n);
  ASSERT_TRUE(controller->Compute(0.0, q0, zero, Setpoint(n), tau));
  const VectorXd G = testing::GravityOf(panda, Method::kRecursive, q0);
  EXPECT_LE((tau - G).norm(), 1e-9 * G.norm());
  EXPECT_LE(task.pose_error().norm(), 1e-12);
  EXPECT_LE(PoseError(task.commanded().pose, FramePose(panda, "panda_link8", q0)).norm(), 1e-12);
  // Elsewhere, the same target: τ − G = Jᵀ K e.
  VectorXd q = q0;
  q[3] += 0.05;
  q[5] -= 0.05;
  ASSERT_TRUE(controller->Compute(kTick, q, zero, Setpoint(n), tau));
  const Kinematics kin(MakeRigidTree(panda));
  const auto kdata = kin.MakeData();
  kin.ComputeFrameKinematics(*kdata, q, zero);
  const Matrix6Xd& J = kdata->jacobian(task.frame(), FrameAxes::kWorldAligned);
  const Vector6d e = PoseError(FramePose(panda, "panda_link8", q0), FramePose(panda, "panda_link8", q));
  EXPECT_LE((task.pose_error() - e).norm(), 1e-12);
  const VectorXd expected =
      testing::GravityOf(panda, Method::kRecursive, q) + J.transpose() * controller->gains().kp.cwiseProduct(e);
  EXPECT_LE((tau - expected).norm(), 1e-9 * expected.norm());
}

// D_i = 2 ζ sqrt(K_i Λ_ii(q0)) when the config gives no damping.
TEST(TaskSpace, DefaultImpedanceDampingIsTheDampingRatioOverTheTaskInertia) {
  const PlantSpec panda = Robot("panda");
  ControllerConfig c = TaskConfig(ControllerType::kCartesianImpedance, PandaPose(), 500.0, 40.0, -1, -1);
  c.task.damping_ratio = 0.7;
  auto controller = MakeController(c, panda, Unlimited(7));
  const auto dynamics = MakeDynamics(panda, Method::kRecursive);
  const Kinematics kin(MakeRigidTree(panda));
  const Matrix6d lambda = TaskInertiaAt(*dynamics, kin, kin.num_frames() - 1, PandaPose(), SingularityDamping{});
  const Vector6d expected = 2.0 * 0.7 * (c.gains.kp.cwiseProduct(lambda.diagonal())).cwiseSqrt();
  EXPECT_LE((controller->gains().kd - expected).norm(), 1e-12 * expected.norm());
}

// The acceptance case: the Panda's hand 5 cm and 0.15 rad from its target
// pose at rest, under Cartesian impedance (K = 600 N/m, 50 N·m/rad, critically
// damped at q0) with the posture task, an exact model and the URDF's torque
// limits. The task's slowest mode, sqrt(K/Λ) ≈ 8 rad/s along the heaviest
// axis (Λ_xx ≈ 9.5 kg), decays as e^{−8t}(1 + 8t): from 5 cm below 0.1 mm
// by t ≈ 1.1 s. After 4 s: within 0.1 mm and 1 mrad.
TEST(TaskSpace, CartesianImpedancePandaSettlesAtItsTargetPose) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  ControllerConfig c = TaskConfig(ControllerType::kCartesianImpedance, PandaPose(), 600.0, 50.0, -1, -1);
  c.task.null_space.kp = VectorXd::Constant(n, 10.0);
  c.task.null_space.kd = VectorXd::Constant(n, 2.0);
  const Pose start = FramePose(panda, "", PandaPose());
  Pose target = start;
  target.position += Eigen::Vector3d(0.03, -0.03, 0.03);
  target.orientation = ExpMap(Eigen::Vector3d(0.1, -0.05, 0.1)) * start.orientation;
  c.task.trajectory.target = target;
  const VectorXd limits = (VectorXd(7) << 87, 87, 87, 87, 12, 12, 12).finished();
  ClosedLoop loop(panda, MakeController(c, panda, limits), PandaPose());
  TaskSpaceController& task = TaskOf(*loop.controller);
  ASSERT_TRUE(loop.Run(4.0, kTick));
  EXPECT_LT(PositionError(target, task.pose()), 1e-4);
  EXPECT_LT(AngleError(target, task.pose()), 1e-3);
  // And the plant agrees, measured apart from the controller.
  const Pose reached = FramePose(panda, "", loop.q);
  EXPECT_LT(PositionError(target, reached), 1e-4);
  EXPECT_LT(AngleError(target, reached), 1e-3);
  EXPECT_LT(loop.qd.norm(), 1e-3);
}

// Hold the hand where it is (K = 1000 N/m, 60 N·m/rad) and push joint 3
// with 1 N·m for 0.1 s: mostly the redundant Panda's self-motion, which
// moves the elbow (panda_link4) and not the hand. With the posture task
// (k_ns = 20 N·m/rad, d_ns = 4 N·m·s/rad) the arm returns to its posture
// within about a second; without it the self-motion is undamped (J q̇ = 0:
// the task's damping never sees it) and the elbow keeps drifting, about
// 0.3 m in 4 s. The hand stays within 2 mm in both.
TEST(TaskSpace, NullSpacePostureHoldsTheElbowWhileTheHandIsHeld) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  const Pose hand = FramePose(panda, "", PandaPose());
  const Pose elbow = FramePose(panda, "panda_link4", PandaPose());
  EffectsConfig push;
  VectorXd shove = VectorXd::Zero(n);
  shove[2] = 1.0;
  push.disturbance.push_back(Push{0.1, 0.1, shove});
  struct Outcome {
    double elbow_moved, hand_error, posture_error;
  };
  auto run = [&](bool posture) {
    ControllerConfig c = TaskConfig(ControllerType::kCartesianImpedance, PandaPose(), 1000.0, 60.0, -1, -1);
    if (posture) {
      c.task.null_space.kp = VectorXd::Constant(n, 20.0);
      c.task.null_space.kd = VectorXd::Constant(n, 4.0);
    }
    ClosedLoop loop(panda, MakeController(c, panda, Unlimited(n)), PandaPose(), push);
    double hand_error = 0.0;
    EXPECT_TRUE(loop.Run(4.0, kTick, nullptr, [&](double) {
      hand_error = std::max(hand_error, PositionError(hand, FramePose(panda, "", loop.q)));
    }));
    return Outcome{PositionError(elbow, FramePose(panda, "panda_link4", loop.q)), hand_error,
                   (loop.q - PandaPose()).cwiseAbs().maxCoeff()};
  };
  const Outcome held = run(true), free = run(false);
  EXPECT_LT(held.elbow_moved, 1e-4) << "elbow " << held.elbow_moved << " m";
  EXPECT_LT(held.posture_error, 1e-3);
  EXPECT_GT(free.elbow_moved, 0.1) << "elbow " << free.elbow_moved << " m";
  for (const Outcome& o : {held, free}) EXPECT_LT(o.hand_error, 2e-3);
}

// The UR5 (6 joints: no null space) under operational-space control follows
// a Cartesian circle of radius 0.1 m at 0.25 Hz (0.157 m/s), horizontal,
// started from rest over a 1 s ramp, with Kp = 400 1/s², Kd = 40 1/s
// (critically damped at 20 rad/s), an exact model and the URDF's effort
// limits. The feed-forward ẍ_d and ẋ_d leave only the zero-order hold's
// error, the torque's change over a tick against the law's stiffness:
// measured 5.7e-6 m and 3.5e-5 rad at worst over 8 s (two turns). Bounds
// 5e-5 m and 2e-4 rad; and the path stays within 0.1 mm of the circle.
TEST(TaskSpace, OperationalSpaceUr5TracksACartesianCircle) {
  const PlantSpec ur5 = Robot("ur5");
  const VectorXd limits = (VectorXd(6) << 150, 150, 150, 28, 28, 28).finished();
  ControllerConfig c = TaskConfig(ControllerType::kOperationalSpace, Ur5Pose(), 400.0, 400.0, 40.0, 40.0);
  c.task.trajectory.type = PoseTrajectory::Type::kCircle;
  c.task.trajectory.center = Eigen::Vector3d(0.0, 0.1, 0.0);
  c.task.trajectory.frequency = 0.25;
  c.task.trajectory.ramp = 1.0;
  ClosedLoop loop(ur5, MakeController(c, ur5, limits), Ur5Pose());
  TaskSpaceController& task = TaskOf(*loop.controller);
  const Pose start = FramePose(ur5, "", Ur5Pose());
  const Eigen::Vector3d center = start.position + c.task.trajectory.center;
  double position = 0.0, angle = 0.0, off_circle = 0.0, travelled = 0.0;
  ASSERT_TRUE(loop.Run(8.0, kTick, nullptr, [&](double) {
    position = std::max(position, task.pose_error().head<3>().norm());
    angle = std::max(angle, task.pose_error().tail<3>().norm());
    const Pose p = FramePose(ur5, "", loop.q);
    const Eigen::Vector3d r = p.position - center;
    off_circle = std::max(off_circle, std::hypot(std::hypot(r.x(), r.y()) - 0.1, r.z()));
    travelled = std::max(travelled, (p.position - start.position).norm());
  }));
  EXPECT_LT(position, 5e-5);
  EXPECT_LT(angle, 2e-4);
  EXPECT_LT(off_circle, 1e-4);
  EXPECT_GT(travelled, 0.199);  // across the circle: its diameter
}

// From q5 = 0.25 to the pose at q5 = −0.25 (the other joints alike) on a
// straight minimum-jerk path over 2 s, the UR5 passes through its wrist
// singularity (q5 = 0: joints 4 and 6 aligned, σmin(J) → 0; measured 2.7e-5).
// With the damped least squares the law stays finite, its torque within a
// third of the effort limits and the joints below 5 rad/s, and it arrives.
// Without (ε = 1e-9: λ = 0 everywhere) the same passage saturates the wrist's
// torque and spins it up to ~40 rad/s.
TEST(TaskSpace, Ur5ThroughItsWristSingularityStaysFiniteBoundedAndWithinTorqueLimits) {
  const PlantSpec ur5 = Robot("ur5");
  const VectorXd limits = (VectorXd(6) << 150, 150, 150, 28, 28, 28).finished();
  VectorXd q0 = Ur5Pose(), q1 = Ur5Pose();
  q0[4] = 0.25;
  q1[4] = -0.25;
  struct Outcome {
    double torque_fraction = 0.0, speed = 0.0, sigma = kInf, arrived = kInf;
  };
  auto run = [&](double threshold) {
    ControllerConfig c = TaskConfig(ControllerType::kOperationalSpace, q0, 100.0, 100.0, 20.0, 20.0);
    c.task.trajectory.type = PoseTrajectory::Type::kMinimumJerk;
    c.task.trajectory.target = FramePose(ur5, "", q1);
    c.task.trajectory.duration = 2.0;
    c.task.singularity.threshold = threshold;
    ClosedLoop loop(ur5, MakeController(c, ur5, limits), q0);
    TaskSpaceController& task = TaskOf(*loop.controller);
    Outcome o;
    EXPECT_TRUE(loop.Run(4.0, kTick, nullptr, [&](double) {
      EXPECT_TRUE(loop.tau.allFinite() && loop.q.allFinite());
      o.torque_fraction = std::max(o.torque_fraction, loop.tau.cwiseAbs().cwiseQuotient(limits).maxCoeff());
      o.speed = std::max(o.speed, loop.qd.cwiseAbs().maxCoeff());
      o.sigma = std::min(o.sigma, task.operational_space().smallest_singular_value());
    }));
    o.arrived = task.pose_error().norm();
    return o;
  };
  const Outcome damped = run(SingularityDamping{}.threshold), undamped = run(1e-9);
  EXPECT_LT(damped.sigma, 1e-3);  // it did pass the singularity
  EXPECT_LE(damped.torque_fraction, 0.5);
  EXPECT_LT(damped.speed, 5.0);
  EXPECT_LT(damped.arrived, 1e-9);
  EXPECT_GE(undamped.torque_fraction, 1.0);  // saturated: the limits were all that held it
  EXPECT_GT(undamped.speed, 4.0 * damped.speed);
}

// MoveTo starts a minimum-jerk move from the measured pose at the next
// Compute (not from the previous target) and arrives; Reset goes back to the
// scene's trajectory (here: hold) from wherever the frame then is.
TEST(TaskSpace, MoveToStartsFromTheMeasuredPoseAndResetHoldsWhereTheFrameIs) {
  const PlantSpec ur5 = Robot("ur5");
  ControllerConfig c = TaskConfig(ControllerType::kOperationalSpace, Ur5Pose(), 400.0, 400.0, 40.0, 40.0);
  ClosedLoop loop(ur5, MakeController(c, ur5, Unlimited(6)), Ur5Pose());
  TaskSpaceController& task = TaskOf(*loop.controller);
  ASSERT_TRUE(loop.Run(0.1, kTick));
  Pose target = task.pose();
  target.position += Eigen::Vector3d(-0.05, 0.05, 0.1);
  target.orientation = ExpMap(Eigen::Vector3d(0.0, 0.3, 0.0)) * target.orientation;
  task.MoveTo(target, 1.0);
  const Pose before = FramePose(ur5, "", loop.q);
  ASSERT_TRUE(loop.Run(kTick, kTick));
  EXPECT_LT(PositionError(task.commanded().pose, before), 1e-12);  // the first sample: where it was
  ASSERT_TRUE(loop.Run(2.0, kTick));
  EXPECT_LT(PoseError(target, task.pose()).norm(), 1e-6);
  loop.qd.setConstant(0.05);  // moving when reset
  task.Reset();
  const Pose at_reset = FramePose(ur5, "", loop.q);
  ASSERT_TRUE(loop.Run(kTick, kTick));
  EXPECT_LT(PoseError(task.commanded().pose, at_reset).norm(), 1e-12);
}

// The largest gains the tick allows (the corner of the task box) hold the
// Panda's hand 1 cm off its target without a fault, and ten times a bound is
// refused: by the scene check, by the factory, by SetGains (which leaves the
// gains as they were) and CheckGains (a gain command), all with the joint
// controllers' message naming the bound and its rule. The impedance box keeps
// ρ(Λ⁻¹K) h² <= 1 and ρ(Λ⁻¹D) h <= 2 at q0, as the joint PD's does for M.
TEST(TaskSpace, TheLargestAllowedTaskGainsRunAndTenTimesTheBoundIsRefused) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  for (ControllerType type : {ControllerType::kCartesianImpedance, ControllerType::kOperationalSpace}) {
    ControllerConfig c = TaskConfig(type, PandaPose(), 0.0, 0.0, 0.0, 0.0);
    const GainBounds bounds = ComputeGainBounds(c, panda);
    ASSERT_EQ(bounds.num_dofs(), 6);
    EXPECT_TRUE(bounds.task_axes);
    if (type == ControllerType::kCartesianImpedance) {
      const auto dynamics = MakeDynamics(panda, Method::kRecursive);
      const Kinematics kin(MakeRigidTree(panda));
      const Matrix6d lambda_inv =
          TaskInertiaAt(*dynamics, kin, kin.num_frames() - 1, PandaPose(), SingularityDamping{}).inverse();
      auto spectral_radius = [&](const VectorXd& k) {  // of Λ⁻¹ diag(k), via K^½ Λ⁻¹ K^½
        const Matrix6d S = k.cwiseSqrt().asDiagonal() * lambda_inv * k.cwiseSqrt().asDiagonal();
        return SymmetricEigenvalues(S).maxCoeff();
      };
      EXPECT_NEAR(spectral_radius(bounds.kp_max) * kTick * kTick, 1.0, 1e-9);
      EXPECT_NEAR(spectral_radius(bounds.kd_max) * kTick, 2.0, 1e-9);
    } else {
      EXPECT_EQ(bounds.kp_max, VectorXd::Constant(6, 1e6));
      EXPECT_EQ(bounds.kd_max, VectorXd::Constant(6, 2e3));
    }
    c.gains = {bounds.kp_max, bounds.kd_max};
    ASSERT_FALSE(ValidateController(c, panda)) << ToString(type);
    ClosedLoop loop(panda, MakeController(c, panda, Unlimited(n)), PandaPose());
    TaskSpaceController& task = TaskOf(*loop.controller);
    PoseSetpoint target;
    target.pose = FramePose(panda, "", PandaPose());
    target.pose.position.z() += 0.01;
    task.SetPoseTarget(target);
    ASSERT_TRUE(loop.Run(1.0, kTick)) << ToString(type);
    EXPECT_LT(task.pose_error().norm(), 1e-3) << ToString(type);
    for (const bool kd : {false, true}) {
      Gains ten_times = {bounds.kp_max, bounds.kd_max};
      (kd ? ten_times.kd : ten_times.kp)[4] *= 10.0;
      c.gains = ten_times;
      const std::optional<std::string> err = ValidateController(c, panda);
      ASSERT_TRUE(err) << ToString(type);
      EXPECT_EQ(err->rfind(kd ? "kd[4]: expected |gain| <= " : "kp[4]: expected |gain| <= ", 0), 0u) << *err;
      const std::string rule = kd ? bounds.kd_rule : bounds.kp_rule;
      EXPECT_NE(err->find(" (" + rule + ")"), std::string::npos) << *err;
      const char* expected_rule = type == ControllerType::kOperationalSpace ? (kd ? "Kd·h <= 2" : "Kp·h² <= 1")
                                  : kd                                      ? "D_i·h·c/Λ_ii <= 2"
                                                                            : "K_i·h²·c/Λ_ii <= 1";
      EXPECT_EQ(rule.rfind(expected_rule, 0), 0u) << rule;
      try {
        MakeController(c, panda, Unlimited(n));
        ADD_FAILURE() << "built with " << *err;
      } catch (const std::invalid_argument& e) {
        EXPECT_EQ(e.what(), *err);
      }
      EXPECT_EQ(CheckGains(type, ten_times, loop.controller->gain_bounds()), err);
      EXPECT_FALSE(loop.controller->SetGains(ten_times));
      EXPECT_EQ(loop.controller->gains().kp, bounds.kp_max);
    }
    EXPECT_EQ(*CheckGains(type, n, Gains{VectorXd::Ones(n), VectorXd::Ones(n)}),
              "kp: expected 6 gains (one per task axis: x, y, z, rx, ry, rz), got 7");
    EXPECT_TRUE(loop.controller->SetGains(Gains{bounds.kp_max / 2, bounds.kd_max / 2}));
  }
}

// The posture task's gains are a joint PD's, bounded as its (ComputeGainBounds
// for pd), and named under null_space.
TEST(TaskSpace, NullSpaceGainsAreBoundedAsTheJointPd) {
  const PlantSpec panda = Robot("panda");
  ControllerConfig c = TaskConfig(ControllerType::kCartesianImpedance, PandaPose(), 500.0, 40.0, -1, -1);
  const GainBounds pd = ComputeGainBounds(ControllerType::kPd, panda, PandaPose(), kTick);
  c.task.null_space.kp = pd.kp_max;
  ASSERT_FALSE(ValidateController(c, panda));
  c.task.null_space.kp[6] *= 1e3;  // beyond both of the PD's boxes
  const std::optional<std::string> err = ValidateController(c, panda);
  ASSERT_TRUE(err);
  EXPECT_EQ(err->rfind("null_space.kp[6]: expected |gain| <= ", 0), 0u) << *err;
  c.task.null_space.kp = VectorXd::Ones(6);
  EXPECT_EQ(*ValidateController(c, panda), "null_space.kp: expected 7 gains (one per joint), got 6");
  c.task.null_space.kp = VectorXd::Ones(7);
  c.task.null_space.posture = VectorXd::Zero(3);
  EXPECT_EQ(*ValidateController(c, panda), "null_space.posture: expected 7 finite values (one per joint)");
}

// A frame the robot does not have, a robot of fewer than 6 joints, a
// trajectory without a target: refused with the key and what was expected.
TEST(TaskSpace, RefusesAFrameTheRobotLacksARobotTooSmallAndAMoveWithoutATarget) {
  const PlantSpec panda = Robot("panda");
  ControllerConfig c = TaskConfig(ControllerType::kOperationalSpace, PandaPose(), 100.0, 100.0, 20.0, 20.0);
  c.task.frame = "panda_hand";
  EXPECT_EQ(*ValidateController(c, panda),
            "frame: expected a frame of the robot (panda_link0, panda_link1, panda_link2, panda_link3, panda_link4, "
            "panda_link5, panda_link6, panda_link7, panda_link8), got 'panda_hand'");
  c.task.frame = "panda_link4";
  EXPECT_FALSE(ValidateController(c, panda));
  EXPECT_EQ(TaskOf(*MakeController(c, panda, Unlimited(7))).frame_name(), "panda_link4");
  c.task.trajectory.type = PoseTrajectory::Type::kMinimumJerk;
  EXPECT_EQ(*ValidateController(c, panda),
            "trajectory.target: expected the pose to move to (position and orientation)");
  c.task.trajectory = PoseTrajectoryConfig{};
  c.task.singularity.threshold = 0.0;
  EXPECT_EQ(*ValidateController(c, panda),
            "singularity.threshold: expected a positive number (σmin(J) below which damping ramps in)");
  ControllerConfig arm = TaskConfig(ControllerType::kCartesianImpedance, VectorXd::Zero(2), 100.0, 10.0, -1, -1);
  EXPECT_EQ(*ValidateController(arm, DefaultPlantSpec(PlantType::kArm2)),
            "type: cartesian-impedance needs a robot of at least 6 joints (a frame's 6-D pose), got 2");
}

// Compute, with the posture task on, and every command between computes
// (a streamed target, a move, a trajectory, a reset, new gains) allocate
// nothing, for both laws.
TEST(TaskSpace, ComputeAndTargetCommandsAllocateNothing) {
  const PlantSpec panda = Robot("panda");
  const int n = 7;
  for (ControllerType type : {ControllerType::kCartesianImpedance, ControllerType::kOperationalSpace}) {
    ControllerConfig c = TaskConfig(type, PandaPose(), 200.0, 20.0, 20.0, 1.0);
    c.task.null_space.kp = VectorXd::Constant(n, 10.0);
    c.task.null_space.kd = VectorXd::Constant(n, 1.0);
    auto controller = MakeController(c, panda, Unlimited(n));
    TaskSpaceController& task = TaskOf(*controller);
    const Gains gains = controller->gains();
    PoseTrajectoryConfig circle;
    circle.type = PoseTrajectory::Type::kCircle;
    PoseSetpoint target;
    target.pose = FramePose(panda, "", PandaPose());
    VectorXd q = PandaPose(), qd = VectorXd::Constant(n, 0.1), tau(n);
    const Setpoint sp(n);
    bool ok = true;
    std::int64_t allocations = 0;
    {
      testing::AllocationCounter counter;
      for (int k = 0; k < 100; ++k) {
        switch (k % 20) {
          case 3: task.SetPoseTarget(target); break;
          case 7: task.MoveTo(target.pose, 0.5); break;
          case 11: task.StartTrajectory(circle); break;
          case 15: task.Reset(); break;
          case 17: ok = controller->SetGains(gains) && ok; break;
          default: break;
        }
        q[1] += 1e-4;
        ok = controller->Compute(k * kTick, q, qd, sp, tau) && ok;
      }
      allocations = counter.count();
    }
    EXPECT_EQ(allocations, 0) << ToString(type);
    EXPECT_TRUE(ok);
    EXPECT_TRUE(tau.allFinite());
  }
}

// A non-finite state gives no law: Compute faults (false, τ = 0) and never
// outputs a NaN.
TEST(TaskSpace, ANonFiniteStateFaultsWithZeroTorque) {
  const PlantSpec panda = Robot("panda");
  auto controller = MakeController(TaskConfig(ControllerType::kOperationalSpace, PandaPose(), 100.0, 100.0, 20.0, 20.0),
                                   panda, Unlimited(7));
  VectorXd q = PandaPose(), tau(7);
  q[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(controller->Compute(0.0, q, VectorXd::Zero(7), Setpoint(7), tau));
  EXPECT_EQ(tau, VectorXd::Zero(7));
}

}  // namespace
}  // namespace lagrange
