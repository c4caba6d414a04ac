"""lagrange.simulate and lagrange.Instance against lagrangectl simulate: the same
Instance code, so the same doubles; and the stepping interface a Python controller uses."""
import os
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import lagrange
from bus_support import LAGRANGECTL, config, joint_block, numbers, read_csv

DURATION = 1.0  # s: 1000 steps of the shipped scenes


def lagrangectl_simulate(scene, duration, tmp_path):
    csv = str(tmp_path / "run.csv")
    r = subprocess.run([LAGRANGECTL, "simulate", scene, "--duration", str(duration), "--csv", csv],
                       capture_output=True, text=True)
    return r, csv


def significant_digits(text):
    mantissa = text.lower().lstrip("-").split("e")[0].replace(".", "")
    return mantissa.strip("0")


def test_the_csv_holds_the_shortest_text_that_reads_back_to_each_double(tmp_path):
    # The premise of comparing bit for bit: lagrangectl simulate writes each double as the shortest text that
    # reads back to it, as Python's repr does; so they have the same digits, and float(text) is the double.
    r, csv = lagrangectl_simulate(config("chain7_minjerk.yaml"), DURATION, tmp_path)
    assert r.returncode == 0, r.stderr
    columns = read_csv(csv)
    texts = [t for name in ("q0", "qd3", "tau6", "kinetic_energy") for t in columns[name]]
    for text in texts:
        assert significant_digits(text) == significant_digits(repr(float(text))), text
    assert max(len(significant_digits(t)) for t in texts) >= 16  # every digit a double needs, not %g's six


# panda_mujoco_minjerk.yaml: a MuJoCo plant (issue 25) runs through the same Instance code.
@pytest.mark.parametrize("scene", ["default.yaml", "chain7_minjerk.yaml", "pendulum.yaml", "panda_mujoco_minjerk.yaml"])
def test_simulate_returns_bit_for_bit_what_lagrangectl_simulate_writes(scene, tmp_path):
    r, csv = lagrangectl_simulate(config(scene), DURATION, tmp_path)
    assert r.returncode == 0, r.stderr
    results = lagrange.simulate(config(scene), DURATION)
    several = len(results) > 1
    moved = False
    for name, run in results.items():
        path = csv.replace(".csv", "." + name + ".csv") if several else csv
        columns = read_csv(path)
        n = run.q.shape[1]
        assert run.t.shape == (int(round(DURATION / 0.001)) + 1,)
        np.testing.assert_array_equal(run.t, numbers(columns, "t"))
        for field in ("q", "qd", "q_des", "tau"):
            np.testing.assert_array_equal(getattr(run, field), joint_block(columns, field, n), err_msg=field)
        np.testing.assert_array_equal(run.kinetic_energy, numbers(columns, "kinetic_energy"))
        np.testing.assert_array_equal(run.potential_energy, numbers(columns, "potential_energy"))
        names = read_csv(path.replace(".csv", ".joints.csv"))["name"]
        assert run.joint_names == names
        assert run.fault is None
        assert run.base is None  # a fixed base: no base rows, the joints' arrays as before
        moved = moved or np.ptp(run.q, axis=0).max() > 1e-3
    assert moved  # a run that stands still would prove little


def test_a_scene_given_as_yaml_text_runs_as_its_file_does():
    path = config("pendulum.yaml")
    with open(path) as f:
        text = f.read()
    from_file = lagrange.simulate(path, 0.2)["pendulum"]
    from_text = lagrange.simulate(text, 0.2)["pendulum"]
    np.testing.assert_array_equal(from_file.q, from_text.q)
    # os.PathLike is a path too.
    import pathlib
    np.testing.assert_array_equal(lagrange.simulate(pathlib.Path(path), 0.2)["pendulum"].q, from_file.q)


