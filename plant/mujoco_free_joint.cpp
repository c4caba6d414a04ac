#include "plant/mujoco_free_joint.hpp"

#include <Eigen/Geometry>

namespace lagrange {
namespace {

using Vec3 = Eigen::Map<const Eigen::Vector3d>;
using Out3 = Eigen::Map<Eigen::Vector3d>;

}  // namespace

Eigen::Matrix3d FreeJointRotation(const double* q) {
  return Eigen::Quaterniond(q[6], q[3], q[4], q[5]).toRotationMatrix();  // (w, x, y, z): Eigen's constructor
}

void FreeJointFromMujoco(const double* qpos, const double* qvel, double* q, double* v) {
  q[0] = qpos[0], q[1] = qpos[1], q[2] = qpos[2];
  q[3] = qpos[4], q[4] = qpos[5], q[5] = qpos[6], q[6] = qpos[3];  // (w, x, y, z) => (x, y, z, w)
  Out3{v} = FreeJointRotation(q).transpose() * Vec3(qvel);      // v_b = Rᵀ ṗ
  Out3{v + 3} = Vec3(qvel + 3);                                  // ω_b
}

void FreeJointToMujoco(const double* q, const double* v, double* qpos, double* qvel) {
  qpos[0] = q[0], qpos[1] = q[1], qpos[2] = q[2];
  qpos[3] = q[6], qpos[4] = q[3], qpos[5] = q[4], qpos[6] = q[5];  // (x, y, z, w) => (w, x, y, z)
  Out3{qvel} = FreeJointRotation(q) * Vec3(v);                     // ṗ = R v_b
  Out3{qvel + 3} = Vec3(v + 3);
}

void FreeJointAccelerationFromMujoco(const double* q, const double* v, const double* qacc, double* a) {
  Out3{a} = FreeJointRotation(q).transpose() * Vec3(qacc) - Vec3(v + 3).cross(Vec3(v));  // Rᵀ p̈ − ω_b × v_b
  Out3{a + 3} = Vec3(qacc + 3);
}

void FreeJointAccelerationToMujoco(const double* q, const double* v, const double* a, double* qacc) {
  Out3{qacc} = FreeJointRotation(q) * (Vec3(a) + Vec3(v + 3).cross(Vec3(v)));  // p̈ = R (v̇_b + ω_b × v_b)
  Out3{qacc + 3} = Vec3(a + 3);
}

void FreeJointForceFromMujoco(const double* q, const double* qfrc, double* f) {
  Out3{f} = FreeJointRotation(q).transpose() * Vec3(qfrc);
  Out3{f + 3} = Vec3(qfrc + 3);
}

void FreeJointForceToMujoco(const double* q, const double* f, double* qfrc) {
  Out3{qfrc} = FreeJointRotation(q) * Vec3(f);
  Out3{qfrc + 3} = Vec3(f + 3);
}

}  // namespace lagrange
