#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The command line as users call it: pkss-align on the bundled sample pair,
one process per run, wall time (the whole process) and the device
preparation it reports (-v), medians over --repeats runs. With --baseline
a second pkss-align runs alternately with the first (A/B in one run), so a
busy machine slows both alike.

  python3 tools/bench_cli.py --align build/tools/pkss-align \\
      [--baseline OTHER/tools/pkss-align] [--repeats 11]
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAIR = [os.path.join(ROOT, "tests", "data", "airplane_0001_%s.ply" % w) for w in "st"]


def run_once(align):
    """Wall seconds of one process and the prepare seconds it reports."""
    t0 = time.perf_counter()
    p = subprocess.run([align, *PAIR, "-q", "-v"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{align} failed ({p.returncode}): {p.stderr[-600:]}")
    prep = None
    for line in p.stderr.splitlines():
        if "times (s):" in line and "prepare" in line:
            prep = float(line.split("prepare")[1].split(",")[0])
    return wall, prep


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--align", default=os.path.join(ROOT, "build", "tools", "pkss-align"))
    ap.add_argument("--baseline", help="a second pkss-align, run alternately")
    ap.add_argument("--labels", default="this,baseline")
    ap.add_argument("--repeats", type=int, default=11)
    ap.add_argument("--warmup", type=int, default=2,
                    help="runs first, not counted (warm caches: files, PoCL, pkss)")
    a = ap.parse_args()
    aligns = [a.align] + ([a.baseline] if a.baseline else [])
    labels = a.labels.split(",")[: len(aligns)]
    for _ in range(a.warmup):
        for x in aligns:
            run_once(x)
    runs = {x: [] for x in aligns}
    for _ in range(a.repeats):
        for x in aligns:
            runs[x].append(run_once(x))
    print(f"pkss-align on the bundled pair, {a.repeats} runs each"
          f"{' alternating' if a.baseline else ''}; load average "
          f"{' '.join('%.2f' % v for v in os.getloadavg())}")
    print("| build | wall s (median) | wall s (best) | prepare s (median) |")
    print("|---|---:|---:|---:|")
    for x, label in zip(aligns, labels):
        wall = [w for w, _ in runs[x]]
        prep = [p for _, p in runs[x] if p is not None]
        print(f"| {label} | {statistics.median(wall):.4f} | {min(wall):.4f} | "
              f"{statistics.median(prep) if prep else float('nan'):.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
