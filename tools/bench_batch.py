#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Throughput of many pairs against one template (not a test).

    python tools/bench_batch.py [--pairs 200] [--repeats 3] [--param k=v ...]

Measures pairs/s, median of --repeats runs, for
  (a)  a plain loop over pkss.register(source, template)  (prepares both each time)
  (a') a loop over Context.register(source, prepared template)  (template once)
  (b)  pkss.register_many in process (threads)
  (c)  register_many on a Dask LocalCluster of 1 and 2 worker processes
       (one thread each; sources as .npy paths read on the workers)
and the Dask scheduler overhead per task (200 no-op tasks). Prints a
Markdown table stamped with the commit, the machine and the command.
Needs pkss[batch] (dask[distributed]) for (c).
"""
from __future__ import annotations

import argparse
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _value(text: str):
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(text.lower(), text)


def make_sources(template: np.ndarray, n: int, folder: Path):
    """n perturbed scans of the template (70 % of the points, a random
    similarity), as arrays and as .npy files."""
    rng = np.random.default_rng(1)
    arrays, paths = [], []
    for i in range(n):
        y = template[rng.random(len(template)) < 0.7]
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w, x, yy, z = q
        R = np.array([[1 - 2 * (yy * yy + z * z), 2 * (x * yy - z * w), 2 * (x * z + yy * w)],
                      [2 * (x * yy + z * w), 1 - 2 * (x * x + z * z), 2 * (yy * z - x * w)],
                      [2 * (x * z - yy * w), 2 * (yy * z + x * w), 1 - 2 * (x * x + yy * yy)]])
        s = np.exp(rng.uniform(np.log(0.5), np.log(2.0)))
        y = y @ (s * R).T + rng.normal(size=3)
        p = folder / ("src%04d.npy" % i)
        np.save(p, y)
        arrays.append(y)
        paths.append(str(p))
    return arrays, paths


def timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--template", default=str(REPO / "tests/data/airplane_0001_t.ply"))
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--no-dask", action="store_true")
    args = ap.parse_args()

    import pkss
    from pkss import batch

    params = {"backend": "reference"}
    for item in args.param:
        k, _, v = item.partition("=")
        params[k] = _value(v)
    template = batch._read(args.template)
    tmp = Path(tempfile.mkdtemp(prefix="pkss-bench-batch-"))
    sources, paths = make_sources(template, args.pairs, tmp)
    tpath = str(tmp / "template.npy")
    np.save(tpath, template)
    n = args.pairs
    rows = []

    task_ms = {}  # run name -> median seconds of a task on its worker

    def record(name: str, times):
        med = statistics.median(times)
        rows.append((name, n / med, med / n * 1e3, times, task_ms.pop("last", None)))
        print("%-46s %7.2f pairs/s  (%s s)" % (name, n / med, ", ".join("%.2f" % t for t in times)),
              file=sys.stderr, flush=True)

    def loop_register():
        for s in sources:
            pkss.register(s, template, **params)

    def loop_prepared():
        with pkss.Context(**params) as ctx:
            tpl = ctx.prepare_cloud(template)
            for s in sources:
                ctx.register(s, tpl)

    def many(executor=None, srcs=sources):
        out = pkss.register_many(sources=srcs, templates=[tpath], executor=executor, **params)
        task_ms["last"] = statistics.median(r.seconds for r in out) * 1e3
        bad = [r for r in out if not r.ok]
        if bad:
            raise SystemExit("bench: %d pairs failed, e.g. %s: %s" % (len(bad), bad[0].status,
                                                                      bad[0].detail))

    record("(a) loop over pkss.register", [timed(loop_register) for _ in range(args.repeats)])
    record("(a') loop, template prepared once", [timed(loop_prepared) for _ in range(args.repeats)])
    record("(b) register_many, threads (%d)" % (os.cpu_count() or 1),
           [timed(many) for _ in range(args.repeats)])
    overhead = None
    if not args.no_dask:
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            print("bench: dask.distributed not installed: (c) skipped", file=sys.stderr)
        else:
            for workers in (1, 2):
                with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, Client(cluster) as client:
                    # warm-up: imports and the template cache on every worker
                    many(client, paths[: 2 * workers])
                    record("(c) register_many, Dask LocalCluster x%d" % workers,
                           [timed(lambda: many(client, paths)) for _ in range(args.repeats)])
                    if workers == 1:
                        def noop():
                            fs = [client.submit(int, i, pure=False) for i in range(n)]
                            client.gather(fs)
                        overhead = statistics.median(timed(noop) for _ in range(args.repeats)) / n

    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "unknown"
    print("\n%d pairs against one template (%s, %d points), params %s; pkss %s, commit %s; "
          "%s, %d CPUs, Python %s." % (n, Path(args.template).name, len(template), params,
                                       pkss.library_version, commit, platform.processor() or
                                       platform.machine(), os.cpu_count() or 1,
                                       platform.python_version()))
    print("Command: `python tools/bench_batch.py %s`\n" % " ".join(map(shlex.quote, sys.argv[1:])))
    print("| run | pairs/s | ms/pair | task on its worker (ms, median) | runs (s) |")
    print("|---|---:|---:|---:|---|")
    for name, rate, ms, times, task in rows:
        print("| %s | %.2f | %.1f | %s | %s |" % (name, rate, ms, "-" if task is None else
                                                "%.1f" % task, ", ".join("%.2f" % t for t in times)))
    a = {r[0][:4]: r[2] for r in rows}
    if "(b) " in a and "(a')" in a:
        print("\nThreads over the prepared-template loop: %.2fx." % (a["(a')"] / a["(b) "]))
    print("\nPreparing the template once: %.2fx (a -> a')." % (a["(a) "] / a["(a')"]))
    if overhead is not None:
        print("Dask scheduler overhead: %.2f ms per task (median of %d runs of %d no-op tasks, "
              "1 worker)." % (overhead * 1e3, args.repeats, n))
    return 0


if __name__ == "__main__":
    sys.exit(main())
