# SPDX-License-Identifier: MIT
"""The registration methods of the benchmark. Each runs inside a worker
process (worker.py) and is called as fn(source, target, seed) -> (T, info),
T a 4x4 similarity mapping source onto target.

Peers get the scale normalisation the paper gave them (Sec. 6, "a scale
normalization method is used as the auxiliary function for comparative
methods"): both clouds are centred on their centroid and divided by their
RMS radius, the peer registers the normalised clouds rigidly, and the scale
sigma_t / sigma_s is composed back. CPD estimates its own residual scale on
top. All peer parameters are in those normalised units (RMS radius 1).
"""
from __future__ import annotations

import ctypes
import os
import sys

import numpy as np

VOXEL = 0.05          # FPFH / RANSAC / FGR / GICP resolution (RMS radius = 1)
ICP_VOXEL = 0.03      # plain ICP input resolution
ICP_MAX_DIST = 0.5    # ICP from identity: wide gate (half the RMS radius)
CPD_POINTS = 1000     # probreg CPD works on <= this many points per cloud

THREADS = int(os.environ.get("PKSS_BENCH_THREADS", "1"))
PKSS_LIB = os.environ.get("PKSS_BENCH_LIB", "")  # development: a built libpkss


def normalise(x):
    c = x.mean(axis=0)
    sig = float(np.sqrt(((x - c) ** 2).sum(axis=1).mean()))
    return (x - c) / sig, c, sig


def compose(T_n, cs, ss, ct, st, extra_scale=1.0):
    """Rigid (or scaled) T_n on normalised clouds -> T in caller units."""
    A = T_n[:3, :3]
    s = st / ss
    T = np.eye(4)
    T[:3, :3] = s * A
    T[:3, 3] = st * T_n[:3, 3] + ct - s * A @ cs
    return T


# ---------------------------------------------------------------- pkss
_pkss = None


def check_library(loaded, wanted):
    """Raise ImportError unless the bindings loaded `wanted` (a path; "" asks
    for nothing): their loader tries a library bundled into the package (by
    `pip install`, editable installs too) before $PKSS_LIBRARY."""
    if wanted and os.path.realpath(loaded) != os.path.realpath(wanted):
        raise ImportError(
            f"pkss: asked for {wanted} but the bindings loaded {loaded}, which their loader "
            "tries first; remove that library (or reinstall the bindings from this tree) "
            "to measure the one asked for")


def _load_pkss():
    global _pkss
    if _pkss is None:
        if PKSS_LIB:
            # the bindings from this source tree, whose loader takes
            # $PKSS_LIBRARY unless a library is bundled there (checked below)
            os.environ["PKSS_LIBRARY"] = PKSS_LIB
            sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                            "..", "..", "bindings", "python"))
        import pkss
        check_library(pkss.library_path, PKSS_LIB)
        _pkss = pkss
    return _pkss


