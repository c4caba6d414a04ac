"""The report's first table: the targets of the per-call figures and the loop."""

from .common import ns, percentile, ratio, us, yes
from .loop import delivery_rows, pct, us_limit


def targets(derive, effects, d, calib, effects_calib):
    s = d["summary"]
    wake99, cyc99 = percentile(d["wake"], 99), pct(d["cyclictest_concurrent"], 99)
    cpu = float(s["daemon_cpu_window_percent"])
    per_call = [  # (target, measured ns, limit ns, the same run's sin+cos)
        ("forward dynamics, arm2 (closed form)", derive[("arm2", "closed-form", "FD")], 60.0, calib),
        ("forward dynamics, cart-pole (closed form)", derive[("cartpole", "closed-form", "FD")], 60.0, calib),
        ("one RK4 step, arm2 (closed form, default effects)", effects[("arm2", "default")]["cpu_ns"], 300.0,
         effects_calib),
        ("one RK4 step, cart-pole (closed form, default effects)", effects[("cartpole", "default")]["cpu_ns"], 300.0,
         effects_calib),
        ("forward dynamics, 30-link chain, recursive", derive[("chain30", "recursive", "FD")], 4000.0, calib),
    ]
    rows = [[name, f"≤ {ns(limit)}", f"{ns(v)} ({v / base:.1f}× sin+cos)", yes(v <= limit)]
            for name, v, limit, base in per_call]
    rows.append(["default scene, tick compute p99", "≤ 20 µs", us(percentile(d["compute"], 99)),
                 yes(percentile(d["compute"], 99) <= 20.0)])
    rows.append(["wake-up latency p99 / cyclictest's p99 (same window)", "≤ 1.2",
                 f"{ratio(wake99, cyc99):.2f} ({us(wake99)} / {us_limit(cyc99, d['cyclictest_concurrent'])})",
                 yes(wake99 <= 1.2 * cyc99)])
    rows.append(["lagranged CPU (steady window)", "≤ 10 % of one core", f"{cpu:.2f} %", yes(cpu <= 10.0)])
    rows += delivery_rows(d)
    return rows
