# SPDX-License-Identifier: MIT
"""Unit tests of the benchmark's own parts (readers, generator, metrics).
Run: python3 -m pytest tools/bench/test_bench.py -q   (needs numpy, scipy)."""
import os
import sys

import numpy as np
from scipy.spatial import cKDTree
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cases as C  # noqa: E402
import readers  # noqa: E402
from metrics import Evaluator, decompose  # noqa: E402

needs_data = pytest.mark.skipif(not os.path.isdir(C.DATA), reason="shared/data not found")


@needs_data
@pytest.mark.parametrize("orig,conv", [
    ("stanford_bunny/bun000.ply", "stanford_bunny/converted/bun000.ply"),  # ascii PLY
    ("pcl/chef.pcd", "pcl/converted/chef.ply"),                           # binary_compressed PCD
    ("pcl/bun4.pcd", "pcl/converted/bun4.ply"),                           # ascii PCD
    ("libpointmatcher/car_cloud400.csv", "libpointmatcher/converted/car_cloud400.ply"),
    ("3dmatch/geotransformer_demo/src.npy", "3dmatch/geotransformer_demo/converted/src.ply"),
])
def test_readers_agree_with_converted_copies(orig, conv):
    a = readers.read_points(os.path.join(C.DATA, orig))
    b = readers.read_points(os.path.join(C.DATA, conv))
    assert a.shape == b.shape
    assert np.abs(a - b).max() < 1e-6


@needs_data
def test_kitti_and_text_counts():
    assert readers.read_points(os.path.join(C.DATA, "kitti_patchworkpp/000000.bin")).shape[0] > 100000
    assert readers.read_points(os.path.join(C.DATA, "goicp/model_bunny.txt")).shape == (35947, 3)


def test_random_rotation_is_rotation():
    rng = np.random.default_rng(0)
    for _ in range(20):
        R = C.random_rotation(rng)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(R), 1.0)


@needs_data
@pytest.mark.parametrize("case", ["similarity", "partial", "allpert"])
def test_disjoint_pairs_share_no_point(case):
    # two samplings of one surface: at the truth no source point lies on a
    # target point, yet each lies within the model's own spacing of one
    a = C.make_synthetic("chef", case, 0, 0, disjoint=True)
    b = C.make_synthetic("chef", case, 0, 0, disjoint=True)
    assert np.array_equal(a.source, b.source) and np.array_equal(a.target, b.target)
    tmpl = C.load_object("chef")
    x = C.apply(a.T_gt, a.source)
    d, _ = cKDTree(a.target).query(x)
    own, _ = cKDTree(tmpl).query(tmpl, k=2)
    assert np.median(d) > 1e-6 * C.diameter(tmpl)
    assert np.median(d) < 3.0 * np.median(own[:, 1])
    if case == "similarity":
        assert len(a.source) + len(a.target) == len(tmpl)
        # without the split every point has its twin
        shared = C.make_synthetic("chef", case, 0, 0)
        d, _ = cKDTree(shared.target).query(C.apply(shared.T_gt, shared.source))
        assert np.max(d) < 1e-9 * C.diameter(tmpl)


@needs_data
@pytest.mark.parametrize("case", C.SYNTH_CASES)
def test_generator_is_seeded_and_gt_is_exact(case):
    a = C.make_synthetic("chef", case, 0)
    b = C.make_synthetic("chef", case, 0)
    assert np.array_equal(a.source, b.source) and np.array_equal(a.T_gt, b.T_gt)
    s = a.meta["gt_scale"]
    assert 0.5 - 1e-9 <= s <= 2.0 + 1e-9
    ev = Evaluator(a)
    m = ev(a.T_gt)
    assert m["rre_deg"] < 1e-4 and m["scale_err_pct"] < 1e-6 and m["rte_pct"] < 1e-6
    assert m["strict"]
    if case == "similarity":
        assert m["mse"] < 1e-20 and m["rr"]
    if case == "defective":
        n = len(C.load_object("chef"))
        assert abs(len(a.source) - (1 - a.meta["missing"]) * n) <= 1


def test_metrics_known_errors():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(500, 3))
    case = C.Case("t", "similarity", "t", 0, 0, x, x.copy(), np.eye(4), {})
    ev = Evaluator(case)
    ang = np.radians(10.0)
    Rz = np.array([[np.cos(ang), -np.sin(ang), 0], [np.sin(ang), np.cos(ang), 0], [0, 0, 1]])
    T = C.similarity(1.03, Rz, np.zeros(3))
    m = ev(T)
    assert abs(m["rre_deg"] - 10.0) < 1e-9
    assert abs(m["scale_err_pct"] - 3.0) < 1e-9
    assert abs(m["gt_cos"] - (1 + 2 * np.cos(ang)) / 3) < 1e-12
    assert not m["strict"]
    s, R, t = decompose(T)
    assert np.isclose(s, 1.03) and np.allclose(R, Rz)


