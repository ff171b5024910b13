# SPDX-License-Identifier: MIT
"""Generated pairs for the confidence model (fit.py, evaluate.py): the
benchmark's perturbation families (tools/bench/cases.py SYNTH_CASES) plus
its hard ones (HARD_CASES) and, optionally, its real pairs; each pair is
registered by conf_dump (the library's features, alternatives, symmetry)
and scored by tools/bench/metrics.py (strict success, symmetric rule).

A run folder holds the pairs (raw float64), manifest.txt, runs.jsonl (what
conf_dump printed) and records.json (one record per pair); a folder already
holding records.json for the same plan is reused as it is."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "bench"))
import cases as C  # noqa: E402
import metrics as M  # noqa: E402
import numpy as np  # noqa: E402

FAMILIES = C.SYNTH_CASES + C.HARD_CASES


def plan(objects, families, seeds, real_pairs=(), real_seeds=0):
    """Items (kind, name, family, index), seed index outermost."""
    items = []
    for i in range(max(seeds, real_seeds)):
        if i < seeds:
            items += [("s", o, f, i) for f in families for o in objects]
        if i < real_seeds:
            items += [("r", p, "real", i) for p in real_pairs]
    return items


def make(item, base_seed):
    kind, name, fam, i = item
    if kind == "s":
        return C.make_synthetic(name, fam, i, base_seed)
    return C.make_real(name, i, base_seed)


def run(out, items, base_seed, conf_dump, backend="opencl", log=sys.stderr, keep=False,
        rescore=False):
    """Registers and scores every item; returns the records. Cached: the
    registrations (runs.jsonl) of the same items are reused, the scores
    (records.json) unless rescore (after a change to metrics.py). keep:
    leave the pair files in out (to rerun conf_dump by hand)."""
    os.makedirs(out, exist_ok=True)
    rec_path = os.path.join(out, "records.json")
    key = {"items": items, "base_seed": base_seed}
    if os.path.exists(rec_path) and not rescore:
        with open(rec_path) as f:
            cached = json.load(f)
        if cached.get("key") == json.loads(json.dumps(key)):
            return cached["records"]
    runs_path = os.path.join(out, "runs.jsonl")
    runs = []
    if os.path.exists(runs_path):  # registered already: score again only
        with open(runs_path) as f:
            runs = [json.loads(line) for line in f]
        if [r["id"] for r in runs] != [item_case_id(it) for it in items]:
            runs = []
    if not runs:
        runs = register(out, items, base_seed, conf_dump, backend, log, keep)
    return score(out, items, base_seed, runs, key)


def item_case_id(item):
    kind, name, fam, i = item
    return f"{fam}/{name}/{i}" if kind == "s" else f"real/{name}/{i}"


def register(out, items, base_seed, conf_dump, backend, log, keep):
    t0 = time.time()
    with open(os.path.join(out, "manifest.txt"), "w") as man:
        for n, it in enumerate(items):
            cs = make(it, base_seed)
            stem = f"p{n:05d}"
            cs.source.astype("<f8").tofile(os.path.join(out, stem + "_s.bin"))
            cs.target.astype("<f8").tofile(os.path.join(out, stem + "_t.bin"))
            man.write(f"{cs.case_id} {cs.seed % 2**31} {stem}_s.bin {stem}_t.bin\n")
    print(f"[pairs] {len(items)} pairs written in {time.time() - t0:.0f} s", file=log)
    t1 = time.time()
    runs_path = os.path.join(out, "runs.jsonl")
    with open(runs_path + ".part", "w") as f:
        subprocess.run([conf_dump, out, backend], stdout=f, check=True)
    os.replace(runs_path + ".part", runs_path)
    print(f"[pairs] registered in {time.time() - t1:.0f} s", file=log)
    with open(runs_path) as f:
        runs = [json.loads(line) for line in f]
    for n in range(len(items)):
        for fn in (f"p{n:05d}_s.bin", f"p{n:05d}_t.bin"):
            if not keep and os.path.exists(os.path.join(out, fn)):
                os.remove(os.path.join(out, fn))
    return runs


def score(out, items, base_seed, runs, key):
    records = []
    for n, (it, r) in enumerate(zip(items, runs)):
        cs = make(it, base_seed)
        assert r["id"] == cs.case_id, (r["id"], cs.case_id)
        rec = {"id": cs.case_id, "family": it[2], "obj": it[1], "status": r["status"]}
        if r["status"] == "PKSS_OK":
            ev = M.Evaluator(cs)
            met = ev(np.array(r["T"]).reshape(4, 4))
            rec.update({k: r[k] for k in ("confidence", "ambiguous", "symmetry", "order",
                                          "axis", "features", "time", "assess_time")})
            rec["alternatives"] = [{k: a[k] for k in ("angle", "axis", "fit", "candidate")}
                                   for a in r["alternatives"]]
            rec.update({"right": met["strict"], "sym": met["sym"],
                        "rre": met["rre_deg"], "rte": met["rte_pct"],
                        "scale_err": met["scale_err_pct"]})
            # is every alternative itself right (a symmetric image)?
            rec["alt_right"] = [bool(ev(np.array(a["T"]).reshape(4, 4))["strict"])
                                for a in r["alternatives"][:4]]
        else:
            rec.update({"right": False, "sym": False, "confidence": 0.0, "ambiguous": 0})
        records.append(rec)
    with open(os.path.join(out, "records.json"), "w") as f:
        json.dump({"key": key, "records": records}, f)
    return records
