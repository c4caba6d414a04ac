"""lagrange.optimize_trajectory: the mpc controller's box-DDP solver offline. The cart-pole swings up from hanging
within its force limit along a plan the integrator's own step reproduces; on a linear-quadratic problem the result is
the Riccati recursion's gains and the stacked least-squares optimum; the cost never increases; bad arguments raise
one-line errors naming the argument."""
import _thread
import ast
import os
import re
import threading

import numpy as np
import pytest

import lagrange

UPRIGHT = 0.05     # rad: |θ − π| at the plan's end
FORCE = 10.0       # N: the cart's force box
GAIN_RTOL = 1e-10  # relative, DDP gains against the Riccati recursion (as tests/controllers/ddp_test.cpp)
LQ_RTOL = 1e-8     # relative, the DDP trajectory against the stacked least-squares optimum


def swing_up(**overrides):
    args = dict(cost={"q": [1.0, 1.0], "qd": [0.01, 0.01], "tau": 0.01, "q_terminal": [100.0, 300.0],
                      "qd_terminal": [10.0, 10.0], "q_ref": [0.0, np.pi]},
                tau_limits=FORCE, integrator="semi-implicit-euler", max_iterations=100)
    args.update(overrides)
    return lagrange.optimize_trajectory(lagrange.Model.builtin("cartpole"), [0.0, 0.0], [0.0, 0.0], 100, 0.02, **args)


def test_the_cart_pole_swings_up_from_hanging_within_its_force_limit():
    r = swing_up()
    assert r.status in ("converged", "max-iterations"), r
    assert r.q.shape == (101, 2) and r.qd.shape == (101, 2) and r.tau.shape == (100, 2) and r.K.shape == (100, 1, 4)
    assert r.actuated == [0]  # the mpc scene key's default: the cart
    assert abs(r.q[-1, 1] - np.pi) < UPRIGHT, r.q[-1]
    assert np.all(np.abs(r.tau[:, 0]) <= FORCE)
    assert np.max(np.abs(r.tau[:, 0])) == FORCE  # the box binds: the swing-up needs the whole force
    assert np.all(r.tau[:, 1] == 0.0)  # the pole is not actuated
    np.testing.assert_array_equal(r.t, 0.02 * np.arange(101))


def test_the_plan_is_a_rollout_of_the_integrators_step():
    # semi-implicit Euler: qd⁺ = qd + dt qdd(q, qd, tau), q⁺ = q + dt qd⁺, with the model's own forward dynamics.
    model, dt = lagrange.Model.builtin("cartpole"), 0.02
    r = swing_up()
    qdd = model.forward_dynamics(r.q[:-1], r.qd[:-1], r.tau)
    np.testing.assert_allclose(r.qd[1:], r.qd[:-1] + dt * qdd, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.q[1:], r.q[:-1] + dt * r.qd[1:], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.q[0], [0.0, 0.0])


def test_the_cost_never_increases_from_one_iteration_to_the_next():
    r = swing_up()
    assert r.iterations >= 5 and r.cost_history.shape == (r.iterations + 1,)
    assert np.all(np.diff(r.cost_history) <= 0.0), r.cost_history
    assert r.cost_history[-1] == r.cost and r.cost < 0.2 * r.cost_history[0]


