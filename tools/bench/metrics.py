# SPDX-License-Identifier: MIT
"""Metrics of SPEC 7 (paper Sec. 6) plus the strict ones.

For an estimate T (4x4 similarity, x_t = s R x_s + t) against T_gt:
  mse      mean squared distance from each aligned source point to its
           nearest target point, divided by the target's RMS radius^2
           (the template's pre-shape units)
  mse_n    mean squared angle (radians) between the unoriented PCA normals
           (12-NN) of those nearest-neighbour pairs
  gt_cos   trace(R_gt^T R) / 3
  rr       gt_cos > 0.8 and mse < 0.001 (the paper's registration recall)
  rre_deg  geodesic rotation error, degrees
  rte_pct  translation error as % of the target diameter, measured where it
           matters: the distance between T(c) and T_gt(c) for the source
           centroid c (the raw |t - t_gt| mixes in the lever arm from the
           coordinate origin, which the random similarity moves far away)
  scale_err_pct  |s / s_gt - 1| * 100
  strict   rre < 5 deg and rte < 2 % and scale error < 2 %
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

import cases as C

STRICT_RRE_DEG = 5.0
STRICT_RTE_PCT = 2.0
STRICT_SCALE_PCT = 2.0


def decompose(T):
    A = np.asarray(T, dtype=np.float64)[:3, :3]
    det = np.linalg.det(A)
    s = float(np.cbrt(det)) if det != 0 else 0.0
    u, sv, vt = np.linalg.svd(A)
    R = u @ vt
    if np.linalg.det(R) < 0:  # reflection: keep nearest rotation
        u[:, -1] *= -1
        R = u @ vt
    if s <= 0:
        s = float(sv.mean())
    return s, R, np.asarray(T)[:3, 3]


class Evaluator:
    """Precomputes what every method's metrics on one case share."""

    def __init__(self, case):
        self.case = case
        src, tgt = case.source, case.target
        self.tree = cKDTree(tgt)
        self.rms_t = C.rms_radius(tgt)
        self.diam_t = C.diameter(tgt)
        self.n_src, _ = C.knn_stats(src)
        self.n_tgt, _ = C.knn_stats(tgt)
        self.c_src = src.mean(axis=0)
        self.s_gt, self.R_gt, self.t_gt = decompose(case.T_gt)

    def __call__(self, T):
        case = self.case
        T = np.asarray(T, dtype=np.float64)
        s, R, t = decompose(T)
        al = C.apply(T, case.source)
        d, nn = self.tree.query(al)
        mse = float((d ** 2).mean() / self.rms_t ** 2)
        ns = self.n_src @ R.T
        cosang = np.abs((ns * self.n_tgt[nn]).sum(axis=1)).clip(0.0, 1.0)
        mse_n = float((np.arccos(cosang) ** 2).mean())
        tr = float(np.trace(self.R_gt.T @ R))
        gt_cos = tr / 3.0
        rre = float(np.degrees(np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0))))
        p = C.apply(T, self.c_src[None])[0]
        p_gt = C.apply(case.T_gt, self.c_src[None])[0]
        rte = float(np.linalg.norm(p - p_gt) / self.diam_t * 100.0)
        scale_err = float(abs(s / self.s_gt - 1.0) * 100.0)
        return {
            "mse": mse, "mse_n": mse_n, "gt_cos": gt_cos,
            "rr": bool(gt_cos > 0.8 and mse < 0.001),
            "rre_deg": rre, "rte_pct": rte, "scale_err_pct": scale_err,
            "t_err_raw": float(np.linalg.norm(t - self.t_gt)),
            "scale": s, "gt_scale": self.s_gt,
            "strict": bool(rre < STRICT_RRE_DEG and rte < STRICT_RTE_PCT
                           and scale_err < STRICT_SCALE_PCT),
        }
