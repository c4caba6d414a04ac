"""Sections 1 and 2: work-precision (error against cost for every integrator)
and long-horizon energy, from work_precision's CSV files."""

import matplotlib.pyplot as plt

from .common import INTEGRATORS, PLANTS, ns, read_csv, sci, table, tidy_numbers


def work_precision(out):
    rows = read_csv(out / "work_precision.csv")
    for r in rows:
        for k in ("h_s", "rtol", "q_error", "qd_error", "max_energy_error_J", "ns_per_sim_s"):
            r[k] = float(r[k])
    for plant in PLANTS:
        plot_work_precision(out, plant, [r for r in rows if r["plant"] == plant])
    return rows


def plot_work_precision(out, plant, rows):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for integrator in INTEGRATORS:
        pts = sorted((r for r in rows if r["integrator"] == integrator), key=lambda r: r["ns_per_sim_s"])
        cost = [r["ns_per_sim_s"] * 1e-6 for r in pts]  # ms of CPU per simulated s
        axes[0].loglog(cost, [max(r["q_error"], 1e-17) for r in pts], "o-", label=integrator, ms=4)
        axes[1].loglog(cost, [max(r["max_energy_error_J"], 1e-17) for r in pts], "o-", label=integrator, ms=4)
    axes[0].set_ylabel("error at the final time, max |q − q_ref| (rad or m)")
    axes[1].set_ylabel("max |E(t) − E(0)| (J)")
    for ax in axes:
        ax.set_xlabel("cost (ms of CPU per simulated second)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    reference = rows[0]["reference"] if rows else ""
    fig.suptitle(f"Work-precision: {plant} (reference: {reference}); fixed steps 10 ms … 10 µs, dopri5 rtol 1e-3 … 1e-12")
    fig.tight_layout()
    fig.savefig(out / f"work_precision_{plant}.png", dpi=110)
    plt.close(fig)


def cheapest_below(rows, plant, integrator, tolerance):
    """The cheapest run of `integrator` on `plant` with final error <= tolerance."""
    ok = [r for r in rows if r["plant"] == plant and r["integrator"] == integrator and r["q_error"] <= tolerance]
    return min(ok, key=lambda r: r["ns_per_sim_s"]) if ok else None


def work_precision_section(out, rows):
    md = ["## 1. Work-precision\n",
          "Undamped, unforced plants (default parameters): pendulum θ0 = 2 rad at rest for 10 s against the exact "
          "elliptic-function solution; arm2 q0 = (−0.6, 0.8) rad for 5 s and cart-pole q0 = (0 m, 2 rad) for 10 s "
          "against Dormand–Prince at rtol 1e-13. Cost is CPU time per simulated second (fastest of repeated passes "
          "without energy bookkeeping); energy error is the largest |E(t) − E(0)| over every step (dopri5: sampled "
          "at as many equal intervals as it took steps). All points: `work_precision.csv`.\n"]
    refs = read_csv(out / "reference.csv")
    md.append("Reference checks (`reference.csv`; max state difference in rad, m, rad/s or m/s):\n")
    md.append(table(["plant", "check", "difference", "estimated error of the check"],
                    [[r["plant"], tidy_numbers(r["check"]), sci(float(r["max_state_difference"])),
                      sci(float(r["estimated_error_of_check"])) if r["estimated_error_of_check"] else ""]
                     for r in refs]))
    md.append("\nCheapest run reaching a final error ≤ 1e-6 (rad or m), with its step or tolerance and its largest "
              "energy error:\n")
    body = []
    for plant in PLANTS:
        for integrator in INTEGRATORS:
            r = cheapest_below(rows, plant, integrator, 1e-6)
            if r is None:
                limit = "rtol ≥ 1e-12" if integrator == "dopri5" else "h ≥ 10 µs"
                body.append([plant, integrator, f"not reached ({limit})", "", "", ""])
                continue
            setting = f"rtol {r['rtol']:.0e}" if integrator == "dopri5" else f"h = {ns(r['h_s'] * 1e9)}"
            body.append([plant, integrator, setting, ns(r["ns_per_sim_s"]) + " per s", sci(r["q_error"]),
                         sci(r["max_energy_error_J"]) + " J"])
    md.append(table(["plant", "integrator", "setting", "cost", "final error", "max energy error"], body))
    for plant in PLANTS:
        md.append(f"\n![work-precision {plant}](work_precision_{plant}.png)\n")
    return "\n".join(md)


def long_horizon_section(out):
    rows = read_csv(out / "long_horizon.csv")
    fig, ax = plt.subplots(figsize=(10, 4.8))
    summary = []
    for integrator in INTEGRATORS:
        pts = [r for r in rows if r["integrator"] == integrator]
        finite = [r for r in pts if r["max_abs_energy_error_J"] != "inf"]
        t = [float(r["t_s"]) for r in finite]
        e = [max(float(r["max_abs_energy_error_J"]), 1e-17) for r in finite]
        ax.loglog(t, e, label=integrator, lw=1.2)
        diverged = next((float(r["t_s"]) for r in pts if r["max_abs_energy_error_J"] == "inf"), None)
        summary.append([integrator, f"{t[-1]:.0f} s" if t else "0 s", sci(e[-1]) + " J" if e else "n/a",
                        sci(max(e)) + " J" if e else "n/a",
                        f"beyond 1e6 J at t = {diverged:.3g} s" if diverged else "no"])
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("max |E − E(0)| per second of simulation (J)")
    ax.set_title("Long horizon: undamped arm2, h = 1 ms, 10⁶ steps (dopri5: rtol 1e-8, atol 1e-10 per 1 ms call)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "long_horizon_energy.png", dpi=110)
    plt.close(fig)
    md = ["## 2. Long-horizon energy\n",
          "10⁶ steps of 1 ms (1000 s) of the undamped, unforced arm from q0 = (−0.6, 0.8) rad at rest. Each row of "
          "`long_horizon.csv` is one second: the largest |E − E(0)| in it and E − E(0) at its end.\n",
          table(["integrator", "recorded to", "|ΔE| in the last second", "largest |ΔE|", "diverged"], summary),
          "\n![long-horizon energy](long_horizon_energy.png)\n"]
    return "\n".join(md)
