"""lagrange.Model on a floating base (from_urdf(..., floating_base=True)): q of nq = nv + 1 (p, quaternion x y z w,
joints), velocities of nv (v_b, ω_b in base axes, joint rates), integrate/difference on the manifold, and the C++
library's numbers (lagrangectl eval --floating-base's, bit for bit, and physics: a tree at rest falls at g)."""
import json
import os
import pickle
import subprocess

import numpy as np
import pytest

import lagrange

SOURCE = os.environ["LAGRANGE_SOURCE_DIR"]
LAGRANGECTL = os.environ.get("LAGRANGECTL", "")
TWO_ARMS = os.path.join(SOURCE, "tests/fixtures/urdf/two_arms.urdf")  # a base of mass > 0 with two arms
BRICK = os.path.join(SOURCE, "tests/fixtures/urdf/brick.urdf")
MIMIC_ARMS = os.path.join(SOURCE, "tests/fixtures/urdf/mimic_arms.urdf")  # two_arms with a third arm's joint a mimic
TOL = 1e-12


def random_state(model, rng):
    q = rng.uniform(-1.0, 1.0, model.num_positions)
    q[3:7] /= np.linalg.norm(q[3:7])
    return q, rng.uniform(-1.0, 1.0, model.num_velocities)


@pytest.fixture(scope="module")
def model():
    return lagrange.Model.from_urdf(TWO_ARMS, floating_base=True)


def test_sizes_count_the_free_flyer(model):
    fixed = lagrange.Model.from_urdf(TWO_ARMS)
    n = fixed.num_dofs
    assert model.floating_base and not fixed.floating_base
    assert (model.num_dofs, model.num_positions, model.num_velocities) == (n, n + 7, n + 6)
    assert (fixed.num_positions, fixed.num_velocities) == (n, n)
    assert model.joint_names == fixed.joint_names
    q, v = random_state(model, np.random.default_rng(1))
    nv = model.num_velocities
    assert model.mass_matrix(q).shape == (nv, nv)
    assert model.gravity(q).shape == (nv,)
    assert model.forward_dynamics(q, v, np.zeros(nv)).shape == (nv,)
    assert model.inverse_dynamics(q, v, np.zeros(nv)).shape == (nv,)
    frame = model.frame_names[-1]
    R, p = model.frame_pose(frame, q)
    assert R.shape == (3, 3) and p.shape == (3,)
    assert model.frame_jacobian(frame, q).shape == (6, nv)
    assert model.frame_bias_acceleration(frame, q, v).shape == (6,)
    qs = np.stack([q, q, q])
    assert model.mass_matrix(qs).shape == (3, nv, nv)
    assert model.integrate(qs, v, 0.1).shape == (3, model.num_positions)
    assert "floating base" in repr(model)


def test_errors_name_which_size(model):
    q, v = random_state(model, np.random.default_rng(2))
    nq, nv = model.num_positions, model.num_velocities
    with pytest.raises(ValueError, match=rf"^q: expected {nq} values \(nq = nv \+ 1: p, quaternion x y z w"):
        model.mass_matrix(v)
    with pytest.raises(ValueError, match=rf"^qd: expected {nv} values \(nv: v_b, ω_b"):
        model.forward_dynamics(q, q, np.zeros(nv))
    with pytest.raises(ValueError, match=rf"^tau: expected {nv} values"):
        model.forward_dynamics(q, v, np.zeros(nq))
    with pytest.raises(ValueError, match="^coriolis_matrix: a floating base has no C matrix"):
        model.coriolis_matrix(q, v)
    with pytest.raises(ValueError, match="^method: a floating base has the recursive and lagrangian paths, got "
                                         "'closed-form'"):
        lagrange.Model.from_urdf(TWO_ARMS, floating_base=True, method="closed-form")
    fixed = lagrange.Model.from_urdf(TWO_ARMS)
    for call, args in [("center_of_mass", (np.zeros(2),)), ("centroidal_momentum_matrix", (np.zeros(2),)),
                       ("centroidal_momentum_bias", (np.zeros(2), np.zeros(2)))]:
        with pytest.raises(ValueError, match=f"^{call}: a floating-base Model's"):
            getattr(fixed, call)(*args)
    with pytest.raises(ValueError, match="^model: a floating-base Model"):
        model.inverse_dynamics_derivatives(q, v, np.zeros(nv))


