# SPDX-License-Identifier: MIT
"""End to end on the shared data with ground truth (the bars of
tests/test_e2e_registration.c), prepared clouds, the 'auto' backend, and
parallel registrations in threads (the GIL is released in C)."""
from __future__ import annotations

import threading
import time

import numpy as np

import pkss
from pkss import _lib

from conftest import (DATA, FAST, LibSpy, apply, data_file, diameter, load, pose_error,
                      random_similarity, read_ply, shape)

BUNNY = "stanford_bunny/reconstruction/bun_zipper_res2.ply"
AIRPLANE_S = "modelnet40_pkss/airplane_0001_s.ply"
AIRPLANE_T = "modelnet40_pkss/airplane_0001_t.ply"
AIRPLANE_GT = "modelnet40_pkss/gt_similarity_s_to_t.txt"
SEED = 20261122


def _airplane():
    src, tgt = load(AIRPLANE_S), load(AIRPLANE_T)
    T = np.loadtxt(data_file(AIRPLANE_GT), comments="#")
    return src, tgt, T


def test_airplane_exact_pair():
    """An exact similarity copy, rows shuffled: < 0.01 deg, < 0.01 % scale,
    < 0.01 % of the diameter."""
    src, tgt, T = _airplane()
    rng = np.random.default_rng(7)
    src_s, tgt_s = src[rng.permutation(len(src))], tgt[rng.permutation(len(tgt))]
    res = pkss.register(src_s, tgt_s, backend="reference")
    e = pose_error(res.transform, T, src_s.mean(axis=0))
    assert e["rot_deg"] < 0.01, e
    assert e["scale_rel"] < 1e-4, e
    assert e["trans"] / diameter(tgt) < 1e-4, e
    assert res.backend == "reference" and res.device
    # Result fields agree with each other; apply() maps the source rows onto
    # the corresponding target rows.
    np.testing.assert_allclose(res.transform[:3, :3], res.scale * res.rotation, atol=1e-12)
    np.testing.assert_allclose(res.transform[:3, 3], res.translation)
    np.testing.assert_allclose(res.transform[3], [0, 0, 0, 1])
    assert abs(np.linalg.det(res.rotation) - 1) < 1e-9
    assert np.abs(res.apply(src) - tgt).max() < 1e-4 * diameter(tgt)
    assert 0 <= res.winner < len(res.candidates) <= 10
    assert res.candidates[res.winner].score == res.score
    assert res.overlap > 0.9 and res.rms >= 0
    # the fit (overlap within 1 spacing) picked the winner and cannot exceed
    # the overlap (within 2); an exact copy lies on itself
    assert res.fit == res.candidates[res.winner].fit and res.fit > 0.9
    assert all(0 <= c.fit <= c.overlap <= 1 for c in res.candidates)
    assert res.n_rotations > 0 and res.n_offsets == 125 and res.n_evaluations > 0
    assert res.counts.source.input == len(src) and res.counts.target.input == len(tgt)
    assert res.counts.source.resampled == 3000
    t = res.timings
    assert 0 < t.total and t.search > 0 and t.validate + t.preprocess + t.search <= t.total * 1.01


def _subset(rng, xyz, p=0.7):
    return xyz[rng.uniform(size=len(xyz)) < p]


def test_bunny_random_similarities():
    """Random similarities of independent 70 % subsets of the bunny:
    rotation < 2 deg, scale < 1 %, translation < 1 % of the diameter."""
    cloud = load(BUNNY)
    dia = diameter(cloud)
    rng = np.random.default_rng(SEED)
    failures = []
    with pkss.Context(backend="reference") as ctx:
        for case in range(5):
            src, tgt = _subset(rng, cloud), _subset(rng, cloud)
            T = random_similarity(rng, dia)
            tgt = apply(T, tgt)
            res = ctx.register(src, tgt)
            e = pose_error(res.transform, T, src.mean(axis=0))
            s_gt = np.cbrt(np.linalg.det(T[:3, :3]))
            e["trans_rel"] = e["trans"] / (dia * s_gt)
            if not (e["rot_deg"] < 2 and e["scale_rel"] < 0.01 and e["trans_rel"] < 0.01):
                failures.append((case, e))
    assert not failures, "seed %d: %s" % (SEED, failures)


def test_prepared_template_matches_register():
    """One template prepared once, several sources: the same pose as
    register() on the arrays (as the C test checks)."""
    cloud = load(BUNNY)
    rng = np.random.default_rng(99)
    with pkss.Context(backend="reference") as ctx:
        template = ctx.prepare_cloud(cloud)
        assert len(template) == 3000 and template.points.shape == (3000, 3)
        assert template.counts.input == len(cloud)
        for _ in range(2):
            T = random_similarity(rng, diameter(cloud))
            Ti = np.linalg.inv(T)
            src = apply(Ti, cloud)  # template = T * source
            a = ctx.register(ctx.prepare_cloud(src), template)
            b = ctx.register(src, cloud)
            c = ctx.register(src, template)  # mixed array / Cloud
            np.testing.assert_allclose(a.transform, b.transform, atol=1e-9)
            np.testing.assert_allclose(c.transform, a.transform, atol=1e-9)
            e = pose_error(a.transform, T, src.mean(axis=0))
            assert e["rot_deg"] < 1.0 and e["scale_rel"] < 0.005, e


