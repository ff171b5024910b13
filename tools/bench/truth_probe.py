# SPDX-License-Identifier: MIT
"""Does a real pair's own data hold its ground truth?

Starts two textbook ICPs (plain numpy/scipy, neither pkss nor a peer) at each
real pair's ground truth and lets them settle: a similarity ICP (point-to-point,
Umeyama's closed form) and a rigid point-to-plane ICP, each with pairs gated at
a few target spacings. Where the data hold the truth, both stay within the
benchmark's strict bars; where they drift out of them, the pair's data prefer
another pose, and no estimator that follows the data can be held to those bars
on it. The table gives the settled poses' errors as metrics.py measures them.

Run: python3 tools/bench/truth_probe.py [--pairs NAME ...] [--gates 1.5 2 3]
(needs numpy, scipy and ../shared/data; about a minute for all real pairs).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.spatial import cKDTree

import cases as C
from metrics import STRICT_RRE_DEG, STRICT_RTE_PCT, STRICT_SCALE_PCT, decompose

MAX_ITERATIONS = 100   # both ICPs settle within 20-60 on the real pairs
SETTLED = 1e-7         # relative change of the pose that ends a run


def umeyama(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The similarity T minimising sum |T(x) - y|^2 (Umeyama 1991)."""
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    u, sv, vt = np.linalg.svd(yc.T @ xc)
    d = np.ones(3)
    d[2] = np.sign(np.linalg.det(u @ vt))
    R = u @ np.diag(d) @ vt
    s = float((sv * d).sum() / (xc ** 2).sum())
    T = np.eye(4)
    T[:3, :3] = s * R
    T[:3, 3] = my - s * R @ mx
    return T


def plane_step(x: np.ndarray, y: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The small rigid motion minimising sum (n . (x + w x x + v - y))^2."""
    A = np.hstack([np.cross(x, n), n])
    b = -((x - y) * n).sum(axis=1)
    w_v = np.linalg.lstsq(A, b, rcond=None)[0]
    w, v = w_v[:3], w_v[3:]
    th = np.linalg.norm(w)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    R = np.eye(3) if th == 0 else (np.eye(3) + np.sin(th) / th * K
                                   + (1 - np.cos(th)) / th ** 2 * K @ K)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, v
    return T


def settle(T0, src, tgt, tree, tgt_normals, gate, mode):
    """ICP from T0 until the pose stops moving; mode 'similarity' or 'plane'."""
    T = T0.copy()
    scale = np.linalg.norm(tgt.max(axis=0) - tgt.min(axis=0))
    for _ in range(MAX_ITERATIONS):
        x = C.apply(T, src)
        d, j = tree.query(x, distance_upper_bound=gate)
        keep = np.isfinite(d)
        if keep.sum() < 6:
            break
        if mode == "similarity":
            T_new = umeyama(src[keep], tgt[j[keep]])
        else:
            T_new = plane_step(x[keep], tgt[j[keep]], tgt_normals[j[keep]]) @ T
        moved = np.abs(T_new[:3, :3] - T[:3, :3]).max() + np.abs(T_new[:3, 3] - T[:3, 3]).max() / scale
        T = T_new
        if moved < SETTLED:
            break
    return T


def errors(T, T_gt, src, diam):
    """rre (deg), rte (% of the target diameter, at the source centroid) and
    scale error (%), as metrics.py measures them."""
    s, R, _ = decompose(T)
    s_gt, R_gt, _ = decompose(T_gt)
    rre = float(np.degrees(np.arccos(np.clip((np.trace(R_gt.T @ R) - 1) / 2, -1, 1))))
    c = src.mean(axis=0)[None]
    rte = float(np.linalg.norm(C.apply(T, c) - C.apply(T_gt, c)) / diam * 100)
    return rre, rte, float(abs(s / s_gt - 1) * 100)


def probe(src, tgt, T_gt, gates):
    """Rows (mode, gate in spacings, rre, rte %, scale error %, within the bars)."""
    tree = cKDTree(tgt)
    n = C.knn_stats(tgt)[0]
    h = C.spacing(tgt, tree)
    diam = C.diameter(tgt)
    rows = []
    for mode in ("similarity", "plane"):
        for g in gates:
            T = settle(T_gt, src, tgt, tree, n, g * h, mode)
            rre, rte, se = errors(T, T_gt, src, diam)
            ok = rre < STRICT_RRE_DEG and rte < STRICT_RTE_PCT and se < STRICT_SCALE_PCT
            rows.append((mode, g, rre, rte, se, ok))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", nargs="*", help="real pairs (default: all, the hard ones too)")
    ap.add_argument("--gates", nargs="*", type=float, default=[1.5, 2.0, 3.0],
                    help="pair gates in target spacings (default 1.5 2 3)")
    a = ap.parse_args(argv)
    names = a.pairs or [*C.REAL_PAIRS, *C.HARD_REAL_PAIRS]
    print("| pair | overlap | ICP from the truth | gate (spacings) | rotation (deg) "
          "| translation (% diam.) | scale (%) | within the strict bars |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        kind, s, t, T, ov = C.load_real_pair(name)
        for mode, g, rre, rte, se, ok in probe(s, t, T, a.gates):
            label = "similarity, point-to-point" if mode == "similarity" else "rigid, point-to-plane"
            print(f"| {name} | {ov:.0%} | {label} | {g:g} | {rre:.2f} | {rte:.2f} | "
                  f"{se:.2f} | {'yes' if ok else '**no**'} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