def test_the_energy_residual_of_a_free_pendulum_is_its_energy_drift():
    # No torque, no damping: no work is done, so ε = E − E(0) − W is E − E(0), the integrator's drift.
    run = lagrange.simulate(config("pendulum.yaml"), 2.0)["pendulum"]
    energy = run.kinetic_energy + run.potential_energy
    assert np.all(np.isfinite(run.energy_residual))
    np.testing.assert_allclose(run.energy_residual, energy - energy[0], rtol=0, atol=1e-12)
    assert np.max(np.abs(energy - energy[0])) < 1e-4 * np.max(np.abs(run.potential_energy))
    np.testing.assert_array_equal(run.epsilon, run.energy_residual)
    np.testing.assert_array_equal(run.energies, np.stack([run.kinetic_energy, run.potential_energy], axis=1))


def test_stepping_without_a_torque_is_the_simulation_step_for_step():
    run = lagrange.simulate(config("default.yaml"), 0.5)["arm"]
    inst = lagrange.Instance(config("default.yaml"), "arm")
    assert inst.t == 0.0 and inst.period == 0.001
    np.testing.assert_array_equal(inst.q, run.q[0])
    for k in range(1, len(run.t)):
        inst.step()
        assert inst.t == run.t[k]
        np.testing.assert_array_equal(inst.q, run.q[k])
        np.testing.assert_array_equal(inst.qd, run.qd[k])
        np.testing.assert_array_equal(inst.tau, run.tau[k])
    assert inst.kinetic_energy == run.kinetic_energy[-1]
    assert inst.base is None
    inst.reset()
    assert inst.t == 0.0
    np.testing.assert_array_equal(inst.q, run.q[0])


def impedance(target, stiffness=40.0, damping=8.0):
    """tau = K (q* − q) − D q̇: the scene adds G(q) (compensate_gravity: true)."""
    target = np.asarray(target, dtype=float)
    return lambda t, q, qd: stiffness * (target - q) - damping * qd


def test_a_python_law_under_an_external_controller_holds_the_arm_at_its_target():
    target = [0.3, 0.6]
    run = lagrange.simulate(config("arm_impedance_client.yaml"), 3.0, controller=impedance(target))["arm"]
    # Gravity compensated in the scene, a PD law in Python: the arm settles at the target, at rest.
    np.testing.assert_allclose(run.q[-1], target, atol=1e-3)
    np.testing.assert_allclose(run.qd[-1], [0.0, 0.0], atol=1e-3)
    # The applied torque is the law's plus G(q): at rest it holds the arm against gravity.
    assert abs(run.tau[-1][0]) > 1.0


def test_stepping_a_python_law_is_simulate_with_that_law_step_for_step():
    law = impedance([0.3, 0.6])
    run = lagrange.simulate(config("arm_impedance_client.yaml"), 0.3, controller={"arm": law})["arm"]
    inst = lagrange.Instance(config("arm_impedance_client.yaml"))
    assert inst.controller == "external"
    for k in range(1, len(run.t)):
        inst.step(law(inst.t, inst.q, inst.qd))
        np.testing.assert_array_equal(inst.q, run.q[k])
        np.testing.assert_array_equal(inst.tau, run.tau[k])


def test_a_scene_path_may_be_bytes_or_a_file_name_that_is_not_utf8(tmp_path):
    want = lagrange.simulate(config("pendulum.yaml"), 0.05)["pendulum"].q
    name = os.path.join(os.fsencode(tmp_path), b"pendulum\xff.yaml")
    shutil.copyfile(config("pendulum.yaml"), name)
    np.testing.assert_array_equal(lagrange.simulate(name, 0.05)["pendulum"].q, want)
    np.testing.assert_array_equal(lagrange.simulate(os.fsdecode(name), 0.05)["pendulum"].q, want)
    assert lagrange.Instance(name).name == "pendulum"
    with pytest.raises(FileNotFoundError, match=r"nothing\\xff\.yaml"):
        lagrange.simulate(os.path.join(os.fsencode(tmp_path), b"nothing\xff.yaml"), 0.05)


