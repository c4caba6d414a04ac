"""Section 3, frame kinematics against Orocos KDL: kinematics_bench (plant/kinematics.hpp beside KDL's
ChainFkSolverPos_recursive, ChainJntToJacSolver and ChainJntToJacDotSolver on the URDF robots)."""

import math

from .common import median_of, ns, read_csv, table, times_sincos, write_csv, yes
from .derivation import ROBOTS

# (term, what is timed: KDL / lagrange), in bench/kinematics_bench.cpp's order.
KIN_TERMS = [
    ("poses", "every frame's pose: `ChainFkSolverPos_recursive::JntToCart` (the overload that fills every "
              "segment's pose in one pass) / `ComputeFramePlacements`"),
    ("pose", "the end effector's pose: `JntToCart` to its segment / `ComputeFramePlacement`"),
    ("jacobian", "the end effector's Jacobian: `ChainJntToJacSolver::JntToJac` / `ComputeFrameJacobian`, "
                 "world-aligned"),
    ("jacobians", "every frame's Jacobian: `JntToJac` once per frame (KDL has no pass for all) / "
                  "`ComputeFrameJacobians`, world-aligned"),
    ("jdotqd", "the end effector's J̇q̇: `ChainJntToJacDotSolver::JntToJacDot` (HYBRID) into a twist / "
               "`ComputeFrameBiasAcceleration`, world-aligned"),
]
KIN_TARGET_TERMS = ["poses", "pose", "jacobian", "jacobians"]  # issue 22: FK and Jacobian, ≤ 0.3 × KDL per call
KIN_RATIO_LIMIT = 0.3
END_EFFECTORS = {"panda": "panda_link8", "ur5": "flange"}


def kinematics_subsection(out, runs, calib, context):
    """Markdown for kinematics_bench's run, and {robot: (worst ratio over KIN_TARGET_TERMS, its term)}."""
    get = {}
    for name, r in runs.items():
        parts = name.split("/")
        if parts[0] == "kin":
            get[(parts[1], parts[2], parts[3])] = r["cpu_ns"]
    rows, worst = [], {}
    for robot in ROBOTS:
        for term, _ in KIN_TERMS:
            kdl, ours = get.get((robot, "kdl", term)), get.get((robot, "lagrange", term))
            if kdl is None or ours is None:
                continue
            rows.append([robot, term, kdl, ours, ours / kdl])
            if term in KIN_TARGET_TERMS and (robot not in worst or ours / kdl > worst[robot][0]):
                worst[robot] = (ours / kdl, term)
    write_csv(out / "kinematics_ratios.csv", ["robot", "term", "kdl_ns", "lagrange_ns", "ratio", "kdl_x_sincos",
                                              "lagrange_x_sincos"],
              [[r[0], r[1], f"{r[2]:.4g}", f"{r[3]:.4g}", f"{r[4]:.3f}", f"{r[2] / calib:.3g}", f"{r[3] / calib:.3g}"]
               for r in rows])
    terms = "; ".join(f"{term}: {what}" for term, what in KIN_TERMS)
    md = ["### Frame kinematics against Orocos KDL\n",
          f"`kinematics_bench`, a separate run: Orocos KDL {context.get('kdl_version', '?')} beside lagrange's "
          "`Kinematics` (plant/kinematics.hpp) on the same URDF numbers, KDL's chain `kdl_bench`'s with the "
          "robot's frames as segments (the end effector, "
          + ", ".join(f"{robot}'s `{frame}`" for robot, frame in END_EFFECTORS.items())
          + ", a fixed segment after the last joint, as kdl_parser builds it). CPU time per call, "
          f"{median_of(context)}; in brackets the multiple of that run's sin + cos ({ns(calib)}). {terms}. "
          f"Target (issue 22): lagrange / KDL ≤ {KIN_RATIO_LIMIT} for poses and Jacobians; J̇q̇ has none.\n",
          table(["robot", "term", "KDL", "lagrange", "lagrange / KDL", "met"],
                [[r[0], r[1], times_sincos(r[2], calib), times_sincos(r[3], calib), f"{r[4]:.3f}",
                  yes(r[4] <= KIN_RATIO_LIMIT) if r[1] in KIN_TARGET_TERMS else "(no target)"] for r in rows])]
    every = [(robot, get.get((robot, "lagrange", "all"))) for robot in ROBOTS]
    if all(v is not None for _, v in every):
        md.append("\n`ComputeFrameKinematics` (every frame's pose, both axes' Jacobians and J̇q̇ in one pass; KDL "
                  "has no such call): " + ", ".join(f"{robot} {times_sincos(v, calib)}" for robot, v in every)
                  + ".\n")
    agreement = out / "kinematics_agreement.csv"
    if agreement.exists():
        arows = read_csv(agreement)
        limit = float(arows[0]["limit_rel"]) if arows else math.nan
        md.append("\nBefore timing, `kinematics_bench` checks every term against the KDL calls it times, for every "
                  "frame, at 8 seeded random states per robot (and on a random 12-link chain with prismatic joints "
                  "and frames at random placements, on the world too); it times nothing if any difference, relative "
                  f"to 1 + max |KDL's value|, is above {limit:.0e}. Largest differences per term, over what it "
                  "computes (`kinematics_agreement.csv` has each quantity; pose in m or per unit, J in m/s or rad/s "
                  "per unit velocity, J̇q̇ in m/s² or rad/s²; all: `ComputeFrameKinematics`):\n")
        terms = list(dict.fromkeys(r["term"] for r in arows))
        robots = list(dict.fromkeys(r["robot"] for r in arows))
        gap = {}
        for r in arows:
            key = (r["robot"], r["term"])
            gap[key] = max(gap.get(key, 0.0), float(r["max_abs_diff"]))
        md.append(table(["robot"] + terms,
                        [[robot] + [f"{gap[(robot, t)]:.1e}" if (robot, t) in gap else "n/a" for t in terms]
                         for robot in robots]))
    return "\n".join(md), worst


def kinematics_targets(worst):
    return [[f"lagrange / KDL per call, frame kinematics, {robot} (worst of {', '.join(KIN_TARGET_TERMS)})",
             f"≤ {KIN_RATIO_LIMIT}", f"{ratio:.3f} ({term})", yes(ratio <= KIN_RATIO_LIMIT)]
            for robot, (ratio, term) in worst.items()]
