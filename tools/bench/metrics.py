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
  strict   rre < 5 deg and rte < 2 % and scale error < 2 %, or a pose
           equivalent to the truth under a symmetry of the shape (sym)
  sym      the symmetric-equivalence rule: not strict by the errors above,
           yet the clean source (the whole template carried into the source
           frame by T_gt^-1 for synthetic cases; the source itself for real
           pairs), aligned by T, lies on the clean target as closely as
           under T_gt: mean closest-point distance <= that under T_gt +
           SYM_TOL_SPACINGS x the clean target's median point spacing, and
           the scale error < 2 % (a symmetry turns the shape, it does not
           resize it)
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

import cases as C

STRICT_RRE_DEG = 5.0
STRICT_RTE_PCT = 2.0
STRICT_SCALE_PCT = 2.0
# A symmetric image's points fall between the clean target's samples: a
# mean distance of ~1.05 spacings (box, cylinder), the truth's 0-0.8; wrong
# poses of the benchmark's objects read >= 4.9 (docs/confidence.md).
SYM_TOL_SPACINGS = 1.5


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
        self._sym = None  # built on first use: only non-strict poses need it

    def _sym_setup(self):
        case = self.case
        if case.case == "real":
            clean_t, clean_s = case.target, case.source
            tree = self.tree
        else:
            clean_t = case.clean_target if case.clean_target is not None else case.target
            clean_s = C.apply(np.linalg.inv(case.T_gt), clean_t)
            tree = cKDTree(clean_t)
        h = float(np.median(tree.query(clean_t[:5000], k=2)[0][:, 1]))
        d_gt = float(tree.query(C.apply(case.T_gt, clean_s))[0].mean())
        self._sym = (tree, clean_s, h, d_gt)

    def symmetric_equivalent(self, T, scale_err_pct):
        """The sym rule of the module docstring."""
        if scale_err_pct >= STRICT_SCALE_PCT:
            return False
        if self._sym is None:
            self._sym_setup()
        tree, clean_s, h, d_gt = self._sym
        d = float(tree.query(C.apply(T, clean_s))[0].mean())
        return d <= d_gt + SYM_TOL_SPACINGS * h

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
        strict = bool(rre < STRICT_RRE_DEG and rte < STRICT_RTE_PCT
                      and scale_err < STRICT_SCALE_PCT)
        sym = not strict and self.symmetric_equivalent(T, scale_err)
        return {
            "mse": mse, "mse_n": mse_n, "gt_cos": gt_cos,
            "rr": bool(gt_cos > 0.8 and mse < 0.001),
            "rre_deg": rre, "rte_pct": rte, "scale_err_pct": scale_err,
            "t_err_raw": float(np.linalg.norm(t - self.t_gt)),
            "scale": s, "gt_scale": self.s_gt,
            "strict": strict or sym, "sym": sym,
        }
