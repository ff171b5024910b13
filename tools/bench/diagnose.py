#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Failure analysis of pkss: re-runs pkss on every case where it missed
strict success in OUT/pairs.csv (same seeded case, same pkss seed) and
looks at all refined candidates, to tell a coarse-search miss (no candidate
near the truth) from a selection miss (a near-correct candidate was refined
but another won on the overlap score) or a refinement miss (the best
candidate has the right rotation but scale/translation off).

  python3 tools/bench/diagnose.py --out tools/bench/results
writes OUT/pkss_failures.md.
"""
from __future__ import annotations

import argparse
import csv
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def run_args(results_md):
    """The base seed and the --disjoint flag of the run.py command recorded in
    results.md's header."""
    try:
        with open(results_md, encoding="utf-8") as f:
            for line in f:
                if line.startswith("- command:"):
                    m = re.search(r"--seed (\d+)", line)
                    disjoint = bool(re.search(r"--disjoint\b", line))
                    return (int(m.group(1)) if m else 0), disjoint
    except OSError:
        pass
    return 0, False


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="bench-out")
    ap.add_argument("--seed", type=int, default=None,
                    help="the run's base seed (default: the --seed of the command "
                         "in OUT/results.md, else run.py's default 0)")
    args = ap.parse_args()
    seed, disjoint = run_args(os.path.join(args.out, "results.md"))
    if args.seed is None:
        args.seed = seed
    import numpy as np
    import pkss

    from methods import check_library
    check_library(pkss.library_path, os.environ.get("PKSS_LIBRARY", ""))

    import cases as C
    from metrics import Evaluator
    rows = [r for r in csv.DictReader(open(os.path.join(args.out, "pairs.csv")))
            if r["method"] == "pkss" and r["strict"] != "True"]
    lines = ["# pkss strict failures, candidate by candidate\n",
             "Candidate errors: rotation error (deg) / scale error (%) / translation error "
             "(% of diameter) / pkss overlap score. `*` = the winner. A case is a "
             "*search miss* if no candidate is within 5 deg, a *selection miss* if a "
             "strict-correct candidate lost on the overlap score, a *refinement miss* if "
             "the rotation is right (< 5 deg) but scale or translation are not.\n",
             "| case | verdict | winner RRE / scale % / RTE % / overlap | best candidate "
             "RRE / scale % / RTE % / overlap | refined within 5 deg | coarse (refine=False) "
             "within 20 deg, best coarse RRE |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        kind, obj, idx = r["case_id"].split("/")
        idx = int(idx)
        case = (C.make_real(obj, idx, args.seed) if kind == "real"
                else C.make_synthetic(obj, kind, idx, args.seed, disjoint))
        ev = Evaluator(case)
        res = pkss.register(case.source, case.target, seed=int(case.seed % (2 ** 31)))
        win = ev(res.transform)
        cands = []
        for c in res.candidates:
            m = ev(c.transform)
            cands.append((m, c.overlap))
        coarse = pkss.register(case.source, case.target, seed=int(case.seed % (2 ** 31)),
                               refine=False)
        coarse_err = sorted(ev(c.transform)["rre_deg"] for c in coarse.candidates)
        n_coarse20 = sum(e < 20 for e in coarse_err)
        good_rot = [c for c in cands if c[0]["rre_deg"] < 5]
        strict_c = [c for c in cands if c[0]["strict"]]
        if win["strict"]:
            verdict = "passes on re-run (timing/nondeterminism?)"
        elif strict_c:
            verdict = "selection miss"
        elif win["rre_deg"] < 5 or good_rot:
            verdict = "refinement miss (rotation found, scale/translation off)"
        elif n_coarse20:
            verdict = "refinement miss (a coarse candidate within 20 deg did not converge)"
        else:
            verdict = "search miss (no candidate near the truth)"
        best = min(cands, key=lambda c: c[0]["rre_deg"] + c[0]["scale_err_pct"]) if cands else None
        f = lambda m, ov: (f"{m['rre_deg']:.1f} / {m['scale_err_pct']:.1f} / "
                           f"{m['rte_pct']:.1f} / {ov:.3f}")
        lines.append(f"| {r['case_id']} | {verdict} | {f(win, res.overlap)} | "
                     f"{f(*best) if best else '-'} | {len(good_rot)}/{len(cands)} | "
                     f"{n_coarse20}/{len(coarse_err)}, "
                     f"{coarse_err[0] if coarse_err else float('nan'):.1f} |")
        print(lines[-1], flush=True)
    path = os.path.join(args.out, "pkss_failures.md")
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(f"wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
