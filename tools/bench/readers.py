# SPDX-License-Identifier: MIT
"""Point-cloud file readers for the benchmark, numpy only.

Every reader returns the x y z columns as a float64 (n, 3) array; other
columns (normals, colours, faces) are ignored. Non-finite points are
dropped (organized PCD clouds mark missing points with NaN).

Formats: PLY (ascii, binary_little_endian, binary_big_endian; any scalar
properties; list properties such as faces after the vertices are skipped),
PCD (ascii, binary, binary_compressed with LZF), XYZ/CSV/TXT text (first
three numeric columns, comma and/or blank separated, a non-numeric header
line skipped, a first line holding one integer taken as a point count),
KITTI .bin (float32 x y z reflectance records), numpy .npy, and 4x4
transform text files (``#`` comments).
"""
from __future__ import annotations

import os
import re

import numpy as np

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _finite(xyz: np.ndarray) -> np.ndarray:
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    return np.ascontiguousarray(xyz[np.isfinite(xyz).all(axis=1)])


def read_ply(path: str) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError(f"{path}: not a PLY file")
    nl = data.find(b"\n", end)
    header = data[:end].decode("ascii", "replace").splitlines()
    body = data[nl + 1:]
    fmt = None
    elements = []  # (name, count, [(prop, type) or (prop, ('list', ctype, itype))])
    for line in header:
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format":
            fmt = tok[1]
        elif tok[0] == "element":
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property":
            if tok[1] == "list":
                elements[-1][2].append((tok[4], ("list", tok[2], tok[3])))
            else:
                elements[-1][2].append((tok[2], tok[1]))
    if not elements or elements[0][0] != "vertex":
        # vertex need not be first in general; find it
        pass
    if fmt == "ascii":
        lines = body.decode("ascii", "replace").split("\n")
        pos = 0
        for name, count, props in elements:
            if name == "vertex":
                names = [p[0] for p in props]
                if any(isinstance(p[1], tuple) for p in props):
                    raise ValueError(f"{path}: list property in vertex element")
                rows = np.array(" ".join(lines[pos:pos + count]).split(),
                                dtype=np.float64).reshape(count, len(props))
                idx = [names.index(c) for c in ("x", "y", "z")]
                return _finite(rows[:, idx])
            pos += count
        raise ValueError(f"{path}: no vertex element")
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{path}: unsupported PLY format {fmt}")
    endian = "<" if fmt == "binary_little_endian" else ">"
    off = 0
    for name, count, props in elements:
        if any(isinstance(p[1], tuple) for p in props):
            if name == "vertex":
                raise ValueError(f"{path}: list property in vertex element")
            break  # lists only after the vertices matter not
        dt = np.dtype([(p[0], endian + _PLY_TYPES[p[1]]) for p in props])
        if name == "vertex":
            arr = np.frombuffer(body, dtype=dt, count=count, offset=off)
            return _finite(np.stack([arr["x"], arr["y"], arr["z"]], axis=1))
        off += dt.itemsize * count
    raise ValueError(f"{path}: no vertex element before list elements")


def _lzf_decompress(src: bytes, out_len: int) -> bytes:
    out = bytearray(out_len)
    i = o = 0
    n = len(src)
    while i < n:
        ctrl = src[i]
        i += 1
        if ctrl < 32:
            ln = ctrl + 1
            out[o:o + ln] = src[i:i + ln]
            i += ln
            o += ln
        else:
            ln = ctrl >> 5
            ref = o - ((ctrl & 0x1F) << 8) - 1
            if ln == 7:
                ln += src[i]
                i += 1
            ref -= src[i]
            i += 1
            ln += 2
            for k in range(ln):  # may overlap: byte by byte
                out[o + k] = out[ref + k]
            o += ln
    if o != out_len:
        raise ValueError("LZF: size mismatch")
    return bytes(out)


