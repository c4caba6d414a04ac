"""Section 3: derivation cost, from dynamics_bench (planar plants and chains),
spatial_cost (the URDF robots and random spatial chains) and kdl_bench
(Orocos KDL beside lagrange)."""

import math

import matplotlib.pyplot as plt
import numpy as np

from .common import PLANTS, median_of, ns, read_csv, table, times_sincos, write_csv, yes


METHODS = ["closed-form", "lagrangian", "recursive"]
TERMS = ["M", "C", "Cqd", "G", "FD"]
CHAIN_SIZES = [2, 4, 7, 12, 20, 30, 50, 64]  # bench/dynamics_bench.cpp registers these chains
FIT_FROM_LINKS = 7  # growth exponents fitted over chains of this many links and more
ROBOTS = ["panda", "ur5"]  # config/robots/*.urdf
TREE_METHODS = ["lagrangian", "recursive"]  # the methods a RigidTree has
SPATIAL_TERMS = ["M", "C", "Cqd", "G", "dTdq", "ID", "FD"]
SPATIAL_SIZES = CHAIN_SIZES  # bench_plants.cpp SpatialChainSizes()
KDL_TERMS = ["M", "G", "Cqd", "ID", "FD"]  # the terms Orocos KDL has
KDL_RATIO_LIMIT = 0.3  # lagrange / KDL per call
PLANAR_SPATIAL_TERMS = ["M", "C", "Cqd", "G", "ID", "FD"]  # the terms dynamics_bench times on both


def links_of(plant, family):
    """n of a sized plant name ("chain30", "spatial7") of that family, else None."""
    rest = plant[len(family):] if plant.startswith(family) else ""
    return int(rest) if rest.isdigit() else None


def derivation_rows(runs, family="chain", calib=None):
    """derive/<plant>/<method>/<term> rows; links set for plants named <family><n>."""
    rows = []
    for name, r in runs.items():
        parts = name.split("/")
        if parts[0] != "derive":
            continue
        plant, method, term = parts[1], parts[2], parts[3]
        rows.append({"plant": plant, "links": links_of(plant, family), "method": method, "term": term,
                     "x_sincos": r["cpu_ns"] / calib if calib else math.nan, **r})
    return rows


def fit_exponent(rows, method, term, first):
    pts = sorted((r["links"], r["cpu_ns"]) for r in rows
                 if r["links"] and r["links"] >= first and r["method"] == method and r["term"] == term)
    if len(pts) < 2:
        return float("nan")
    n, t = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(n, t, 1)[0])


def plot_derivation(out, rows, terms=TERMS, title="Derivation cost on n-link chains", file="derivation_cost.png"):
    fig, axes = plt.subplots(1, len(terms), figsize=(2.6 * len(terms) + 5, 4.2), sharey=True)
    for ax, term in zip(axes, terms):
        for method in ("lagrangian", "recursive"):
            pts = sorted((r["links"], r["cpu_ns"]) for r in rows
                         if r["links"] and r["method"] == method and r["term"] == term)
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=method, ms=4)
        ax.set_title(term)
        ax.set_xlabel("links n")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("CPU time per call (ns)")
    axes[0].legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out / file, dpi=110)
    plt.close(fig)


def exponent_cells(rows, methods, terms):
    """'b (b_all)' per method and term: fitted from n >= FIT_FROM_LINKS, in brackets from every n."""
    return [[m] + [f"{fit_exponent(rows, m, t, FIT_FROM_LINKS):.2f} ({fit_exponent(rows, m, t, 1):.2f})"
                   for t in terms] for m in methods]


def exponent_csv_rows(family, rows, methods, terms):
    return [[family, m, t, f"{fit_exponent(rows, m, t, FIT_FROM_LINKS):.3f}", f"{fit_exponent(rows, m, t, 1):.3f}"]
            for m in methods for t in terms]