def test_integrate_and_difference_are_inverse(model):
    rng = np.random.default_rng(3)
    for _ in range(10):
        q0, v = random_state(model, rng)
        v *= 3.0
        q1 = model.integrate(q0, v, 0.4)
        assert abs(np.linalg.norm(q1[3:7]) - 1.0) < TOL
        np.testing.assert_allclose(model.difference(q0, q1), 0.4 * v, rtol=0, atol=1e-11)
        np.testing.assert_allclose(model.integrate(q0, model.difference(q0, q1), 1.0), q1, rtol=0, atol=1e-11)
    qs = np.stack([random_state(model, rng)[0] for _ in range(4)])
    vs = rng.uniform(-1.0, 1.0, (4, model.num_velocities))
    batch = model.integrate(qs, vs, 0.2)
    for i in range(4):
        np.testing.assert_array_equal(batch[i], model.integrate(qs[i], vs[i], 0.2))
    fixed = lagrange.Model.from_urdf(TWO_ARMS)
    q, v = rng.uniform(-1, 1, fixed.num_dofs), rng.uniform(-1, 1, fixed.num_dofs)
    np.testing.assert_array_equal(fixed.integrate(q, v, 0.5), q + 0.5 * v)
    np.testing.assert_array_equal(fixed.difference(q, v), v - q)


def test_a_tree_at_rest_falls_at_gravity(model):
    # No velocity, no force: every body falls at g; the base's v̇_b is gravity in base axes, ω̇_b and q̈ zero.
    rng = np.random.default_rng(4)
    q, _ = random_state(model, rng)
    nv = model.num_velocities
    a = model.forward_dynamics(q, np.zeros(nv), np.zeros(nv))
    x, y, z, w = q[3:7]
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    expected = np.zeros(nv)
    expected[:3] = R.T @ np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(a, expected, rtol=0, atol=TOL)
    brick = lagrange.Model.from_urdf(BRICK, floating_base=True)
    np.testing.assert_allclose(brick.forward_dynamics([0, 0, 1, 0, 0, 0, 1], np.zeros(6), np.zeros(6)),
                               [0, 0, -9.81, 0, 0, 0], rtol=0, atol=TOL)


def test_dynamics_agree_with_each_other(model):
    rng = np.random.default_rng(5)
    q, v = random_state(model, rng)
    nv = model.num_velocities
    tau = rng.uniform(-2.0, 2.0, nv)
    M = model.mass_matrix(q)
    np.testing.assert_allclose(M, M.T, rtol=0, atol=TOL)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    a = model.forward_dynamics(q, v, tau)
    np.testing.assert_allclose(model.inverse_dynamics(q, v, a), tau, rtol=0, atol=1e-10)
    assert model.kinetic_energy(q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)
    bias = model.inverse_dynamics(q, v, np.zeros(nv))
    np.testing.assert_allclose(M @ a + bias, tau, rtol=0, atol=1e-10)


def test_frame_jacobian_gives_the_frames_velocity(model):
    rng = np.random.default_rng(6)
    q, v = random_state(model, rng)
    eps = 1e-6
    for frame in model.frame_names:
        _, pp = model.frame_pose(frame, model.integrate(q, v, eps))
        _, pm = model.frame_pose(frame, model.integrate(q, v, -eps))
        J = model.frame_jacobian(frame, q)
        np.testing.assert_allclose(J[:3] @ v, (pp - pm) / (2 * eps), rtol=0, atol=1e-8)
        R, _ = model.frame_pose(frame, q)
        local = model.frame_jacobian(frame, q, reference="local")
        np.testing.assert_allclose(local[:3], R.T @ J[:3], rtol=0, atol=TOL)


