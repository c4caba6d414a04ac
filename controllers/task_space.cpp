#include "controllers/task_space.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "plant/eigenvalues.hpp"

namespace lagrange {

OperationalSpace::OperationalSpace(int n, SingularityDamping damping)
    : dls_(damping), mass_(n), minv_jt_(n, kTaskDims), y_(n) {
  a_.setZero();
  lambda_.setZero();
}

bool OperationalSpace::Compute(const MatrixXd& M, const Matrix6Xd& J) {
  mass_.compute(M);
  if (mass_.info() != Eigen::Success) return false;
  minv_jt_ = J.transpose();
  mass_.solveInPlace(minv_jt_);
  a_.noalias() = J * minv_jt_;
  // σmin(J)² is the smallest eigenvalue of J Jᵀ (6 x 6, fixed size: no allocation).
  Matrix6d jjt;
  jjt.noalias() = J * J.transpose();
  Vector6d jjt_eigenvalues;  // ascending
  SymmetricEigen6(jjt, jjt_eigenvalues);
  sigma_ = std::sqrt(std::max(jjt_eigenvalues[0], 0.0));
  const double ratio = sigma_ / dls_.threshold;
  damping_ = ratio >= 1.0 ? 0.0 : dls_.max_damping * (1.0 - ratio * ratio);
  task_.compute(a_ + damping_ * Matrix6d::Identity());
  if (task_.info() != Eigen::Success) {  // A numerically singular above ε: damp in full
    damping_ = dls_.max_damping;
    task_.compute(a_ + damping_ * Matrix6d::Identity());
  }
  lambda_.setIdentity();
  task_.solveInPlace(lambda_);
  return lambda_.allFinite();
}

void OperationalSpace::ProjectToNullSpace(const Matrix6Xd& J, ConstVecRef tau0, VecRef out) {
  // P τ0 = τ0 − Jᵀ (Λ (J (M⁻¹ τ0))): J̄ᵀ τ0 = Λ J M⁻¹ τ0.
  y_ = tau0;
  mass_.solveInPlace(y_);
  const Vector6d f = lambda_ * (J * y_);
  out = tau0;
  out.noalias() -= J.transpose() * f;
}

std::optional<int> FindTaskFrame(const Kinematics& kinematics, const std::string& name) {
  if (name.empty()) {
    if (kinematics.num_frames() == 0) return std::nullopt;
    return kinematics.num_frames() - 1;
  }
  return kinematics.FrameIndex(name);
}

Matrix6d TaskInertiaAt(const Dynamics& dynamics, const Kinematics& kinematics, int frame, const VectorXd& q,
                       SingularityDamping damping) {
  const int n = dynamics.num_dofs();
  const std::unique_ptr<KinematicsData> kd = kinematics.MakeData();
  kinematics.ComputeFrameJacobian(*kd, q, frame, FrameAxes::kWorldAligned);
  MatrixXd M(n, n);
  dynamics.ComputeMassMatrix(*dynamics.MakeData(), q, M);
  OperationalSpace os(n, damping);
  if (!os.Compute(M, kd->jacobian(frame, FrameAxes::kWorldAligned))) {
    return Matrix6d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return os.inertia();
}

namespace {

void CheckSize(const VectorXd& v, int n, const char* what) {
  if (v.size() != n) {
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(n) + " values, got " +
                                std::to_string(v.size()));
  }
}

}  // namespace

TaskSpaceController::TaskSpaceController(std::vector<JointType> joints, VectorXd torque_limits, Gains gains,
                                         TaskSpaceOptions options, const VectorXd& q0,
                                         std::shared_ptr<const Dynamics> dynamics,
                                         std::shared_ptr<const Kinematics> kinematics, int frame)
    : Controller(std::move(joints), std::move(torque_limits)),
      gains_(std::move(gains)),
      os_(num_dofs(), options.singularity),
      options_(std::move(options)),
      dynamics_(std::move(dynamics)),
      kinematics_(std::move(kinematics)),
      frame_(frame),
      M_(num_dofs(), num_dofs()),
      zero_(VectorXd::Zero(num_dofs())),
      bias_tau_(num_dofs()),
      tau0_(num_dofs()),
      projected_(num_dofs()),
      target_(options_.trajectory) {
  const int n = num_dofs();
  if (!dynamics_ || !kinematics_) throw std::invalid_argument("a task-space controller needs its models");
  if (dynamics_->num_dofs() != n || kinematics_->num_dofs() != n) {
    throw std::invalid_argument("a task-space controller's models must have the controller's joints");
  }
  if (frame_ < 0 || frame_ >= kinematics_->num_frames()) throw std::invalid_argument("frame: out of range");
  CheckSize(gains_.kp, kTaskDims, "kp");
  CheckSize(gains_.kd, kTaskDims, "kd");
  CheckSize(q0, n, "q0");
  const NullSpaceOptions& ns = options_.null_space;
  posture_on_ = ns.kp.size() > 0 || ns.kd.size() > 0;
  k_ns_ = ns.kp.size() > 0 ? ns.kp : VectorXd::Zero(n);
  d_ns_ = ns.kd.size() > 0 ? ns.kd : VectorXd::Zero(n);
  posture_ = ns.posture.value_or(q0);
  CheckSize(k_ns_, n, "null_space.kp");
  CheckSize(d_ns_, n, "null_space.kd");
  CheckSize(posture_, n, "null_space.posture");
  dynamics_data_ = dynamics_->MakeData();
  kinematics_data_ = kinematics_->MakeData();
  J_ = &kinematics_data_->jacobian(frame_, FrameAxes::kWorldAligned);
}

void TaskSpaceController::ApplyGains(const Gains& gains) {
  gains_.kp = gains.kp;
  gains_.kd = gains.kd;
}

void TaskSpaceController::SetPoseTarget(const PoseSetpoint& setpoint) { target_.Set(setpoint); }

void TaskSpaceController::MoveTo(const Pose& target, double duration) { target_.MoveTo(target, duration); }

void TaskSpaceController::StartTrajectory(const PoseTrajectoryConfig& config) { target_.Start(config); }

void TaskSpaceController::Reset() { StartTrajectory(options_.trajectory); }

void TaskSpaceController::MeasureFrame(ConstVecRef q, ConstVecRef qd) {
  kinematics_->ComputeFrameJacobianAndBias(*kinematics_data_, q, qd, frame_, FrameAxes::kWorldAligned);
  pose_.position = kinematics_data_->position(frame_);
  pose_.orientation = Eigen::Quaterniond(kinematics_data_->rotation(frame_));
  bias_ = kinematics_data_->bias_acceleration(frame_, FrameAxes::kWorldAligned);
  xdot_.noalias() = *J_ * qd;
}

void TaskSpaceController::FollowTarget(double t) {
  target_.Begin(t, pose_);
  target_.Sample(t, commanded_);
  e_ = PoseError(commanded_.pose, pose_);
  edot_ = commanded_.twist - xdot_;
}

void TaskSpaceController::AddPosture(ConstVecRef q, ConstVecRef qd, VecRef tau) {
  if (!posture_on_) return;
  for (int i = 0; i < num_dofs(); ++i) tau0_[i] = k_ns_[i] * Error(i, posture_[i], q[i]) - d_ns_[i] * qd[i];
  os_.ProjectToNullSpace(*J_, tau0_, projected_);
  tau += projected_;
}

void TaskSpaceController::ComputeLaw(double t, ConstVecRef q, ConstVecRef qd, const Setpoint&, VecRef tau) {
  MeasureFrame(q, qd);
  FollowTarget(t);
  dynamics_->ComputeMassMatrix(*dynamics_data_, q, M_);
  if (!os_.Compute(M_, *J_)) {  // M not positive definite: no law (Compute faults on the NaN)
    tau.setConstant(std::numeric_limits<double>::quiet_NaN());
    return;
  }
  tau.noalias() = J_->transpose() * TaskForce();
  dynamics_->ComputeInverseDynamics(*dynamics_data_, q, qd, zero_, DynamicsTerms{}, bias_tau_);  // C qd + G
  tau += bias_tau_;
  AddPosture(q, qd, tau);
}

Vector6d CartesianImpedanceController::TaskForce() const {
  return gains_.kp.cwiseProduct(e_) + gains_.kd.cwiseProduct(edot_);
}

Vector6d OperationalSpaceController::TaskForce() const {
  const Vector6d a = commanded_.acceleration + gains_.kd.cwiseProduct(edot_) + gains_.kp.cwiseProduct(e_) - bias_;
  return os_.inertia() * a;
}

}  // namespace lagrange
