# SPDX-License-Identifier: MIT
"""Writes the README's results headline from a benchmark run's output folder.

    python3 tools/bench/headline.py tools/bench/results README.md

Reads OUT/pairs.csv and the stamp (date, commit, machine) that run.py wrote at
the top of OUT/results.md, and replaces the README block between
<!-- results:begin --> and <!-- results:end --> with one table: per case, pkss's
strict success and median time, and the best peer reaching >= 80 % there.
run.py --readme PATH calls it after a run.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import report  # noqa: E402
from methods import LABELS  # noqa: E402

BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"

# (README label, case filter)
CASES = [
    ("similarity", report._is("similarity")),
    ("density bands", report._is("density")),
    ("30–50 % missing", report._is("defective")),
    ("Gaussian noise r = 0.4", report._is("noise_g0.4")),
    ("5 % outliers", report._is("outliers")),
    ("all combined", report._is("combined")),
    ("real pairs ≥ 45 % overlap", report._real(report.real_scan_hi)),
]
PEER_BAR = 0.8


def stamp(results_md):
    """date, commit and machine lines of run.py's header."""
    want = {}
    with open(results_md) as f:
        for line in f:
            m = re.match(r"- (date|commit|machine): (.*)", line.strip())
            if m:
                want[m.group(1)] = m.group(2)
    return want


def short_name(method):
    label = LABELS.get(method, method)
    return label.split(" (")[0]


def table(rows):
    methods = report.method_order(rows)
    peers = [m for m in methods if m not in ("pkss", "identity")]
    out = ["| case | pkss strict | pkss median time | best peer ≥ 80 % (time) |",
           "|---|---|---|---|"]
    for label, pred in CASES:
        st = report.stats(report._sel(rows, "pkss", pred))
        if st is None:
            continue
        best = None
        for m in peers:
            ps = report.stats(report._sel(rows, m, pred))
            if ps and ps["strict"] >= PEER_BAR and (best is None or ps["strict"] > best[1]["strict"]):
                best = (m, ps)
        peer = "none" if best is None else (
            f"{short_name(best[0])} {100 * best[1]['strict']:.0f} % "
            f"({best[1]['time_median']:.2f} s)")
        out.append(f"| {label} | {100 * st['strict']:.0f} % | {st['time_median']:.2f} s | {peer} |")
    return "\n".join(out)


def block(out_dir):
    rows = report.load_rows(os.path.join(out_dir, "pairs.csv"))
    s = stamp(os.path.join(out_dir, "results.md"))
    n_pairs = len({r["case_id"] for r in rows})
    peers = [short_name(m) for m in report.method_order(rows) if m not in ("pkss", "identity")]
    intro = (f"Measured by `tools/bench/run.py` on {n_pairs} pairs, pkss against "
             f"{', '.join(peers)} on the same pairs in one run; {s.get('machine', '?')}; "
             f"{s.get('date', '?')[:10]}, commit {s.get('commit', '?')}. Strict success: "
             "rotation < 5°, translation < 2 % of the diameter, scale < 2 %.")
    return "\n".join([BEGIN, intro, "", table(rows), END])


def write(out_dir, readme):
    with open(readme) as f:
        text = f.read()
    if BEGIN not in text or END not in text:
        sys.exit(f"{readme}: no {BEGIN} ... {END} block to replace")
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + block(out_dir) + tail
    tmp = readme + ".tmp"
    with open(tmp, "w") as f:
        f.write(new)
    os.replace(tmp, readme)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    write(sys.argv[1], sys.argv[2])
