# SPDX-License-Identifier: MIT
"""pkss.read_points / pkss.write_points (the C library's readers and
writers) and Open3D inputs."""
from __future__ import annotations

import io
import struct
import subprocess
import sys
import zipfile

import numpy as np
import pytest

import pkss
from conftest import FAST, REPO

PAIR = REPO / "tests" / "data"

# Doubles that text formats lose unless printed with 17 digits, plus signed
# zero, a subnormal and the extremes.
SPECIAL = np.array([[1.0 / 3.0, -2e-300, 1e300], [0.1, 0.2, 0.3], [-0.0, 12345.6789, -7.25],
                    [5e-324, -1.7976931348623157e308, 2.5]])


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.fixture(scope="module")
def cloud() -> np.ndarray:
    return pkss.read_points(PAIR / "airplane_0001_s.ply")


def test_read_bundled_pair(cloud):
    assert cloud.shape == (10001, 3) and cloud.dtype == np.float64
    assert cloud.flags["C_CONTIGUOUS"] and cloud.flags["WRITEABLE"]


@pytest.mark.parametrize("ext", pkss.io.WRITABLE_FORMATS)
@pytest.mark.parametrize("ascii", [False, True])
def test_round_trip_bit_identical(tmp_path, cloud, ext, ascii):
    for pts in (SPECIAL, cloud):
        p = tmp_path / ("c." + ext)
        pkss.write_points(p, pts, ascii=ascii)
        assert same_bits(pkss.read_points(p), pts)
        # the format argument instead of the extension
        q = tmp_path / "noext"
        pkss.write_points(q, pts, format=ext, ascii=ascii)
        assert same_bits(pkss.read_points(q, format=ext), pts)


def test_round_trip_file_objects(cloud):
    for fmt in pkss.io.WRITABLE_FORMATS:
        buf = io.BytesIO()
        pkss.write_points(buf, cloud, format=fmt)
        buf.seek(0)
        assert same_bits(pkss.read_points(buf, format=fmt), cloud)


def test_numpy_interop(tmp_path, cloud):
    pkss.write_points(tmp_path / "a.npy", cloud)
    assert same_bits(np.load(tmp_path / "a.npy"), cloud)  # numpy reads ours
    f32 = cloud.astype(np.float32)
    for name, arr, kw in [("c.npy", cloud, {}), ("f.npy", np.asfortranarray(cloud), {}),
                          ("s.npy", f32, {}), ("be.npy", cloud.astype(">f8"), {}),
                          ("v2.npy", cloud, {"version": (2, 0)}),
                          ("v3.npy", cloud, {"version": (3, 0)})]:
        with open(tmp_path / name, "wb") as f:
            np.lib.format.write_array(f, arr, **kw)
        assert same_bits(pkss.read_points(tmp_path / name), arr.astype(np.float64)), name


def test_npz_members(tmp_path, cloud):
    np.savez(tmp_path / "one.npz", cloud)
    assert same_bits(pkss.read_points(tmp_path / "one.npz"), cloud)
    np.savez(tmp_path / "two.npz", points=cloud, normals=cloud[:10])
    assert same_bits(pkss.read_points(tmp_path / "two.npz"), cloud)  # "points"
    assert same_bits(pkss.read_points(str(tmp_path / "two.npz") + ":normals"), cloud[:10])
    assert same_bits(pkss.read_points(tmp_path / "two.npz", array="normals"), cloud[:10])
    np.savez(tmp_path / "anon.npz", cloud, cloud[:3])
    with pytest.raises(pkss.InvalidArgument, match="none named 'points' or 'xyz'"):
        pkss.read_points(tmp_path / "anon.npz")
    with pytest.raises(pkss.InvalidArgument, match="no array 'nope'"):
        pkss.read_points(tmp_path / "two.npz", array="nope")
    np.savez_compressed(tmp_path / "z.npz", points=cloud)
    with pytest.raises(pkss.InvalidArgument, match="savez_compressed") as e:
        pkss.read_points(tmp_path / "z.npz")
    assert e.value.name == "PKSS_ERR_UNSUPPORTED_FORMAT"


