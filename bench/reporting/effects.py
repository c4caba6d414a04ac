"""Section 4: effects cost, from effects_bench."""

import matplotlib.pyplot as plt
import numpy as np

from .common import ns, table, write_csv


EFFECT_CASES = ["bare", "default", "no-gravity", "no-coriolis", "damping", "friction", "limits",
                "saturation", "disturbance", "all"]


def effects_section(out, runs, calib):
    plants = ["pendulum", "arm2", "cartpole", "chain7"]
    get = {}
    for name, r in runs.items():
        parts = name.split("/")
        if parts[0] == "effects":
            get[(parts[1], parts[2])] = r
    rows = []
    for p in plants:
        default = get[(p, "default")]["cpu_ns"]
        for c in EFFECT_CASES:
            r = get[(p, c)]
            rows.append([p, c, f"{r['cpu_ns']:.4g}", f"{r['cpu_ns'] / default:.3f}", int(r.get("off_stage_runs", 0))])
    write_csv(out / "effects_cost.csv", ["plant", "case", "cpu_ns", "ratio_to_default", "off_stage_runs"], rows)
    plot_effects(out, plants, get)
    md = ["## 4. Effects cost\n",
          "CPU time of one RK4 step (h = 1 ms, zero command) through `PlantModel`, by case; in brackets the ratio "
          "to `default` (gravity and Coriolis on, every optional effect off). `bare` is the same RK4 written "
          "against the dynamics alone, with no effects layer. `off_stage_runs`, the number of times a stage that "
          "was off ran, is 0 in every case.\n"]
    body = []
    for c in EFFECT_CASES:
        body.append([c] + [f"{ns(get[(p, c)]['cpu_ns'])} ({get[(p, c)]['cpu_ns'] / get[(p, 'default')]['cpu_ns']:.2f})"
                           for p in plants])
    md.append(table(["case"] + plants, body))
    off = sum(int(get[(p, c)].get("off_stage_runs", 0)) for p in plants for c in EFFECT_CASES)
    md.append(f"\nSum of `off_stage_runs` over every case: {off}.\n")
    bare = ", ".join(f"{p} {get[(p, 'bare')]['cpu_ns'] / get[(p, 'default')]['cpu_ns']:.2f}" for p in plants)
    md.append("\nAn effect that is off is never evaluated (its stage returns at its gate and `off_stage_runs` stays 0), "
              "and switching one on costs what its table row shows over `default`. What every case pays, effects on "
              f"or off, is the `PlantModel` → `Effects` pass-through: `bare` / `default` = {bare}. A profile "
              "(callgrind) puts that in the by-value `Eigen::Ref<const VectorXd>` arguments of "
              "`PlantModel::ComputeAcceleration` and the `Effects` stages (each copy holds an empty `VectorXd` "
              "whose destructor calls `free`) and the out-of-line stage calls, not in the gated effects.\n")
    md.append("\n![effects cost](effects_cost.png)\n")
    return "\n".join(md), get


def plot_effects(out, plants, get):
    fig, ax = plt.subplots(figsize=(12, 4.5))
    width = 0.8 / len(plants)
    x = np.arange(len(EFFECT_CASES))
    for i, p in enumerate(plants):
        default = get[(p, "default")]["cpu_ns"]
        ax.bar(x + i * width, [get[(p, c)]["cpu_ns"] / default for c in EFFECT_CASES], width, label=p)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(x + 0.4 - width / 2, EFFECT_CASES, rotation=20)
    ax.set_ylabel("RK4 step time / default")
    ax.set_title("Effects cost: one RK4 step, relative to the default case of each plant")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "effects_cost.png", dpi=110)
    plt.close(fig)