def derivation_section(out, runs, calib, context, spatial=None):
    """Planar plants and chains from dynamics_bench; with `spatial` = (runs, calib, context) of
    spatial_cost, the URDF robots and random spatial chains too."""
    rows = derivation_rows(runs, "chain", calib)
    srows = derivation_rows(spatial[0], "spatial", spatial[1]) if spatial else []
    write_csv(out / "derivation_cost.csv", ["plant", "links", "method", "term", "cpu_ns", "real_ns", "x_sincos"],
              [[r["plant"], r["links"] or "", r["method"], r["term"], f"{r['cpu_ns']:.4g}", f"{r['real_ns']:.4g}",
                f"{r['x_sincos']:.3g}"] for r in rows + srows])
    plot_derivation(out, rows)
    get = {(r["plant"], r["method"], r["term"]): r["cpu_ns"] for r in rows}
    md = ["## 3. Derivation cost\n",
          f"CPU time per call, {median_of(context)} (Google Benchmark; each call on one of 16 seeded random "
          "states). M: mass matrix; C: Coriolis matrix; Cqd: C(q, q̇) q̇; G: gravity; FD: forward dynamics "
          f"q̈ = M⁻¹(τ − C q̇ − G). Baseline in the same run: one sin + one cos = {ns(calib)}. "
          "All figures: `derivation_cost.csv`.\n"]
    body = []
    for plant in PLANTS:
        for method in METHODS:
            if (plant, method, "M") in get:
                body.append([plant, method] + [ns(get[(plant, method, t)]) for t in TERMS])
    md.append(table(["plant", "method"] + TERMS, body))
    md.append("\nChains (default links: 1 kg, 0.5 m uniform rods; no closed form):\n")
    body = []
    for method in ("lagrangian", "recursive"):
        for n in CHAIN_SIZES:
            body.append([f"chain{n}", method] + [ns(get.get((f"chain{n}", method, t), float("nan"))) for t in TERMS])
    md.append(table(["plant", "method"] + TERMS, body))
    md.append(f"\nFitted growth exponent b in time ∝ n^b (least squares on log-log, chains n ≥ {FIT_FROM_LINKS}; "
              "in brackets over every n from 2):\n")
    md.append(table(["method"] + TERMS, exponent_cells(rows, ("lagrangian", "recursive"), TERMS)))
    exponents = exponent_csv_rows("chain", rows, ("lagrangian", "recursive"), TERMS)
    md.append("\n![derivation cost](derivation_cost.png)\n")
    if planar_spatial := planar_against_spatial(get):
        md.append(planar_spatial)
    if srows:
        md.append(spatial_subsection(out, srows, spatial[1], spatial[2]))
        exponents += exponent_csv_rows("spatial", srows, TREE_METHODS, SPATIAL_TERMS)
    write_csv(out / "derivation_exponents.csv",
              ["family", "method", "term", f"exponent_n_ge_{FIT_FROM_LINKS}", "exponent_all_n"], exponents)
    return "\n".join(md), get


def planar_against_spatial(get):
    """The chains' planar algorithms (method recursive: the chain's tree folded to 2-D) against the spatial
    ones on the same tree (method spatial), per chain size and term; "" when dynamics_bench timed no
    derive/<chain>/spatial rows."""
    terms = [t for t in PLANAR_SPATIAL_TERMS if any((f"chain{n}", "spatial", t) in get for n in CHAIN_SIZES)]
    if not terms:
        return ""

    def cell(plant, term):
        planar, spatial = get.get((plant, "recursive", term)), get.get((plant, "spatial", term))
        if planar is None or spatial is None:
            return "n/a"
        return f"{ns(planar)} / {ns(spatial)} ({planar / spatial:.2f})"

    body = [[f"chain{n}"] + [cell(f"chain{n}", t) for t in terms] for n in CHAIN_SIZES]
    return "\n".join([
        "\nPlanar against spatial on the same chains: `recursive` runs the planar algorithms on the chain's "
        "`RigidTree` folded to 2-D (`PlanarChainOf`), `spatial` the spatial ones (`SpatialDynamics`: CRBA, RNEA, "
        "ABA) on the tree itself. Per term, planar / spatial time per call, and in brackets their ratio (below 1: "
        "the planar algorithms are faster). ID: inverse dynamics τ = M q̈ + C q̇ + G.\n",
        table(["plant"] + terms, body)])


def spatial_subsection(out, rows, calib, context):
    get = {(r["plant"], r["method"], r["term"]): r["cpu_ns"] for r in rows}
    plot_derivation(out, rows, SPATIAL_TERMS, "Derivation cost on random spatial chains of n links",
                    "derivation_cost_spatial.png")
    md = ["### 3-D robots (URDF) and random spatial chains\n",
          f"`spatial_cost`, a separate run: CPU time per call, {median_of(context)}, and in brackets its multiple "
          f"of that run's sin + cos ({ns(calib)}). Both methods a `RigidTree` has: lagrangian "
          "(`LagrangianDynamics<RigidTree>`, automatic differentiation of T and V) and recursive "
          "(`SpatialDynamics`: CRBA, RNEA, ABA). dTdq: ∂T/∂q; ID: inverse dynamics τ = M q̈ + C q̇ + G; FD as "
          "above. Robots from `config/robots/*.urdf` (fixed joints merged):\n"]
    body = [[robot, method] + [times_sincos(get.get((robot, method, t)), calib) for t in SPATIAL_TERMS]
            for robot in ROBOTS for method in TREE_METHODS if (robot, method, "M") in get]
    md.append(table(["robot", "method"] + SPATIAL_TERMS, body))
    md.append("\nRandom spatial chains (`RandomRigidTree` of plant/random_tree.hpp as a chain, seed 42: revolute "
              "joints with random origins within ±0.5 m and random axes, bodies of 0.2–3 kg with full random "
              "inertias, gravity in a random direction), time per call:\n")
    body = [[f"spatial{n}", method] + [ns(get.get((f"spatial{n}", method, t), math.nan)) for t in SPATIAL_TERMS]
            for method in TREE_METHODS for n in SPATIAL_SIZES]
    md.append(table(["plant", "method"] + SPATIAL_TERMS, body))
    md.append(f"\nFitted growth exponent b in time ∝ n^b on the random spatial chains (n ≥ {FIT_FROM_LINKS}; in "
              "brackets over every n from 2); all in `derivation_exponents.csv`:\n")
    md.append(table(["method"] + SPATIAL_TERMS, exponent_cells(rows, TREE_METHODS, SPATIAL_TERMS)))
    md.append("\n![derivation cost, spatial](derivation_cost_spatial.png)\n")
    return "\n".join(md)