def _turned(case, deg, axis):
    """The truth followed by a turn of `deg` about `axis` through the target's centre."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    th = np.radians(deg)
    R = np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K
    c = case.target.mean(axis=0)
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = c - R @ c
    return M @ case.T_gt


def test_symmetric_rule_counts_images_not_misses():
    """A box turned half-way about an axis is right (a symmetric image), a
    turn of 90 degrees is not (the box is 1 x 0.7 x 0.45), and neither is
    an 8-degree miss; generated shapes need no shared data."""
    case = C.make_synthetic("box", "noise_g0.2", 0, 0)
    ev = Evaluator(case)
    half = ev(_turned(case, 180.0, [0, 0, 1]))
    assert half["strict"] and half["sym"], half
    quarter = ev(_turned(case, 90.0, [0, 0, 1]))
    assert not quarter["strict"] and not quarter["sym"]
    miss = ev(_turned(case, 8.0, [1, 1, 0]))
    assert not miss["strict"] and not miss["sym"]
    truth = ev(case.T_gt)
    assert truth["strict"] and not truth["sym"]  # right by the errors themselves
    cyl = C.make_synthetic("cylinder", "similarity", 0, 0)
    ev = Evaluator(cyl)
    assert ev(_turned(cyl, 37.0, [0, 0, 1]))["sym"]  # any turn about its axis
    assert not ev(_turned(cyl, 37.0, [1, 0, 0]))["strict"]


def _rows(spec):
    """Rows of report.load_rows' shape: (method, case, strict, seconds) each."""
    return [{"method": m, "case": c, "case_id": f"{c}/obj/{i}", "obj": "obj",
             "strict": ok, "rr": ok, "sym": False, "status": "ok", "time_s": t,
             "mse": 0.0, "mse_n": 0.0, "gt_cos": 1.0, "rre_deg": 0.0, "pair_kind": "",
             "overlap": 1.0}
            for i, (m, c, ok, t) in enumerate(spec)]


def test_paper_target_falls_back_to_the_fastest_peer():
    """Issue #26: >= 3x faster than the fastest peer at >= 80 %, or than the
    fastest of all where no peer reaches 80 %."""
    import report
    st = {"strict": 1.0, "time_median": 0.2}
    good_slow = ("o3d_fpfh_ransac_icp", {"strict": 0.9, "time_median": 0.9})
    bad_fast = ("small_gicp", {"strict": 0.1, "time_median": 0.1})
    ok_rate, ok_time, best = report._judge_paper(st, 0.95, [good_slow, bad_fast])
    assert ok_rate and ok_time and best[0] == "o3d_fpfh_ransac_icp"
    weak = ("o3d_fpfh_ransac_icp", {"strict": 0.5, "time_median": 0.9})
    ok_rate, ok_time, best = report._judge_paper(st, 0.95, [weak, bad_fast])
    assert best[0] == "small_gicp" and not ok_time
    assert report._judge_paper(st, 0.95, [])[1]  # nothing to be timed against


def test_headline_takes_each_case_from_the_first_run_with_it():
    import headline
    first = _rows([("pkss", "similarity", True, 0.1), ("o3d_fgr", "similarity", True, 0.4),
                   ("small_gicp", "similarity", False, 0.05),
                   ("pkss", "defective", True, 0.3), ("small_gicp", "defective", False, 0.05)])
    second = _rows([("pkss", "similarity", False, 9.0), ("pkss", "cut45", True, 0.5),
                    ("o3d_fpfh_ransac_sicp", "cut45", True, 0.6),
                    ("o3d_fpfh_ransac_icp", "cut45", False, 0.3)])
    lines = headline.table([(first, 1), (second, 2)]).splitlines()
    body = {ln.split(" | ")[0].lstrip("| "): ln for ln in lines[2:]}
    assert body["similarity"].endswith("| FGR 100 % (0.40 s) | 1 |")
    assert "| 100 % | 0.10 s |" in body["similarity"]
    assert "no peer succeeds" in body["30–50 % missing"]
    assert body["half-space cut 45 %"].endswith("| FPFH+RANSAC+scaled ICP 100 % (0.60 s) | 2 |")
    assert len(body) == 3


def test_a_library_asked_for_but_not_loaded_is_refused(tmp_path):
    import methods
    a, b = tmp_path / "a.so", tmp_path / "b.so"
    a.write_bytes(b"")
    b.write_bytes(b"")
    methods.check_library(str(a), "")  # nothing asked for
    methods.check_library(str(a), str(tmp_path / "." / "a.so"))  # the same file
    with pytest.raises(ImportError, match="asked for"):
        methods.check_library(str(a), str(b))