def test_read_only_formats(tmp_path):
    pts = SPECIAL[1:3]  # finite, ordinary values
    rows = "".join("%.17g %.17g %.17g\n" % tuple(p) for p in pts)
    (tmp_path / "a.off").write_text("OFF\n%d 0 0\n%s" % (len(pts), rows))
    (tmp_path / "a.vtk").write_text("# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n"
                                    "POINTS %d double\n%s" % (len(pts), rows))
    (tmp_path / "a.csv").write_text("x,y,z\n" + rows.replace(" ", ","))
    (tmp_path / "a.bin").write_bytes(b"".join(struct.pack("<4f", *p, 0.0) for p in pts))
    for name in ("a.off", "a.vtk", "a.csv"):
        assert same_bits(pkss.read_points(tmp_path / name), pts), name
    assert same_bits(pkss.read_points(tmp_path / "a.bin"), pts.astype(np.float32).astype(float))


def test_errors(tmp_path, cloud):
    with pytest.raises(pkss.FileError) as e:
        pkss.read_points(tmp_path / "missing.ply")
    assert isinstance(e.value, OSError) and e.value.name == "PKSS_ERR_IO"
    assert "missing.ply" in str(e.value)
    (tmp_path / "bad.ply").write_text("ply\nformat ascii 1.0\nelement vertex 5\n")
    with pytest.raises(pkss.InvalidArgument) as e:
        pkss.read_points(tmp_path / "bad.ply")
    assert isinstance(e.value, ValueError) and e.value.name == "PKSS_ERR_FORMAT"
    (tmp_path / "empty.xyz").write_bytes(b"")
    with pytest.raises(pkss.InvalidArgument, match="empty") as e:
        pkss.read_points(tmp_path / "empty.xyz")
    assert e.value.name == "PKSS_ERR_EMPTY_INPUT"
    with pytest.raises(pkss.InvalidArgument, match="unknown format"):
        pkss.read_points(tmp_path / "bad.ply", format="obj")
    with pytest.raises(pkss.InvalidArgument, match="cannot write format 'off'"):
        pkss.write_points(tmp_path / "x.off", cloud)
    assert not (tmp_path / "x.off").exists()
    with pytest.raises(pkss.InvalidArgument, match="give the format"):
        pkss.write_points("-", cloud)
    with pytest.raises(pkss.FileError):
        pkss.write_points(tmp_path / "no" / "dir" / "x.ply", cloud)
    with pytest.raises(pkss.InvalidArgument, match=r"\(N, 3\)"):
        pkss.write_points(tmp_path / "x.ply", cloud[:, :2])
    # a refused write leaves the existing file as it was
    pkss.write_points(tmp_path / "keep.npy", cloud)
    with pytest.raises(pkss.InvalidArgument):
        pkss.write_points(tmp_path / "keep.npy", np.zeros((0, 3)))
    assert same_bits(pkss.read_points(tmp_path / "keep.npy"), cloud)


def test_open3d_not_imported():
    code = "import sys, pkss; pkss.read_points; assert 'open3d' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_open3d_inputs(tmp_path, cloud):
    o3d = pytest.importorskip("open3d", reason="open3d is not installed "
                              "(pip install open3d) : the tensor-input test needs it")
    legacy = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud))
    tensor64 = o3d.core.Tensor(cloud)
    tcloud = o3d.t.geometry.PointCloud(tensor64)
    tcloud32 = o3d.t.geometry.PointCloud(o3d.core.Tensor(cloud.astype(np.float32)))
    for obj, want in [(legacy, cloud), (tensor64, cloud), (tcloud, cloud),
                      (tcloud32, cloud.astype(np.float32).astype(np.float64)),
                      (o3d.core.Tensor(cloud.astype(np.float32)),
                       cloud.astype(np.float32).astype(np.float64))]:
        pkss.write_points(tmp_path / "o.npy", obj)
        assert same_bits(pkss.read_points(tmp_path / "o.npy"), want), type(obj)
    r = pkss.register(tcloud, o3d.t.geometry.PointCloud(o3d.core.Tensor(cloud * 2.0)), **FAST)
    assert abs(r.scale - 2.0) < 0.02
    assert np.allclose(r.apply(tcloud), r.apply(cloud))
    with pytest.raises(pkss.InvalidArgument, match="positions"):
        pkss.register(o3d.t.geometry.PointCloud(), cloud, **FAST)
