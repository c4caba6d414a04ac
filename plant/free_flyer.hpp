#pragma once
// The configuration manifold of a floating-base tree (plant/rigid_tree.hpp):
// q = (p, x, y, z, w, q_joints) (nq), v = (v_b, ω_b, qd_joints) (nv = nq − 1),
// Pinocchio's free-flyer conventions. The base moves on SE(3), the joints on ℝⁿ.
//
//   Integrate   q ⊕ h v: the base by SE(3)'s exponential of the body twist
//               h (v_b, ω_b), as Pinocchio's `integrate`: (R, p)⁺ = (R, p) · exp(h v),
//               i.e. R⁺ = R exp(h [ω_b]×), p⁺ = p + R V(h ω_b) h v_b with
//               V(φ) = 1 + (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×², θ = ‖φ‖ —
//               exact for a twist held constant in base axes; the joints q + h qd.
//               The quaternion is composed with exp's and renormalised (its
//               norm stays 1 to round-off; tests/plant/free_flyer_test.cpp).
//   Difference  the inverse: v with Integrate(q0, v, 1) = q1, by SE(3)'s log of
//               (R0, p0)⁻¹ (R1, p1) (the shorter rotation: angle <= π).
//   TwistRate   dexp⁻¹ of the right-trivialised exponential to second order:
//               ξ̇ = v + ½ ξ × v + 1/12 ξ × (ξ × v) (spatial cross product on the
//               base's six entries; the joints' part is v): the rate of the
//               local coordinates ξ of q = q0 ⊕ ξ moving with velocity v, which a
//               Runge–Kutta–Munthe-Kaas step of order <= 4 needs.
//   IntegrateCayley  q ⊕ ξ by SE(3)'s Cayley map instead of exp, the variational
//               integrator's retraction: (R, p)⁺ = (R, p) · cay(ξ_b), cay(X) =
//               (1 − X/2)⁻¹ (1 + X/2) on the 4 x 4 twist matrix, i.e.
//               R⁺ = R cay([φ]×) (the rotation by 2 atan(‖φ‖/2) about φ: the
//               quaternion ∝ (φ/2, 1)), p⁺ = p + R (1 − [φ]×/2)⁻¹ ρ, ξ_b = (ρ, φ);
//               the joints q + ξ. The quaternion is renormalised.
//   CayleyMomentum  (dcay⁻¹_ξ)ᵀ μ: the dual of the inverse right-trivialised
//               tangent dcay⁻¹_ξ(z) = (1 − ξ/2) z (1 + ξ/2), exact (no series),
//               on a base momentum μ = (linear, angular) (6). With −ξ it is the
//               left-trivialised one. The variational step's discrete momenta are
//               μ0 = (dcay⁻¹_ξ)ᵀ μ and μ1 = (dcay⁻¹_−ξ)ᵀ μ; they are the same
//               momentum in the world: μ1 = CayleyTransport(ξ, μ0)
//               (tests/plant/free_flyer_test.cpp).
//   CayleyTransport  a base momentum μ = (f, n) in the axes of g, re-expressed
//               in those of g cay(ξ_b) (Ad*): (Cᵀ f, Cᵀ (n − d × f)) with
//               C = cay([φ]×), d = (1 − [φ]×/2)⁻¹ ρ; the world's momentum is unchanged.
// Sizes are checked by eigen_assert (q and its result nq, v nq − 1).

#include "plant/types.hpp"

namespace lagrange {

// (q (nq), v (nv), h) => q ⊕ h v (nq). `out` may alias `q`.
void Integrate(ConstVecRef q, ConstVecRef v, double h, VecRef out);
// (q0, q1) (nq each) => v (nv) with Integrate(q0, v, 1) = q1.
void Difference(ConstVecRef q0, ConstVecRef q1, VecRef v);
// (ξ, v) (nv each) => the local coordinates' rate (nv), above.
void TwistRate(ConstVecRef xi, ConstVecRef v, VecRef rate);
// (q (nq), ξ (nv)) => q ⊕ ξ by the Cayley map (nq). `out` may alias `q`.
void IntegrateCayley(ConstVecRef q, ConstVecRef xi, VecRef out);
// (ξ_b, μ) (6 each) => (dcay⁻¹_ξ)ᵀ μ (6), above.
Eigen::Matrix<double, 6, 1> CayleyMomentum(const Eigen::Matrix<double, 6, 1>& xi,
                                           const Eigen::Matrix<double, 6, 1>& mu);
// (ξ_b, μ) (6 each) => μ in the axes of the base moved by cay(ξ_b) (6), above.
Eigen::Matrix<double, 6, 1> CayleyTransport(const Eigen::Matrix<double, 6, 1>& xi,
                                            const Eigen::Matrix<double, 6, 1>& mu);

}  // namespace lagrange