@needs_data
def test_truth_probe_holds_an_exact_pair():
    # at an exact similarity copy every textbook ICP stays at the truth
    import truth_probe as P
    case = C.make_synthetic("chef", "similarity", 0, 0)
    for mode, gate, rre, rte, scale_err, ok in P.probe(case.source, case.target, case.T_gt, [1.5],
                                                       P.MODES):
        assert ok and rre < 0.05 and rte < 0.05 and abs(scale_err) < 0.05, mode


@needs_data
def test_truth_probe_similarity_icp_mends_a_scale_offset():
    # started 1.5 % large, the similarity ICP returns to the truth's scale
    import truth_probe as P
    case = C.make_synthetic("chef", "similarity", 0, 0)
    tree = cKDTree(case.target)
    T0 = case.T_gt.copy()
    T0[:3, :3] *= 1.015
    h = C.spacing(case.target, tree)
    T = P.settle(T0, case.source, case.target, tree, C.knn_stats(case.target)[0], 3 * h,
                 "similarity")
    assert P.errors(T0, case.T_gt, case.source, C.diameter(case.target))[2] > 1.4
    assert abs(P.errors(T, case.T_gt, case.source, C.diameter(case.target))[2]) < 0.05


@needs_data
def test_truth_probe_plane_similarity_mends_scale_and_turn():
    # started 1.5 % large and 2 degrees off, the point-to-plane similarity
    # ICPs (one way, both ways, weighted) return to the truth
    import truth_probe as P
    case = C.make_synthetic("chef", "similarity", 0, 0)
    tree = cKDTree(case.target)
    T0 = case.T_gt.copy()
    T0[:3, :3] = 1.015 * P.rotation_exp(np.radians([2.0, 0.0, 0.0])) @ T0[:3, :3]
    h = C.spacing(case.target, tree)
    diam = C.diameter(case.target)
    rre0, _, se0 = P.errors(T0, case.T_gt, case.source, diam)
    assert rre0 > 1.9 and se0 > 1.4
    for mode in ("plane-similarity", "plane-both", "plane-robust"):
        T = P.settle(T0, case.source, case.target, tree, C.knn_stats(case.target)[0], 3 * h,
                     mode, C.knn_stats(case.source)[0])
        rre, rte, se = P.errors(T, case.T_gt, case.source, diam)
        assert rre < 0.05 and rte < 0.05 and abs(se) < 0.05, (mode, rre, rte, se)


def test_truth_probe_welsch_weights_fade_pairs_off_the_surface():
    # rows on a unit sphere with small noise and a fifth of them 0.3 off it:
    # the far rows weigh nearly nothing, and the weighted step then leaves
    # the sphere's rows on it while the plain step scales them off
    import truth_probe as P
    rng = np.random.default_rng(3)
    y = rng.normal(size=(500, 3))
    y /= np.linalg.norm(y, axis=1)[:, None]
    x = y * (1.0 + rng.normal(0.0, 0.005, 500))[:, None]
    x[400:] = 1.3 * y[400:]
    w = P.welsch_weights(x, y, y, gate=1.0)
    assert w[400:].max() < 1e-6 and np.median(w[:400]) > 0.7

    def off_surface(step):
        return np.abs(np.linalg.norm(C.apply(step, x[:400]), axis=1) - 1.0).mean()
    assert off_surface(P.similarity_plane_step(x, y, y)) > 0.03
    assert off_surface(P.similarity_plane_step(x, y, y, w)) < 0.01


@needs_data
def test_truth_probe_pairs_back_on_turned_source_normals():
    # at the truth of an exact copy, each template point's pair back on the
    # source carries the source's normal turned into the template frame:
    # the template's own normal there, up to sign
    import truth_probe as P
    case = C.make_synthetic("chef", "similarity", 0, 0)
    tree = cKDTree(case.target)
    n_t, n_s = C.knn_stats(case.target)[0], C.knn_stats(case.source)[0]
    h = C.spacing(case.target, tree)
    x, y, n = P.plane_rows(case.T_gt, case.source, case.target, tree, n_t, n_s, 1.5 * h, True)
    n_fwd = len(P.plane_rows(case.T_gt, case.source, case.target, tree, n_t, n_s, 1.5 * h,
                             False)[0])
    assert len(x) > n_fwd
    back = slice(n_fwd, None)
    j = tree.query(y[back])[1]
    assert np.median(np.abs((n[back] * n_t[j]).sum(axis=1))) > 0.99