def kdl_subsection(out, runs, calib, context):
    """Orocos KDL beside lagrange's recursive method on the URDF robots (kdl_bench); returns the markdown
    and {robot: (worst ratio, its term)}."""
    get = {}
    for name, r in runs.items():
        parts = name.split("/")
        if parts[0] == "kdl":
            get[(parts[1], parts[2], parts[3])] = r["cpu_ns"]
    rows, worst = [], {}
    for robot in ROBOTS:
        for term in KDL_TERMS:
            kdl, ours = get.get((robot, "kdl", term)), get.get((robot, "lagrange", term))
            if kdl is None or ours is None:
                continue
            rows.append([robot, term, kdl, ours, ours / kdl])
            if robot not in worst or ours / kdl > worst[robot][0]:
                worst[robot] = (ours / kdl, term)
    write_csv(out / "kdl_ratios.csv", ["robot", "term", "kdl_ns", "lagrange_ns", "ratio", "kdl_x_sincos",
                                       "lagrange_x_sincos"],
              [[r[0], r[1], f"{r[2]:.4g}", f"{r[3]:.4g}", f"{r[4]:.3f}", f"{r[2] / calib:.3g}", f"{r[3] / calib:.3g}"]
               for r in rows])
    md = ["### 3-D robots against Orocos KDL\n",
          f"`kdl_bench`, a separate run: Orocos KDL {context.get('kdl_version', '?')} (Debian `liborocos-kdl-dev`) "
          "on the same URDF numbers, the `RigidTree` converted to a `KDL::Chain`, beside lagrange's recursive method "
          f"(`SpatialDynamics`). CPU time per call, {median_of(context)}; in brackets the multiple of that run's "
          f"sin + cos ({ns(calib)}). M: `ChainDynParam::JntToMass` / `ComputeMassMatrix`; G: `JntToGravity` / "
          "`ComputeGravityForce`; Cqd: `JntToCoriolis` / `ComputeCoriolisForce`; ID: `ChainIdSolver_RNE` / "
          "`ComputeInverseDynamics`; FD: `ChainFdSolver_RNE` (M by KDL's CRBA, then an LDLᵀ solve) / "
          f"`ComputeForwardDynamics`. Target: lagrange / KDL ≤ {KDL_RATIO_LIMIT}.\n",
          table(["robot", "term", "KDL", "lagrange", "lagrange / KDL", "met"],
                [[r[0], r[1], times_sincos(r[2], calib), times_sincos(r[3], calib), f"{r[4]:.3f}",
                  yes(r[4] <= KDL_RATIO_LIMIT)] for r in rows])]
    agreement = out / "kdl_agreement.csv"
    if agreement.exists():
        arows = read_csv(agreement)
        limit = float(arows[0]["limit_rel"]) if arows else math.nan
        md.append(f"\nBefore timing, `kdl_bench` checks that the two agree on 8 seeded random states per robot "
                  "(and on a random 12-link chain with prismatic joints, which the robots lack), for both of "
                  "lagrange's methods; it times nothing if any difference, relative to 1 + max |KDL's value|, is "
                  f"above {limit:.0e}. Largest differences (`kdl_agreement.csv`; N·m, N, kg·m² or rad/s²):\n")
        by = {(r["robot"], r["method"], r["term"]): r for r in arows}
        robots = list(dict.fromkeys(r["robot"] for r in arows))
        body = [[robot, method] + [f"{float(by[(robot, method, t)]['max_abs_diff']):.1e}"
                                   if (robot, method, t) in by else "n/a" for t in KDL_TERMS]
                for robot in robots for method in ("recursive", "lagrangian")]
        md.append(table(["robot", "lagrange method"] + KDL_TERMS, body))
    return "\n".join(md), worst


def kdl_targets(worst):
    return [[f"lagrange / KDL per call, {robot} (worst of {', '.join(KDL_TERMS)})", f"≤ {KDL_RATIO_LIMIT}",
             f"{ratio:.3f} ({term})", yes(ratio <= KDL_RATIO_LIMIT)] for robot, (ratio, term) in worst.items()]
