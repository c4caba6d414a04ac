"""lagrange.Client against a live lagranged on private LCM ports (8322-8327 and
9120, this host only): states, setpoints, torques and commands through the
project's own client, with the verdicts and errors lagrangectl reports."""
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import lagrange
from bus_support import LAGRANGECTL, config, lagranged, lcm_url, wait_until

PORT = 8322  # default.yaml: arm (computed torque) and cartpole
TWO_RUNS_PORT = 8323
SIGNED_PORT = 8324
FLOATING_PORT = 9120  # config/quadruped_free_fall.yaml: the A1 on a floating base, publishing A1_BASE


@pytest.fixture(scope="module")
def daemon():
    with lagranged(config("default.yaml"), PORT) as p:
        client = lagrange.Client(url=lcm_url(PORT), wait=5.0)
        client.state("arm", timeout=5.0)  # started
        yield client
        assert p.poll() is None  # nothing the tests sent stopped it


def lagrangectl(*args, port=PORT):
    return subprocess.run([LAGRANGECTL, *args, "--lcm-url", lcm_url(port)], capture_output=True, text=True)


def test_the_latest_state_is_the_arms_held_at_its_initial_pose(daemon):
    s = daemon.state("arm")
    assert s.num_dofs == 2 and s.q.shape == (2,) and s.q.dtype == np.float64
    assert s.run_id != 0 and s.controller == "computed-torque"
    assert s.mode in ("running", "hold")
    assert np.all(np.isfinite(s.q)) and np.all(np.isfinite(s.tau))
    # Computed torque holds the arm where it started (pi/4, 0) against gravity: tau is G(q), not zero.
    np.testing.assert_allclose(s.q, [np.pi / 4, 0.0], atol=1e-6)
    assert abs(s.tau[0]) > 1.0
    assert s.kinetic_energy == pytest.approx(0.0, abs=1e-9)
    assert daemon.state("cartpole").num_dofs == 2


def test_states_come_in_tick_order_from_one_run(daemon):
    states = list(daemon.states("arm", duration=0.3))
    assert len(states) > 0
    ticks = [s.tick for s in states]
    assert ticks == sorted(set(ticks))
    assert len({s.run_id for s in states}) == 1
    assert all(b.received >= a.received for a, b in zip(states, states[1:]))


def test_a_states_iterator_gets_every_state_whatever_another_one_does(daemon):
    # Each iterator has its own queue: two at once both see the states that came while both listened (one
    # shared queue would hand each state to one of them), and one that goes (`it = c.states(...)` again)
    # leaves the other listening (it had stopped the queue they shared).
    one, two = daemon.states("arm", duration=10.0), daemon.states("arm", duration=10.0)
    ticks_one, ticks_two = [], []
    for _ in range(5):
        ticks_one.append(next(one).tick)
        ticks_two.append(next(two).tick)
    assert set(ticks_one) & set(ticks_two)
    del one
    a, b = next(two), next(two)
    assert b.tick > a.tick > ticks_two[-1]
    del two


def test_waiting_for_states_releases_the_gil(daemon):
    # With a switch interval of 1000 s, another Python thread runs only while this one gives the GIL up of its
    # own accord (the interpreter never takes it from this one): a thread that counts, sleeping 1 ms between
    # counts so that this one gets the GIL back, counts during the wait only if the wait released it.
    count = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1
            time.sleep(0.001)

    interval = sys.getswitchinterval()
    t = threading.Thread(target=spin)
    sys.setswitchinterval(1000.0)
    try:
        t.start()
        before = count[0]
        for _ in daemon.states("arm", duration=0.3):
            pass
        during = count[0] - before
    finally:
        stop.set()
        t.join()
        sys.setswitchinterval(interval)
    assert during > 0


