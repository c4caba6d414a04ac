"""The shipped model-predictive swing-up (config/cartpole_mpc_swingup.yaml) from 20 seeded initial states, simulated
offline by lagrange.simulate (lagranged's Instance code, the mpc controller planning inline every replan_period of
simulated time): after 5 s the pole is upright and the cart never left its ±0.5 m rail; the same start gives the same
run, bit for bit. The sweep runs here, in the Release tree (tests/daemon/mpc_test.cpp runs 3 seeded starts of its own
under the sanitizers)."""
import os

import numpy as np
import pytest

import lagrange

# The checkout: ctest names it; run by hand (the README's command), this file's.
SOURCE = os.environ.get("LAGRANGE_SOURCE_DIR", os.path.join(os.path.dirname(os.path.abspath(__file__)), "../.."))
SCENE = os.path.join(SOURCE, "config/cartpole_mpc_swingup.yaml")
SEEDS = range(20)
DURATION = 5.0  # s
UPRIGHT = 0.05  # rad: |θ − π| at the end
RAIL = 0.5      # m: |x| at every step
AT_REST = "      q: [0.0, 0.0]                  # hanging down, at rest\n"


def start(seed):
    """A seeded state near hanging at rest: x within ±0.1 m, θ ±0.2 rad, ẋ ±0.1 m/s, θ̇ ±0.2 rad/s."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, 2) * [0.1, 0.2], rng.uniform(-1, 1, 2) * [0.1, 0.2]


def swing_up(seed):
    q0, qd0 = start(seed)
    with open(SCENE) as f:
        text = f.read()
    assert AT_REST in text, "the shipped scene's initial state moved: update AT_REST"
    numbers = lambda v: ", ".join(repr(float(x)) for x in v)  # noqa: E731  (repr: the double itself)
    text = text.replace(AT_REST, f"      q: [{numbers(q0)}]\n      qd: [{numbers(qd0)}]\n")
    run = lagrange.simulate(text, DURATION)["cartpole"]
    assert run.fault is None, run.fault
    np.testing.assert_array_equal(run.q[0], q0)
    np.testing.assert_array_equal(run.qd[0], qd0)
    return run


@pytest.mark.parametrize("seed", SEEDS)
def test_the_swing_up_stands_the_pole_up_and_keeps_the_cart_on_its_rail(seed):
    run = swing_up(seed)
    assert run.t[-1] == pytest.approx(DURATION)
    worst_x, theta_error = np.max(np.abs(run.q[:, 0])), abs(run.q[-1, 1] - np.pi)
    print(f"seed {seed}: worst |x| {worst_x:.4f} m, final |θ − π| {theta_error:.2e} rad")
    assert theta_error < UPRIGHT
    assert worst_x <= RAIL
    assert np.all(np.abs(run.tau[:, 0]) <= 10.0)  # the scene's force box


def test_the_same_start_gives_the_same_run_bit_for_bit():
    a, b = swing_up(7), swing_up(7)
    for name in ("t", "q", "qd", "tau"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
