#!/usr/bin/env python3
"""The Panda over 10⁵ sampled states in a few calls: Yoshikawa's manipulability of its flange and the condition
number of its mass matrix, as histograms in a PNG. No Python loop over states: each quantity is one batched call.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/batch_analysis.py --out panda_batch.png

q is sampled uniformly within the URDF's joint limits (read here with the standard library's XML parser).
  manipulability  w(q) = sqrt(det(J Jᵀ)), J the world-aligned Jacobian (6, 7) of panda_link8 (m³/rad³ mixed units:
                  compare values of one robot, not across robots); 0 at a singularity
  cond(M)         the 2-norm condition number of M(q) (7, 7): how unevenly the arm's inertia is spread over its joints
"""
import argparse
import os
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np

import lagrange

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def joint_limits(urdf, names):
    """(lower, upper) per joint in q order, rad, from the URDF's <limit> elements."""
    joints = {j.get("name"): j for j in ET.parse(urdf).getroot().iter("joint")}
    lower = [float(joints[n].find("limit").get("lower")) for n in names]
    upper = [float(joints[n].find("limit").get("upper")) for n in names]
    return np.array(lower), np.array(upper)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--urdf", default=os.path.join(ROOT, "config/robots/panda.urdf"))
    parser.add_argument("--frame", default="panda_link8")
    parser.add_argument("--states", type=int, default=100_000, help="how many states to sample (default 10⁵)")
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default="panda_batch.png", help="the PNG to write")
    args = parser.parse_args()

    model = lagrange.Model.from_urdf(args.urdf)
    lower, upper = joint_limits(args.urdf, model.joint_names)
    q = np.random.default_rng(42).uniform(lower, upper, (args.states, model.num_dofs))

    start = time.perf_counter()
    J = model.frame_jacobian(args.frame, q, threads=args.threads)  # (N, 6, 7)
    M = model.mass_matrix(q, threads=args.threads)                 # (N, 7, 7)
    lagrange_s = time.perf_counter() - start
    w = np.sqrt(np.maximum(np.linalg.det(J @ J.transpose(0, 2, 1)), 0.0))
    cond = np.linalg.cond(M)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.hist(w, bins=100, color="tab:blue")
    a.set(xlabel="manipulability sqrt(det(J Jᵀ)) of " + args.frame, ylabel="states",
          title="%d states within the joint limits" % args.states)
    b.hist(np.log10(cond), bins=100, color="tab:orange")
    b.set(xlabel="log10 cond(M)", ylabel="states", title="mass matrix condition number")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)

    print("%d states: J and M in %.3f s (%d threads)" % (args.states, lagrange_s, args.threads))
    print("manipulability: median %.4g, min %.3g, max %.4g" % (np.median(w), w.min(), w.max()))
    print("cond(M): median %.4g, min %.4g, max %.4g" % (np.median(cond), cond.min(), cond.max()))
    print("wrote " + args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
