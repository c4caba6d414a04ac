#!/usr/bin/python3
"""Identify a payload's mass from a logged run: least squares on inverse dynamics.

A user's first system-identification step. The arm's rigid-body torque is
linear in its inertial parameters; with the link modelled as a uniform rod it
is affine in the link's mass m2 alone:

    tau(q, q̇, q̈; m2) = tau_a + (m2 − a) / (b − a) · (tau_b − tau_a)

where tau_a, tau_b are lagrange.Model.inverse_dynamics of the nominal arm with
m2 = a and m2 = b (two batched calls over every logged state: no Python loop).
Stacking every logged state gives an overdetermined linear system in m2,
solved by least squares against the torque the daemon applied (state_t.tau);
the payload is m2 − the nominal m2.

    build/daemon/lagranged --config examples/python/arm_payload.yaml &
    lcm-logger -f run.lcm            # a few seconds, then Ctrl-C
    PYTHONPATH=build/python /usr/bin/python3 examples/python/payload_identification.py run.lcm

Assumes what the run makes true: no damping or friction (the applied torque is
all the rigid body's), and q̈ as the state reports it (the plant's acceleration
at that state under that torque; a real robot's would be filtered from q).
"""
import argparse
import sys

import numpy as np

import lagrange

NOMINAL = {"m1": 1.0, "m2": 0.8, "L1": 0.6, "L2": 0.5, "g": 9.81}  # the README's arm


def identify_link_mass(q, qd, qdd, tau, nominal=NOMINAL, link="m2"):
    """(N, n) arrays of a run → (the link's mass, kg; the fit's rms torque residual, N·m)."""
    a, b = nominal[link], nominal[link] + 1.0
    tau_a = lagrange.Model.builtin("arm2", **{**nominal, link: a}).inverse_dynamics(q, qd, qdd)
    tau_b = lagrange.Model.builtin("arm2", **{**nominal, link: b}).inverse_dynamics(q, qd, qdd)
    regressor = (tau_b - tau_a).reshape(-1, 1)  # ∂tau/∂m2, stacked over every state and joint
    x, *_ = np.linalg.lstsq(regressor, (tau - tau_a).reshape(-1), rcond=None)
    mass = a + x[0] * (b - a)
    residual = tau - (tau_a + x[0] * (tau_b - tau_a))
    return mass, float(np.sqrt(np.mean(residual**2)))


def states_of(log_path, channel):
    """The run's states from the log (lagrange.read_log, log2csv's decoding), running mode only."""
    records = lagrange.read_log(log_path, channel=channel)
    if channel not in records or records[channel].type != "state_t":
        sys.exit("payload_identification: no state_t on %s in %s" % (channel, log_path))
    s = records[channel]
    running = s.mode == 0  # MODE_RUNNING: the plant integrated under the applied torque
    return s.q[running], s.qd[running], s.qdd[running], s.tau[running]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("log", help="an lcm-logger file of the run")
    p.add_argument("--channel", default="ARM_STATE", help="the instance's state channel")
    args = p.parse_args(argv)
    q, qd, qdd, tau = states_of(args.log, args.channel)
    mass, rms = identify_link_mass(q, qd, qdd, tau)
    print("%d states: m2 = %.6f kg (nominal %.3f kg): payload %.6f kg; rms torque residual %.2g N·m"
          % (len(q), mass, NOMINAL["m2"], mass - NOMINAL["m2"], rms))
    return 0


if __name__ == "__main__":
    sys.exit(main())
