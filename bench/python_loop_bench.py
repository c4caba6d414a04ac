#!/usr/bin/python3
"""The loop a Python controller closes with lagranged, beside the same law in C++.

lagranged runs config/arm_impedance_client.yaml (the arm under `controller:
external`, gravity compensated) on a private LCM URL, and lcm-logger records
its ARM_STATE and ARM_TORQUE, while, one after the other for --seconds each,
  1. examples/python/external_controller.py (lagrange.Client: the project's
     client code, a torque_t for every state_t), and
  2. examples/cpp/impedance_client (the same law in C++ over lcm::LCM), the
     baseline measured in the same run,
hold the arm at (0.3, 0.6). From the log (lagrange.read_log) for every torque
answering state k:
  - state → torque: its utime (the controller's wall clock at the send) −
    utime of state k (the tick's), µs: computing and sending, from the tick;
  - late: the torque was sent after tick k + 1 began (utime of state k + 1),
    so that tick ran on the previous torque;
  - answered: the fraction of the states that got a torque.
Writes OUT/python_loop.csv and prints the table with the Python/C++ ratios.

  bench/python_loop_bench.py --build build-bench --out bench/results [--seconds 10] [--port 7752]
"""
import argparse
import csv
import os
import signal
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(HERE)


def url(port):
    return "udpm://239.255.76.67:%d?ttl=0" % port


def run_one(args, name, controller_argv, log_path):
    daemon = subprocess.Popen([os.path.join(args.build, "daemon", "lagranged"), "--config",
                               os.path.join(SOURCE, "config", "arm_impedance_client.yaml"), "--lcm-url", url(args.port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    logger = None
    try:
        time.sleep(0.5)
        logger = subprocess.Popen(["lcm-logger", "--lcm-url=" + url(args.port), "-c", "ARM_STATE|ARM_TORQUE", "-f",
                                   log_path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(0.3)
        r = subprocess.run(controller_argv, capture_output=True, text=True, timeout=args.seconds + 30,
                           env={**os.environ, "PYTHONPATH": os.path.join(args.build, "python")})
        if r.returncode != 0:
            sys.exit("python_loop_bench: %s failed: %s" % (name, (r.stderr or r.stdout).strip()))
    finally:
        if logger is not None:
            logger.send_signal(signal.SIGINT)
            logger.wait(timeout=10)
        daemon.terminate()
        daemon.wait(timeout=10)


def analyse(name, log_path):
    sys.path.insert(0, os.path.join(ARGS.build, "python"))
    import lagrange
    log = lagrange.read_log(log_path)
    states, torques = log["ARM_STATE"], log["ARM_TORQUE"]
    first = states.run_id[0]
    one_run = states.run_id == first
    utime_of = dict(zip(states.tick[one_run].tolist(), states.utime[one_run].tolist()))
    latency, late = [], []
    for tick, sent in zip(torques.state_tick.tolist(), torques.utime.tolist()):
        if tick not in utime_of:
            continue
        latency.append(sent - utime_of[tick])
        if tick + 1 in utime_of:
            late.append(sent > utime_of[tick + 1])
    latency = np.array(latency, dtype=float)
    # The states while the controller ran: from the first torque's state to the last's.
    answered_ticks = set(torques.state_tick.tolist())
    span = [t for t in utime_of if min(answered_ticks) <= t <= max(answered_ticks)]
    return {
        "controller": name,
        "states": len(span),
        "torques": len(latency),
        "answered": len(answered_ticks & set(span)) / max(len(span), 1),
        "latency_p50_us": float(np.percentile(latency, 50)),
        "latency_p99_us": float(np.percentile(latency, 99)),
        "latency_max_us": float(latency.max()),
        "late_fraction": float(np.mean(late)),
    }


def main():
    global ARGS
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default=os.path.join(SOURCE, "build"), help="build tree (lagranged, the module, impedance_client)")
    p.add_argument("--out", default=os.path.join(SOURCE, "bench", "results"))
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--port", type=int, default=7752, help="private LCM port on udpm://239.255.76.67 (ttl=0)")
    ARGS = args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    target = "0.3,0.6"
    runs = [
        ("python", [sys.executable, os.path.join(SOURCE, "examples", "python", "external_controller.py"), "--url",
                    url(args.port), "--target", target, "--duration", str(args.seconds)]),
        ("c++", [os.path.join(args.build, "examples", "cpp", "impedance_client"), "--lcm-url", url(args.port), "--target",
                 target, "--duration", str(args.seconds)]),
    ]
    rows = []
    for name, argv in runs:
        log_path = os.path.join(args.out, "python_loop_%s.lcmlog" % name.replace("+", "p"))
        run_one(args, name, argv, log_path)
        rows.append(analyse(name, log_path))
    with open(os.path.join(args.out, "python_loop.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("| controller | states | answered | state → torque p50 / p99 / max (µs) | late |")
    print("|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %.1f %% | %.0f / %.0f / %.0f | %.2f %% |" % (
            r["controller"], r["states"], 100 * r["answered"], r["latency_p50_us"], r["latency_p99_us"],
            r["latency_max_us"], 100 * r["late_fraction"]))
    py, cc = rows
    print("Python / C++: p50 latency %.2f×, p99 %.2f×" % (py["latency_p50_us"] / cc["latency_p50_us"],
                                                            py["latency_p99_us"] / cc["latency_p99_us"]))


if __name__ == "__main__":
    main()
