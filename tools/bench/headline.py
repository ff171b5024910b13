# SPDX-License-Identifier: MIT
"""Writes the README's results headline from benchmark runs' output folders.

    python3 tools/bench/headline.py OUT [OUT ...] README.md

Reads each OUT/pairs.csv and the stamp (date, commit, machine) that run.py
wrote at the top of OUT/results.md, and replaces the README block between
<!-- results:begin --> and <!-- results:end --> with one table: per case (the
paper's cases, then issue #25's hard families), pkss's strict success and
median time, and the most successful peer in the same run with its success
and median time. A case is taken from the first folder that has it, so a
default run and a hard-family run (run.py --cases ...) make one table.
run.py --readme PATH calls it after a run with that run's folder alone.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import report  # noqa: E402
from methods import LABELS  # noqa: E402

BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"

# (README label, case filter): the paper's cases, then the hard families of
# report.HARD_TARGETS (their labels and filters)
PAPER_CASES = [
    ("similarity", report._is("similarity")),
    ("density bands", report._is("density")),
    ("30–50 % missing", report._is("defective")),
    ("Gaussian noise r = 0.4", report._is("noise_g0.4")),
    ("5 % outliers", report._is("outliers")),
    ("all combined", report._is("combined")),
    ("real pairs ≥ 45 % overlap", report._real(report.real_scan_hi)),
]
HARD_CASES = [(label, pred) for label, pred, _ in report.HARD_TARGETS]
CASES = PAPER_CASES + HARD_CASES


def stamp(results_md):
    """date, commit, machine and command lines of run.py's header."""
    want = {}
    with open(results_md) as f:
        for line in f:
            m = re.match(r"- (date|commit|machine|command): (.*)", line.strip())
            if m:
                want[m.group(1)] = m.group(2)
    return want


def short_name(method):
    label = LABELS.get(method, method)
    return label.split(" (")[0]


def table(runs):
    """runs: [(rows, run number)]; a case comes from the first run with it."""
    out = ["| case | pkss strict | pkss median time | most successful peer (strict, median time) | run |",
           "|---|---|---|---|---|"]
    for label, pred in CASES:
        for rows, k in runs:
            st = report.stats(report._sel(rows, "pkss", pred))
            if st is None:
                continue
            best = report.most_successful_peer(report._peer_stats(rows, pred))
            peer = "none" if best is None else "no peer succeeds" if best[1]["strict"] == 0 else (
                f"{short_name(best[0])} {100 * best[1]['strict']:.0f} % "
                f"({best[1]['time_median']:.2f} s)")
            out.append(f"| {label} | {100 * st['strict']:.0f} % | {st['time_median']:.2f} s "
                       f"| {peer} | {k} |")
            break
    return "\n".join(out)


def intro(out_dirs, runs, with_hard):
    stamps = [stamp(os.path.join(d, "results.md")) for d in out_dirs]
    machines = [s.get("machine", "?") for s in stamps]
    one_machine = len(set(machines)) == 1
    parts = []
    for s, m_, (rows, k) in zip(stamps, machines, runs):
        n_pairs = len({r["case_id"] for r in rows})
        peers = [short_name(m) for m in report.method_order(rows) if m not in ("pkss", "identity")]
        parts.append(f"- run {k}: {n_pairs} pairs, pkss against {', '.join(peers)}; "
                     f"{s.get('date', '?')[:10]}, commit {s.get('commit', '?')}"
                     + ("" if one_machine else f", {m_}") + f"; {s.get('command', '?')}")
    where = machines[0] if one_machine else "machines as listed per run"
    return "\n".join(
        [f"Measured by `tools/bench/run.py`, every method on the same pairs in each run; "
         f"{where}. Strict success: rotation < 5°, translation < 2 % of the diameter, "
         "scale < 2 %, or a pose the shape's symmetry makes equivalent."
         + (f" The rows from {HARD_CASES[0][0]} on are the harder families of "
            "`tools/bench/README.md`." if with_hard else ""), ""] + parts)


def block(out_dirs):
    runs = [(report.load_rows(os.path.join(d, "pairs.csv")), k + 1)
            for k, d in enumerate(out_dirs)]
    with_hard = any(report._sel(rows, "pkss", pred)
                    for rows, _ in runs for _, pred in HARD_CASES)
    return "\n".join([BEGIN, intro(out_dirs, runs, with_hard), "", table(runs), END])


def write(out_dirs, readme):
    if isinstance(out_dirs, str):
        out_dirs = [out_dirs]
    with open(readme) as f:
        text = f.read()
    if BEGIN not in text or END not in text:
        sys.exit(f"{readme}: no {BEGIN} ... {END} block to replace")
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    new = head + block(out_dirs) + tail
    tmp = readme + ".tmp"
    with open(tmp, "w") as f:
        f.write(new)
    os.replace(tmp, readme)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    write(sys.argv[1:-1], sys.argv[-1])
