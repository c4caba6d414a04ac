#!/usr/bin/env python3
"""What a call of lagrange.Model costs from Python beside the same C++ call, in one process and one run.

For arm2 and the Panda (config/robots/panda.urdf), forward dynamics at one state:
  cpp     Model._time_forward_dynamics: the C++ call alone in a loop (ComputeForwardDynamics on the
          model's data, the inputs already Eigen vectors), at the one state python times
  cpp_states  the same over the N states the batch evaluates (one call each, cycling)
  python  m.forward_dynamics(q, qd, tau) from Python (timeit), numpy arrays in and out
  out     m.forward_dynamics(q, qd, tau, out=buffer): the same into a preallocated array (issue 37; "-" for a
          module without out=)
  batch   m.forward_dynamics(Q, QD, TAU) over N states (N, n), one thread, per state; and over 2 threads
The targets (issue 23): python − cpp ≤ 1 µs (issue 37: ≤ 0.25 µs at low load); batch ≤ 1.2 × cpp_states (the C++ single call on the same states). Each figure is the median of the repetitions,
each repetition timing cpp, python and batch back to back (so a loaded machine slows all three alike).

Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [--quick] [--out DIR]
Writes DIR/python.json (with --out) and prints a table.
"""
import argparse
import json
import os
import statistics
import sys
import timeit

import numpy as np

import lagrange

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def measure(model, calls, states, repetitions):
    n = model.num_dofs
    rng = np.random.default_rng(42)
    q, qd, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-5, 5, n)
    Q, QD, TAU = rng.uniform(-1, 1, (states, n)), rng.uniform(-1, 1, (states, n)), rng.uniform(-5, 5, (states, n))
    f = model.forward_dynamics
    f(q, qd, tau), f(Q[:10], QD[:10], TAU[:10])  # warm up
    buffer = np.empty(n)
    try:
        f(q, qd, tau, out=buffer)
        has_out = True
    except TypeError:  # a module from before out=
        has_out = False
    rows = {"cpp": [], "cpp_states": [], "python": [], "out": [], "batch": [], "batch_2_threads": []}
    for _ in range(repetitions):
        rows["cpp"].append(model._time_forward_dynamics(q, qd, tau, calls))
        rows["cpp_states"].append(model._time_forward_dynamics(Q, QD, TAU, states))
        rows["python"].append(timeit.timeit(lambda: f(q, qd, tau), number=calls) / calls)
        if has_out:
            rows["out"].append(timeit.timeit(lambda: f(q, qd, tau, out=buffer), number=calls) / calls)
        rows["batch"].append(timeit.timeit(lambda: f(Q, QD, TAU), number=1) / states)
        rows["batch_2_threads"].append(timeit.timeit(lambda: f(Q, QD, TAU, threads=2), number=1) / states)
    # The lambda's own call is part of what Python pays; timeit of an empty lambda says how much (reported, not subtracted).
    empty = min(timeit.repeat(lambda: None, number=calls, repeat=repetitions)) / calls
    med = {k: statistics.median(v) if v else float("nan") for k, v in rows.items()}
    return {
        "num_dofs": n,
        "cpp_ns": med["cpp"] * 1e9,
        "python_ns": med["python"] * 1e9,
        "overhead_ns": (med["python"] - med["cpp"]) * 1e9,
        "out_overhead_ns": (med["out"] - med["cpp"]) * 1e9,
        "empty_lambda_ns": empty * 1e9,
        "batch_ns_per_state": med["batch"] * 1e9,
        "cpp_states_ns": med["cpp_states"] * 1e9,
        "batch_over_cpp": med["batch"] / med["cpp_states"],
        "batch_2_threads_ns_per_state": med["batch_2_threads"] * 1e9,
        "states": states,
        "calls": calls,
        "repetitions": repetitions,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer calls and states: a smoke run")
    parser.add_argument("--out", help="write python.json here")
    args = parser.parse_args()
    calls, states, repetitions = (20000, 20000, 3) if args.quick else (200000, 100000, 7)
    models = {
        "arm2": lagrange.Model.builtin("arm2"),
        "panda": lagrange.Model.from_urdf(os.path.join(ROOT, "config/robots/panda.urdf")),
    }
    results = {name: measure(m, calls, states, repetitions) for name, m in models.items()}
    print("forward dynamics   one state: C++     Python   overhead  out= overhead | N states: C++/state  batch/state "
          "(× C++)  2 threads")
    for name, r in results.items():
        print("  %-6s (n = %d)  %11.1f ns %8.1f ns %7.1f ns %8.1f ns | %12.1f ns %9.1f ns (%.2f×) %7.1f ns" % (
            name, r["num_dofs"], r["cpp_ns"], r["python_ns"], r["overhead_ns"], r["out_overhead_ns"], r["cpp_states_ns"],
            r["batch_ns_per_state"], r["batch_over_cpp"], r["batch_2_threads_ns_per_state"]))
    print("  (the timing lambda itself: %.1f ns per call, inside 'from Python')" % results["arm2"]["empty_lambda_ns"])
    if args.out:
        with open(os.path.join(args.out, "python.json"), "w") as f:
            json.dump({"python": sys.version.split()[0], "numpy": np.__version__, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
