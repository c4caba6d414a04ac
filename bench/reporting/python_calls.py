"""The Python module's per-call cost (bench/python_bench.py's python.json): target rows for the report."""
import json


def python_target_rows(out):
    """Rows [target, limit, measured, met] for the call overhead and the batch, arm2 and Panda; [] without python.json."""
    path = out / "python.json"
    if not path.exists():
        return []
    rows = []
    for name, r in json.loads(path.read_text())["results"].items():
        rows.append(["Python call overhead, %s forward dynamics (one state)" % name, "≤ 1 µs",
                     "%.0f ns (%.0f ns from Python, %.0f ns the C++ call)" % (r["overhead_ns"], r["python_ns"],
                                                                              r["cpp_ns"]),
                     "yes" if r["overhead_ns"] <= 1000 else "no"])
        rows.append(["Python batch (N, n) per state / C++ call, %s forward dynamics" % name, "≤ 1.2",
                     "%.2f (%.0f / %.0f ns, N = %d, 1 thread)" % (r["batch_over_cpp"], r["batch_ns_per_state"],
                                                                 r["cpp_states_ns"], r["states"]),
                     "yes" if r["batch_over_cpp"] <= 1.2 else "no"])
    return rows