def test_a_run_whose_rows_would_not_fit_in_memory_is_refused_before_it_starts():
    # simulate keeps every row: 1e12 s of the pendulum at 1 kHz would be 6.4e16 bytes. Refused at once, in one
    # line that says how long a run fits, never left to grow until the kernel kills the interpreter.
    for duration in (1e12, 1e300):
        with pytest.raises(ValueError) as e:
            lagrange.simulate(config("pendulum.yaml"), duration)
        assert str(e.value).startswith("duration: ") and "of rows; a quarter of this machine's memory" in str(e.value)
        assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="of rows"):
        lagrange.simulate(config("pendulum.yaml"), 1e12, controller=lambda t, q, qd: [0.0])


def test_bad_scenes_raise_the_cli_one_line_errors(tmp_path):
    missing = str(tmp_path / "missing.yaml")
    with pytest.raises(FileNotFoundError) as e:
        lagrange.simulate(missing, 1.0)
    r, _ = lagrangectl_simulate(missing, 1.0, tmp_path)
    assert r.stderr.strip() == "lagrangectl simulate: " + str(e.value)
    # An external controller needs a torque from somewhere: refused as the CLI refuses it.
    scene = config("arm_impedance_client.yaml")
    with pytest.raises(ValueError) as e:
        lagrange.simulate(scene, 1.0)
    r, _ = lagrangectl_simulate(scene, 1.0, tmp_path)
    assert r.stderr.strip() == "lagrangectl simulate: " + str(e.value)
    with pytest.raises(ValueError, match=r"<scene text>:1:9: period: expected a positive number, got -1"):
        lagrange.simulate("period: -1\ninstances: []\n", 1.0)
    with pytest.raises(ValueError, match="duration"):
        lagrange.simulate(config("pendulum.yaml"), float("nan"))
    with pytest.raises(TypeError):
        lagrange.simulate(42, 1.0)
    with pytest.raises(ValueError, match="no instance 'arn'"):
        lagrange.simulate(config("default.yaml"), 1.0, controller={"arn": impedance([0, 0])})
    with pytest.raises(ValueError, match="2 instances"):
        lagrange.Instance(config("default.yaml"))