def test_the_same_problem_gives_the_same_doubles():
    a, b = swing_up(), swing_up()
    for name in ("q", "qd", "tau", "K", "cost_history"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


# A linear plant: two prismatic joints along x without gravity (constant M, no Coriolis), so every integrator's step
# is linear in (x, u) and the cost is quadratic, as the C++ solver's own test.
W = {"q": [2.0, 1.0], "qd": [0.1, 0.2], "tau": [0.5, 0.3], "q_terminal": [10.0, 5.0], "qd_terminal": [1.0, 1.5]}
Q_REF = np.array([0.5, -0.3])  # an offset target: the gains do not depend on it


def linear_problem(integrator, horizon, **overrides):
    model = lagrange.Model.builtin("chain", links=2, joints="prismatic", m=[1.0, 0.6], g=0.0)
    args = dict(cost=dict(W, q_ref=Q_REF), integrator=integrator)
    args.update(overrides)
    return model, lagrange.optimize_trajectory(model, [0.0, 0.1], [0.2, 0.0], horizon, 0.05, **args)


@pytest.mark.parametrize("integrator", ["explicit-euler", "semi-implicit-euler", "rk4"])
def test_one_iteration_on_a_linear_quadratic_problem_gives_the_riccati_gains(integrator):
    N = 30
    model, r = linear_problem(integrator, N, max_iterations=1)
    assert r.iterations == 1
    A, B = model.step_derivatives([0.3, -0.2], [0.1, 0.4], [1.0, -2.0], 0.05, integrator)  # the same everywhere
    Q, QN, R = np.diag(W["q"] + W["qd"]), np.diag(W["q_terminal"] + W["qd_terminal"]), np.diag(W["tau"])
    # The backward Riccati recursion: S_N = Q_N, K_k = (R + BᵀSB)⁻¹ BᵀSA, S ← Q + AᵀSA − AᵀSB K_k; u = −K x.
    S = QN
    for k in range(N - 1, -1, -1):
        K = np.linalg.solve(R + B.T @ S @ B, B.T @ S @ A)
        assert np.linalg.norm(r.K[k] + K) <= GAIN_RTOL * np.linalg.norm(K), k
        S = Q + A.T @ S @ A - A.T @ S @ B @ K


@pytest.mark.parametrize("integrator", ["explicit-euler", "rk4"])
def test_on_a_linear_quadratic_problem_the_trajectory_is_the_least_squares_optimum(integrator):
    N, dt = 30, 0.05
    model, r = linear_problem(integrator, N)
    assert r.status == "converged", r
    A, B = model.step_derivatives(np.zeros(2), np.zeros(2), np.zeros(2), dt, integrator)
    # x_k = A^k x_0 + Σ_{j<k} A^{k−1−j} B u_j stacked: X = Sx x_0 + Su U; then J(U) is quadratic and its minimiser
    # solves (Suᵀ Q̄ Su + R̄) U = −Suᵀ Q̄ (Sx x_0 − X_ref).
    x0 = np.array([0.0, 0.1, 0.2, 0.0])
    Sx, Su = np.zeros((4 * (N + 1), 4)), np.zeros((4 * (N + 1), 2 * N))
    power = np.eye(4)
    for k in range(N + 1):
        Sx[4 * k:4 * k + 4] = power
        power = A @ power
        for j in range(k):
            Su[4 * k:4 * k + 4, 2 * j:2 * j + 2] = np.linalg.matrix_power(A, k - 1 - j) @ B
    Qbar = np.diag(np.concatenate([np.tile(W["q"] + W["qd"], N), W["q_terminal"] + W["qd_terminal"]]))
    Rbar = np.diag(np.tile(W["tau"], N))
    X_ref = np.tile(np.concatenate([Q_REF, np.zeros(2)]), N + 1)
    U = np.linalg.solve(Su.T @ Qbar @ Su + Rbar, -Su.T @ Qbar @ (Sx @ x0 - X_ref))
    X = (Sx @ x0 + Su @ U).reshape(N + 1, 4)
    np.testing.assert_allclose(r.tau, U.reshape(N, 2), rtol=0, atol=LQ_RTOL * np.max(np.abs(U)))
    np.testing.assert_allclose(r.q, X[:, :2], rtol=0, atol=LQ_RTOL * np.max(np.abs(X)))
    np.testing.assert_allclose(r.qd, X[:, 2:], rtol=0, atol=LQ_RTOL * np.max(np.abs(X)))
    # J = ½ Σ |x − x_ref|²_Q + ½ |u|²_R: the solver's cost is this sum over its own trajectory.
    E = (X - X_ref.reshape(N + 1, 4)).ravel()
    J = 0.5 * E @ Qbar @ E + 0.5 * U @ Rbar @ U
    assert abs(r.cost - J) <= 1e-10 * J


def test_limits_given_as_lower_and_upper_hold_at_every_knot():
    r = swing_up(tau_limits=(-4.0, 7.0))
    assert np.all(r.tau[:, 0] >= -4.0) and np.all(r.tau[:, 0] <= 7.0)
    assert np.min(r.tau[:, 0]) == -4.0 and np.max(r.tau[:, 0]) == 7.0  # both bounds bind
    # Every joint's limits ([x, θ]): the actuated joint's are taken.
    np.testing.assert_array_equal(swing_up(tau_limits=[FORCE, 3.0]).tau, swing_up().tau)


def test_a_rollout_that_leaves_the_finite_numbers_raises():
    # A chain spun fast under explicit Euler with a huge step: the centrifugal terms overflow the tau = 0 rollout.
    model = lagrange.Model.builtin("chain", links=3)
    with pytest.raises(RuntimeError, match="diverged"):
        lagrange.optimize_trajectory(model, [0.0, 0.5, 0.5], [300.0, -500.0, 700.0], 2000, 1.0,
                                     integrator="explicit-euler")


def test_ctrl_c_stops_a_long_solve_between_iterations():
    # 10⁵ knots, up to 10⁴ iterations: minutes of solving, unless the KeyboardInterrupt stops it (DdpData::stop).
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            lagrange.optimize_trajectory(lagrange.Model.builtin("cartpole"), [0.0, 0.0], [0.0, 0.0], 100000, 0.001,
                                         cost={"q_ref": [0.0, np.pi]}, tau_limits=FORCE, max_iterations=10000,
                                         tolerance=0.0)
    finally:
        timer.cancel()


CARTPOLE = lagrange.Model.builtin("cartpole")
BAD = [
    (dict(q0=[0.0]), r"^q0: expected 2 values \(one per joint\), got 1$"),
    (dict(q0=[0.0, np.nan]), r"^q0: expected finite numbers, got nan at q0\[1\]$"),
    (dict(qd0=np.zeros((3, 2))), r"^qd0: expected one state \(2,\), got a batch of 3$"),
    (dict(horizon=0), r"^horizon: expected 1\.\.100000 knots$"),
    (dict(horizon=100001), r"^horizon: expected 1\.\.100000 knots$"),
    (dict(dt=0.0), r"^dt: expected a finite number > 0 \(s\)$"),
    (dict(dt=np.inf), r"^dt: expected a finite number > 0 \(s\)$"),
    (dict(cost={"q": [1.0, 2.0, 3.0]}),
     r"^cost\['q'\]: expected a number or 2 values \(one per joint\), got 3 values$"),
    (dict(cost={"tau": 0.0}), r"^cost\['tau'\]: expected \(1\) finite values > 0$"),
    (dict(cost={"q_terminal": [1.0, np.nan]}), r"^cost\['q_terminal'\]: expected \(2\) finite values >= 0$"),
    (dict(cost={"qd": -1.0}), r"^cost\['qd'\]: expected \(2\) finite values >= 0$"),
    (dict(cost={"Q": 1.0}), r"^cost: unknown key 'Q' \(expected q, qd, tau, q_terminal, qd_terminal, q_ref, qd_ref\)$"),
    (dict(cost={"q_ref": np.zeros((5, 2))}), r"^cost\['q_ref'\]: expected \(2,\) or \(horizon \+ 1, 2\) = \(11, 2\)"),
    (dict(cost={"qd_ref": [0.0, np.inf]}), r"^cost\['qd_ref'\]: expected finite numbers, got inf"),
    (dict(cost="q=1"), r"^cost: expected a dict of weights and references .* got str$"),
    (dict(cost=[("q", 1.0)]), r"^cost: expected a dict of weights and references .* got list$"),
    (dict(tau_limits=-1.0), r"^tau_limits: expected limits >= 0"),
    (dict(tau_limits=[1.0, 2.0, 3.0]),
     r"^tau_limits: expected a number, 1 value \(one per actuated joint\) or 2 values \(one per joint\), "
     r"got 3 values$"),
    (dict(tau_limits=np.nan), r"^tau_limits: expected numbers \(inf allowed\), got nan$"),
    (dict(tau_limits=(5.0, 1.0)), r"^tau_limits: expected lower <= upper .* got \[5, 1\] on joint 0$"),
    (dict(tau_limits="10"), r"^tau_limits: expected a number, .* got str$"),
    (dict(integrator="dopri5"), r"^integrator: "),
    (dict(integrator="leapfrog"), r"^integrator: expected explicit-euler, semi-implicit-euler or rk4, got 'leapfrog'$"),
    (dict(actuated=[1, 0]), r"^actuated: expected ascending joint indices in 0\.\.1$"),
    (dict(actuated=[2]), r"^actuated: expected ascending joint indices in 0\.\.1$"),
    (dict(actuated=[]), r"^actuated: expected at least one joint index$"),
    (dict(actuated="x"), r"^actuated: expected a sequence of joint indices"),
    (dict(max_iterations=0), r"^max_iterations: expected 1\.\.10000$"),
    (dict(tolerance=-1.0), r"^tolerance: expected a finite number >= 0$"),
]


@pytest.mark.parametrize("change,message", BAD, ids=[f"{i}-{next(iter(c))}" for i, (c, _) in enumerate(BAD)])
def test_a_bad_argument_raises_a_value_error_naming_it(change, message):
    args = dict(model=CARTPOLE, q0=[0.0, 0.0], qd0=[0.0, 0.0], horizon=10, dt=0.02)
    args.update(change)
    with pytest.raises(ValueError, match=message):
        lagrange.optimize_trajectory(**args)


def test_a_model_that_is_not_a_lagrange_model_is_a_type_error():
    with pytest.raises(TypeError, match="^model: expected a lagrange.Model, got str$"):
        lagrange.optimize_trajectory("cartpole", [0.0, 0.0], [0.0, 0.0], 10, 0.02)


def test_the_stubs_and_help_document_the_call_and_its_result():
    with open(os.path.join(os.path.dirname(lagrange.__file__), "__init__.pyi")) as f:
        stub = f.read()
    ast.parse(stub)
    assert re.search(r"^def optimize_trajectory\(model: Model, q0", stub, re.M)
    section = stub[stub.index("class TrajectoryResult"):stub.index("def optimize_trajectory")]
    for name in (n for n in dir(lagrange.TrajectoryResult) if not n.startswith("_")):
        assert re.search(r"^    %s: " % name, section, re.M), name
        assert getattr(lagrange.TrajectoryResult, name).__doc__, name
    doc = lagrange.optimize_trajectory.__doc__
    for phrase in ("1..100000", "tau_limits", "(lower, upper)", "(N, m, 2n)", "q_ref", "ValueError", "GIL"):
        assert phrase in doc, phrase
