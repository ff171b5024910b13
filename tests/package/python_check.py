# SPDX-License-Identifier: MIT
"""Run by python_routes.sh in a fresh venv, from a folder outside the
repository: the installed pkss reads the bundled pair with its own readers,
registers it and meets the ground truth (rotation < 2 deg, scale within
1 %); with --reference-only it must also run on the reference backend.

    python python_check.py DATA_DIR [--reference-only]
"""
import sys

import numpy as np

import pkss

data = sys.argv[1]
reference_only = "--reference-only" in sys.argv
src = pkss.read_points(data + "/airplane_0001_s.ply")
tgt = pkss.read_points(data + "/airplane_0001_t.ply")
gt = np.loadtxt(data + "/gt_similarity_s_to_t.txt")
r = pkss.register(src, tgt)
s_gt = np.cbrt(np.linalg.det(gt[:3, :3]))
cos = (np.trace(r.rotation.T @ (gt[:3, :3] / s_gt)) - 1) / 2
angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
print("pkss %s from %s: library %s, backend %s%s; scale %.6f (truth %.6f), rotation error "
      "%.4f deg" % (pkss.__version__, pkss.__file__, pkss.library_path, r.backend,
                    " (fell back: %s)" % r.note if r.fell_back else "", r.scale, s_gt, angle))
assert angle < 2.0 and abs(r.scale / s_gt - 1) < 0.01, "registration beyond the ground-truth bars"
if reference_only:
    assert r.backend == "reference", r.backend
print("PASS")
