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
(background_fill: lambda -> count(rho < 4 lambda) / V) with where they end.

    python3 tools/bench/cull_probe.py car6 airplane bunny --frac 0.2
"""
import argparse
import os
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cases as C  # noqa: E402

K = 12            # PKSS_KNN_K
KAPPA = 4.0       # STAT_BG_KAPPA
FILL = 0.8        # STAT_BG_FILL
QUANTILE = 0.005  # STAT_QUANTILE
MIN_SIDE = 0.02   # STAT_MIN_SIDE


def density(x):
    r12 = cKDTree(x).query(x, K + 1)[0][:, K]
    return K / (4.0 / 3.0 * np.pi * r12 ** 3)


def quantile_box_volume(x):
    q = np.quantile(x, [QUANTILE, 1.0 - QUANTILE], axis=0)
    side = q[1] - q[0]
    return float(np.prod(np.maximum(side, MIN_SIDE * side.max())))


def fill_steps(rho, nv, steps=64):
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


def probe(obj, frac, seed):
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("objects", nargs="+")
    ap.add_argument("--frac", type=float, default=0.20, help="outlier share (add_outliers)")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    for obj in a.objects:
        probe(obj, a.frac, a.seed)


if __name__ == "__main__":
    main()
