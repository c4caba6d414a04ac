"""lagrange.Model's derivatives: forward_dynamics_derivatives and inverse_dynamics_derivatives give
`lagrangectl eval --derivatives`' doubles bit for bit for every method, step_derivatives matches differences of the
step, batches equal their single calls, and bad input raises one-line Python errors."""
import json
import os
import re
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import lagrange

SOURCE = os.environ["LAGRANGE_SOURCE_DIR"]
LAGRANGECTL = os.environ["LAGRANGECTL"]
PANDA = os.path.join(SOURCE, "config/robots/panda.urdf")
PANDA_HAND = os.path.join(SOURCE, "config/robots/panda_hand.urdf")  # a prismatic finger and its mimic

# (name, how Model is built, eval's arguments for the same plant, methods)
PLANTS = [
    ("arm2", lambda m: lagrange.Model.builtin("arm2", method=m, m1=1.2), ["--plant", "arm2", "--param", "m1=1.2"],
     ["closed-form", "lagrangian", "recursive"]),
    ("cartpole", lambda m: lagrange.Model.builtin("cartpole", method=m), ["--plant", "cartpole"],
     ["closed-form", "lagrangian", "recursive"]),
    ("chain", lambda m: lagrange.Model.builtin("chain", method=m, links=3, joints=["revolute", "prismatic", "revolute"]),
     ["--plant", "chain", "--links", "3", "--param", "joints=revolute,prismatic,revolute"], ["lagrangian", "recursive"]),
    ("panda", lambda m: lagrange.Model.from_urdf(PANDA, method=m), ["--urdf", PANDA], ["recursive", "lagrangian"]),
    ("panda_hand", lambda m: lagrange.Model.from_urdf(PANDA_HAND, method=m), ["--urdf", PANDA_HAND],
     ["recursive", "lagrangian"]),
]
CASES = [(name, build, args, method) for name, build, args, methods in PLANTS for method in methods]


def numbers(values):
    return ",".join(repr(float(x)) for x in values)


