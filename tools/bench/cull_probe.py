#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""How separable box outliers are from an object's surface by 12-NN density,
the quantity the statistical cull's sparse clause judges (src/preshape/cull.c,
docs/tuning.md "Background density").

For each object: the outliers of cases.add_outliers (uniform in the bounding
box, labelled here) are added to the clean object, and the script prints the
true background density lambda_b, the quantiles of the outliers' and the
surface's 12-NN densities in units of lambda_b, the shares of each below
kappa * lambda_b, and the steps of the library's background estimate
(background_fill: lambda -> count(rho < 4 lambda) / V) with where they end,
then where they end with the cloud turned (--turns), on the cull's
coordinate-axes box and on a box along the cloud's principal axes.

    python3 tools/bench/cull_probe.py car6 airplane bunny --frac 0.2
"""
import argparse
import os
import re
import sys

import numpy as np
from scipy.spatial import cKDTree

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cases as C  # noqa: E402


def tuning(*names):
    """The cull's constants, read from their one definition, src/tuning.h."""
    text = open(os.path.join(HERE, "..", "..", "src", "tuning.h")).read()
    return [float(re.search(r"#define %s\s+([0-9.eE+-]+)" % n, text).group(1)) for n in names]


K, KAPPA, FILL, QUANTILE, MIN_SIDE, STEPS = tuning(
    "PKSS_KNN_K", "STAT_BG_KAPPA", "STAT_BG_FILL", "STAT_QUANTILE", "STAT_MIN_SIDE",
    "STAT_BG_STEPS")
K, STEPS = int(K), int(STEPS)


def density(x):
    r12 = cKDTree(x).query(x, K + 1)[0][:, K]
    return K / (4.0 / 3.0 * np.pi * r12 ** 3)


def quantile_box_volume(x, principal=False):
    """The cull's quantile box (coordinate axes), or one along x's principal axes."""
    if principal:
        c = x - x.mean(axis=0)
        x = c @ np.linalg.eigh(c.T @ c)[1]
    q = np.quantile(x, [QUANTILE, 1.0 - QUANTILE], axis=0)
    side = q[1] - q[0]
    return float(np.prod(np.maximum(side, MIN_SIDE * side.max())))


def fill_steps(rho, nv, steps=STEPS):
    """background_fill's sequence of lambdas and how it ends."""
    lam, seq = nv, []
    for _ in range(steps):
        c = int((rho < KAPPA * lam).sum())
        nxt = c * nv / len(rho)
        seq.append((lam, c))
        if 2 * c < len(rho) and nxt >= FILL * lam:
            return seq, "background found"
        if nxt >= lam:
            return seq, "solid (no background)"
        if nxt <= 0.0:
            return seq, "fell to 0 (no background)"
        lam = nxt
    return seq, "no end within %d steps" % steps


def probe(obj, frac, seed, turns):
    x0 = C.load_object(obj)
    rng = np.random.default_rng(seed)
    x, m = C.add_outliers(x0, rng, frac)
    out = np.zeros(len(x), bool)
    out[-m:] = True
    lam_b = m / float(np.prod(x0.max(axis=0) - x0.min(axis=0)))
    rho = density(x)
    qs = [0.05, 0.25, 0.5, 0.75]
    print(f"{obj}: {len(x0)} surface points + {m} outliers, "
          f"lambda_b = {lam_b:.4g} per unit volume")
    print("  outliers rho/lambda_b at 5/25/50/75 %: " +
          " ".join(f"{v:.2f}" for v in np.quantile(rho[out] / lam_b, qs)))
    print("  surface  rho/lambda_b at 1/5/25/50 %: " +
          " ".join(f"{v:.2f}" for v in np.quantile(rho[~out] / lam_b, [0.01, 0.05, 0.25, 0.5])))
    for kap in (KAPPA, 2 * KAPPA, 4 * KAPPA):
        print(f"  below {kap:g} lambda_b: outliers {100 * (rho[out] < kap * lam_b).mean():.1f} %, "
              f"surface {100 * (rho[~out] < kap * lam_b).mean():.2f} %")
    seq, end = fill_steps(rho, len(x) / quantile_box_volume(x))
    print("  background_fill: " + " -> ".join(f"{lam:.4g} ({c})" for lam, c in seq[:8]) +
          (" ..." if len(seq) > 8 else "") + f"; {end}")
    for k in range(1, turns + 1):
        y = x @ C.random_rotation(np.random.default_rng(k)).T
        ends = [fill_steps(rho, len(y) / quantile_box_volume(y, p)) for p in (False, True)]
        print(f"  turn {k}: coordinate-axes box: lambda {ends[0][0][-1][0]:.4g}, {ends[0][1]}; "
              f"principal-axes box: lambda {ends[1][0][-1][0]:.4g}, {ends[1][1]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("objects", nargs="+")
    ap.add_argument("--frac", type=float, default=0.20, help="outlier share (add_outliers)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--turns", type=int, default=3,
                    help="random rotations of the cloud to estimate the background on")
    a = ap.parse_args()
    for obj in a.objects:
        probe(obj, a.frac, a.seed, a.turns)


if __name__ == "__main__":
    main()