def run_pkss(src, tgt, seed):
    pk = _load_pkss()
    res = pk.register(src, tgt, seed=int(seed % (2 ** 31)))
    tim = res.timings
    if not isinstance(tim, dict):
        tim = {k: getattr(tim, k) for k in ("preprocess", "search", "refine", "total")
               if hasattr(tim, k)}
    info = {"device": str(getattr(res, "device", "")),
            "overlap_est": float(getattr(res, "overlap", float("nan"))),
            "t_search": float(tim.get("search", float("nan"))),
            "t_refine": float(tim.get("refine", float("nan"))),
            "t_pre": float(tim.get("preprocess", float("nan")))}
    per_search = getattr(res, "n_rotations", 0) * getattr(res, "n_offsets", 0)
    if per_search:
        # 2 when the second search (wide offset grid) ran
        info["searches"] = int(getattr(res, "n_evaluations", 0) // per_search)
    return np.asarray(res.transform, dtype=np.float64), info


def run_identity(src, tgt, seed):
    return np.eye(4), {}


# ---------------------------------------------------------------- Open3D
_o3d = None


def _load_o3d():
    global _o3d
    if _o3d is None:
        try:  # Open3D links libusb-1.0; the libusb-package wheel ships it
            import libusb_package
            p = libusb_package.get_library_path()
            if p:
                ctypes.CDLL(str(p), mode=ctypes.RTLD_GLOBAL)
        except Exception:
            pass
        import open3d as o3d
        o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
        _o3d = o3d
    return _o3d


def _pcd(x):
    o3d = _load_o3d()
    p = o3d.geometry.PointCloud()
    p.points = o3d.utility.Vector3dVector(x)
    return p


def _fpfh(x, voxel):
    o3d = _load_o3d()
    p = _pcd(x).voxel_down_sample(voxel)
    p.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    f = o3d.pipelines.registration.compute_fpfh_feature(
        p, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
    return p, f


def _ransac(sn, tn, seed):
    o3d = _load_o3d()
    reg = o3d.pipelines.registration
    o3d.utility.random.seed(int(seed % (2 ** 31)))
    ps, fs = _fpfh(sn, VOXEL)
    pt, ft = _fpfh(tn, VOXEL)
    d = 1.5 * VOXEL
    r = reg.registration_ransac_based_on_feature_matching(
        ps, pt, fs, ft, True, d,
        reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         reg.CorrespondenceCheckerBasedOnDistance(d)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    return np.asarray(r.transformation), {"fitness": float(r.fitness)}


def _icp(sn, tn, init, max_dist, iters, voxel, scaling=False):
    o3d = _load_o3d()
    reg = o3d.pipelines.registration
    ps = _pcd(sn).voxel_down_sample(voxel)
    pt = _pcd(tn).voxel_down_sample(voxel)
    r = reg.registration_icp(ps, pt, max_dist, init,
                             reg.TransformationEstimationPointToPoint(scaling),
                             reg.ICPConvergenceCriteria(max_iteration=iters))
    return np.asarray(r.transformation), {"fitness": float(r.fitness)}


def run_o3d_icp(src, tgt, seed):
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    Tn, info = _icp(sn, tn, np.eye(4), ICP_MAX_DIST, 50, ICP_VOXEL)
    return compose(Tn, cs, ss, ct, st), info


def run_o3d_ransac(src, tgt, seed):
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    Tn, info = _ransac(sn, tn, seed)
    return compose(Tn, cs, ss, ct, st), info


def run_o3d_ransac_icp(src, tgt, seed, scaling=False):
    """FPFH+RANSAC, then ICP; with scaling the ICP also fits the scale, which
    the RMS normalisation gets wrong where a cloud has outliers or lacks a
    part."""
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    T0, _ = _ransac(sn, tn, seed)
    Tn, info = _icp(sn, tn, T0, VOXEL, 60, ICP_VOXEL, scaling)
    return compose(Tn, cs, ss, ct, st), info


def run_o3d_ransac_sicp(src, tgt, seed):
    return run_o3d_ransac_icp(src, tgt, seed, scaling=True)


def run_o3d_fgr(src, tgt, seed):
    o3d = _load_o3d()
    reg = o3d.pipelines.registration
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    ps, fs = _fpfh(sn, VOXEL)
    pt, ft = _fpfh(tn, VOXEL)
    r = reg.registration_fgr_based_on_feature_matching(
        ps, pt, fs, ft,
        reg.FastGlobalRegistrationOption(maximum_correspondence_distance=0.5 * VOXEL))
    return compose(np.asarray(r.transformation), cs, ss, ct, st), {"fitness": float(r.fitness)}


# ---------------------------------------------------------------- small_gicp
def run_small_gicp(src, tgt, seed):
    import small_gicp
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    r = small_gicp.align(tn, sn, np.eye(4), registration_type="GICP",
                         downsampling_resolution=VOXEL,
                         max_correspondence_distance=ICP_MAX_DIST,
                         num_threads=THREADS, max_iterations=50)
    return compose(np.asarray(r.T_target_source), cs, ss, ct, st), \
        {"converged": bool(r.converged)}


# ---------------------------------------------------------------- probreg CPD
def run_cpd(src, tgt, seed):
    _load_o3d()  # probreg imports open3d
    from probreg import cpd
    rng = np.random.default_rng(seed)
    sn, cs, ss = normalise(src)
    tn, ct, st = normalise(tgt)
    if len(sn) > CPD_POINTS:
        sn_ = sn[rng.choice(len(sn), CPD_POINTS, replace=False)]
    else:
        sn_ = sn
    if len(tn) > CPD_POINTS:
        tn_ = tn[rng.choice(len(tn), CPD_POINTS, replace=False)]
    else:
        tn_ = tn
    res = cpd.registration_cpd(sn_, tn_, tf_type_name="rigid", update_scale=True,
                               maxiter=50, tol=1e-3)
    tf = res.transformation
    Tn = np.eye(4)
    Tn[:3, :3] = tf.scale * np.asarray(tf.rot)
    Tn[:3, 3] = np.asarray(tf.t)
    return compose(Tn, cs, ss, ct, st), {"cpd_scale": float(tf.scale)}


METHODS = {
    "pkss": run_pkss,
    "identity": run_identity,
    "o3d_icp": run_o3d_icp,
    "o3d_fpfh_ransac": run_o3d_ransac,
    "o3d_fpfh_ransac_icp": run_o3d_ransac_icp,
    "o3d_fpfh_ransac_sicp": run_o3d_ransac_sicp,
    "o3d_fgr": run_o3d_fgr,
    "small_gicp": run_small_gicp,
    "probreg_cpd": run_cpd,
}

LABELS = {
    "pkss": "PKSS-Align (pkss)",
    "identity": "Identity (no motion)",
    "o3d_icp": "ICP (Open3D, from identity)",
    "o3d_fpfh_ransac": "FPFH+RANSAC (Open3D)",
    "o3d_fpfh_ransac_icp": "FPFH+RANSAC+ICP (Open3D)",
    "o3d_fpfh_ransac_sicp": "FPFH+RANSAC+scaled ICP (Open3D)",
    "o3d_fgr": "FGR (Open3D)",
    "small_gicp": "GICP (small_gicp, from identity)",
    "probreg_cpd": "CPD rigid+scale (probreg)",
}


def available(name):
    """(ok, message): can this method be imported here?"""
    try:
        if name == "pkss":
            _load_pkss()
        elif name.startswith("o3d_"):
            _load_o3d()
        elif name == "small_gicp":
            import small_gicp  # noqa: F401
        elif name == "probreg_cpd":
            _load_o3d()
            import probreg  # noqa: F401
        return True, ""
    except Exception as e:  # ImportError, OSError (missing libusb), ...
        return False, f"{type(e).__name__}: {e}"
