#include "controllers/task_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace lagrange {
namespace {

// |q| within this of 1 counts as unit (a pose read from text with 9 digits is).
constexpr double kUnitTolerance = 1e-6;
// A normal and a centre offset are perpendicular when |n·c| <= this × |c|.
constexpr double kPerpendicularTolerance = 1e-9;

bool IsUnit(const Eigen::Quaterniond& q) { return std::abs(q.norm() - 1.0) <= kUnitTolerance; }

bool FinitePose(const Pose& p) { return p.position.allFinite() && p.orientation.coeffs().allFinite(); }

}  // namespace

Eigen::Vector3d LogMap(const Eigen::Quaterniond& q_in) {
  // The short way round: w >= 0 (q and −q are one rotation).
  const double sign = q_in.w() < 0.0 ? -1.0 : 1.0;
  const double w = sign * q_in.w();
  const Eigen::Vector3d v = sign * q_in.vec();
  const double s = v.norm();  // sin(θ/2)
  // θ = 2 atan2(s, w), and θu = (θ/s) v; θ/s → 2/w (1 − s²/(3w²)) as s → 0.
  const double scale = s < 1e-6 ? 2.0 / w * (1.0 - s * s / (3.0 * w * w)) : 2.0 * std::atan2(s, w) / s;
  return scale * v;
}

Eigen::Quaterniond ExpMap(const Eigen::Vector3d& r) {
  const double theta = r.norm();
  // sin(θ/2)/θ → 1/2 − θ²/48 as θ → 0.
  const double k = theta < 1e-6 ? 0.5 - theta * theta / 48.0 : std::sin(0.5 * theta) / theta;
  return Eigen::Quaterniond(std::cos(0.5 * theta), k * r.x(), k * r.y(), k * r.z());
}

Vector6d PoseError(const Pose& desired, const Pose& measured) {
  Vector6d e;
  e.head<3>() = desired.position - measured.position;
  e.tail<3>() = LogMap(desired.orientation * measured.orientation.conjugate());
  return e;
}

TimeScaling MinimumJerkScaling(double t, double duration) {
  if (!(t > 0.0)) return {0.0, 0.0, 0.0};
  if (t >= duration) return {1.0, 0.0, 0.0};
  const double u = t / duration;
  return {u * u * u * (10.0 + u * (-15.0 + 6.0 * u)), u * u * (30.0 + u * (-60.0 + 30.0 * u)) / duration,
          u * (60.0 + u * (-180.0 + 120.0 * u)) / (duration * duration)};
}

PoseTrajectory PoseTrajectory::Hold(const Pose& pose) {
  PoseTrajectory p;
  p.type_ = Type::kHold;
  p.start_.pose = pose;
  return p;
}

PoseTrajectory PoseTrajectory::Constant(const PoseSetpoint& setpoint) {
  PoseTrajectory p;
  p.type_ = Type::kHold;
  p.start_ = setpoint;
  return p;
}

PoseTrajectory PoseTrajectory::MinimumJerk(const Pose& from, const Pose& to, double duration) {
  PoseTrajectory p;
  p.type_ = Type::kMinimumJerk;
  p.start_.pose = from;
  p.end_ = to;
  p.delta_ = to.position - from.position;
  p.rotation_ = LogMap(to.orientation * from.orientation.conjugate());
  p.duration_ = duration;
  return p;
}

PoseTrajectory PoseTrajectory::Circle(const Pose& from, const Eigen::Vector3d& center, const Eigen::Vector3d& normal,
                                      double frequency, double ramp) {
  PoseTrajectory p;
  p.type_ = Type::kCircle;
  p.start_.pose = from;
  p.radius_ = center.norm();
  p.delta_ = from.position + center;
  p.a_ = -center / p.radius_;
  p.b_ = normal.cross(p.a_);
  p.omega_ = 2.0 * std::numbers::pi * frequency;
  p.duration_ = ramp;
  return p;
}

