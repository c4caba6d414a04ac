#pragma once
// Where MuJoCo's free joint and lagrange's free-flyer (plant/rigid_tree.hpp,
// Pinocchio's conventions) meet: the one place their numbers are converted
// (README, "Floating base"). R is the body's axes in the world (the quaternion's rotation).
//
//            position                     velocity
//   MuJoCo   qpos = (p, w, x, y, z)        qvel = (ṗ, ω_b): the body origin's velocity in the world,
//                                                 the angular velocity in body axes
//   lagrange q    = (p, x, y, z, w)        v    = (v_b, ω_b) = (Rᵀ ṗ, ω_b), both in body (base) axes
//
// p, ω_b and the quaternion's four numbers are the same (its scalar moves
// from first to last); the linear velocity turns by R. So qvel = T v with
// T = diag(R, 1₃), and what follows from it:
//   acceleration   a = (Rᵀ p̈ − ω_b × v_b, ω̇_b)    (v_b = Rᵀ ṗ differentiated)
//   force          f = Tᵀ qfrc = (Rᵀ f_world, n_b)  (the same power: qvelᵀ qfrc = vᵀ f; the moment,
//                                                  about the body origin, in body axes on both sides)
// Each pair is exact both ways to round-off (tests/plant/mujoco_plant_test.cpp).
// Arguments point at the free joint's entries: MuJoCo's 7 (qpos) or 6
// (qvel, qacc, qfrc), lagrange's 7 (q) or 6 (v, a, f); `q` is always lagrange's.

#include <Eigen/Core>

namespace lagrange {

// R from lagrange's q: the quaternion (x, y, z, w) at q[3..6].
Eigen::Matrix3d FreeJointRotation(const double* q);

// (qpos, qvel) (MuJoCo's) => (q, v) (lagrange's), and back.
void FreeJointFromMujoco(const double* qpos, const double* qvel, double* q, double* v);
void FreeJointToMujoco(const double* q, const double* v, double* qpos, double* qvel);

// At (q, v): MuJoCo's qacc => lagrange's a, and back.
void FreeJointAccelerationFromMujoco(const double* q, const double* v, const double* qacc, double* a);
void FreeJointAccelerationToMujoco(const double* q, const double* v, const double* a, double* qacc);

// At q: MuJoCo's generalized force (qfrc) => lagrange's (f), and back.
void FreeJointForceFromMujoco(const double* q, const double* qfrc, double* f);
void FreeJointForceToMujoco(const double* q, const double* f, double* qfrc);

}  // namespace lagrange
