#!/usr/bin/env python3
"""Turns the raw benchmark output in a results folder into report.md, summary
CSV files and PNG plots (issue 6). Run by scripts/bench; usage:

    bench/report.py RESULTS_DIR

Reads dynamics.json, effects.json, tick.json, and when present spatial_cost.json,
kdl.json and kinematics.json (Google Benchmark), kdl_agreement.csv, kinematics_agreement.csv, mujoco.json and
mujoco_agreement.csv (when MuJoCo was found), the CSV files of
work_precision, loop_bench and hostile_bench, external_bench's external.json, live_bench's live.csv,
live_offline.csv and live.json, flood_bench's flood_cases.csv, mpc_sweep's mpc_sweep.csv, python_bench.py's python.json, cyclictest's JSON files
(cyclictest_*.json) and machine.txt. Times from Google Benchmark
are CPU time per call (the median of the repetitions); every one is also given
as a multiple of calib/sincos, one sin and one cos measured in the same run
(the same program's run: each JSON file has its own).

This file is the report's table of contents; each section is a module of
bench/reporting/ (common: reading and formatting; precision: 1 and 2;
derivation: 3, kinematics: 3's frame kinematics; effects: 4; loop: 5 and 6; hostile: 7; external: 8; live: 9; flood: 10;
mpc_sweep: what accuracy costs in time for MPC; targets: the first table).
"""

import sys
from pathlib import Path

from reporting.common import median_of, ns, read_benchmarks, table, write_csv
from reporting.derivation import derivation_section, kdl_subsection, kdl_targets
from reporting.effects import effects_section
from reporting.flood import flood_data, flood_section, flood_targets
from reporting.external import external_data, external_section, external_target_rows
from reporting.hostile import hostile_data, hostile_section, hostile_targets
from reporting.kinematics import kinematics_subsection, kinematics_targets
from reporting.mujoco import mujoco_subsection
from reporting.live import live_data, live_section
from reporting.mpc_sweep import mpc_sweep_section
from reporting.loop import delivery_section, loop_data, loop_section, tick_target
from reporting.python_calls import python_target_rows
from reporting.python_loop import python_loop_section
from reporting.precision import long_horizon_section, work_precision, work_precision_section
from reporting.targets import targets


def calib(runs):
    """calib/sincos of one program's run, ns."""
    return runs["calib/sincos"]["cpu_ns"]


def optional_benchmarks(path):
    """(runs, calib/sincos, context) of a Google Benchmark file; None when there is none."""
    if not path.exists():
        return None
    runs, context = read_benchmarks(path)
    return runs, calib(runs), context


def derivation(out, derive_runs, derive_calib, context):
    """Section 3 with the spatial (spatial_cost), KDL (kdl_bench) and frame kinematics (kinematics_bench)
    subsections when they ran: (markdown, the planar figures, the KDL targets' rows)."""
    spatial = optional_benchmarks(out / "spatial_cost.json")
    md, derive = derivation_section(out, derive_runs, derive_calib, context, spatial)
    kdl_rows = []
    kdl = optional_benchmarks(out / "kdl.json")
    if kdl:
        kdl_md, kdl_worst = kdl_subsection(out, *kdl)
        md += "\n" + kdl_md
        kdl_rows += kdl_targets(kdl_worst)
    kinematics = optional_benchmarks(out / "kinematics.json")
    if kinematics:
        kin_md, kin_worst = kinematics_subsection(out, *kinematics)
        md += "\n" + kin_md
        kdl_rows += kinematics_targets(kin_worst)
    mujoco = optional_benchmarks(out / "mujoco.json")  # only where MuJoCo was found
    if mujoco:
        md += "\n" + mujoco_subsection(out, *mujoco)
    return md, derive, kdl_rows


def introduction(context, derive_calib):
    return ["# lagrange benchmarks\n",
            "Made by `scripts/bench` (issue 6). Release build (-O3), g++, on the machine below. Per-call times are "
            f"CPU time, {median_of(context)}; each is also given as a multiple of one sin + one cos measured in "
            f"the same run ({ns(derive_calib)}), the figure to compare across runs and machines. Google Benchmark "
            f"reports its library as a {context.get('library_build_type', '?')} build (the Debian package); that "
            "affects only its own bookkeeping, not the code timed.\n"]


def main(out):
    out = Path(out)
    derive_runs, context = read_benchmarks(out / "dynamics.json")
    effects_runs, _ = read_benchmarks(out / "effects.json")
    tick_runs, _ = read_benchmarks(out / "tick.json")
    wp_rows = work_precision(out)
    deriv_md, derive, kdl_rows = derivation(out, derive_runs, calib(derive_runs), context)
    effects_md, effects = effects_section(out, effects_runs, calib(derive_runs))
    loop = loop_data(out)
    hostile = hostile_data(out) if (out / "hostile_cases.csv").exists() else None
    external = external_data(out) if (out / "external.json").exists() else None
    flood = flood_data(out) if (out / "flood_cases.csv").exists() else None
    target_rows = targets(derive, effects, loop, calib(derive_runs), calib(effects_runs))
    target_rows += kdl_rows + [tick_target(tick_runs)]
    target_rows += (hostile_targets(hostile) if hostile else []) + (external_target_rows(external) if external else [])
    target_rows += flood_targets(flood) if flood else []
    target_rows += python_target_rows(out)
    write_csv(out / "targets.csv", ["target", "limit", "measured", "met"], target_rows)
    md = introduction(context, calib(derive_runs)) + [
        "## Targets\n", table(["target", "limit", "measured", "met"], target_rows),
        work_precision_section(out, wp_rows), long_horizon_section(out), deriv_md, effects_md,
        loop_section(out, loop, tick_runs), delivery_section(loop)]
    if hostile:
        md.append(hostile_section(out, hostile))
    if external:
        md.append(external_section(external))
    if (out / "live.csv").exists():
        md.append(live_section(out, live_data(out)))
    if flood:
        md.append(flood_section(flood))
    if (out / "python_loop.csv").exists():
        md.append(python_loop_section(out))
    if (out / "mpc_sweep.csv").exists():
        md.append(mpc_sweep_section(out))
    machine = (out / "machine.txt").read_text() if (out / "machine.txt").exists() else ""
    md += ["## Machine\n", "```\n" + machine.strip() + "\n```\n"]
    (out / "report.md").write_text("\n".join(md))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: bench/report.py RESULTS_DIR")
    main(sys.argv[1])
