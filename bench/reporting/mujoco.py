"""MuJoCo beside lagrange on the URDF robots (mujoco_bench): section 3's MuJoCo subsection."""

import math

from reporting.common import median_of, ns, read_csv, table, write_csv
from reporting.derivation import ROBOTS

MUJOCO_TERMS = ["FD", "M", "ID", "G"]
# The floating quadruped (config/robots/a1.urdf read floating, FloatingDynamics; MuJoCo's a1.xml, a free joint):
# mujoco/a1/<library>/<term>.
FLOATING_ROBOT = "a1"
FLOATING_TERMS = ["FD", "ID", "M", "A_G"]


def mujoco_subsection(out, runs, calib, context):
    """The markdown of MuJoCo against lagrange's recursive method (the fixed-base robots, then the floating
    quadruped), per call; writes mujoco_ratios.csv."""
    get = {}
    for name, r in runs.items():
        parts = name.split("/")
        if parts[0] == "mujoco":
            get[(parts[1], parts[2], parts[3])] = r["cpu_ns"]
    rows = []
    for robot, terms in [(r, MUJOCO_TERMS) for r in ROBOTS] + [(FLOATING_ROBOT, FLOATING_TERMS)]:
        for term in terms:
            theirs, ours = get.get((robot, "mujoco", term)), get.get((robot, "lagrange", term))
            if theirs is None or ours is None:
                continue
            rows.append([robot, term, theirs, ours, theirs / ours])
    write_csv(out / "mujoco_ratios.csv", ["robot", "term", "mujoco_ns", "lagrange_ns", "mujoco_over_lagrange"],
              [[r[0], r[1], f"{r[2]:.4g}", f"{r[3]:.4g}", f"{r[4]:.3f}"] for r in rows])
    md = ["### 3-D robots against MuJoCo\n",
          f"`mujoco_bench`, a separate run: MuJoCo {context.get('mujoco_version', '?')} (Debian `libmujoco-dev`) "
          "loading the same URDF file by its own importer, with lagrange's exact inertias, beside lagrange's "
          f"recursive method in one process. CPU time per call, {median_of(context)}; in brackets the multiple of "
          f"that run's sin + cos ({ns(calib)}). MuJoCo's cheapest pipeline pieces for each term (bench/mujoco_bench.cpp): "
          "FD mj_kinematics, mj_comPos, mj_crb, mj_factorM, mj_comVel, mj_rne, mj_solveM; M the same to mj_crb, then "
          "mj_fullM; ID mj_rne with q̈; G mj_rne at q̇ = 0. The A1 (`a1`, 18 velocities) is the floating quadruped: "
          "lagrange's `FloatingDynamics` beside its MJCF twin with a free joint, MuJoCo timed in its own coordinates; "
          "its A_G is MuJoCo's M with the free joint's rows carried to the centre of mass (MuJoCo 2.2.2 has no "
          "centroidal matrix).\n",
          table(["robot", "term", "MuJoCo", "lagrange", "MuJoCo / lagrange"],
                [[r[0], r[1], f"{r[2]:.0f} ns ({r[2] / calib:.3g} ×)", f"{r[3]:.0f} ns ({r[3] / calib:.3g} ×)",
                  f"{r[4]:.2f}"] for r in rows])]
    agreement = out / "mujoco_agreement.csv"
    if agreement.exists():
        arows = read_csv(agreement)
        limit = float(arows[0]["limit_rel"]) if arows else math.nan
        md.append(f"\nBefore timing, `mujoco_bench` checks that the two agree on 8 seeded random states per robot; "
                  f"it times nothing if any difference, relative to 1 + max |MuJoCo's value|, is above {limit:.0e}. "
                  "Largest relative differences (`mujoco_agreement.csv`):\n")
        by = {(r["robot"], r["term"]): r for r in arows}
        columns = MUJOCO_TERMS + [t for t in FLOATING_TERMS if t not in MUJOCO_TERMS]
        body = [[robot] + [f"{float(by[(robot, t)]['max_rel_diff']):.1e}" if (robot, t) in by else "n/a"
                           for t in columns] for robot in dict.fromkeys(r["robot"] for r in arows)]
        md.append(table(["robot"] + columns, body))
    return "\n".join(md)
