# SPDX-License-Identifier: MIT
"""Does a real pair's own data hold its ground truth?

Starts textbook ICPs (plain numpy/scipy, neither pkss nor a peer) at each
real pair's ground truth and lets them settle, each with pairs gated at a few
target spacings:
  similarity        point-to-point, Umeyama's closed form;
  plane             rigid, point-to-plane (the template's normals);
  plane-similarity  the similarity, point-to-plane, source to template;
  plane-both        the same with the template's points paired back to the
                    source on the source's normals as well (a partial
                    overlap leaves pairs past either cloud's edge);
  plane-robust      plane-similarity with each pair weighted by Welsch's
                    kernel exp(-(r / c)^2), c = ROBUST_SIGMAS times the
                    pairs' noise (1.4826 x their median |r|), re-estimated
                    every step: pairs beside the surface fade instead of
                    being cut at the gate.
Where the data hold the truth, they stay within the benchmark's strict bars;
where they drift out of them, the pair's data prefer another pose, and no
estimator that follows the data can be held to those bars on it. The table
gives the settled poses' errors as metrics.py measures them, the scale's
signed (negative: the source came out small).

Run: python3 tools/bench/truth_probe.py [--pairs NAME ...] [--gates 1.5 2 3]
     [--modes similarity plane plane-similarity plane-both plane-robust]
     (default: the first two)
(needs numpy, scipy and ../shared/data; about a minute for all real pairs with
the default modes).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.spatial import cKDTree

import cases as C
from metrics import STRICT_RRE_DEG, STRICT_RTE_PCT, STRICT_SCALE_PCT, decompose

MAX_ITERATIONS = 100   # the ICPs settle within 20-60 on the real pairs
SETTLED = 1e-7         # relative change of the pose that ends a run
ROBUST_SIGMAS = 1.5    # below Welsch's 95 %-efficiency 2.98: pairs beside the surface fade sooner
ROBUST_FLOOR = 0.05    # c never below this share of the gate (an exact copy has r = 0)
MODES = ("similarity", "plane", "plane-similarity", "plane-both", "plane-robust")
LABELS = {"similarity": "similarity, point-to-point", "plane": "rigid, point-to-plane",
          "plane-similarity": "similarity, point-to-plane",
          "plane-both": "similarity, point-to-plane both ways",
          "plane-robust": "similarity, point-to-plane, Welsch-weighted"}


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


def rotation_exp(w: np.ndarray) -> np.ndarray:
    """Rodrigues' formula: the rotation by |w| about w."""
    th = np.linalg.norm(w)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return np.eye(3) if th == 0 else (np.eye(3) + np.sin(th) / th * K
                                      + (1 - np.cos(th)) / th ** 2 * K @ K)