def read_pcd(path: str) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    hdr = {}
    pos = 0
    while True:
        nl = data.find(b"\n", pos)
        line = data[pos:nl].decode("ascii", "replace").strip()
        pos = nl + 1
        if not line or line.startswith("#"):
            continue
        key, *vals = line.split()
        hdr[key.upper()] = vals
        if key.upper() == "DATA":
            break
    fields = hdr["FIELDS"]
    sizes = [int(s) for s in hdr["SIZE"]]
    types = hdr["TYPE"]
    counts = [int(c) for c in hdr.get("COUNT", ["1"] * len(fields))]
    npts = int(hdr["POINTS"][0])
    kind = hdr["DATA"][0].lower()
    np_t = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2",
            ("I", 4): "i4", ("I", 8): "i8", ("U", 1): "u1", ("U", 2): "u2",
            ("U", 4): "u4", ("U", 8): "u8"}
    if kind == "ascii":
        txt = data[pos:].decode("ascii", "replace").split()
        ncol = sum(counts)
        arr = np.array(txt[: npts * ncol], dtype=np.float64).reshape(npts, ncol)
        col = {}
        c = 0
        for fld, cnt in zip(fields, counts):
            col[fld] = c
            c += cnt
        return _finite(arr[:, [col["x"], col["y"], col["z"]]])
    dt_fields = []
    for fld, sz, ty, cnt in zip(fields, sizes, types, counts):
        base = "<" + np_t[(ty, sz)]
        dt_fields.append((fld, base, (cnt,)) if cnt > 1 else (fld, base))
    # '_' fields (padding) may repeat: rename
    seen = {}
    fixed = []
    for f_ in dt_fields:
        name = f_[0]
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            name = f"{name}_{seen[name]}"
        fixed.append((name,) + f_[1:])
    dt = np.dtype(fixed)
    if kind == "binary":
        arr = np.frombuffer(data, dtype=dt, count=npts, offset=pos)
        xyz = np.stack([arr["x"], arr["y"], arr["z"]], axis=1)
    elif kind == "binary_compressed":
        csize, usize = np.frombuffer(data, dtype="<u4", count=2, offset=pos)
        raw = _lzf_decompress(data[pos + 8: pos + 8 + int(csize)], int(usize))
        # column-major layout: all values of field 0, then field 1, ...
        cols = {}
        off = 0
        for fld, sz, ty, cnt in zip(fields, sizes, types, counts):
            nbytes = sz * cnt * npts
            if fld in ("x", "y", "z"):
                cols[fld] = np.frombuffer(raw, dtype="<" + np_t[(ty, sz)],
                                          count=npts * cnt, offset=off)[::cnt]
            off += nbytes
        xyz = np.stack([cols["x"], cols["y"], cols["z"]], axis=1)
    else:
        raise ValueError(f"{path}: unsupported PCD DATA {kind}")
    return _finite(xyz)


def read_text(path: str) -> np.ndarray:
    rows = []
    declared = None
    with open(path, "r", errors="replace") as f:
        for k, line in enumerate(f):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            tok = [t for t in re.split(r"[,\s;]+", line) if t]
            try:
                vals = [float(t) for t in tok[:3]]
            except ValueError:
                if not rows:
                    continue  # header line
                raise
            if not rows and declared is None and len(tok) == 1:
                declared = int(vals[0])
                continue
            if len(vals) < 3:
                raise ValueError(f"{path}:{k + 1}: fewer than 3 columns")
            rows.append(vals)
    xyz = np.array(rows, dtype=np.float64)
    if declared is not None and declared != len(xyz):
        raise ValueError(f"{path}: declares {declared} points, has {len(xyz)}")
    return _finite(xyz)


def read_kitti_bin(path: str) -> np.ndarray:
    return _finite(np.fromfile(path, dtype="<f4").reshape(-1, 4)[:, :3])


def read_points(path: str) -> np.ndarray:
    ext = os.path.splitext(path)[1].lower()
    if ext == ".ply":
        return read_ply(path)
    if ext == ".pcd":
        return read_pcd(path)
    if ext == ".bin":
        return read_kitti_bin(path)
    if ext == ".npy":
        return _finite(np.load(path))
    if ext in (".xyz", ".txt", ".csv", ".pts", ".asc"):
        return read_text(path)
    raise ValueError(f"{path}: unknown point-cloud extension {ext}")


def read_matrix(path: str) -> np.ndarray:
    """A 4x4 matrix from a text file ('#' comments, blank separated)."""
    vals = []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                vals.extend(float(t) for t in line.split())
    m = np.array(vals, dtype=np.float64)
    if m.size != 16:
        raise ValueError(f"{path}: expected 16 numbers, got {m.size}")
    return m.reshape(4, 4)


def read_pose_list(path: str) -> dict:
    """Stanford-style gt_poses_4x4.txt: a scan name line then 4 rows."""
    poses = {}
    name = None
    rows = []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            tok = line.split()
            try:
                vals = [float(t) for t in tok]
            except ValueError:
                name, rows = line, []
                continue
            rows.append(vals)
            if len(rows) == 4:
                poses[name] = np.array(rows, dtype=np.float64)
    return poses
