"""examples/python/batch_analysis.py runs on a few states and writes its plot; its batched quantities are physical."""
import os
import subprocess
import sys

import numpy as np

import lagrange

SOURCE = os.environ["LAGRANGE_SOURCE_DIR"]
EXAMPLE = os.path.join(SOURCE, "examples/python/batch_analysis.py")


def test_the_batch_analysis_example_writes_its_png(tmp_path):
    out = tmp_path / "panda.png"
    r = subprocess.run([sys.executable, EXAMPLE, "--states", "300", "--threads", "2", "--out", str(out)],
                       capture_output=True, text=True, env=dict(os.environ, MPLCONFIGDIR=str(tmp_path)))
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "300 states" in r.stdout


def test_the_manipulability_it_plots_vanishes_at_a_singularity_and_cond_m_is_at_least_one():
    model = lagrange.Model.from_urdf(os.path.join(SOURCE, "config/robots/panda.urdf"))
    q = np.random.default_rng(4).uniform(-1.5, 1.5, (100, 7))
    q[0] = [0, 0, 0, -0.1, 0, 3.5, 0]  # not a singularity
    q[1] = [0, 0, 0, 0, 0, 0, 0]       # the elbow stretched (joint 4 at 0): the flange loses a direction
    J = model.frame_jacobian("panda_link8", q)
    w = np.sqrt(np.maximum(np.linalg.det(J @ J.transpose(0, 2, 1)), 0.0))
    assert w[1] < 1e-6 < w[0]
    assert np.all(np.linalg.cond(model.mass_matrix(q)) >= 1.0)