void PoseTrajectory::Sample(double t, PoseSetpoint& out) const {
  switch (type_) {
    case Type::kHold: out = start_; return;
    case Type::kMinimumJerk: {
      if (t >= duration_) {  // arrived: exactly the target, at rest
        out.pose = end_;
        out.twist.setZero();
        out.acceleration.setZero();
        return;
      }
      const TimeScaling s = MinimumJerkScaling(t, duration_);
      out.pose.position = start_.pose.position + s.s * delta_;
      out.pose.orientation = (ExpMap(s.s * rotation_) * start_.pose.orientation).normalized();
      out.twist << s.sd * delta_, s.sd * rotation_;
      out.acceleration << s.sdd * delta_, s.sdd * rotation_;
      return;
    }
    case Type::kCircle: {
      // φ̇ = ω s_r(t) over the ramp (s_r the minimum-jerk profile on [0, T]),
      // so φ = ω T (2.5u⁴ − 3u⁵ + u⁶) with u = t/T; then φ = ω (t − T/2).
      const double T = duration_, tc = std::max(t, 0.0);
      double phi = 0.0, phid = omega_, phidd = 0.0;
      if (tc < T) {
        const double u = tc / T;
        phi = omega_ * T * u * u * u * u * (2.5 + u * (-3.0 + u));
        phid = omega_ * u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
        phidd = omega_ / T * u * u * (30.0 + u * (-60.0 + 30.0 * u));
      } else {
        phi = omega_ * (tc - 0.5 * T);
      }
      const double c = std::cos(phi), s = std::sin(phi);
      const Eigen::Vector3d radial = c * a_ + s * b_, tangent = -s * a_ + c * b_;
      out.pose.position = delta_ + radius_ * radial;
      out.pose.orientation = start_.pose.orientation;
      out.twist << radius_ * phid * tangent, Eigen::Vector3d::Zero();
      out.acceleration << radius_ * (phidd * tangent - phid * phid * radial), Eigen::Vector3d::Zero();
      return;
    }
  }
}

std::string_view ToString(PoseTrajectory::Type type) {
  switch (type) {
    case PoseTrajectory::Type::kHold: return "hold";
    case PoseTrajectory::Type::kMinimumJerk: return "min-jerk";
    case PoseTrajectory::Type::kCircle: return "circle";
  }
  return "hold";
}

std::optional<std::string> ValidatePoseTrajectory(const PoseTrajectoryConfig& c) {
  if (c.target && !FinitePose(*c.target)) return std::string("target: expected a finite position and orientation");
  if (c.target && !IsUnit(c.target->orientation)) {
    return std::string("target.orientation: expected a unit quaternion [w, x, y, z]");
  }
  switch (c.type) {
    case PoseTrajectory::Type::kHold: return std::nullopt;
    case PoseTrajectory::Type::kMinimumJerk:
      if (!c.target) return std::string("target: expected the pose to move to (position and orientation)");
      if (!(std::isfinite(c.duration) && c.duration > 0.0)) {
        return std::string("duration: expected a positive number of seconds");
      }
      return std::nullopt;
    case PoseTrajectory::Type::kCircle: {
      if (!c.normal.allFinite() || std::abs(c.normal.norm() - 1.0) > kUnitTolerance) {
        return std::string("normal: expected a unit vector [nx, ny, nz]");
      }
      const double r = c.center.norm();
      if (!c.center.allFinite() || !(r > 0.0)) {
        return std::string("center: expected the circle's centre as a nonzero offset from the start, m");
      }
      if (std::abs(c.normal.dot(c.center)) > kPerpendicularTolerance * r) {
        return std::string("center: expected an offset perpendicular to the normal (in the circle's plane)");
      }
      if (!(std::isfinite(c.frequency) && c.frequency > 0.0)) return std::string("frequency: expected a positive Hz");
      if (!(std::isfinite(c.ramp) && c.ramp >= 0.0)) return std::string("ramp: expected seconds >= 0");
      return std::nullopt;
    }
  }
  return std::nullopt;
}

PoseTrajectory MakePoseTrajectory(const PoseTrajectoryConfig& c, const Pose& start) {
  Pose target = c.target.value_or(start);
  target.orientation.normalize();  // unit within kUnitTolerance: exactly unit from here
  switch (c.type) {
    case PoseTrajectory::Type::kHold: return PoseTrajectory::Hold(target);
    case PoseTrajectory::Type::kMinimumJerk: return PoseTrajectory::MinimumJerk(start, target, c.duration);
    case PoseTrajectory::Type::kCircle:
      return PoseTrajectory::Circle(start, c.center, c.normal.normalized(), c.frequency, c.ramp);
  }
  return PoseTrajectory::Hold(start);
}

}  // namespace lagrange