def test_streamed_setpoints_move_the_arm_there(daemon):
    target = np.array([0.5, -0.3])
    # Streamed for 1.5 s of simulated time (a loaded machine runs fewer ticks per wall second), 60 s at most.
    start = daemon.state("arm").t
    deadline = time.monotonic() + 60.0
    while daemon.state("arm").t - start < 1.5 and time.monotonic() < deadline:
        assert daemon.send_setpoint("arm", q=target)
        time.sleep(0.01)
    s = daemon.state("arm")
    np.testing.assert_allclose(s.q_des, target)
    np.testing.assert_allclose(s.q, target, atol=1e-2)
    with pytest.raises(ValueError, match=r"q: expected 2 values \(one per joint\), got 3"):
        daemon.send_setpoint("arm", q=[0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match="qd: expected finite values"):
        daemon.send_setpoint("arm", q=target, qd=[0.0, float("inf")])


def test_commands_return_the_daemons_verdict_as_lagrangectl_reports_it(daemon):
    r = daemon.command("arm", "pause")
    assert r.accepted and bool(r)
    assert r.message == "arm: pause done; now paused with computed-torque"
    assert daemon.state("arm").mode == "paused"
    cli = lagrangectl("command", "arm", "resume")
    assert cli.returncode == 0, cli.stderr
    # A refusal is lagranged's, word for word as lagrangectl prints it.
    r = daemon.command("arm", "controller", "lqr-of-dreams")
    assert not r.accepted and r.message.startswith("refused: unknown controller 'lqr-of-dreams' for arm")
    cli = lagrangectl("command", "arm", "controller", "lqr-of-dreams")
    assert cli.returncode == 1 and cli.stderr.strip() == "lagrangectl command: " + r.message
    r = daemon.command("arm", "gains", kp=[150, 100], kd=20)
    assert r.accepted, r.message
    r = daemon.command("arm", "estop")
    assert r.accepted and r.message.startswith("arm: estop done; now estop")
    assert daemon.state("arm").mode == "estop"
    time.sleep(0.5)  # an estop lasts the scene's estop_dwell (0.5 s) before a clear can end it
    assert daemon.command("arm", "clear").accepted


def test_bad_words_and_arguments_raise_value_error_before_anything_is_sent(daemon):
    with pytest.raises(ValueError) as e:
        daemon.command("arm", "explode")
    cli = lagrangectl("command", "arm", "explode")
    assert cli.returncode == 2 and cli.stderr.strip() == "lagrangectl command: " + str(e.value)
    with pytest.raises(ValueError, match="effect damping: expected on or off, got 'maybe'"):
        daemon.command("arm", "effect", "damping", "maybe")
    with pytest.raises(ValueError, match="gains: needs both kp and kd"):
        daemon.command("arm", "gains", kp=1.0)
    with pytest.raises(ValueError, match="kp: expected gains >= 0"):
        daemon.command("arm", "gains", kp=-1.0, kd=1.0)
    with pytest.raises(ValueError, match="LCM URL 'udp://x': not a udpm:// URL"):
        lagrange.Client(url="udp://x")
    with pytest.raises(ValueError, match="bus key"):
        lagrange.Client(url=lcm_url(PORT), key_file="/nonexistent/key")
    # An empty path (an unset variable) is refused, never read as "unsigned"; an empty domain likewise.
    with pytest.raises(ValueError, match="bus key '': an empty path"):
        lagrange.Client(url=lcm_url(PORT), key_file="")
    with pytest.raises(ValueError, match="--bus-domain: an empty bus domain"):
        lagrange.Client(url=lcm_url(PORT), bus_domain="")
    with pytest.raises(ValueError, match="prefix: expected the start of an LCM channel name"):
        lagrange.Client(url=lcm_url(PORT), prefix="SIM ")
    # A name no channel can carry is the caller's mistake, said before anything waits.
    for name in ("arm rm", "a\x00b", "x" * 80, ""):
        with pytest.raises(ValueError, match="name"):
            daemon.state(name)
    with pytest.raises(ValueError, match="timeout: expected a positive number of seconds"):
        daemon.state("arm", timeout=-1.0)
    with pytest.raises(ValueError, match=r"tau: expected 2 values \(one per joint\), got 1"):
        daemon.send_torque("arm", tau=[1.0])
    with pytest.raises(ValueError, match="channel: expected an LCM channel name"):
        daemon.send_torque("arm", tau=[0.0, 0.0], channel="NO SPACES")


def test_an_instance_nobody_publishes_is_a_runtime_error_naming_the_nearest(daemon):
    with pytest.raises(RuntimeError, match=r"no state from instance 'arn' on ARN_STATE.*did you mean 'arm'\?"):
        lagrange.Client(url=lcm_url(PORT)).state("arn", timeout=2.0)


def test_two_runs_on_one_channel_refuse_to_act_but_both_take_the_estop():
    with lagranged(config("default.yaml"), TWO_RUNS_PORT), lagranged(config("default.yaml"), TWO_RUNS_PORT):
        def refused():  # once both publish (a loaded machine may start one later)
            try:
                lagrange.Client(url=lcm_url(TWO_RUNS_PORT), wait=5.0).state("arm", timeout=5.0)
                return False
            except RuntimeError as e:
                assert "two lagranged runs publish ARM_STATE" in str(e) and "refusing to act" in str(e)
                return True
        assert wait_until(refused, 30.0)
        r = lagrange.Client(url=lcm_url(TWO_RUNS_PORT), wait=5.0).command("arm", "estop")
        assert r.accepted, r.message
        lines = r.message.splitlines()
        assert len(lines) == 2 and all(": estop done; now estop" in line for line in lines)
        # lagrangectl reports the same estop in the same words (one command session, protocol/command_session.hpp).
        cli = lagrangectl("command", "arm", "estop", "--wait", "5", port=TWO_RUNS_PORT)
        assert cli.returncode == 0, cli.stderr
        assert cli.stdout.splitlines() == lines


def test_a_signed_daemon_is_heard_only_with_its_key(tmp_path):
    key = str(tmp_path / "bus.key")
    assert subprocess.run([LAGRANGECTL, "keygen", key], capture_output=True).returncode == 0
    with lagranged(config("default.yaml"), SIGNED_PORT, "--bus-key", key):
        signed = lagrange.Client(url=lcm_url(SIGNED_PORT), key_file=key, wait=5.0)
        assert signed.state("arm", timeout=5.0).num_dofs == 2
        assert signed.command("arm", "pause").accepted
        # The key and another bus domain: its tags are not the daemon's, nothing verifies, and it says why.
        elsewhere = lagrange.Client(url=lcm_url(SIGNED_PORT), key_file=key, bus_domain="cell-9", wait=2.0)
        with pytest.raises(RuntimeError, match=r"another bus domain \(this client's is cell-9"):
            elsewhere.state("arm", timeout=2.0)
        unsigned = lagrange.Client(url=lcm_url(SIGNED_PORT), key_file=None, wait=2.0)
        env_key = os.environ.pop("LAGRANGE_BUS_KEY_FILE", None)
        try:
            with pytest.raises(RuntimeError, match="its states are signed; give the daemon's key"):
                unsigned.state("arm", timeout=2.0)
        finally:
            if env_key is not None:
                os.environ["LAGRANGE_BUS_KEY_FILE"] = env_key


HOSTILE_PORT = 8325


def test_a_channel_name_that_is_not_utf8_on_the_bus_reaches_python_escaped():
    # A datagram in LCM's format (LC02, seqno, channel NUL, payload) on a channel whose name is not UTF-8:
    # the client's hint lists it, and the message reaches Python with those bytes as \xHH.
    import socket
    import struct
    from bus_support import prepare_loopback_multicast
    prepare_loopback_multicast()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    datagram = b"LC02" + struct.pack(">I", 1) + b"\xff\xfe_STATE\0" + b"not a state"
    stop = threading.Event()

    def send():
        while not stop.is_set():
            sock.sendto(datagram, ("239.255.76.67", HOSTILE_PORT))
            time.sleep(0.01)

    t = threading.Thread(target=send)
    t.start()
    try:
        with pytest.raises(RuntimeError) as e:
            lagrange.Client(url=lcm_url(HOSTILE_PORT), wait=1.0).state("arm", timeout=1.0)
    finally:
        stop.set()
        t.join()
        sock.close()
    assert "\\xff\\xfe_STATE" in str(e.value)


# ---- issue 32 ----------------------------------------------------------------------------------------------------

TORQUE_PORT = 8500  # arm_impedance_client.yaml: the arm under its external controller


def test_a_torque_to_an_instance_that_takes_none_is_refused_unsent(daemon):
    # default.yaml's arm runs computed torque and its scene lists no external controller: nothing listens for
    # torques, so none is sent, and the refusal is in lagranged's words.
    v = daemon.send_torque("arm", tau=[1.0, 0.2])
    assert isinstance(v, lagrange.Verdict) and not v and not v.accepted
    assert v.message == "refused: the instance is not running its external controller (active: computed-torque)"
    assert v.run_id == daemon.state("arm").run_id


def test_a_torque_is_sent_to_a_running_external_controller_and_refused_as_lagranged_refuses_it():
    with lagranged(config("arm_impedance_client.yaml"), TORQUE_PORT):
        client = lagrange.Client(url=lcm_url(TORQUE_PORT), wait=5.0)
        assert client.state("arm", timeout=5.0).controller == "external"
        v = client.send_torque("arm", tau=[0.5, 0.1])
        assert v.accepted and bool(v) and v.message == "arm: torque 1 sent on ARM_TORQUE", v.message
        assert client.send_torque("arm", tau=[0.5, 0.1]).message == "arm: torque 2 sent on ARM_TORQUE"
        assert client.command("arm", "controller", "gravity-compensation").accepted
        v = client.send_torque("arm", tau=[0.5, 0.1])
        assert not v.accepted
        reason = "the instance is not running its external controller (active: gravity-compensation)"
        assert v.message == "refused: " + reason
        # The one wording: lagranged, sent such a torque by lagrangectl, refuses it with the same reason.
        cli = subprocess.run([LAGRANGECTL, "send", "arm", "--tau", "0.5,0.1", "--for", "0.3", "--lcm-url",
                              lcm_url(TORQUE_PORT)], capture_output=True, text=True)
        assert cli.returncode == 1 and "torque: " + reason in cli.stderr, cli.stderr


def test_a_wait_beyond_a_day_is_refused_in_lagrangectl_s_words():
    # inf and nan were refused; 1e9 s (32 years) was accepted and held the caller. The bound is the client's one
    # rule (protocol/client.hpp: CheckWait), which lagrangectl --wait applies too.
    expected = "expected a positive number of seconds up to 86400 (a day), got 1e+09"
    with pytest.raises(ValueError) as e:
        lagrange.Client(url=lcm_url(PORT), wait=1e9)
    assert str(e.value) == "wait: " + expected
    cli = lagrangectl("command", "arm", "pause", "--wait", "1e9")
    assert cli.returncode == 2 and cli.stderr.strip().endswith("--wait: " + expected), cli.stderr
    client = lagrange.Client(url=lcm_url(PORT), wait=1.0)
    for bad in (1e9, float("inf"), float("nan"), 0.0, -1.0):
        with pytest.raises(ValueError, match=r"^timeout: expected a positive number of seconds up to 86400 \(a day\)"):
            client.state("arm", timeout=bad)
        with pytest.raises(ValueError, match=r"^wait: expected a positive number of seconds up to 86400"):
            lagrange.Client(url=lcm_url(PORT), wait=bad)
    lagrange.Client(url=lcm_url(PORT), wait=86400.0)  # a day is still a wait


def test_a_floating_base_s_base_state_comes_from_the_run_beside_its_states_and_a_fixed_base_has_none(daemon):
    with lagranged(config("quadruped_free_fall.yaml"), FLOATING_PORT):
        client = lagrange.Client(url=lcm_url(FLOATING_PORT), wait=5.0)
        state = client.state("a1", timeout=5.0)
        assert state.num_dofs == 12  # state_t carries the joints alone
        first = client.base_state("a1")
        assert first.run_id == state.run_id and first.tick is not None and first.utime is not None
        assert first.position.shape == (3,) and first.orientation.shape == (4,) and first.com.shape == (3,)
        assert abs(np.linalg.norm(first.orientation) - 1.0) < 1e-12
        assert wait_until(lambda: client.base_state("a1").tick > first.tick + 10, 5.0)
        later = client.base_state("a1")
        # Free fall: the linear momentum grows by m g Δt between any two ticks, whatever the legs do.
        mass = lagrange.Model.from_urdf(config("robots/a1.urdf"), floating_base=True).mass_matrix(
            np.concatenate([first.position, first.orientation, np.zeros(12)]))[0, 0]
        np.testing.assert_allclose(later.linear_momentum - first.linear_momentum,
                                   [0.0, 0.0, -9.81 * mass * (later.t - first.t)], rtol=0, atol=1e-6)
        np.testing.assert_allclose(later.angular_momentum, first.angular_momentum, rtol=0, atol=1e-6)
    # A fixed base publishes no <NAME>_BASE: said in one line, after the timeout.
    with pytest.raises(RuntimeError, match=r"^no base state from instance 'arm' on ARM_BASE within 0.5 s .*floating"):
        daemon.base_state("arm", timeout=0.5)