def plane_step(x: np.ndarray, y: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The small rigid motion minimising sum (n . (x + w x x + v - y))^2."""
    A = np.hstack([np.cross(x, n), n])
    b = -((x - y) * n).sum(axis=1)
    w_v = np.linalg.lstsq(A, b, rcond=None)[0]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation_exp(w_v[:3]), w_v[3:]
    return T


def similarity_plane_step(x: np.ndarray, y: np.ndarray, n: np.ndarray,
                          weights: np.ndarray | None = None) -> np.ndarray:
    """The small similarity about the (weighted) centroid c of x minimising
    sum_k a_k (n . (c + (1 + sg)(x - c) + w x (x - c) + v - y))^2, a the
    weights (1 if none)."""
    a = np.ones(len(x)) if weights is None else weights
    c = (x * a[:, None]).sum(axis=0) / a.sum()
    u = x - c
    A = np.hstack([(u * n).sum(axis=1)[:, None], np.cross(u, n), n])
    b = -((x - y) * n).sum(axis=1)
    root = np.sqrt(a)
    p = np.linalg.lstsq(A * root[:, None], b * root, rcond=None)[0]
    step = np.eye(4)
    R = rotation_exp(p[1:4])
    step[:3, :3] = (1.0 + p[0]) * R
    step[:3, 3] = c + p[4:] - (1.0 + p[0]) * R @ c
    return step


def welsch_weights(x: np.ndarray, y: np.ndarray, n: np.ndarray, gate: float) -> np.ndarray:
    """Welsch's weights of the point-to-plane residuals at ROBUST_SIGMAS of
    their robust spread (floored at ROBUST_FLOOR of the gate)."""
    r = ((x - y) * n).sum(axis=1)
    c = max(ROBUST_SIGMAS * 1.4826 * float(np.median(np.abs(r))), ROBUST_FLOOR * gate)
    return np.exp(-(r / c) ** 2)


def plane_rows(T, src, tgt, tree, tgt_normals, src_normals, gate, both):
    """Point-to-plane rows (aligned source point, its partner, the partner's
    normal) of the source's pairs on the template, and with both, of the
    template's pairs on the aligned source (its normals turned by T)."""
    x = C.apply(T, src)
    d, j = tree.query(x, distance_upper_bound=gate)
    k = np.isfinite(d)
    rows = [(x[k], tgt[j[k]], tgt_normals[j[k]])]
    if both:
        d, i = cKDTree(x).query(tgt, distance_upper_bound=gate)
        kb = np.isfinite(d)
        R = T[:3, :3] / np.cbrt(np.linalg.det(T[:3, :3]))
        rows.append((x[i[kb]], tgt[kb], src_normals[i[kb]] @ R.T))
    return [np.vstack(r) for r in zip(*rows)]


def settle(T0, src, tgt, tree, tgt_normals, gate, mode, src_normals=None):
    """ICP from T0 until the pose stops moving (mode: one of MODES;
    src_normals only for plane-both)."""
    T = T0.copy()
    scale = np.linalg.norm(tgt.max(axis=0) - tgt.min(axis=0))
    for _ in range(MAX_ITERATIONS):
        if mode in ("plane-similarity", "plane-both", "plane-robust"):
            x, y, n = plane_rows(T, src, tgt, tree, tgt_normals, src_normals, gate,
                                 mode == "plane-both")
            if len(x) < 7:
                break
            T_new = similarity_plane_step(x, y, n, welsch_weights(x, y, n, gate)
                                          if mode == "plane-robust" else None) @ T
        else:
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
    scale error (%, signed: s / s_gt - 1), as metrics.py measures them."""
    s, R, _ = decompose(T)
    s_gt, R_gt, _ = decompose(T_gt)
    rre = float(np.degrees(np.arccos(np.clip((np.trace(R_gt.T @ R) - 1) / 2, -1, 1))))
    c = src.mean(axis=0)[None]
    rte = float(np.linalg.norm(C.apply(T, c) - C.apply(T_gt, c)) / diam * 100)
    return rre, rte, float((s / s_gt - 1) * 100)


def probe(src, tgt, T_gt, gates, modes=MODES[:2]):
    """Rows (mode, gate in spacings, rre, rte %, signed scale error %, within
    the bars)."""
    tree = cKDTree(tgt)
    n = C.knn_stats(tgt)[0]
    n_src = C.knn_stats(src)[0] if "plane-both" in modes else None
    h = C.spacing(tgt, tree)
    diam = C.diameter(tgt)
    rows = []
    for mode in modes:
        for g in gates:
            T = settle(T_gt, src, tgt, tree, n, g * h, mode, n_src)
            rre, rte, se = errors(T, T_gt, src, diam)
            ok = rre < STRICT_RRE_DEG and rte < STRICT_RTE_PCT and abs(se) < STRICT_SCALE_PCT
            rows.append((mode, g, rre, rte, se, ok))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", nargs="*", help="real pairs (default: all, the hard ones too)")
    ap.add_argument("--gates", nargs="*", type=float, default=[1.5, 2.0, 3.0],
                    help="pair gates in target spacings (default 1.5 2 3)")
    ap.add_argument("--modes", nargs="*", choices=MODES, default=list(MODES[:2]),
                    help="ICPs to run (default: similarity plane)")
    a = ap.parse_args(argv)
    names = a.pairs or [*C.REAL_PAIRS, *C.HARD_REAL_PAIRS]
    print("| pair | overlap | ICP from the truth | gate (spacings) | rotation (deg) "
          "| translation (% diam.) | scale (%) | within the strict bars |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        kind, s, t, T, ov = C.load_real_pair(name)
        for mode, g, rre, rte, se, ok in probe(s, t, T, a.gates, a.modes):
            print(f"| {name} | {ov:.0%} | {LABELS[mode]} | {g:g} | {rre:.2f} | {rte:.2f} | "
                  f"{round(se, 2) + 0.0:+.2f} | {'yes' if ok else '**no**'} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