def exactly(a, b):
    """Bit for bit: the same shape and the same doubles."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def evaluate(args, method, q, qd, tau):
    r = subprocess.run([LAGRANGECTL, "eval", *args, "--method", method, "--q", numbers(q), "--qd", numbers(qd),
                        "--tau", numbers(tau), "--derivatives"], capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


def state(model, seed, count=None):
    rng = np.random.default_rng(seed)
    shape = (model.num_dofs,) if count is None else (count, model.num_dofs)
    return rng.uniform(-1.5, 1.5, shape), rng.uniform(-2, 2, shape), rng.uniform(-5, 5, shape)


@pytest.mark.parametrize("name,build,args,method", CASES, ids=[f"{c[0]}-{c[3]}" for c in CASES])
def test_derivatives_are_lagrangectl_evals_doubles_bit_for_bit(name, build, args, method):
    model = build(method)
    q, qd, tau = state(model, 42)
    ref = evaluate(args, method, q, qd, tau)
    d = ref["derivatives"]
    dqdd_dq, dqdd_dqd, dqdd_dtau = model.forward_dynamics_derivatives(q, qd, tau)
    assert exactly(dqdd_dq, d["dqdd_dq"]) and exactly(dqdd_dqd, d["dqdd_dqd"]) and exactly(dqdd_dtau, d["dqdd_dtau"])
    dtau_dq, dtau_dqd, dtau_dqdd = model.inverse_dynamics_derivatives(q, qd, ref["qdd"])
    assert exactly(dtau_dq, d["dtau_dq"]) and exactly(dtau_dqd, d["dtau_dqd"])
    # M by the derivative sweep: the mass matrix to round-off (a different order of the same sums).
    M = model.mass_matrix(q)
    np.testing.assert_allclose(dtau_dqdd, M, rtol=0, atol=1e-14 * np.abs(M).max())


@pytest.mark.parametrize("name,build,args,methods", PLANTS, ids=[p[0] for p in PLANTS])
def test_every_method_gives_the_same_derivatives(name, build, args, methods):
    q, qd, tau = state(build(methods[0]), 3, count=4)
    results = [build(m).forward_dynamics_derivatives(q, qd, tau) for m in methods]
    for other in results[1:]:
        for a, b in zip(results[0], other):
            np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9 * np.abs(a).max())


def test_forward_derivatives_match_central_differences_and_dqdd_dtau_inverts_m():
    model = lagrange.Model.from_urdf(PANDA_HAND)
    q, qd, tau = state(model, 8)
    dq, dqd, dtau = model.forward_dynamics_derivatives(q, qd, tau)
    h = 1e-6
    for j in range(model.num_dofs):
        e = np.zeros(model.num_dofs)
        e[j] = h
        col = (model.forward_dynamics(q + e, qd, tau) - model.forward_dynamics(q - e, qd, tau)) / (2 * h)
        np.testing.assert_allclose(dq[:, j], col, rtol=1e-5, atol=1e-6 * np.abs(dq).max())
        col = (model.forward_dynamics(q, qd + e, tau) - model.forward_dynamics(q, qd - e, tau)) / (2 * h)
        np.testing.assert_allclose(dqd[:, j], col, rtol=1e-5, atol=1e-6 * np.abs(dqd).max())
    np.testing.assert_allclose(dtau @ model.mass_matrix(q), np.eye(model.num_dofs), atol=1e-10)


@pytest.mark.parametrize("integrator", ["explicit-euler", "semi-implicit-euler", "rk4"])
def test_step_derivatives_match_differences_of_the_step(integrator):
    # The step of the same integrator, written here from forward_dynamics: x⁺ = Φ(x, tau, dt).
    model = lagrange.Model.builtin("arm2")
    q, qd, tau = np.array([0.4, -0.8]), np.array([1.1, -0.3]), np.array([0.5, 1.5])
    dt = 0.01

    def step(x, u):
        p, v = x[:2], x[2:]
        f = lambda p, v: np.concatenate([v, model.forward_dynamics(p, v, u)])  # noqa: E731
        if integrator == "explicit-euler":
            return x + dt * f(p, v)
        if integrator == "semi-implicit-euler":
            v1 = v + dt * model.forward_dynamics(p, v, u)
            return np.concatenate([p + dt * v1, v1])
        k1 = f(p, v)
        k2 = f(*np.split(x + dt / 2 * k1, 2))
        k3 = f(*np.split(x + dt / 2 * k2, 2))
        k4 = f(*np.split(x + dt * k3, 2))
        return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    A, B = model.step_derivatives(q, qd, tau, dt, integrator)
    assert A.shape == (4, 4) and B.shape == (4, 2)
    x, h = np.concatenate([q, qd]), 1e-6
    for j in range(4):
        e = np.zeros(4)
        e[j] = h
        np.testing.assert_allclose(A[:, j], (step(x + e, tau) - step(x - e, tau)) / (2 * h), rtol=1e-6, atol=1e-8)
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        np.testing.assert_allclose(B[:, j], (step(x, tau + e) - step(x, tau - e)) / (2 * h), rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("threads", [1, 3])
def test_a_batch_equals_its_single_calls_row_by_row(threads):
    model = lagrange.Model.from_urdf(PANDA)
    q, qd, tau = state(model, 11, count=5)
    fd = model.forward_dynamics_derivatives(q, qd, tau, threads=threads)
    idd = model.inverse_dynamics_derivatives(q, qd, tau, threads=threads)
    step = model.step_derivatives(q, qd, tau, 1e-3, threads=threads)
    assert [a.shape for a in fd] == [(5, 7, 7)] * 3 and [a.shape for a in idd] == [(5, 7, 7)] * 3
    assert step[0].shape == (5, 14, 14) and step[1].shape == (5, 14, 7)
    for i in range(5):
        for batch, one in ((fd, model.forward_dynamics_derivatives(q[i], qd[i], tau[i])),
                           (idd, model.inverse_dynamics_derivatives(q[i], qd[i], tau[i])),
                           (step, model.step_derivatives(q[i], qd[i], tau[i], 1e-3))):
            for b, o in zip(batch, one):
                assert exactly(b[i], o)
    # A single state is used for every row of a batched argument.
    shared = model.forward_dynamics_derivatives(q, qd[0], tau[0])
    for i in range(5):
        assert exactly(shared[0][i], model.forward_dynamics_derivatives(q[i], qd[0], tau[0])[0])



@pytest.mark.parametrize("call", ["forward_dynamics_derivatives", "inverse_dynamics_derivatives", "step_derivatives"])
def test_a_batch_lets_other_python_threads_run_meanwhile(call):
    # With a switch interval of 1000 s the interpreter never takes the GIL from this thread: another thread that
    # counts runs only while this one gives the GIL up of its own accord. Held through a batch, the count cannot
    # move at all; released, it moves as soon as the counting thread is scheduled (the batch lasts milliseconds).
    model = lagrange.Model.from_urdf(PANDA)
    q, qd, tau = state(model, 5, count=10000)
    args = (q, qd, tau, 1e-3) if call == "step_derivatives" else (q, qd, tau)
    count, stop = [0], threading.Event()

    def counter():
        while not stop.is_set():
            count[0] += 1
            time.sleep(0)

    interval = sys.getswitchinterval()
    worker = threading.Thread(target=counter)
    sys.setswitchinterval(1000.0)
    try:
        worker.start()
        while count[0] < 100:  # running (this sleep gives the GIL up)
            time.sleep(0.001)
        moved = []
        for _ in range(3):
            before = count[0]
            getattr(model, call)(*args)
            moved.append(count[0] - before)
    finally:
        stop.set()
        worker.join()
        sys.setswitchinterval(interval)
    assert max(moved) > 0, moved


def test_bad_input_is_one_line_naming_the_argument():
    model = lagrange.Model.builtin("arm2")
    with pytest.raises(ValueError, match=r"^q: expected 2 values \(one per joint\), got 3$"):
        model.forward_dynamics_derivatives([0, 0, 0], [0, 0], [0, 0])
    with pytest.raises(ValueError, match=r"^qdd: expected finite numbers"):
        model.inverse_dynamics_derivatives([0, 0], [0, 0], [np.nan, 0])
    with pytest.raises(ValueError, match=r"^integrator: integrator dopri5 has no step derivatives "
                                         r"\(explicit-euler, semi-implicit-euler or rk4 have\)$"):
        model.step_derivatives([0, 0], [0, 0], [0, 0], 1e-3, "dopri5")
    with pytest.raises(ValueError, match=r"^integrator: expected explicit-euler, semi-implicit-euler or rk4, got 'rk5'$"):
        model.step_derivatives([0, 0], [0, 0], [0, 0], 1e-3, "rk5")
    with pytest.raises(ValueError, match=r"^dt: expected a positive number of seconds, got -0.001$"):
        model.step_derivatives([0, 0], [0, 0], [0, 0], -1e-3)
    with pytest.raises(ValueError, match=r"^threads: expected 1..1024, got 0$"):
        model.forward_dynamics_derivatives([0, 0], [0, 0], [0, 0], threads=0)
    with pytest.raises(RuntimeError, match=r"^the derivatives are not finite at state 1$"):
        model.forward_dynamics_derivatives([[0, 0], [0, 0]], [[0, 0], [1e200, 0]], [0, 0])


def readme_examples():
    """The README's "Derivatives" section: each ```python block with the ``` block after "prints" that follows it."""
    with open(os.path.join(SOURCE, "README.md"), encoding="utf-8") as f:
        text = f.read()
    section = text[text.index("\n## Derivatives\n"):]
    section = section[:section.index("\n## ", 1)]
    return re.findall(r"```python\n(.*?)```\n\nprints\n\n```\n(.*?)```", section, re.S)


NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def test_the_readmes_derivatives_examples_run_as_written_and_print_what_it_quotes(monkeypatch, capsys):
    examples = readme_examples()
    assert len(examples) == 2  # linearising the Panda; continuous and discrete LQR
    monkeypatch.chdir(SOURCE)  # its paths are the checkout's
    for code, quoted in examples:
        scope = {}
        exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 - the README's own example
        printed = capsys.readouterr().out
        # The same lines but for the numbers, and the numbers to within a factor of 2 (round-off of the
        # differences, another build's last bits).
        assert NUMBER.sub("#", printed) == NUMBER.sub("#", quoted)
        for got, want in zip(NUMBER.findall(printed), NUMBER.findall(quoted)):
            got, want = float(got), float(want)
            assert (got == want == 0) or 0.5 <= got / want <= 2, (got, want)
        if "panda" in scope:
            # The linearisation matches the differences to far better than their own 1e-6 step allows,
            # and the step's A leaves I + h A by O(h²): a quarter of it at half the step.
            assert scope["worst"] < 1e-6
            panda, q, qd, tau, A = (scope[k] for k in ("panda", "q", "qd", "tau", "A"))
            gap = [np.abs(panda.step_derivatives(q, qd, tau, h, "rk4")[0] - (np.eye(14) + h * A)).max()
                   for h in (1e-3, 5e-4)]
            assert 3.5 < gap[0] / gap[1] < 4.5
        else:
            late = {name: np.abs(np.remainder(run.q[run.t > 10.0, 1], 2 * np.pi) - np.pi).max()
                    for name, run in scope["runs"].items()}
            assert late["continuous"] > 0.1 and late["discrete"] < 1e-4
