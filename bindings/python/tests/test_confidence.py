# SPDX-License-Identifier: MIT
"""Result.confidence, .ambiguous, .alternatives and .symmetry: a generated
box (three half turns fit as well: ambiguous, each alternative a 180-degree
turn about one of the box's axes, and the alternatives' poses right too),
a cylinder (an axial symmetry along its axis), and an asymmetric object
(the bunny: confident, not ambiguous)."""
from __future__ import annotations

import pickle

import numpy as np

import pkss

from conftest import apply, load, pose_error, random_similarity

BUNNY = "stanford_bunny/reconstruction/bun_zipper_res2.ply"


def _box(n=8000, dims=(1.0, 0.7, 0.45), seed=3):
    rng = np.random.default_rng(seed)
    a = np.asarray(dims)
    area = np.array([a[1] * a[2], a[0] * a[2], a[0] * a[1]])
    face = rng.choice(3, n, p=area / area.sum())
    x = (rng.random((n, 3)) - 0.5) * a
    x[np.arange(n), face] = np.where(rng.random(n) < 0.5, -0.5, 0.5) * a[face]
    return x


def _cylinder(n=8000, h=1.2, seed=4):
    rng = np.random.default_rng(seed)
    lat = rng.random(n) < h / (h + 1.0)
    t = rng.random(n) * 2 * np.pi
    r = np.where(lat, 1.0, np.sqrt(rng.random(n)))
    z = np.where(lat, (rng.random(n) - 0.5) * h, np.where(rng.random(n) < 0.5, -h / 2, h / 2))
    return np.column_stack([r * np.cos(t), r * np.sin(t), z])


def test_box_is_ambiguous_with_its_half_turns():
    tgt = _box()
    rng = np.random.default_rng(11)
    T = random_similarity(rng, 2.0)
    src = apply(np.linalg.inv(T), tgt)[rng.permutation(len(tgt))]
    res = pkss.register(src, tgt, backend="reference", seed=5)
    assert res.ambiguous
    assert res.symmetry.kind == "discrete"
    assert res.symmetry.order == 2
    axes = set()
    for alt in res.alternatives:
        assert isinstance(alt, pkss.Alternative)
        assert abs(alt.angle - 180.0) < 3.0, alt
        k = int(np.argmax(np.abs(alt.axis)))
        assert abs(alt.axis[k]) > 0.99, alt  # a box axis (the target is axis-aligned)
        axes.add(k)
        # a symmetric image: the alternative's pose puts the box on itself
        al = alt.apply(src)
        assert np.allclose(al.min(axis=0), tgt.min(axis=0), atol=0.02), al.min(axis=0)
        assert np.allclose(al.max(axis=0), tgt.max(axis=0), atol=0.02), al.max(axis=0)
    assert axes == {0, 1, 2}
    assert 0.0 <= res.confidence <= 1.0
    assert res.confidence > 0.9  # the result is right, and its images explain the ties
    assert "ambiguous (discrete)" in repr(res)
    copy = pickle.loads(pickle.dumps(res))
    assert copy.alternatives[0].angle == res.alternatives[0].angle
    assert copy.symmetry == res.symmetry


def test_cylinder_reports_an_axial_symmetry():
    tgt = _cylinder()
    rng = np.random.default_rng(12)
    T = random_similarity(rng, 2.0)
    src = apply(np.linalg.inv(T), tgt)[rng.permutation(len(tgt))]
    res = pkss.register(src, tgt, backend="reference", seed=6)
    assert res.ambiguous
    assert res.symmetry.kind == "axial"
    assert abs(res.symmetry.axis[2]) > 0.99
    # turns about the axis are not listed one by one
    for alt in res.alternatives:
        assert abs(alt.axis[2]) < 0.1


def test_bunny_is_confident_and_not_ambiguous():
    tgt = load(BUNNY)
    rng = np.random.default_rng(13)
    T = random_similarity(rng, 2.0)
    src = apply(np.linalg.inv(T), tgt)[rng.permutation(len(tgt))]
    src = src + rng.normal(0, 1e-4, src.shape)
    res = pkss.register(src, tgt, backend="reference", seed=7)
    e = pose_error(res.transform, T, src.mean(axis=0))
    assert e["rot_deg"] < 1.0, e
    assert not res.ambiguous
    assert res.alternatives == ()
    assert res.symmetry.kind == "none"
    assert res.confidence > 0.9
