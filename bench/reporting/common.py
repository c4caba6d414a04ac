"""What every section of the report shares: reading the benchmarks' files, the
figures' formats and the markdown table."""

import csv
import json
import math
import re
from pathlib import Path

import numpy as np

INTEGRATORS = ["explicit-euler", "semi-implicit-euler", "rk4", "dopri5", "variational"]
PLANTS = ["pendulum", "arm2", "cartpole"]


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def read_benchmarks(path):
    """name -> {"cpu_ns", "real_ns", counters...}: the median over repetitions."""
    data = json.loads(Path(path).read_text())
    scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}
    runs = {}
    repetitions = max([int(b.get("repetitions", 1)) for b in data["benchmarks"]] + [1])
    data.setdefault("context", {})["repetitions"] = repetitions
    for b in data["benchmarks"]:
        if b.get("error_occurred"):  # skipped (e.g. a scene not there): no figure
            continue
        aggregate = b.get("aggregate_name")
        if b.get("run_type") == "aggregate" and aggregate != "median":
            continue
        name = b.get("run_name", b["name"]).split("/iterations:")[0].split("/manual_time")[0]
        row = {"cpu_ns": b["cpu_time"] * scale[b["time_unit"]], "real_ns": b["real_time"] * scale[b["time_unit"]]}
        for key in ("dofs", "off_stage_runs", "p50_ns", "p99_ns", "max_ns"):
            if key in b:
                row[key] = b[key]
        if aggregate == "median" or name not in runs:
            runs[name] = row
    return runs, data["context"]


def percentile(values, p):
    return float(np.percentile(np.asarray(values, dtype=float), p)) if len(values) else float("nan")


def ns(x):
    """A time in ns, in the unit that reads best."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if x < 1e3:
        return f"{x:.3g} ns"
    if x < 1e6:
        return f"{x / 1e3:.3g} µs"
    if x < 1e9:
        return f"{x / 1e6:.3g} ms"
    return f"{x / 1e9:.3g} s"


def us(x):
    return "n/a" if not math.isfinite(x) else f"{x:.1f} µs" if x < 1e3 else f"{x / 1e3:.2f} ms"


def sci(x):
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.2e}"


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def tidy_numbers(text):
    """Long decimals in a label to 3 significant digits (1.9999999999999999e-06 -> 2e-06)."""
    return re.sub(r"\d+\.\d{6,}(e[-+]?\d+)?", lambda m: f"{float(m.group(0)):.3g}", text)


def median_of(context):
    n = context.get("repetitions", 1)
    return f"median of {n} repetitions" if n > 1 else "one repetition"


def times_sincos(x, calib):
    """'1.2 µs (34×)': a time and its multiple of the same run's sin + cos."""
    if x is None or not math.isfinite(x):
        return "n/a"
    k = x / calib
    return f"{ns(x)} ({k:.3g}×)" if k < 1000 else f"{ns(x)} ({k:,.0f}×)"


def ratio(a, b):
    return a / b if b and math.isfinite(a) and math.isfinite(b) else math.nan


def yes(ok):
    return "yes" if ok else "**no**"
