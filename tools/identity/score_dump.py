#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Scores pkss_dump outputs against the ground truths of the pairs that
export_pairs.py wrote (the same arguments regenerate them): per case, the
strict + symmetric successes of tools/bench/metrics.py, the median and the
sum of the registration times, and each miss with its errors.

    python3 tools/identity/score_dump.py DUMP [DUMP ...] --seeds 1 --real-seeds 0 \\
        [--base-seed 0] [--cases outliers20 partial ...]

Two dumps of one build on the same pairs time the machine's noise; only
alternating runs of two builds compare their times."""
import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import cases as C  # noqa: E402
import export_pairs as E  # noqa: E402
import numpy as np  # noqa: E402
from metrics import Evaluator  # noqa: E402


def read_dump(path):
    """(case id, status, 4x4 T, seconds) per line of a pkss_dump output."""
    for line in open(path):
        f = line.split()
        if len(f) == 19:
            T = np.array([float.fromhex(x) for x in f[2:18]]).reshape(4, 4)
            yield f[0], f[1], T, float(f[18])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dumps", nargs="+")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--real-seeds", type=int, default=2)
    ap.add_argument("--base-seed", type=int, default=0)
    ap.add_argument("--cases", nargs="*", default=C.SYNTH_CASES)
    ap.add_argument("--objects", nargs="*", help="as given to export_pairs.py")
    ap.add_argument("--disjoint", action="store_true", help="as given to export_pairs.py")
    a = ap.parse_args()
    evaluators = {}
    for item in E.pair_items(a.seeds, a.real_seeds, a.cases, a.objects):
        try:
            cs = E.make_case(item, a.base_seed, a.disjoint)
        except (OSError, KeyError, ValueError):
            continue  # export_pairs.py skipped it too
        evaluators[cs.case_id] = Evaluator(cs)
    for path in a.dumps:
        per_case, misses = {}, []
        for cid, status, T, seconds in read_dump(path):
            m = evaluators[cid](T) if status == "PKSS_OK" else None
            ok = bool(m and m["strict"])
            per_case.setdefault(cid.split("/")[0], []).append((ok, seconds))
            if not ok:
                misses.append(f"{cid} {status}" + (
                    f" rotation {m['rre_deg']:.1f} deg, translation {m['rte_pct']:.1f} %, "
                    f"scale {m['scale_err_pct']:.1f} %" if m else ""))
        total = sum(t for rows in per_case.values() for _, t in rows)
        print(f"{path}: {total:.2f} s in all")
        for case, rows in per_case.items():
            times = [t for _, t in rows]
            print(f"  {case:12s} {sum(ok for ok, _ in rows):3d}/{len(rows):3d} right, "
                  f"median {statistics.median(times):.3f} s, sum {sum(times):.2f} s")
        for miss in misses:
            print(f"  miss: {miss}")


if __name__ == "__main__":
    main()
