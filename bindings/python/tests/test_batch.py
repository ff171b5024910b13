# SPDX-License-Identifier: MIT
"""Many pairs: PreparedCloud, register_many, identify and the batch command
(pkss/batch.py, pkss/_batch_cli.py). The Dask tests skip when
dask.distributed is not installed (pip install 'pkss[batch]')."""
from __future__ import annotations

import collections
import concurrent.futures
import csv
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest

import pkss
from pkss import _batch_cli, batch

from conftest import DATA, REPO, apply, random_similarity

try:
    import distributed  # noqa: F401
    HAVE_DASK = True
except ImportError:
    HAVE_DASK = False
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason="dask.distributed is not installed "
                                "(pip install 'pkss[batch]')")

# Fast settings that still identify the shared objects (32 of 32 scans)
P: Dict[str, Any] = dict(points=256, rotation_steps=8, offset_steps=3, top_k=4,
                         backend="reference")
BUNDLED = REPO / "tests" / "data"
# The objects of identify(): the bundled airplane and shared-data objects.
OBJECTS = {
    "airplane": BUNDLED / "airplane_0001_t.ply",
    "bunny": DATA / "stanford_bunny/reconstruction/bun_zipper_res2.ply",
    "dragon": DATA / "stanford_dragon_stand/converted/dragonStandRight_0.ply",
    "parasaurolophus": DATA / "uwa_opencv/parasaurolophus_6700.ply",
    "chef": DATA / "pcl/converted/chef.ply",
    "milk": DATA / "pcl/converted/milk.ply",
    "car6": DATA / "pcl/converted/car6.ply",
    "lamppost": DATA / "pcl/converted/lamppost.ply",
}


def objects() -> Dict[str, np.ndarray]:
    return {k: batch._read(p) for k, p in OBJECTS.items() if p.is_file()}


def scan(rng: np.random.Generator, x: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """A perturbed scan of x: 70 % of the points, noise of 0.2 % of the
    size, a random similarity T (scan = T x)."""
    y = x[rng.random(len(x)) < 0.7]
    size = np.linalg.norm(x.max(0) - x.min(0))
    y = y + rng.normal(scale=0.002 * size, size=y.shape)
    T = random_similarity(rng, size)
    return apply(T, y), T


def rot_error_deg(T_est: np.ndarray, T_gt: np.ndarray) -> float:
    """Rotation angle of T_est after T_gt^-1 (both similarities)."""
    A = T_est[:3, :3] / np.cbrt(np.linalg.det(T_est[:3, :3]))
    B = T_gt[:3, :3] / np.cbrt(np.linalg.det(T_gt[:3, :3]))
    c = (np.trace(A @ B.T) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))))


def make_pairs(tmp: Path, n: int) -> List[Tuple[str, str, str, np.ndarray]]:
    """n (id, source.npy, target.npy, T_gt) pairs: target = T_gt source up
    to resampling, from the bundled airplane and the shared objects."""
    objs = objects()
    names = sorted(objs)
    rng = np.random.default_rng(2024)
    out = []
    for i in range(n):
        x = objs[names[i % len(names)]]
        src = x[rng.random(len(x)) < 0.7]
        tgt, T = scan(rng, x)
        ps, pt = tmp / ("s%02d.npy" % i), tmp / ("t%02d.npy" % i)
        np.save(ps, src)
        np.save(pt, tgt)
        out.append(("pair%02d" % i, str(ps), str(pt), T))
    return out


def cli_env(**extra: str) -> Dict[str, str]:
    env = dict(os.environ)
    pkg_root = str(Path(pkss.__file__).resolve().parent.parent)
    env["PYTHONPATH"] = pkg_root + os.pathsep + env.get("PYTHONPATH", "")
    env["PKSS_LIBRARY"] = pkss.library_path
    env.update(extra)
    return env


