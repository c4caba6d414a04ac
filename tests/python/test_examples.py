"""The examples in examples/python/ against a live lagranged on private ports
(8335, 8336): the external controller holds the arm, and the payload is found
from a logged run."""
import importlib.util
import os
import time

import numpy as np
import pytest

import lagrange
from bus_support import SOURCE, config, lagranged, lcm_url, record_run

CONTROLLER_PORT = 8335
PAYLOAD_PORT = 8336


def example(name):
    path = os.path.join(SOURCE, "examples", "python", name + ".py")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_python_external_controller_holds_the_arm_at_its_target():
    controller = example("external_controller")
    target = np.array([0.3, 0.6])
    with lagranged(config("arm_impedance_client.yaml"), CONTROLLER_PORT):
        client = lagrange.Client(url=lcm_url(CONTROLLER_PORT), wait=5.0)
        before = client.state("arm", timeout=5.0)
        assert before.controller == "external"
        np.testing.assert_allclose(before.q, [np.pi / 4, 0.0], atol=1e-3)  # held where it started, far from the target
        # Until the arm is held at the target after at least 2 s of simulated time (a loaded machine runs fewer
        # ticks per wall second, and may let a torque time out into hold for a while), at most 60 s.
        law = controller.impedance(target, 40.0, 8.0)
        deadline = time.monotonic() + 60.0
        torques = 0
        while True:
            r = controller.run(client, "arm", law, 0.5)
            torques += r["torques"]
            after = r["last"]  # the last state the loop answered (once it stops, the daemon holds after torque_timeout)
            held = after is not None and np.allclose(after.q, target, rtol=0, atol=1e-3)
            if held and after.t - before.t >= 2.0 and after.mode == "running":
                break
            if time.monotonic() > deadline:
                break
    assert torques > 0
    # The Python law (with G(q) added by the daemon) brought the arm to the target and holds it there, at rest.
    assert after.mode == "running"
    np.testing.assert_allclose(after.q, target, atol=1e-3)
    np.testing.assert_allclose(after.qd, [0.0, 0.0], atol=1e-2)
    # The torque applied is the law's plus gravity: holding link 1 up takes more than the law's own share.
    assert abs(after.tau[0]) > 1.0
    # The example's own report: a latency for every torque.
    assert len(r["latency_us"]) == r["torques"]


def test_payload_identification_finds_the_payload_from_a_logged_run(tmp_path):
    ident = example("payload_identification")
    scene = os.path.join(SOURCE, "examples", "python", "arm_payload.yaml")
    log = record_run(scene, PAYLOAD_PORT, str(tmp_path / "run.lcm"), 1.0, until=lambda rows: rows.get("ARM_STATE", 0) >= 300)
    q, qd, qdd, tau = ident.states_of(log, "ARM_STATE")
    assert len(q) > 20  # as many as the logger caught: a loaded machine drops some, least squares needs few
    mass, rms = ident.identify_link_mass(q, qd, qdd, tau)
    # The scene's link 2 weighs 1.1 kg; the nominal model says 0.8: 0.3 kg of payload.
    assert mass == pytest.approx(1.1, abs=1e-6)
    assert rms < 1e-6
    # The nominal model alone misses by the payload's torque.
    nominal = lagrange.Model.builtin("arm2", **ident.NOMINAL).inverse_dynamics(q, qd, qdd)
    assert np.sqrt(np.mean((tau - nominal) ** 2)) > 0.1
