#!/usr/bin/python3
"""A joint impedance controller in Python, closing the loop with lagranged.

    tau = K (q* − q) − D q̇        (N·m; lagranged adds G(q): compensate_gravity: true)

answering every <NAME>_STATE with one torque_t on <NAME>_TORQUE, through
lagrange.Client (the project's own client: one lagranged run followed, states
wire-checked, signed traffic with a key). The scene is
config/arm_impedance_client.yaml: the arm under `controller: external`.

    build/daemon/lagranged --config config/arm_impedance_client.yaml &
    PYTHONPATH=build/python /usr/bin/python3 examples/python/external_controller.py --target 0.3,0.6

It prints how the loop went: states answered, the state → torque latency
(from the tick's start, the state's utime, to the torque's send, on the wall
clock both use), the late fraction (torques sent after the next tick had begun,
so that tick ran on the previous torque) and where the arm ended.
"""
import argparse
import sys
import time

import numpy as np

import lagrange


def impedance(target, stiffness, damping):
    """The law: (q, q̇) → tau, N·m."""
    return lambda q, qd: stiffness * (target - q) - damping * qd


def run(client, name, law, duration):
    """Answers every state of `name` for `duration` s; returns the loop's record."""
    latency_us = []  # send − utime(state), per torque
    sent_at = []     # wall µs of each torque's send
    ticks = []       # the state each torque answered
    next_utime = {}  # tick → utime of the state after it (when heard)
    last = None
    for s in client.states(name, duration):
        if last is not None and s.tick == last.tick + 1:
            next_utime[last.tick] = s.utime
        tau = law(s.q, s.qd)
        client.send_torque(name, tau, state_tick=s.tick)
        now = time.time_ns() // 1000  # the wall clock of state_t.utime (µs since the epoch)
        latency_us.append(now - s.utime)
        sent_at.append(now)
        ticks.append(s.tick)
        last = s
    late = [sent_at[k] > next_utime[t] for k, t in enumerate(ticks) if t in next_utime]
    return {
        "torques": len(ticks),
        "latency_us": np.array(latency_us, dtype=float),
        "late_fraction": float(np.mean(late)) if late else float("nan"),
        "last": last,
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--lcm-url", dest="url", default=None, help="LCM URL (default: $LCM_DEFAULT_URL, else LCM's)")
    p.add_argument("--prefix", default="", help="lagranged's --channel-prefix")
    p.add_argument("--key-file", default=None, help="lagranged's --bus-key (default: $LAGRANGE_BUS_KEY_FILE)")
    p.add_argument("--instance", default="arm")
    p.add_argument("--target", default="0.3,0.6", help="q*, rad, one per joint")
    p.add_argument("--stiffness", type=float, default=40.0, help="K, N·m/rad")
    p.add_argument("--damping", type=float, default=8.0, help="D, N·m·s/rad")
    p.add_argument("--duration", type=float, default=5.0, help="s")
    args = p.parse_args(argv)

    client = lagrange.Client(url=args.url, prefix=args.prefix, key_file=args.key_file)
    target = np.array([float(x) for x in args.target.split(",")])
    first = client.state(args.instance, timeout=3.0)
    if first.num_dofs != len(target):
        sys.exit("external_controller: %s has %d joints, --target gives %d" % (args.instance, first.num_dofs, len(target)))
    r = run(client, args.instance, impedance(target, args.stiffness, args.damping), args.duration)
    lat = r["latency_us"]
    s = r["last"]
    print("answered %d states in %.1f s; state -> torque latency p50 %.0f us, p99 %.0f us, max %.0f us; late %.2f %%"
          % (r["torques"], args.duration, np.percentile(lat, 50), np.percentile(lat, 99), lat.max(),
             100 * r["late_fraction"]))
    print("%s %s: q = %s rad (target %s), |q - q*| = %.2g rad"
          % (args.instance, s.mode, np.array2string(s.q, precision=4), np.array2string(target, precision=4),
             np.linalg.norm(s.q - target)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
