# SPDX-License-Identifier: MIT
"""The confidence model's fit and its measures: a logistic regression by
Newton's method (IRLS, a small L2 penalty), AUROC, expected calibration
error (10 equal-width bins) and precision above a threshold."""
from __future__ import annotations

import numpy as np

# the features in the order of assess.c's PKSS__FEAT_* and their macro names
FEATURES = ["FIT", "OVERLAP", "MARGIN", "RMS", "ASYMMETRY", "COVER_MIN", "SCORE", "REFINED"]


def fit_logistic(X, y, l2=1e-2, iters=50):
    """Coefficients (bias, w) on raw features; fitted on standardised ones
    (the penalty then weighs every feature alike) and folded back."""
    X = np.asarray(X, float)
    y = np.asarray(y, float)
    mu, sd = X.mean(0), X.std(0)
    sd[sd < 1e-12] = 1.0
    Z = np.column_stack([np.ones(len(X)), (X - mu) / sd])
    beta = np.zeros(Z.shape[1])
    pen = l2 * len(X) * np.eye(Z.shape[1])
    pen[0, 0] = 0.0
    for _ in range(iters):
        p = 1.0 / (1.0 + np.exp(-(Z @ beta)))
        g = Z.T @ (p - y) + pen @ beta
        H = (Z * (p * (1 - p))[:, None]).T @ Z + pen
        step = np.linalg.solve(H, g)
        beta -= step
        if np.abs(step).max() < 1e-10:
            break
    w = beta[1:] / sd
    b = beta[0] - (w * mu).sum()
    return float(b), w


def predict(b, w, X):
    return 1.0 / (1.0 + np.exp(-(b + np.asarray(X, float) @ w)))


def auroc(score, y):
    """Probability that a right pose scores above a wrong one (ties 1/2)."""
    score, y = np.asarray(score, float), np.asarray(y, bool)
    pos, neg = score[y], score[~y]
    if len(pos) == 0 or len(neg) == 0:
        return float("nan")
    order = np.argsort(np.concatenate([pos, neg]), kind="mergesort")
    allv = np.concatenate([pos, neg])[order]
    ranks = np.empty(len(allv))
    i = 0
    while i < len(allv):  # average ranks over ties
        j = i
        while j + 1 < len(allv) and allv[j + 1] == allv[i]:
            j += 1
        ranks[i:j + 1] = 0.5 * (i + j) + 1
        i = j + 1
    r = np.empty(len(allv))
    r[order] = ranks
    return float((r[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2) / (len(pos) * len(neg)))


def reliability(conf, y, bins=10):
    """(bin lower edges, mean confidence, share right, count) per bin."""
    conf, y = np.asarray(conf, float), np.asarray(y, float)
    idx = np.minimum((conf * bins).astype(int), bins - 1)
    out = []
    for k in range(bins):
        sel = idx == k
        n = int(sel.sum())
        out.append((k / bins, float(conf[sel].mean()) if n else float("nan"),
                    float(y[sel].mean()) if n else float("nan"), n))
    return out


def ece(conf, y, bins=10):
    rel = reliability(conf, y, bins)
    n = sum(r[3] for r in rel)
    return float(sum(r[3] * abs(r[1] - r[2]) for r in rel if r[3]) / max(n, 1))


def precision_above(conf, y, thr=0.9):
    """(share right among conf >= thr, how many)."""
    conf, y = np.asarray(conf, float), np.asarray(y, bool)
    sel = conf >= thr
    return (float(y[sel].mean()) if sel.any() else float("nan")), int(sel.sum())