def test_auto_backend():
    """The default backend ('auto': OpenCL if usable, else reference)."""
    src, tgt, T = _airplane()
    res = pkss.register(src, tgt)
    assert res.backend in ("reference", "opencl")
    if pkss.devices():
        assert res.backend == "opencl", res
    e = pose_error(res.transform, T, src.mean(axis=0))
    assert e["rot_deg"] < 0.5 and e["scale_rel"] < 0.005, (res, e)


def test_threads_run_in_parallel(monkeypatch):
    """Two threads, two contexts: the C calls overlap in time, which they
    could not if the GIL were held during the call."""
    src = shape(3000)
    tgt = apply(random_similarity(np.random.default_rng(5), 2.0), shape(3000, seed=8))
    intervals = []
    guard = threading.Lock()

    def timed(real):
        def call(*args):
            t0 = time.perf_counter()
            try:
                return real(*args)
            finally:
                t1 = time.perf_counter()
                with guard:
                    intervals.append((t0, t1))
        return call

    monkeypatch.setattr(pkss, "lib", LibSpy(_lib.lib, {"pkss_register": timed}))
    params = dict(points=3000, backend="reference", rotation_steps=8, offset_steps=3)
    ctxs = [pkss.Context(**params) for _ in range(2)]
    results = [None, None]
    errors = []

    def work(i):
        try:
            results[i] = ctxs[i].register(src, tgt)
        except BaseException as e:  # reported below
            errors.append(e)

    start = time.perf_counter()
    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - start
    assert not errors, errors
    np.testing.assert_array_equal(results[0].transform, results[1].transform)
    (a0, a1), (b0, b1) = intervals
    overlap = min(a1, b1) - max(a0, b0)
    shorter = min(a1 - a0, b1 - b0)
    assert overlap > 0.5 * shorter, (
        "C calls in two threads overlapped %.3f s of %.3f s: is the GIL held?" % (overlap, shorter))
    # Sequential wall time, for the report (-s); not asserted: the machine
    # may be shared.
    t0 = time.perf_counter()
    for c in ctxs:
        c.register(src, tgt)
    sequential = time.perf_counter() - t0
    print("\n  threads: parallel %.2f s, sequential %.2f s, speedup %.2f"
          % (wall, sequential, sequential / wall))
    for c in ctxs:
        c.close()


def test_one_context_shared_by_threads_is_serialised(small):
    """Sharing a context is not a crash: calls take turns on its lock."""
    tgt = apply(random_similarity(np.random.default_rng(2), 2.0), small)
    with pkss.Context(**FAST) as ctx:
        cloud = ctx.prepare_cloud(tgt)
        out, errors = [], []

        def work():
            try:
                for _ in range(5):
                    out.append(ctx.register(small, cloud).transform)
            except BaseException as e:
                errors.append(e)

        threads = [threading.Thread(target=work) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert not errors and len(out) == 15
    for T in out:
        np.testing.assert_array_equal(T, out[0])


def test_ply_reader(tmp_path):
    """The test helper itself: ascii and binary_little_endian vertices."""
    xyz = np.random.default_rng(0).normal(size=(5, 3)).astype(np.float32)
    head = "ply\nformat %s 1.0\nelement vertex 5\nproperty float x\nproperty float y\n" \
           "property float z\nproperty uchar red\nelement face 0\n" \
           "property list uchar int vertex_indices\nend_header\n"
    (tmp_path / "a.ply").write_text(head % "ascii" + "".join(
        "%r %r %r 7\n" % tuple(map(float, p)) for p in xyz))
    rec = np.zeros(5, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1")])
    rec["x"], rec["y"], rec["z"] = xyz.T
    (tmp_path / "b.ply").write_bytes((head % "binary_little_endian").encode() + rec.tobytes())
    for name in ("a.ply", "b.ply"):
        np.testing.assert_array_equal(read_ply(tmp_path / name), xyz.astype(np.float64))
    assert DATA  # the data folder is configurable with $PKSS_DATA_DIR


def test_register_reuses_a_context_per_thread(monkeypatch):
    """pkss.register() opens one context per thread and parameter set (the
    seed may change), a reused context gives bit-identical results to a
    fresh one, and new parameters take effect (a new context)."""
    src = shape(2000)
    tgt = apply(random_similarity(np.random.default_rng(11), 1.5), shape(2000, seed=4))
    params = dict(FAST, seed=3)
    fresh3 = pkss.Context(**params).register(src, tgt).transform
    fresh0 = pkss.Context(**FAST).register(src, tgt).transform
    assert pkss.default_params()["seed"] == pkss._DEFAULT_SEED
    created = []

    def counting(real):
        def create(out):
            created.append(1)
            return real(out)
        return create

    monkeypatch.setattr(pkss, "lib", LibSpy(_lib.lib, {"pkss_context_create": counting}))
    monkeypatch.setattr(pkss, "_per_thread", threading.local())
    a = pkss.register(src, tgt, **params)
    b = pkss.register(src, tgt, **params)
    d = pkss.register(src, tgt, **dict(params, seed=None))  # default seed, same context
    assert len(created) == 1
    np.testing.assert_array_equal(a.transform, fresh3)
    np.testing.assert_array_equal(b.transform, fresh3)
    np.testing.assert_array_equal(d.transform, fresh0)
    c = pkss.register(src, tgt, **dict(params, refine=False))
    assert len(created) == 2
    assert not np.array_equal(a.transform, c.transform)  # unrefined pose
