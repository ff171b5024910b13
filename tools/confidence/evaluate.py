#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Measures the confidence model (src/refine/confidence_model.h, fitted by
fit.py) on pairs it was not fitted on: another seed base (1000), every
object of tools/bench/cases.py (the held-out ones too) plus the generated
symmetric shapes, every perturbation family, the real pairs. Writes a
markdown report (the tables of docs/confidence.md) and the reliability
diagram (PNG, needs matplotlib).

  python3 tools/confidence/evaluate.py --conf-dump build/tools/conf_dump \\
      --out /tmp/conf-eval [--seeds 2]

The confidence read is the library's own (pkss_result.confidence)."""
from __future__ import annotations

import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import calib  # noqa: E402
import fit  # noqa: E402
import pairs as P  # noqa: E402
import numpy as np  # noqa: E402

EVAL_BASE_SEED = 1000
OBJECTS = list(P.C.OBJECTS) + list(P.C.SYMMETRIC_OBJECTS)
# the shapes' true symmetry as pkss_symmetry: 1 discrete, 2 axial, 3 spherical
EXPECTED_SYMMETRY = {"box": 1, "hexprism": 1, "cylinder": 2, "sphere": 3}
NON_SYMMETRIC = [o for o in P.C.OBJECTS]


def row(name, recs):
    ok = [r for r in recs if r["status"] == "PKSS_OK"]
    y = np.array([r["right"] for r in recs], bool)
    c = np.array([r["confidence"] for r in recs], float)
    prec, n90 = calib.precision_above(c, y)
    return (f"| {name} | {len(recs)} | {int(y.sum())} | {sum(r['sym'] for r in recs)} | "
            f"{calib.auroc(c, y):.3f} | {calib.ece(c, y):.3f} | "
            f"{'-' if n90 == 0 else f'{100 * prec:.1f}%'} ({n90}) | "
            f"{len(recs) - len(ok)} |")


def symmetry_report(recs):
    out = ["| object | pairs | right | ambiguous among right | symmetry reported among right "
           "(none/discrete/axial/spherical) | expected | orders / alternatives' angles (right, first 3) |",
           "|---|---|---|---|---|---|---|"]
    for o in OBJECTS:
        s = [r for r in recs if r["obj"] == o and r["status"] == "PKSS_OK"]
        if not s:
            continue
        right = [r for r in s if r["right"]]
        kinds = [sum(r["symmetry"] == k for r in right) for k in range(4)]
        exp = {1: "discrete", 2: "axial", 3: "spherical"}.get(EXPECTED_SYMMETRY.get(o), "none")
        ex = "; ".join(f"n={r['order']}: " + ",".join(f"{a['angle']:.0f}" for a in r["alternatives"][:3])
                       for r in right[:3] if r["ambiguous"])
        out.append(f"| {o} | {len(s)} | {len(right)} | {sum(r['ambiguous'] for r in right)} | "
                   f"{'/'.join(map(str, kinds))} | {exp} | {ex or '-'} |")
    return "\n".join(out)


def diagram(path, recs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    y = np.array([r["right"] for r in recs], float)
    c = np.array([r["confidence"] for r in recs], float)
    rel = calib.reliability(c, y)
    fig, (a, b) = plt.subplots(2, 1, figsize=(5, 6.5), sharex=True,
                               gridspec_kw={"height_ratios": [3, 1]})
    a.plot([0, 1], [0, 1], "k:", lw=1, label="perfect calibration")
    xs = [r[1] for r in rel if r[3]]
    ys = [r[2] for r in rel if r[3]]
    a.plot(xs, ys, "o-", label="pkss confidence")
    a.set_ylabel("share right")
    a.set_title(f"Reliability, {len(recs)} held-out pairs: ECE {calib.ece(c, y):.3f}, "
                f"AUROC {calib.auroc(c, y):.3f}", fontsize=9)
    a.legend(loc="upper left", fontsize=8)
    b.bar([r[0] + 0.05 for r in rel], [r[3] for r in rel], width=0.09)
    b.set_yscale("log")
    b.set_xlabel("confidence (10 bins)")
    b.set_ylabel("pairs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conf-dump", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--real-seeds", type=int, default=1)
    ap.add_argument("--backend", default="opencl", choices=["opencl", "reference"])
    ap.add_argument("--rescore", action="store_true")
    a = ap.parse_args()
    items = P.plan(OBJECTS, P.FAMILIES, a.seeds, list(P.C.REAL_PAIRS), a.real_seeds)
    recs = P.run(a.out, items, EVAL_BASE_SEED, a.conf_dump, a.backend, rescore=a.rescore)
    ok = [r for r in recs if r["status"] == "PKSS_OK"]
    held = [r for r in recs if r["obj"] not in fit.FIT_OBJECTS]
    commit = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    hdr = ("| set | pairs | right | of which symmetric equivalents | AUROC | ECE (10 bins) | "
           "right among conf >= 0.9 (n) | errors |\n|---|---|---|---|---|---|---|---|")
    lines = [f"Held-out evaluation (commit {commit}, {a.backend} backend): base seed "
             f"{EVAL_BASE_SEED}, {a.seeds} seeds x {len(OBJECTS)} objects x "
             f"{len(P.FAMILIES)} families + {a.real_seeds} x {len(P.C.REAL_PAIRS)} real pairs; "
             f"the model was fitted on base seed {fit.FIT_BASE_SEED}, objects "
             f"{', '.join(fit.FIT_OBJECTS)}.", "", hdr, row("all", recs),
             row("objects held out of the fit (and real pairs)", held)]
    for fam in P.FAMILIES + ["real"]:
        s = [r for r in recs if r["family"] == fam]
        if s:
            lines.append(row(fam, s))
    lines += ["", "Symmetry and ambiguity (successes only):", "", symmetry_report(recs), ""]
    nonsym_right = [r for r in ok if r["obj"] in NON_SYMMETRIC and r["right"]]
    n_amb = sum(r["ambiguous"] for r in nonsym_right)
    lines.append(f"Non-symmetric objects ({', '.join(NON_SYMMETRIC)}): ambiguous in {n_amb} of "
                 f"{len(nonsym_right)} correct results "
                 f"({100 * n_amb / max(1, len(nonsym_right)):.1f} %).")
    t = np.array([r["time"] for r in ok])
    ta = np.array([r["assess_time"] for r in ok])
    lines.append(f"Cost: median time per pair {np.median(t):.3f} s, of which assess.c "
                 f"{np.median(ta) * 1000:.1f} ms median ({100 * np.median(ta) / np.median(t):.1f} % "
                 f"of the median; mean share {100 * np.mean(ta / t):.1f} %).")
    report = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "confidence.md"), "w") as f:
        f.write(report)
    print(report)
    try:
        diagram(os.path.join(a.out, "reliability.png"), recs)
        print(f"reliability diagram: {os.path.join(a.out, 'reliability.png')}")
    except ImportError:
        print("matplotlib not installed: no reliability diagram", file=sys.stderr)


if __name__ == "__main__":
    main()
