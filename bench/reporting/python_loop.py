"""A controller in Python closing the loop with lagranged beside the same law in C++
(bench/python_loop_bench.py's python_loop.csv): the report's section."""
import csv

from reporting.common import table


def python_loop_section(out):
    """Markdown for python_loop.csv; "" without it."""
    path = out / "python_loop.csv"
    if not path.exists():
        return ""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    body = [[r["controller"], r["states"], "%.1f %%" % (100 * float(r["answered"])),
             "%.0f / %.0f / %.0f" % (float(r["latency_p50_us"]), float(r["latency_p99_us"]), float(r["latency_max_us"])),
             "%.2f %%" % (100 * float(r["late_fraction"]))] for r in rows]
    text = ["## A controller in Python closing the loop\n",
            "examples/python/external_controller.py (lagrange.Client) and examples/cpp/impedance_client (C++), "
            "one after the other on lagranged with config/arm_impedance_client.yaml, measured from an lcm-logger "
            "recording: state → torque = the torque's utime − the state's; late = sent after the next tick began.\n",
            table(["controller", "states", "answered", "state → torque p50 / p99 / max (µs)", "late"], body)]
    by = {r["controller"]: r for r in rows}
    if "python" in by and "c++" in by:
        p50 = float(by["python"]["latency_p50_us"]) / float(by["c++"]["latency_p50_us"])
        p99 = float(by["python"]["latency_p99_us"]) / float(by["c++"]["latency_p99_us"])
        text.append("Python / C++ in the same run: p50 %.2f×, p99 %.2f×.\n" % (p50, p99))
    return "\n".join(text)