def write_manifest(path: Path, rows: List[Tuple[str, str, str]], params: Dict[str, Any]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", "source", "target"] + list(params))
        for r in rows:
            w.writerow(list(r) + list(params.values()))


def transform_of(row: Dict[str, Any]) -> np.ndarray:
    return np.array([float(row["t%d%d" % (i // 4, i % 4)]) for i in range(16)]).reshape(4, 4)


# ---------------------------------------------------------- prepared clouds
def test_prepared_cloud_pickles_and_registers_identically():
    s = batch._read(BUNDLED / "airplane_0001_s.ply")
    t = batch._read(BUNDLED / "airplane_0001_t.ply")
    pc = pkss.PreparedCloud.prepare(t, **P)
    back = pickle.loads(pickle.dumps(pc))
    assert back.to_bytes() == pc.to_bytes() and back.params == pc.params
    ref = pkss.register(s, t, **P)
    with pkss.Context(**P) as ctx:
        a = ctx.register(s, pc.cloud)
        b = ctx.register(s, back.cloud)
    assert np.array_equal(a.transform, ref.transform)
    assert np.array_equal(b.transform, ref.transform)


def test_prepared_cloud_stale_and_corrupt_bytes():
    pc = pkss.PreparedCloud.prepare(BUNDLED / "airplane_0001_t.ply", **P)
    data = pc.to_bytes()
    with pytest.raises(pkss.Error) as e:
        pkss.PreparedCloud.from_bytes(data, **dict(P, points=300))
    assert e.value.name == "PKSS_ERR_STALE_DATA" and "points = 256" in e.value.detail
    bad = bytearray(data)
    bad[len(bad) // 2] ^= 1
    with pytest.raises(pkss.Error) as e:
        pkss.PreparedCloud.from_bytes(bytes(bad), **P)
    assert e.value.name == "PKSS_ERR_CORRUPT_DATA" and "checksum" in e.value.detail
    with pytest.raises(pkss.Error) as e:
        pkss.PreparedCloud.from_bytes(data[:100], **P)
    assert e.value.name == "PKSS_ERR_CORRUPT_DATA" and "truncated" in e.value.detail
    with pytest.raises(pkss.Error) as e:
        pkss.PreparedCloud.from_bytes(b"ply\n" + data, **P)
    assert "magic" in e.value.detail


# ------------------------------------------------------------ register_many
def test_register_many_in_process_and_executor(tmp_path):
    pairs = make_pairs(tmp_path, 4)
    ref = [pkss.register(np.load(s), np.load(t), **P) for _, s, t, _ in pairs]
    as_paths = [{"id": i, "source": s, "target": t} for i, s, t, _ in pairs]
    as_arrays = [(np.load(s), np.load(t)) for _, s, t, _ in pairs]
    for args, kw in ((as_paths, {}), (as_arrays, {}),
                     (as_paths, {"executor": concurrent.futures.ThreadPoolExecutor(2)})):
        out = pkss.register_many(args, **kw, **P)
        assert [r.status for r in out] == ["ok"] * 4
        for r, want in zip(out, ref):
            assert np.array_equal(r.result.transform, want.transform)
    # sources x templates: ids (i, j); each template prepared once
    srcs = [np.load(s) for _, s, _, _ in pairs[:2]]
    tpls = [np.load(t) for _, _, t, _ in pairs[:2]]
    out = pkss.register_many(sources=srcs, templates=tpls, **P)
    assert [r.id for r in out] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert np.array_equal(out[3].result.transform, ref[1].transform)
    with pytest.raises(TypeError):
        pkss.register_many(as_arrays, sources=srcs, **P)
    with pytest.raises(ValueError, match="not unique"):
        pkss.register_many([{"id": 1, "source": srcs[0], "target": tpls[0]}] * 2, **P)


def test_register_many_bad_inputs_are_rows(tmp_path):
    s = batch._read(BUNDLED / "airplane_0001_s.ply")
    t = str(BUNDLED / "airplane_0001_t.ply")
    nan = s.copy()
    nan[5, 1] = np.nan
    trunc = tmp_path / "cut.ply"
    trunc.write_bytes((BUNDLED / "airplane_0001_s.ply").read_bytes()[:2000])
    out = pkss.register_many([(nan, t), (str(trunc), t), (s, t), (s, np.zeros((100, 3)))], **P)
    assert out[0].status == "PKSS_ERR_NONFINITE" and "row 5" in out[0].detail
    assert out[1].status == "PKSS_ERR_FORMAT" and "truncated" in out[1].detail
    assert out[2].ok
    assert out[3].status == "PKSS_ERR_DEGENERATE" and "identical" in out[3].detail


# ----------------------------------------------------------------- identify
def test_identify_matches_single_registrations():
    s = batch._read(BUNDLED / "airplane_0001_s.ply")
    t = batch._read(BUNDLED / "airplane_0001_t.ply")
    rng = np.random.default_rng(5)
    box = rng.uniform(-1, 1, size=(3000, 3)) * [3, 2, 1]
    templates = [box, t, str(BUNDLED / "airplane_0001_t.ply")]
    m = pkss.identify(s, templates, **P)
    assert sorted(x.index for x in m) == [0, 1, 2] and [x.rank for x in m] == [0, 1, 2]
    assert {m[0].index, m[1].index} == {1, 2} and m[2].index == 0
    for x in m:
        want = pkss.register(s, batch._read(templates[x.index]) if isinstance(
            templates[x.index], str) else templates[x.index], **P)
        assert np.array_equal(x.result.transform, want.transform)
    fits = [(x.result.fit, x.result.overlap) for x in m]
    assert fits == sorted(fits, reverse=True)


def test_identify_library_of_objects():
    objs = objects()
    if len(objs) < 6:
        pytest.skip("identify needs >= 6 objects: the shared data folder (%s) is absent or "
                    "incomplete (%d found)" % (DATA, len(objs)))
    names = sorted(objs)
    library = [pkss.PreparedCloud.prepare(objs[k], **P) for k in names]
    rng = np.random.default_rng(7)
    hits, poses, n = 0, 0, 0
    misses = []
    for i, k in enumerate(names):
        for _ in range(max(4, -(-30 // len(names)))):
            y, T = scan(rng, objs[k])
            m = pkss.identify(y, library, **P)
            n += 1
            if m[0].index == i:
                hits += 1
                # the pose maps the scan back onto the object: T_est ~ T^-1
                poses += rot_error_deg(m[0].transform, np.linalg.inv(T)) < 5.0
            else:
                misses.append((k, names[m[0].index]))
    print("identify: %d/%d scans of %d objects identified, %d with rotation error < 5 deg; "
          "misses %s" % (hits, n, len(names), poses, misses))
    assert n >= 30
    assert hits >= 0.9 * n, misses
    # Poses over all scans, not over the identified ones: a scan identified
    # that was not must not fail the test. At these settings car6's scans end
    # turned about its vertical axis (4 of 4; the truth fits clearly better).
    assert poses >= 0.85 * n


# ------------------------------------------------------------ batch command
def test_cli_usage_errors(tmp_path, capsys):
    m = tmp_path / "m.csv"
    write_manifest(m, [("a", "s.npy", "t.npy")], {"nonsense": 1})
    assert _batch_cli.main([str(m), "--out", str(tmp_path / "r.csv")]) == 2
    assert "unknown column(s) nonsense" in capsys.readouterr().err
    write_manifest(m, [("a", "s.npy", "t.npy"), ("a", "s.npy", "t.npy")], {})
    assert _batch_cli.main([str(m), "--out", str(tmp_path / "r.csv")]) == 2
    assert "appears twice" in capsys.readouterr().err
    write_manifest(m, [("a", "s.npy", "t.npy")], {"points": 5})
    assert _batch_cli.main([str(m), "--out", str(tmp_path / "r.csv")]) == 2
    assert "points" in capsys.readouterr().err
    assert _batch_cli.main([str(tmp_path / "none.csv"), "--out", str(tmp_path / "r.csv")]) == 3
    write_manifest(m, [("a", "s.npy", "t.npy")], {})
    (tmp_path / "r.csv").write_text("precious\n")
    assert _batch_cli.main([str(m), "--out", str(tmp_path / "r.csv")]) == 2
    assert (tmp_path / "r.csv").read_text() == "precious\n"
    assert _batch_cli.main([str(m), "--out", str(tmp_path / "r.json")]) == 2


def test_cli_in_process_csv_and_parquet(tmp_path):
    pairs = make_pairs(tmp_path, 3)
    m = tmp_path / "m.csv"
    write_manifest(m, [p[:3] for p in pairs], P)
    ref = {pid: pkss.register(np.load(s), np.load(t), **P).transform for pid, s, t, _ in pairs}
    outs = [tmp_path / "r.csv"]
    try:
        import pyarrow  # noqa: F401
        outs.append(tmp_path / "r.parquet")
    except ImportError:
        pass
    for out in outs:
        assert _batch_cli.main([str(m), "--out", str(out), "--progress", "none"]) == 0
        rows = _batch_cli.read_results(out)
        assert sorted(r["id"] for r in rows) == sorted(ref)
        for r in rows:
            assert r["status"] == "ok"
            assert np.array_equal(transform_of(r), ref[r["id"]])
        # --resume with nothing missing changes nothing
        before = out.read_bytes()
        assert _batch_cli.main([str(m), "--out", str(out), "--resume", "--progress", "none"]) == 0
        assert out.read_bytes() == before


@needs_dask
def test_cli_dask_24_pairs_bit_identical_with_bad_rows(tmp_path):
    """24 pairs through the batch command on a LocalCluster of 2 worker
    processes equal pkss.register bit for bit; a corrupt file and a NaN
    cloud give error rows with the reader's / library's message."""
    pairs = make_pairs(tmp_path, 24)
    corrupt = tmp_path / "corrupt.ply"
    corrupt.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 500\n"
                        b"property float x\nproperty float y\nproperty float z\nend_header\n"
                        + b"\0" * 100)
    nan = np.load(pairs[0][1])
    nan[7] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    rows = [p[:3] for p in pairs] + [("corrupt", str(corrupt), pairs[0][2]),
                                     ("nan", str(tmp_path / "nan.npy"), pairs[0][2])]
    m = tmp_path / "m.csv"
    write_manifest(m, rows, P)
    out = tmp_path / "r.csv"
    proc = subprocess.run([sys.executable, "-m", "pkss._batch_cli", str(m), "--out", str(out),
                           "--workers", "2"], env=cli_env(), capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 1, proc.stderr  # 1: finished, with error rows
    got = {r["id"]: r for r in _batch_cli.read_results(out)}
    assert len(got) == 26 and len(_batch_cli.read_results(out)) == 26
    assert got["corrupt"]["status"] == "PKSS_ERR_FORMAT"
    assert "truncated" in got["corrupt"]["detail"]
    assert got["nan"]["status"] == "PKSS_ERR_NONFINITE" and "row 7" in got["nan"]["detail"]
    good = 0
    for pid, s, t, T in pairs:
        r = got[pid]
        assert r["status"] == "ok", r
        want = pkss.register(np.load(s), np.load(t), **P)
        assert np.array_equal(transform_of(r), want.transform), pid
        assert r["worker"].startswith("tcp://")
        good += rot_error_deg(transform_of(r), T) < 5.0
    assert len({got[p[0]]["worker"] for p in pairs}) == 2
    print("batch: %d/24 poses within 5 deg of the ground truth" % good)
    assert good >= 20


@needs_dask
def test_dask_worker_killed_mid_run(tmp_path):
    """A worker process dies after the first results: Dask reruns its tasks
    elsewhere; every id arrives exactly once, with the right pose."""
    from distributed import Client, LocalCluster

    pairs = make_pairs(tmp_path, 12)
    ref = {pid: pkss.register(np.load(s), np.load(t), **P).transform for pid, s, t, _ in pairs}
    tasks = [(pid, s, t, {}) for pid, s, t, _ in pairs]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        seen: List[str] = []
        killed = None
        for r in batch.iter_register(tasks, client, **P):
            seen.append(r.id)
            assert r.ok, r
            assert np.array_equal(r.result.transform, ref[r.id])
            if killed is None:
                busy = [w for w, keys in client.processing().items() if keys]
                killed = busy[0] if busy else r.worker
                try:  # the worker dies before it can answer
                    client.run(os._exit, 1, workers=[killed])
                except Exception:
                    pass
        assert killed is not None
        workers = {r for r in client.scheduler_info()["workers"]}
    print("worker killed: %s; workers at the end: %s" % (killed, sorted(workers)))
    assert killed not in workers  # it really died (the nanny started a new one)
    assert sorted(seen) == sorted(ref)
    assert all(c == 1 for c in collections.Counter(seen).values())


def test_cli_driver_killed_then_resume(tmp_path):
    """The driver is killed (SIGKILL) after some rows; --resume completes
    the table with every id once, and the finished pairs are not computed
    again (PKSS_BATCH_TRACE counts each computation)."""
    pairs = make_pairs(tmp_path, 14)
    m = tmp_path / "m.csv"
    write_manifest(m, [p[:3] for p in pairs], P)
    out, trace = tmp_path / "r.csv", tmp_path / "trace.txt"
    cmd = [sys.executable, "-m", "pkss._batch_cli", str(m), "--out", str(out), "--threads", "1",
           "--progress", "lines"]
    env = cli_env(PKSS_BATCH_TRACE=str(trace))
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if out.exists() and out.read_text().count("\n") >= 5:  # header + 4 rows
            break
        if proc.poll() is not None:
            break
        time.sleep(0.02)
    proc.kill()
    proc.wait()
    first = {r["id"] for r in _batch_cli.read_results(out)}
    assert 4 <= len(first) < len(pairs), "the driver finished before it could be killed"
    n_trace_first = len(trace.read_text().split())
    done = subprocess.run(cmd + ["--resume"], env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert "%d already in RESULTS" % len(first) in done.stderr
    rows = _batch_cli.read_results(out)
    ids = [r["id"] for r in rows]
    assert sorted(ids) == sorted(p[0] for p in pairs) and len(ids) == len(set(ids))
    calls = collections.Counter(trace.read_text().split())
    second = trace.read_text().split()[n_trace_first:]
    assert sorted(second) == sorted(set(ids) - first)  # only the missing ones ran again
    assert all(calls[i] == 1 for i in first)
    ref = {pid: pkss.register(np.load(s), np.load(t), **P).transform for pid, s, t, _ in pairs}
    for r in rows:
        assert np.array_equal(transform_of(r), ref[r["id"]])
