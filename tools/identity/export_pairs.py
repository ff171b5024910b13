#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the benchmark's pairs (tools/bench/cases.py) to a folder, for
pkss_dump: every synthetic case x object x seed index and every real pair x
seed index, as raw little-endian float64 files and a manifest.

    python3 tools/identity/export_pairs.py --out /tmp/pairs --seeds 3 --real-seeds 2 [--base-seed 0]
        [--cases outliers20 partial ...]   (default: the paper's cases)
        [--objects car6 room ...]          (default: cases.OBJECTS; held-out ones too)

The manifest has one line per pair: id, pkss seed, source file, target file.
A separate --base-seed gives a validation base with other pairs."""
import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
import cases as C  # noqa: E402
import numpy as np  # noqa: E402


def pair_items(seeds, real_seeds, cases, objects=None):
    """The pairs in manifest order: (kind, name, case, index)."""
    objects = objects or list(C.OBJECTS)
    items = [("s", o, c, i) for i in range(seeds) for c in cases for o in objects]
    return items + [("r", p, None, i) for i in range(real_seeds) for p in C.REAL_PAIRS]


def make_case(item, base_seed, disjoint=False):
    """The cases.Case of one item of pair_items."""
    kind, name, case, i = item
    return (C.make_synthetic(name, case, i, base_seed, disjoint) if kind == "s"
            else C.make_real(name, i, base_seed))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--real-seeds", type=int, default=2)
    ap.add_argument("--base-seed", type=int, default=0)
    ap.add_argument("--cases", nargs="*", default=C.SYNTH_CASES,
                    help="synthetic cases (cases.SYNTH_CASES, cases.HARD_CASES)")
    ap.add_argument("--objects", nargs="*",
                    help="object models (default cases.OBJECTS; cases.HOLDOUT_OBJECTS too)")
    ap.add_argument("--disjoint", action="store_true",
                    help="source and target from disjoint halves of each model's points "
                         "(cases.split_samples), as two scans sample a surface")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    items = pair_items(a.seeds, a.real_seeds, a.cases, a.objects)
    with open(os.path.join(a.out, "manifest.txt"), "w") as man:
        for n, item in enumerate(items):
            try:
                cs = make_case(item, a.base_seed, a.disjoint)
            except (OSError, KeyError, ValueError) as e:
                _, name, case, i = item
                print(f"skip {name}/{case}/{i}: {e}", file=sys.stderr)
                continue
            stem = f"p{n:05d}"
            cs.source.astype("<f8").tofile(os.path.join(a.out, stem + "_s.bin"))
            cs.target.astype("<f8").tofile(os.path.join(a.out, stem + "_t.bin"))
            man.write(f"{cs.case_id} {cs.seed % 2**31} {stem}_s.bin {stem}_t.bin\n")
    print(f"{len(items)} pairs in {a.out}")


if __name__ == "__main__":
    main()