@pytest.mark.parametrize("urdf", [TWO_ARMS, MIMIC_ARMS])
def test_the_lagrangian_path_agrees_with_the_recursive_one(urdf):
    # Two derivations (Euler–Poincaré on the energies; RNEA, CRBA, ABA) of the same robot, mimic joint and all.
    recursive = lagrange.Model.from_urdf(urdf, floating_base=True)
    lagrangian = lagrange.Model.from_urdf(urdf, floating_base=True, method="lagrangian")
    assert lagrangian.method == "lagrangian" and recursive.method == "recursive"
    assert lagrangian.num_velocities == recursive.num_velocities
    rng = np.random.default_rng(9)
    qs, vs = zip(*(random_state(recursive, rng) for _ in range(3)))
    qs, vs = np.array(qs), np.array(vs)
    taus = rng.uniform(-2.0, 2.0, vs.shape)
    close = lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
    close(lagrangian.mass_matrix(qs), recursive.mass_matrix(qs))
    close(lagrangian.gravity(qs), recursive.gravity(qs))
    close(lagrangian.forward_dynamics(qs, vs, taus), recursive.forward_dynamics(qs, vs, taus))
    close(lagrangian.inverse_dynamics(qs, vs, taus), recursive.inverse_dynamics(qs, vs, taus))
    close(lagrangian.kinetic_energy(qs, vs), recursive.kinetic_energy(qs, vs))
    close(lagrangian.potential_energy(qs), recursive.potential_energy(qs))
    assert np.abs(recursive.inverse_dynamics(qs, vs, np.zeros_like(vs))).max() > 1e-2  # not a trivial agreement
    again = pickle.loads(pickle.dumps(lagrangian))
    assert again.method == "lagrangian"
    np.testing.assert_array_equal(again.mass_matrix(qs[0]), lagrangian.mass_matrix(qs[0]))


def test_centre_of_mass_and_centroidal_momentum(model):
    rng = np.random.default_rng(10)
    q, v = random_state(model, rng)
    a = rng.uniform(-1.0, 1.0, model.num_velocities)
    eps = 1e-6
    c, Jc = model.center_of_mass(q)
    assert c.shape == (3,) and Jc.shape == (3, model.num_velocities)
    # ċ = J_c v, by central differences along the manifold.
    cp, _ = model.center_of_mass(model.integrate(q, v, eps))
    cm, _ = model.center_of_mass(model.integrate(q, v, -eps))
    np.testing.assert_allclose(Jc @ v, (cp - cm) / (2 * eps), rtol=0, atol=1e-8)
    # The centroidal momentum's linear part is the total mass times ċ; A_G's linear rows are m J_c.
    A = model.centroidal_momentum_matrix(q)
    mass = model.mass_matrix(q)[0, 0]  # the base's linear block is m I in base axes
    np.testing.assert_allclose(A[:3], mass * Jc, rtol=0, atol=1e-10)
    # ḣ_G = A_G a + Ȧ_G v: the derivative of A_G(q(t)) v(t) along q̇ = v, v̇ = a, by central differences.
    h = lambda t: model.centroidal_momentum_matrix(model.integrate(q, v, t)) @ (v + t * a)
    hdot = (h(eps) - h(-eps)) / (2 * eps)
    np.testing.assert_allclose(A @ a + model.centroidal_momentum_bias(q, v), hdot, rtol=0, atol=1e-7)
    # Batches are the single states, row by row.
    qs = np.stack([q, random_state(model, rng)[0]])
    cs, Jcs = model.center_of_mass(qs)
    np.testing.assert_array_equal(cs[0], c)
    np.testing.assert_array_equal(Jcs[0], Jc)
    np.testing.assert_array_equal(model.centroidal_momentum_bias(qs, v)[0], model.centroidal_momentum_bias(q, v))


def test_pickles_with_its_floating_base(model):
    again = pickle.loads(pickle.dumps(model))
    assert again.floating_base and again.num_positions == model.num_positions
    q, _ = random_state(model, np.random.default_rng(7))
    np.testing.assert_array_equal(again.mass_matrix(q), model.mass_matrix(q))


@pytest.mark.skipif(not os.path.exists(LAGRANGECTL), reason="lagrangectl not built")
def test_the_numbers_are_lagrangectl_evals(model):
    rng = np.random.default_rng(8)
    q, v = random_state(model, rng)
    tau = rng.uniform(-2.0, 2.0, model.num_velocities)
    numbers = lambda x: ",".join(repr(float(e)) for e in x)
    r = subprocess.run([LAGRANGECTL, "eval", "--urdf", TWO_ARMS, "--floating-base", "--q", numbers(q), "--qd",
                        numbers(v), "--tau", numbers(tau)], capture_output=True, text=True, check=True)
    out = json.loads(r.stdout)
    assert out["num_positions"] == model.num_positions and out["num_velocities"] == model.num_velocities
    np.testing.assert_array_equal(model.mass_matrix(q), np.array(out["M"]))
    np.testing.assert_array_equal(model.gravity(q), np.array(out["G"]))
    np.testing.assert_array_equal(model.forward_dynamics(q, v, tau), np.array(out["qdd"]))