def test_a_torque_of_the_wrong_shape_or_not_finite_is_refused_and_nothing_moves():
    inst = lagrange.Instance(config("arm_impedance_client.yaml"))
    with pytest.raises(ValueError, match=r"tau: expected 2 values \(one per joint\), got 3"):
        inst.step([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="tau: expected finite values, got nan at index 1"):
        inst.step([1.0, float("nan")])
    with pytest.raises(ValueError, match="needs a torque"):
        inst.step()
    with pytest.raises(ValueError, match="returned tau"):
        lagrange.simulate(config("arm_impedance_client.yaml"), 0.1, controller=lambda t, q, qd: [0.0])
    assert inst.t == 0.0
    # An exception in the law reaches the caller as it was raised.
    def broken(t, q, qd):
        raise KeyError("law")
    with pytest.raises(KeyError):
        lagrange.simulate(config("arm_impedance_client.yaml"), 0.1, controller=broken)


def test_a_step_that_fails_the_health_check_raises_and_leaves_the_last_healthy_state():
    # A torque far beyond what max_energy allows on a bare arm (controller none): the energy leaves its bound.
    scene = """period: 0.001
instances:
  - name: arm
    plant: {type: arm2}
    controller: {type: none}
    max_energy: 5.0
"""
    inst = lagrange.Instance(scene)
    inst.step([0.0, 0.0])
    q, t = inst.q, inst.t
    with pytest.raises(RuntimeError, match=r"arm faulted at t = .* s: the energy left its bound \(max_energy\)"):
        for _ in range(100):
            inst.step([1e6, 1e6])
            q, t = inst.q, inst.t
    assert np.all(np.isfinite(inst.q))
    assert inst.t == t
    np.testing.assert_array_equal(inst.q, q)
    # simulate: the rows end at the last healthy step, and a RuntimeWarning says why.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = lagrange.simulate(scene, 1.0, controller=lambda t, q, qd: [1e6, 1e6])["arm"]
    assert run.fault is not None and "the energy left its bound" in run.fault
    assert len(run.t) < 1001 and np.all(np.isfinite(run.q))
    assert any(issubclass(w.category, RuntimeWarning) and run.fault in str(w.message) for w in caught)


def test_an_mpc_scene_whose_solves_fail_says_how_many_and_why_as_lagrangectl_does(tmp_path):
    # Every solve diverges (the optimiser's explicit Euler at 1 s a knot from 20 rad/s:
    # tests/tools/simulate_test.cpp); the run goes on, and the result and a RuntimeWarning say so.
    scene = """instances:
  - name: arm
    plant: {type: arm2}
    initial: {q: [0, 0], qd: [20, -20]}
    controller: {type: mpc, horizon: 100, dt: 1.0, integrator: explicit-euler, iterations: 1}
    torque_limits: [5, 5]
"""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = lagrange.simulate(scene, 2.5)["arm"]
    assert run.fault is None and len(run.t) == 2501
    assert run.mpc_failures == ("arm: 3 of 3 mpc solves failed (diverged 3); offline the last usable plan is "
                                "followed meanwhile (none yet: no force), where lagranged falls back")
    assert any(issubclass(w.category, RuntimeWarning) and run.mpc_failures in str(w.message) for w in caught)
    path = tmp_path / "failing.yaml"
    path.write_text(scene)
    r, _ = lagrangectl_simulate(str(path), 2.5, tmp_path)
    assert r.returncode == 0 and r.stderr == "lagrangectl simulate: " + run.mpc_failures + "\n"
    assert lagrange.simulate(config("cartpole_mpc_swingup.yaml"), 0.5)["cartpole"].mpc_failures is None


def test_the_stubs_and_docstrings_name_every_simulator_and_bus_call():
    import ast
    import re
    with open(os.path.join(os.path.dirname(lagrange.__file__), "__init__.pyi")) as f:
        stub = f.read()
    ast.parse(stub)
    for name in ("simulate", "Instance", "SimulationResult", "read_log", "LogChannel", "Client", "State", "Verdict",
                 "StateIterator"):
        assert hasattr(lagrange, name), name
        assert re.search(r"^(class|def) %s\b" % name, stub, re.M), name
    for call in (lagrange.simulate, lagrange.read_log, lagrange.Instance.step, lagrange.Client.command,
                 lagrange.Client.send_torque):
        assert call.__doc__ and len(call.__doc__) > 80, call
    assert "(N, n)" in lagrange.SimulationResult.q.__doc__


# Issue 32: the task space that lagrangectl simulate writes to FILE.task.csv comes with simulate's result
# (issue 35: an mpc controller's frame too).
@pytest.mark.parametrize("scene", ["panda_cartesian_impedance.yaml", "ur5_circle.yaml", "panda_mpc_reach.yaml"])
def test_simulate_returns_the_task_rows_lagrangectl_simulate_writes_bit_for_bit(scene, tmp_path):
    r, csv = lagrangectl_simulate(config(scene), DURATION, tmp_path)
    assert r.returncode == 0, r.stderr
    (run,) = lagrange.simulate(config(scene), DURATION).values()
    columns = read_csv(csv.replace(".csv", ".task.csv"))
    task = run.task
    assert task is not None and task.frame == columns["frame"][0]
    assert task.position.shape == (len(run.t), 3) and task.error.shape == (len(run.t), 6)
    np.testing.assert_array_equal(numbers(columns, "t"), run.t)
    for field, width in (("position", 3), ("position_des", 3), ("error", 6)):
        np.testing.assert_array_equal(getattr(task, field), joint_block(columns, field, width), err_msg=field)
    # The row at t = 0 precedes the first control step; the frame then moves and is held near its target.
    assert np.all(np.isnan(task.position[0])) and np.all(np.isfinite(task.position[1:]))
    assert np.ptp(task.position[1:], axis=0).max() > 1e-3
    assert np.abs(task.error[-1, :3]).max() < 0.05


def test_results_of_other_controllers_and_python_laws_carry_no_task_rows():
    assert lagrange.simulate(config("pendulum.yaml"), 0.01)["pendulum"].task is None
    # A Python law bypasses the scene's task-space controller: it computes nothing to record.
    run = lagrange.simulate(config("panda_cartesian_impedance.yaml"), 0.01, controller=lambda t, q, qd: np.zeros(7))
    assert next(iter(run.values())).task is None


# Issue 32: an Instance's q and q̇ can be set, as a simulated robot is moved by hand.
def test_an_instance_set_to_a_state_steps_on_from_it_as_one_that_started_there():
    # The free pendulum (no controller, no trajectory) put at (0.3 rad, 0.5 rad/s) at t = 0 moves as the same
    # scene started there does, bit for bit; set again mid-run, it runs on from there.
    with open(config("pendulum.yaml")) as f:
        text = f.read()
    started = lagrange.Instance(text.replace("q: [1.5707963267948966]", "q: [0.3]\n      qd: [0.5]"))
    moved = lagrange.Instance(text)
    moved.q = [0.3]
    moved.qd = np.array([0.5])
    np.testing.assert_array_equal(moved.q, [0.3])
    np.testing.assert_array_equal(moved.qd, [0.5])
    np.testing.assert_array_equal(moved.qdd, started.qdd)  # recomputed there: −g sin(0.3) / L
    for _ in range(200):
        moved.step()
        started.step()
    np.testing.assert_array_equal(moved.q, started.q)
    np.testing.assert_array_equal(moved.qd, started.qd)
    t = moved.t
    moved.set_state(q=[-0.2], qd=[0.0])
    assert moved.t == t
    moved.step()
    assert moved.q[0] == pytest.approx(-0.2, abs=1e-4) and moved.qd[0] > 0.0  # from rest at −0.2 rad, falling back


def test_setting_an_instances_state_keeps_its_energy_balance_running_on():
    # The jump in energy is no work done: ε stays what it was, then follows the integrator's drift alone.
    inst = lagrange.Instance(config("pendulum.yaml"))  # free: no torque, no damping, so ε is the drift alone
    for _ in range(50):
        inst.step()
    before = inst.energy_residual
    assert np.isfinite(before)
    energy = inst.kinetic_energy + inst.potential_energy
    inst.set_state(q=inst.q + 0.4, qd=inst.qd + 1.0)
    assert abs(inst.kinetic_energy + inst.potential_energy - energy) > 0.1  # a real jump in E
    assert inst.energy_residual == pytest.approx(before, abs=1e-12)  # to rounding in E(0)'s move by the jump
    for _ in range(50):
        inst.step()
    assert abs(inst.energy_residual - before) < 1e-6


def test_an_instances_state_of_the_wrong_shape_or_not_finite_is_refused_and_nothing_changes():
    inst = lagrange.Instance(config("pendulum.yaml"))
    q = inst.q
    with pytest.raises(ValueError, match=r"q: expected 1 value \(one per joint\), got 2"):
        inst.q = [0.1, 0.2]
    with pytest.raises(ValueError, match="qd: expected finite values, got nan at index 0"):
        inst.qd = [float("nan")]
    with pytest.raises(ValueError, match="q: expected finite values, got inf at index 0"):
        inst.set_state(q=[float("inf")], qd=[1.0])
    np.testing.assert_array_equal(inst.q, q)
    assert inst.qd[0] == 0.0


# A floating base (config/quadruped_free_fall.yaml: the A1 thrown up tumbling, no ground, its legs under PD).
FREE_FALL = "quadruped_free_fall.yaml"
BASE_ARRAYS = (("position", 3), ("orientation", 4), ("linear_velocity", 3), ("angular_velocity", 3), ("com", 3),
               ("linear_momentum", 3), ("angular_momentum", 3))  # log2csv's <NAME>_BASE columns, in order
GRAVITY = np.array([0.0, 0.0, -9.81])


def test_a_floating_base_s_rows_are_bit_for_bit_lagrangectl_simulate_s_base_columns(tmp_path):
    r, csv = lagrangectl_simulate(config(FREE_FALL), 0.2, tmp_path)
    assert r.returncode == 0, r.stderr
    columns = read_csv(csv)
    run = lagrange.simulate(config(FREE_FALL), 0.2)["a1"]
    assert run.q.shape == (201, 12)  # the joints' alone, as in the CSV
    for field in ("q", "qd", "q_des", "tau"):
        np.testing.assert_array_equal(getattr(run, field), joint_block(columns, field, 12), err_msg=field)
    np.testing.assert_array_equal(run.kinetic_energy, numbers(columns, "kinetic_energy"))
    assert run.base is not None
    for name, width in BASE_ARRAYS:
        assert getattr(run.base, name).shape == (201, width)
        np.testing.assert_array_equal(getattr(run.base, name), joint_block(columns, name, width), err_msg=name)


def test_the_tumbling_quadruped_s_centre_of_mass_is_on_the_parabola_and_its_momentum_about_it_stays():
    run = lagrange.simulate(config(FREE_FALL), 1.0)["a1"]
    base, t = run.base, run.t[:, None]
    mass = lagrange.Model.from_urdf(config("robots/a1.urdf"), floating_base=True).mass_matrix(
        np.concatenate([base.position[0], base.orientation[0], run.q[0]]))[0, 0]
    assert 10.0 < mass < 20.0  # kg: the A1's 13.74
    # m c̈ = m g whatever the legs do: c(t) = c0 + ċ0 t + ½ g t², ċ0 the momentum over the mass, to rk4's truncation
    # (1.0e-8 m over 1 s at 1 ms: tests/daemon/floating_scene_test.cpp).
    parabola = base.com[0] + base.linear_momentum[0] / mass * t + 0.5 * GRAVITY * t * t
    np.testing.assert_allclose(base.com, parabola, rtol=0, atol=1e-7)
    # and m ċ = m ċ0 + m g t: ċ to 1e-7 m/s (measured 1.0e-8), so the momentum to 1e-7 m/s × m.
    np.testing.assert_allclose(base.linear_momentum, base.linear_momentum[0] + mass * GRAVITY * t, rtol=0,
                               atol=1e-7 * mass)
    # Gravity has no moment about the centre of mass: the angular momentum about it stays (rk4's truncation).
    angular = base.angular_momentum
    assert np.linalg.norm(angular[0]) > 0.1
    assert np.max(np.linalg.norm(angular - angular[0], axis=1)) < 1e-7 * np.linalg.norm(angular[0])
    np.testing.assert_allclose(np.linalg.norm(base.orientation, axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.min(np.abs(base.orientation[:, 3])) < 0.5  # it tumbled: turned more than 120 degrees at some row
    assert np.ptp(run.q, axis=0).max() > 0.5  # while the legs moved


def test_a_floating_base_s_arrays_mean_what_the_model_computes_from_the_full_state():
    # The rows' com and momentum against lagrange.Model's centre of mass and A_G v at the same q, v: the arrays
    # are in the free-flyer's order (position, quaternion x y z w; v_b, ω_b in base axes) and named for what they are.
    run = lagrange.simulate(config(FREE_FALL), 0.1)["a1"]
    model = lagrange.Model.from_urdf(config("robots/a1.urdf"), floating_base=True)
    b = run.base
    q = np.concatenate([b.position, b.orientation, run.q], axis=1)
    v = np.concatenate([b.linear_velocity, b.angular_velocity, run.qd], axis=1)
    com, _ = model.center_of_mass(q)
    np.testing.assert_allclose(b.com, com, rtol=0, atol=1e-12)
    h = np.einsum("kij,kj->ki", model.centroidal_momentum_matrix(q), v)
    np.testing.assert_allclose(b.linear_momentum, h[:, :3], rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.angular_momentum, h[:, 3:], rtol=0, atol=1e-10)


def test_stepping_a_floating_instance_is_the_simulation_step_for_step():
    run = lagrange.simulate(config(FREE_FALL), 0.05)["a1"]
    inst = lagrange.Instance(config(FREE_FALL))
    assert inst.num_dofs == 12
    for k in range(len(run.t)):
        if k:
            inst.step()
        base = inst.base
        assert base.t == run.t[k] and base.utime is None and base.run_id is None and base.tick is None
        for name, width in BASE_ARRAYS:
            assert getattr(base, name).shape == (width,)
            np.testing.assert_array_equal(getattr(base, name), getattr(run.base, name)[k], err_msg=name)
        np.testing.assert_array_equal(inst.q, run.q[k])
    # Moving the joints by hand leaves the base where it is (Instance.set_state: the joints' state).
    where = inst.base.position
    inst.set_state(q=np.zeros(12))
    np.testing.assert_array_equal(inst.base.position, where)
    inst.reset()
    np.testing.assert_array_equal(inst.base.position, run.base.position[0])


def test_set_state_puts_a_floating_base_where_it_is_told_and_it_falls_from_there():
    inst = lagrange.Instance(config(FREE_FALL))
    quarter = [0.0, 0.0, 0.707106781, 0.707106781]  # a quarter turn about z, typed to 9 digits: normalised
    inst.set_state(qd=np.zeros(12), base_q=[1.0, 2.0, 3.0] + quarter, base_v=np.zeros(6))
    base = inst.base
    np.testing.assert_array_equal(base.position, [1.0, 2.0, 3.0])
    assert abs(np.linalg.norm(base.orientation) - 1.0) < 1e-15
    np.testing.assert_allclose(base.orientation, np.array(quarter) / np.linalg.norm(quarter), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(base.linear_velocity, np.zeros(3))
    np.testing.assert_array_equal(base.linear_momentum, np.zeros(3))
    # At rest, whatever the legs then do under their PD: c(t) = c0 + ½ g t², from the state set.
    c0, t0 = base.com.copy(), inst.t
    for _ in range(200):
        inst.step()
    dt = inst.t - t0
    np.testing.assert_allclose(inst.base.com, c0 + 0.5 * GRAVITY * dt * dt, rtol=0, atol=1e-7)
    # base_v alone keeps the pose it is at.
    where = inst.base.position.copy()
    inst.set_state(base_v=[0.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(inst.base.position, where)
    np.testing.assert_array_equal(inst.base.linear_velocity, [0.5, 0.0, 0.0])


def test_set_state_refuses_a_bad_base_and_moves_nothing():
    inst = lagrange.Instance(config(FREE_FALL))
    where, q = inst.base.position.copy(), inst.q.copy()
    with pytest.raises(ValueError, match=r"base_q: expected \[px, py, pz, x, y, z, w\] with a unit quaternion .* got "
                                         r"one of norm 2"):
        inst.set_state(q=np.zeros(12), base_q=[0, 0, 1, 0, 0, 0, 2])
    with pytest.raises(ValueError, match="base_v: expected 6 values"):
        inst.set_state(base_v=[0.0] * 5)
    with pytest.raises(ValueError, match="base_q: expected finite values, got nan"):
        inst.set_state(base_q=[0, 0, float("nan"), 0, 0, 0, 1])
    np.testing.assert_array_equal(inst.base.position, where)
    np.testing.assert_array_equal(inst.q, q)
    fixed = lagrange.Instance(config("pendulum.yaml"))
    with pytest.raises(ValueError, match="base_q: this instance's base is fixed"):
        fixed.set_state(base_q=[0, 0, 0, 0, 0, 0, 1])
    with pytest.raises(ValueError, match="base_v: this instance's base is fixed"):
        fixed.set_state(base_v=np.zeros(6))
