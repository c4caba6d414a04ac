"""One command session (protocol/command_session.hpp) for lagrangectl command and lagrange.Client.command:
against a live lagranged on a private LCM port (8790, this host only), the same command gets the same words
from both: refusals (lagranged's reason, escaped, shown whole) and a command done. (An estop's report over
two runs: test_client.py's two-runs test.)"""
import subprocess

import lagrange
from bus_support import LAGRANGECTL, config, lagranged, lcm_url

PORT = 8790  # default.yaml: arm (computed torque) and cartpole


def lagrangectl(port, *args):
    return subprocess.run([LAGRANGECTL, "command", *args, "--lcm-url", lcm_url(port), "--wait", "5"],
                          capture_output=True, text=True)


def test_a_refusal_reads_the_same_from_python_and_lagrangectl():
    with lagranged(config("default.yaml"), PORT):
        client = lagrange.Client(url=lcm_url(PORT), wait=5.0)
        client.state("arm", timeout=5.0)
        refusals = [
            # (Python's arguments, lagrangectl's words)
            (("arm", "controller", "lqr-of-dreams"), {}, ["arm", "controller", "lqr-of-dreams"]),
            (("cartpole", "controller", "x\x1b[2J"), {}, ["cartpole", "controller", "x\x1b[2J"]),
            # Beyond the computed-torque's bounds at the scene's period: the reason names the bound and its rule.
            (("arm", "gains"), {"kp": [1e9, 1e9], "kd": 1.0}, ["arm", "gains", "--kp", "1e9", "--kd", "1"]),
        ]
        for args, gains, words in refusals:
            r = client.command(*args, **gains)
            cli = lagrangectl(PORT, *words)
            assert not r.accepted and r.message.startswith("refused: "), r.message
            assert cli.returncode == 1, cli.stderr
            assert cli.stdout == ""
            assert cli.stderr.strip() == "lagrangectl command: " + r.message
        assert "\\x1b[2J" in client.command("cartpole", "controller", "x\x1b[2J").message
        assert "gains for computed-torque: kp[0]" in client.command("arm", "gains", kp=[1e9, 1e9], kd=1.0).message
        # A command done: the same line, whoever sent it.
        done = client.command("arm", "pause")
        assert done.accepted and done.message == "arm: pause done; now paused with computed-torque"
        assert client.command("arm", "resume").accepted
        cli = lagrangectl(PORT, "arm", "pause")
        assert cli.returncode == 0, cli.stderr
        assert cli.stdout.strip() == done.message

