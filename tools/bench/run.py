#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""pkss benchmark: the paper's evaluation (Sec. 6, SPEC 7) on real data,
against established peers, with per-pair CSV, markdown tables and plots.

  python3 tools/bench/run.py --quick              # CI smoke test, < 3 min
  python3 tools/bench/run.py --out bench-out/     # full run

See tools/bench/README.md.
"""
from __future__ import annotations

import argparse
import csv
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

FIELDS = ["case_id", "case", "obj", "index", "seed", "method", "status", "time_s",
          "mse", "mse_n", "gt_cos", "rr", "rre_deg", "rte_pct", "scale_err_pct",
          "strict", "scale", "gt_scale", "t_err_raw", "n_source", "n_target",
          "overlap", "pair_kind", "missing", "overlap_est", "device", "info", "message",
          "sym"]

ALL_METHODS = ["pkss", "identity", "o3d_icp", "o3d_fpfh_ransac", "o3d_fpfh_ransac_icp",
               "o3d_fpfh_ransac_sicp",
               "o3d_fgr", "small_gicp", "probreg_cpd"]


class Progress:
    """tqdm if installed, else a plain one-line bar on stderr."""

    def __init__(self, total, desc):
        self.total, self.n, self.desc, self.t0 = total, 0, desc, time.time()
        try:
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc=desc, file=sys.stderr, dynamic_ncols=True)
        except ImportError:
            self.bar = None

    def update(self, note=""):
        self.n += 1
        if self.bar is not None:
            self.bar.set_postfix_str(note[:40], refresh=False)
            self.bar.update(1)
            return
        el = time.time() - self.t0
        eta = el / self.n * (self.total - self.n)
        w = 30
        k = int(w * self.n / max(1, self.total))
        sys.stderr.write(f"\r{self.desc} [{'#' * k}{'.' * (w - k)}] {self.n}/{self.total} "
                         f"{el:.0f}s eta {eta:.0f}s {note[:30]:30s}")
        sys.stderr.flush()

    def close(self):
        if self.bar is not None:
            self.bar.close()
        else:
            sys.stderr.write("\n")


def sh(cmd):
    try:
        return subprocess.run(cmd, shell=True, capture_output=True, text=True,
                              timeout=20).stdout.strip()
    except Exception:
        return ""


def plan(args):
    import cases as C
    if args.quick:
        synth = [("similarity", "bunny", 0), ("similarity", "parasaurolophus", 0),
                 ("defective", "bunny", 0), ("outliers", "chef", 0)]
        real = [("bunny_045_000", 0)]
    else:
        objs = args.objects or list(C.OBJECTS)
        kinds = args.cases or C.SYNTH_CASES
        pairs = args.pairs or list(C.REAL_PAIRS)
        items = []
        # seed index outermost: a run cut short still covers every case evenly
        for i in range(max(args.seeds, args.real_seeds)):
            if i < args.seeds and not args.no_synth:
                items += [("synth", (c, o, i)) for c in kinds for o in objs]
            if i < args.real_seeds and not args.no_real:
                items += [("real", (p, i)) for p in pairs]
        return items
    return [("synth", s) for s in synth] + [("real", r) for r in real]


def make_case(item, base_seed, disjoint=False):
    import cases as C
    kind, p = item
    if kind == "synth":
        return C.make_synthetic(p[1], p[0], p[2], base_seed, disjoint)
    return C.make_real(p[0], p[1], base_seed)


def item_id(item):
    kind, p = item
    return f"{p[0]}/{p[1]}/{p[2]}" if kind == "synth" else f"real/{p[0]}/{p[1]}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: 5 pairs, asserts pkss beats identity and recovers "
                         "exact copies; exit 1 otherwise")
    ap.add_argument("--out", default=None, help="output folder (default bench-out/, "
                    "bench-out-quick/ with --quick)")
    ap.add_argument("--seeds", type=int, default=3,
                    help="seeded cases per object and perturbation (default 3)")
    ap.add_argument("--real-seeds", type=int, default=3,
                    help="random similarities per real pair (default 3)")
    ap.add_argument("--objects", nargs="*", help="subset of object models")
    ap.add_argument("--cases", nargs="*", help="subset of perturbation kinds")
    ap.add_argument("--pairs", nargs="*", help="subset of real pairs")
    ap.add_argument("--no-real", action="store_true")
    ap.add_argument("--no-synth", action="store_true")
    ap.add_argument("--methods", nargs="*", default=None,
                    help=f"methods (default all): {' '.join(ALL_METHODS)}")
    ap.add_argument("--timeout", type=float, default=60.0,
                    help="per-call time limit in seconds (default 60)")
    ap.add_argument("--threads", type=int, default=1,
                    help="threads every method may use (OMP etc.; default 1)")
    ap.add_argument("--seed", type=int, default=0, help="base seed of the generator")
    ap.add_argument("--disjoint", action="store_true",
                    help="generated pairs: source and target from disjoint halves of each "
                         "model's points (cases.split_samples), as two scans sample a surface")
    ap.add_argument("--resume", action="store_true",
                    help="keep rows already in OUT/pairs.csv and run only the missing ones")
    ap.add_argument("--rerun", nargs="*", default=[],
                    help="with --resume: drop these methods' rows from OUT/pairs.csv and run "
                         "them again (e.g. after a pkss change; the peers' rows stay)")
    ap.add_argument("--readme", default="",
                    help="after a run, write its headline table into this README's "
                         "results block (tools/bench/headline.py)")
    ap.add_argument("--report-only", action="store_true",
                    help="rebuild tables and plots from OUT/pairs.csv")
    ap.add_argument("--pkss-lib", default="",
                    help="DEVELOPMENT ONLY: call this libpkss.so through the bindings of "
                         "this source tree instead of the installed pkss package")
    args = ap.parse_args(argv)
    out = args.out or ("bench-out-quick" if args.quick else "bench-out")
    os.makedirs(out, exist_ok=True)
    csv_path = os.path.join(out, "pairs.csv")

    # every method, in every worker, gets the same thread budget
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
              "NUMEXPR_NUM_THREADS", "POCL_MAX_PTHREAD_COUNT"):
        os.environ[v] = str(args.threads)
    os.environ["PKSS_BENCH_THREADS"] = str(args.threads)
    if args.pkss_lib:
        os.environ["PKSS_BENCH_LIB"] = os.path.abspath(args.pkss_lib)

    import report
    import worker as W
    from metrics import Evaluator

    t_start = time.time()
    if not args.report_only:
        methods = args.methods or ALL_METHODS
        avail = {}
        workers = {}
        for m in methods:
            workers[m] = W.MethodWorker(m, args.timeout)
            ok, msg = workers[m].probe()
            avail[m] = ok
            if not ok:
                workers.pop(m).close()
                print(f"[bench] {m}: not available, skipped ({msg.splitlines()[0] if msg else ''})",
                      file=sys.stderr)
        if not avail.get("pkss"):
            print("[bench] pkss is required: pip install ./bindings/python", file=sys.stderr)
            for w in workers.values():
                w.close()
            return 2
        methods = [m for m in methods if avail[m]]
        items = plan(args)
        done = set()
        if args.resume and os.path.exists(csv_path):
            with open(csv_path, newline="") as f:
                kept = [r for r in csv.DictReader(f) if r["method"] not in args.rerun]
            if args.rerun:
                with open(csv_path, "w", newline="") as f:
                    wr = csv.DictWriter(f, FIELDS)
                    wr.writeheader()
                    wr.writerows(kept)
            done = {(r["case_id"], r["method"]) for r in kept}
        else:
            with open(csv_path, "w", newline="") as f:
                csv.DictWriter(f, FIELDS).writeheader()
        todo = [(it, m) for it in items for m in methods if (item_id(it), m) not in done]
        print(f"[bench] {len(items)} pairs x {len(methods)} methods = {len(todo)} calls "
              f"to run; methods: {', '.join(methods)}; out: {out}", file=sys.stderr)
        # untimed warm-up call (imports, first-call allocations)
        import cases as C
        wu = C.make_synthetic("bunny", "similarity", 999, args.seed)
        for m, w in workers.items():
            st = w.warmup(wu.source[::8].copy(), wu.target[::8].copy())
            if st[0] != "ok":
                print(f"[bench] warm-up of {m}: {st[0]} {st[4][:200]}", file=sys.stderr)
        bar = Progress(len(todo), "bench")
        by_item = {}
        for it, m in todo:
            by_item.setdefault(item_id(it), (it, []))[1].append(m)
        try:
            with open(csv_path, "a", newline="") as f:
                wr = csv.DictWriter(f, FIELDS)
                for cid, (it, ms) in by_item.items():
                    case = make_case(it, args.seed, args.disjoint)
                    ev = Evaluator(case)
                    for m in ms:
                        status, T, dt, info, msg = workers[m].call(case.source, case.target,
                                                                   case.seed)
                        import numpy as np
                        met = ev(T if T is not None else np.eye(4))
                        if status != "ok":
                            met["rr"] = met["strict"] = met["sym"] = False
                        row = {"case_id": case.case_id, "case": case.case, "obj": case.obj,
                               "index": case.index, "seed": case.seed, "method": m,
                               "status": status, "time_s": f"{dt:.4f}",
                               "n_source": len(case.source), "n_target": len(case.target),
                               "overlap": case.meta.get("overlap", ""),
                               "pair_kind": case.meta.get("pair_kind", ""),
                               "missing": case.meta.get("missing", ""),
                               "overlap_est": info.pop("overlap_est", ""),
                               "device": info.pop("device", ""),
                               "info": json.dumps(info, sort_keys=True),
                               "message": msg.splitlines()[0][:200] if msg else ""}
                        for k in ("mse", "mse_n", "gt_cos", "rre_deg", "rte_pct",
                                  "scale_err_pct", "scale", "gt_scale", "t_err_raw"):
                            row[k] = f"{met[k]:.6g}"
                        row["rr"], row["strict"] = met["rr"], met["strict"]
                        row["sym"] = met["sym"]
                        wr.writerow(row)
                        f.flush()
                        bar.update(f"{m} {case.case_id}")
        finally:
            bar.close()
            for w in workers.values():
                w.close()
    wall = time.time() - t_start

    commit = sh(f"git -C {HERE} rev-parse --short HEAD")
    dirty = " (+ uncommitted changes)" if sh(f"git -C {HERE} status --porcelain") else ""
    header = "\n".join([
        f"# pkss benchmark results{' (--quick)' if args.quick else ''}\n",
        f"- date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}",
        f"- commit: {commit}{dirty}",
        f"- command: `python3 tools/bench/run.py {' '.join(argv if argv is not None else sys.argv[1:])}`",
        f"- machine: {platform.machine()}, nproc = {os.cpu_count()}, "
        f"{cpu_model()}",
        f"- threads per method: {args.threads}; per-call time limit {args.timeout:.0f} s",
        f"- wall time of this run: {wall:.0f} s" if not args.report_only else "",
        f"- python {platform.python_version()}; " + versions(),
        ""])
    md, figs, rows, results = report.write_report(csv_path, out, header)
    print(f"[bench] wrote {csv_path}, {md}, " + ", ".join(figs), file=sys.stderr)
    print(f"[bench] wall time {wall:.1f} s", file=sys.stderr)
    summary(rows)
    if args.readme and not args.report_only:
        import headline
        headline.write(out, args.readme)
        print(f"[bench] wrote the results headline into {args.readme}", file=sys.stderr)
    if args.quick:
        return quick_checks(rows)
    return 0


def cpu_model():
    for line in sh("lscpu").splitlines():
        if line.startswith("Model name:"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def versions():
    out = []
    from importlib import metadata
    for d in ("pkss", "open3d", "small-gicp", "probreg", "numpy", "scipy"):
        try:
            out.append(f"{d} {metadata.version(d)}")
        except Exception:
            pass
    return ", ".join(out)


def summary(rows):
    import report
    print(report.strict_table(rows))


def quick_checks(rows):
    import numpy as np
    pk = [r for r in rows if r["method"] == "pkss"]
    ident = [r for r in rows if r["method"] == "identity"]
    ok = True
    exact = [r for r in pk if r["case"] == "similarity" or r.get("pair_kind") == "exact"]
    for r in exact:
        if not (r["strict"] and r["rre_deg"] < 1.0 and r["scale_err_pct"] < 0.5):
            print(f"[quick] FAIL: pkss does not recover the exact copy {r['case_id']}: "
                  f"RRE {r['rre_deg']:.2f} deg, scale err {r['scale_err_pct']:.2f} %, "
                  f"RTE {r['rte_pct']:.2f} %", file=sys.stderr)
            ok = False
    sp = np.mean([r["strict"] for r in pk])
    si = np.mean([r["strict"] for r in ident]) if ident else 0.0
    ep = np.median([r["rre_deg"] for r in pk])
    ei = np.median([r["rre_deg"] for r in ident]) if ident else 180.0
    if not (sp > si and ep < ei):
        print(f"[quick] FAIL: pkss does not beat identity (strict {sp:.2f} vs {si:.2f}, "
              f"median RRE {ep:.1f} vs {ei:.1f})", file=sys.stderr)
        ok = False
    if any(r["status"] != "ok" for r in pk):
        print("[quick] FAIL: a pkss call errored or timed out", file=sys.stderr)
        ok = False
    print(f"[quick] {'PASS' if ok else 'FAIL'}: pkss strict {100 * sp:.0f}% vs identity "
          f"{100 * si:.0f}%, {len(exact)} exact copies checked", file=sys.stderr)
    # a plain closing line for CI log readers
    n_fail = 0 if ok else 1
    print(f"bench-quick: {1 - n_fail} passed, {n_fail} failed")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
