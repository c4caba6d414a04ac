"""What accuracy costs in time, for MPC (issue 35), from mpc_sweep's mpc_sweep.csv: per robot, a plot of the
closed-loop tracking cost against the mean solve time (log x), failures marked, the Pareto front joined and the
shipped scene's setting ringed, and a table of the front.

Also on its own, for the README's figures from a run of mpc_sweep alone:

    cd bench && python3 -m reporting.mpc_sweep RESULTS_DIR     # writes RESULTS_DIR/mpc_sweep.md and the plots
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .common import read_csv, table  # noqa: E402

ROBOTS = {"cartpole": "cart-pole swing-up (config/cartpole_mpc_swingup.yaml, 6 s)",
          "panda": "Panda reach (config/panda_mpc_reach.yaml, 3 s)"}
COLOURS = {"explicit-euler": "tab:red", "semi-implicit-euler": "tab:blue", "rk4": "tab:green"}


def mpc_sweep_rows(out):
    rows = read_csv(Path(out) / "mpc_sweep.csv")
    for r in rows:
        for k in ("horizon", "iterations", "solves", "failed_solves"):
            r[k] = int(r[k])
        for k in ("dt_s", "horizon_s", "first_ok_s", "held_since_s", "worst_abs_x_m", "final_position_error_m",
                  "final_rotation_error_rad", "tracking_cost", "mean_solve_ms", "worst_solve_ms"):
            r[k] = float(r[k])
        for k in ("shipped", "success", "tau_exceeded", "fits_horizon", "fits_replan", "front"):
            r[k] = r[k] == "1"
    return rows


def setting(r):
    return f"N = {r['horizon']}, dt = {r['dt_s'] * 1e3:g} ms ({r['horizon_s']:g} s), {r['iterations']} it, {r['integrator']}"


def plot_robot(out, robot, rows):
    fig, ax = plt.subplots(figsize=(7, 4.4))
    # Failures far above the successes are drawn at the top edge (^), so the successes keep the scale.
    top = 3.0 * max([r["tracking_cost"] for r in rows if r["success"]] or [max(r["tracking_cost"] for r in rows)])
    for integrator, colour in COLOURS.items():
        ok = [r for r in rows if r["integrator"] == integrator and r["success"]]
        bad = [r for r in rows if r["integrator"] == integrator and not r["success"] and r["solves"] > 0]
        ax.scatter([r["mean_solve_ms"] for r in ok], [r["tracking_cost"] for r in ok], s=18, color=colour,
                   label=f"{integrator}: success")
        inside = [r for r in bad if r["tracking_cost"] <= top]
        above = [r for r in bad if r["tracking_cost"] > top]
        ax.scatter([r["mean_solve_ms"] for r in inside], [r["tracking_cost"] for r in inside], s=22, marker="x",
                   color=colour, alpha=0.6, label=f"{integrator}: failure")
        ax.scatter([r["mean_solve_ms"] for r in above], [top] * len(above), s=26, marker="^", color=colour,
                   alpha=0.6, clip_on=False)
    front = sorted((r for r in rows if r["front"]), key=lambda r: r["mean_solve_ms"])
    ax.plot([r["mean_solve_ms"] for r in front], [r["tracking_cost"] for r in front], "k-", lw=1, label="front")
    for r in rows:
        if r["shipped"]:
            ax.scatter([r["mean_solve_ms"]], [r["tracking_cost"]], s=140, facecolors="none", edgecolors="k",
                       lw=1.5, label="the shipped scene's setting")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(top=top)
    ax.set_xlabel("mean solve time (ms of CPU)")
    ax.set_ylabel("closed-loop tracking cost (∫ stage cost dt)\n(failures beyond the top: ^ at the edge)")
    ax.set_title(f"MPC work-precision: {ROBOTS.get(robot, robot)}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    name = f"mpc_sweep_{robot}.png"
    fig.savefig(Path(out) / name, dpi=90)
    plt.close(fig)
    return name


def goal(r):
    return f"{r['held_since_s']:.2f} s" if r["success"] else "n/a"


def detail(r):
    """The robot's own figures: the cart's worst |x|, or the flange's final error; the joints held at the box."""
    if r["robot"] == "cartpole":
        text = f"worst abs(x) {r['worst_abs_x_m']:.3f} m"
    else:
        text = f"final {r['final_position_error_m'] * 1e3:.2g} mm, {r['final_rotation_error_rad'] * 1e3:.2g} mrad"
    joints = r["tau_bound_joints"].replace(";", ", ")
    return text + (f"; τ at the box on joint(s) {joints}" if joints else "")


def front_table(rows):
    body = []
    for r in sorted((r for r in rows if r["front"]), key=lambda r: r["mean_solve_ms"]):
        body.append([setting(r) + (" (shipped)" if r["shipped"] else ""), f"{r['tracking_cost']:.4g}", goal(r),
                     detail(r), f"{r['mean_solve_ms']:.3g}", f"{r['worst_solve_ms']:.3g}",
                     "yes" if r["fits_replan"] else "no"])
    return table(["setting", "tracking cost", "at the goal from", "", "mean solve ms", "worst solve ms",
                  "solve < replan_period"], body)


def shipped_line(rows):
    shipped = [r for r in rows if r["shipped"]]
    if not shipped:
        return "The shipped setting was not in this grid.\n"
    r = shipped[0]
    verdict = "on the front" if r["front"] else ("not on the front" if r["success"] else "a failure here")
    return (f"The shipped setting ({setting(r)}) is {verdict}: tracking cost {r['tracking_cost']:.4g}, at the goal "
            f"from {goal(r)}, {detail(r)}, mean solve {r['mean_solve_ms']:.3g} ms, worst {r['worst_solve_ms']:.3g} ms.\n")


def mpc_sweep_section(out):
    rows = mpc_sweep_rows(out)
    md = ["## What accuracy costs in time, for MPC\n",
          "`mpc_sweep` (bench/mpc_sweep.cpp): the shipped mpc scenes offline, the plant integrated as the scene "
          "says (rk4 at 1 ms), the planner inline every replan_period, over a grid of horizon N, knot dt, DDP "
          "iterations per solve and the optimiser's integrator. Tracking cost: the time integral along the actual "
          "path of the shipped scene's stage cost (its weights, the same for every run). Solve time: thread CPU "
          "time of the steps that planned, less a plain step's. Success: the cart-pole upright "
          "(|θ − π| < 0.05 rad, |x| ≤ 0.5 m) over the last 1 s and never off its ±0.5 m rail; the Panda's flange "
          "within 5 mm and 0.05 rad of its target over the last 0.5 s, no τ beyond the box. The front: runs no "
          "other successful run beats on both mean solve time and tracking cost. All runs: `mpc_sweep.csv`.\n"]
    for robot in dict.fromkeys(r["robot"] for r in rows):
        rr = [r for r in rows if r["robot"] == robot]
        wins = sum(r["success"] for r in rr)
        md += [f"### {ROBOTS.get(robot, robot)}\n", f"{wins} of {len(rr)} runs succeeded. The front:\n",
               front_table(rr), shipped_line(rr), f"\n![MPC work-precision, {robot}]({plot_robot(out, robot, rr)})\n"]
    return "\n".join(md)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: cd bench && python3 -m reporting.mpc_sweep RESULTS_DIR")
    (Path(sys.argv[1]) / "mpc_sweep.md").write_text(mpc_sweep_section(sys.argv[1]))
