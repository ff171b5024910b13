#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the small seed corpora of the pkss_io fuzzers into corpus/<fmt>/.

Run from anywhere: python3 tests/fuzz/make_corpus.py [DATA_DIR]
DATA_DIR (default ../shared/data next to the repository) supplies the
first lines of a few real files; without it only synthetic seeds are made.
Every seed is tiny (< 1 KB) so the whole corpus stays a few KB.
"""
import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "corpus")
DATA = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    HERE, "..", "..", "..", "shared", "data")


def put(fmt, name, data):
    d = os.path.join(OUT, fmt)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def head_lines(path, n):
    try:
        with open(os.path.join(DATA, path), "rb") as f:
            return [f.readline() for _ in range(n)]
    except OSError:
        return None


def lzf_compress(data):
    """Greedy LZF compressor (liblzf format), good enough for seeds."""
    out = bytearray()
    lit = bytearray()
    i, n = 0, len(data)
    table = {}

    def flush():
        nonlocal lit
        while lit:
            chunk = lit[:32]
            out.append(len(chunk) - 1)
            out.extend(chunk)
            lit = lit[32:]

    while i < n:
        key = bytes(data[i:i + 3])
        ref = table.get(key) if len(key) == 3 else None
        table[key] = i
        if ref is not None and i - ref - 1 < 8192:
            length = 3
            while (i + length < n and length < 264
                   and data[ref + length] == data[i + length]):
                length += 1
            flush()
            off = i - ref - 1
            l2 = length - 2
            if l2 < 7:
                out.append((l2 << 5) | (off >> 8))
            else:
                out.append((7 << 5) | (off >> 8))
                out.append(l2 - 7)
            out.append(off & 0xFF)
            i += length
        else:
            lit.append(data[i])
            i += 1
    flush()
    return bytes(out)


PTS = [(0.5, -1.25, 2.0), (1.0, 2.0, 3.0), (-4.5, 0.0, 1e-3),
       (7.0, 8.0, 9.0), (1.5, 1.5, 1.5)]


def ply_seeds():
    body = "".join("%g %g %g\n" % p for p in PTS)
    put("ply", "ascii_basic.ply",
        "ply\nformat ascii 1.0\ncomment seed\nelement vertex 5\n"
        "property float x\nproperty float y\nproperty float z\n"
        "end_header\n" + body)
    put("ply", "ascii_face_before_vertex.ply",
        "ply\nformat ascii 1.0\nelement face 2\n"
        "property list uchar int vertex_indices\nelement vertex 5\n"
        "property double x\nproperty double y\nproperty double z\n"
        "property uchar red\nend_header\n3 0 1 2\n3 2 3 4\n" +
        "".join("%g %g %g 255\n" % p for p in PTS))
    lines = head_lines("stanford_bunny/bun000.ply", 40)
    if lines:
        hdr = []
        for ln in lines:
            s = ln.decode("ascii", "replace")
            if s.startswith("element vertex"):
                s = "element vertex 3\n"
            elif s.startswith("element range_grid"):
                s = "element range_grid 4\n"
            hdr.append(s)
            if s.startswith("end_header"):
                break
        put("ply", "bunny_range_grid.ply",
            "".join(hdr) + "".join("%g %g %g\n" % p for p in PTS[:3]) +
            "1 0\n0\n1 2\n0\n")
    le = b"".join(struct.pack("<fff", *p) for p in PTS)
    put("ply", "binary_le_float.ply",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 5\n"
        b"property float x\nproperty float y\nproperty float z\n"
        b"end_header\n" + le)
    be = b"".join(struct.pack(">BdhdB", 1, p[0], 7, p[1], 2) +
                  struct.pack(">d", p[2]) for p in PTS)
    put("ply", "binary_be_mixed.ply",
        b"ply\nformat binary_big_endian 1.0\nelement vertex 5\n"
        b"property uint8 flag\nproperty float64 x\nproperty int16 s\n"
        b"property float64 y\nproperty uchar c\nproperty float64 z\n"
        b"end_header\n" + be)
    lst = b"".join(struct.pack("<B", 2) + struct.pack("<ii", 1, 2) +
                   struct.pack("<hhh", int(p[0]), int(p[1]), int(p[2]))
                   for p in PTS)
    put("ply", "binary_list_in_vertex.ply",
        b"ply\r\nformat binary_little_endian 1.0\r\nelement vertex 5\r\n"
        b"property list uchar int idx\r\nproperty short x\r\n"
        b"property short y\r\nproperty short z\r\nend_header\r\n" + lst +
        b"\x00")


def pcd_seeds():
    hdr = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
           "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
           "WIDTH 5\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 5\n")
    put("pcd", "ascii.pcd", hdr + "DATA ascii\n" +
        "".join("%g %g %g 4278190080\n" % p for p in PTS[:4]) +
        "nan nan nan 0\n")
    rows = b"".join(struct.pack("<fffI", p[0], p[1], p[2], 7) for p in PTS)
    put("pcd", "binary.pcd", hdr.encode() + b"DATA binary\n" + rows)
    soa = (b"".join(struct.pack("<f", p[0]) for p in PTS) +
           b"".join(struct.pack("<f", p[1]) for p in PTS) +
           b"".join(struct.pack("<f", p[2]) for p in PTS) +
           b"".join(struct.pack("<I", 7) for p in PTS))
    comp = lzf_compress(soa)
    put("pcd", "binary_compressed.pcd",
        hdr.encode() + b"DATA binary_compressed\n" +
        struct.pack("<II", len(comp), len(soa)) + comp)
    # repetitive data so the LZF stream has back references
    n = 16
    soa2 = (struct.pack("<f", 1.0) * n + struct.pack("<f", 2.0) * n +
            struct.pack("<d", 3.0) * n)
    comp2 = lzf_compress(soa2)
    put("pcd", "compressed_backref.pcd",
        ("VERSION .7\nFIELDS x y z\nSIZE 4 4 8\nTYPE F F F\nCOUNT 1 1 1\n"
         "WIDTH 4\nHEIGHT 4\nPOINTS 16\nDATA binary_compressed\n").encode() +
        struct.pack("<II", len(comp2), len(soa2)) + comp2)
    lines = head_lines("pcl/bun4.pcd", 15)
    if lines:
        txt = b"".join(lines).replace(b"WIDTH 361", b"WIDTH 5").replace(
            b"POINTS 361", b"POINTS 5")
        put("pcd", "pcl_bun4_head.pcd", txt)


def xyz_seeds():
    put("xyz", "plain.xyz", "".join("%g %g %g\n" % p for p in PTS))
    put("xyz", "csv_header.csv", "x,y,z,nx,ny,nz\n" +
        "".join("%g , %g , %g , 0,0,1\n" % p for p in PTS))
    put("xyz", "count_line.txt", "5\n" + "".join("%g %g %g\n" % p
                                                 for p in PTS))
    put("xyz", "comments_crlf.pts", "# comment\r\n\r\n" +
        "".join("%g\t%g\t%g 10 255 0 0 # c\r\n" % p for p in PTS))
    lines = head_lines("libpointmatcher/car_cloud400.csv", 6)
    if lines:
        put("xyz", "car_cloud400_head.csv", b"".join(lines))


def off_seeds():
    put("off", "cube.off", "OFF\n# cube\n8 6 12\n" +
        "".join("%d %d %d\n" % (x, y, z) for x in (0, 1) for y in (0, 1)
                for z in (0, 1)) +
        "4 0 1 3 2\n4 4 5 7 6\n4 0 1 5 4\n4 2 3 7 6\n4 0 2 6 4\n4 1 3 7 5\n")
    put("off", "coff_same_line.off", "COFF 5 1 0\n" +
        "".join("%g %g %g 255 0 0 255\n" % p for p in PTS) + "3 0 1 2\n")
    put("off", "glued_modelnet.off", "OFF5 1 0\n" +
        "".join("%g %g %g\n" % p for p in PTS) + "3 0 1 2\n")
    put("off", "noff.off", "NOFF\n5 0\n" +
        "".join("%g %g %g 0 0 1\n" % p for p in PTS))


def kitti_seeds():
    put("kitti", "three.bin", b"".join(struct.pack("<ffff", p[0], p[1], p[2],
                                                   0.5) for p in PTS[:3]))
    try:
        with open(os.path.join(DATA, "kitti_patchworkpp/000000.bin"),
                  "rb") as f:
            put("kitti", "kitti_000000_head.bin", f.read(16 * 8))
    except OSError:
        pass


def vtk_seeds():
    put("vtk", "ascii_polydata.vtk",
        "# vtk DataFile Version 3.0\nseed\nASCII\nDATASET POLYDATA\n"
        "POINTS 5 float\n" + "".join("%g %g %g\n" % p for p in PTS) +
        "VERTICES 5 10\n1 0\n1 1\n1 2\n1 3\n1 4\n")
    put("vtk", "binary_be_double.vtk",
        b"# vtk DataFile Version 2.0\nseed\nBINARY\n"
        b"DATASET UNSTRUCTURED_GRID\nPOINTS 5 double\n" +
        b"".join(struct.pack(">ddd", *p) for p in PTS) + b"\n")
    put("vtk", "binary_be_float_structured.vtk",
        b"# vtk DataFile Version 3.0\nseed\nBINARY\n"
        b"DATASET STRUCTURED_GRID\nDIMENSIONS 5 1 1\nPOINTS 5 float\n" +
        b"".join(struct.pack(">fff", *p) for p in PTS))
    lines = head_lines("pcl/tum_rabbit.vtk", 7)
    if lines:
        txt = b"".join(lines).replace(b"POINTS 10429", b"POINTS 3")
        put("vtk", "tum_rabbit_head.vtk", txt)


def npy_bytes(pts, descr="<f8", fortran=False, version=(1, 0), header=None):
    """An .npy file as numpy writes it (header padded to 64 bytes)."""
    fmt = {"<f8": "<d", ">f8": ">d", "<f4": "<f", ">f4": ">f"}[descr]
    if header is None:
        header = "{'descr': '%s', 'fortran_order': %s, 'shape': (%d, 3), }" % (
            descr, "True" if fortran else "False", len(pts))
    pre = 10 if version[0] == 1 else 12
    pad = (-(pre + len(header) + 1)) % 64
    header = (header + " " * pad + "\n").encode("utf-8" if version[0] == 3 else "latin1")
    size = struct.pack("<H", len(header)) if version[0] == 1 else struct.pack("<I", len(header))
    cols = [c for p in pts for c in p] if not fortran else [p[k] for k in range(3) for p in pts]
    return (b"\x93NUMPY" + bytes(version) + size + header +
            b"".join(struct.pack(fmt, c) for c in cols))


def npz_bytes(members):
    """A stored zip of .npy members with zip64 local headers, like np.savez."""
    import io
    import zipfile
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as z:
        for name, data in members:
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            with z.open(info, "w", force_zip64=True) as f:
                f.write(data)
    return buf.getvalue()


def npy_seeds():
    put("npy", "f8_c_v1.npy", npy_bytes(PTS))
    put("npy", "f4_fortran.npy", npy_bytes(PTS, "<f4", fortran=True))
    put("npy", "f8_be_v2.npy", npy_bytes(PTS[:2], ">f8", version=(2, 0)))
    put("npy", "f4_v3.npy", npy_bytes(PTS[:3], "<f4", version=(3, 0)))
    put("npy", "py2_long.npy", npy_bytes(PTS[:2], header=(
        "{'descr': '<f8', 'fortran_order': False, 'shape': (2L, 3L), }")))


def npz_seeds():
    put("npz", "single.npz", npz_bytes([("arr_0.npy", npy_bytes(PTS))]))
    put("npz", "points_and_more.npz", npz_bytes([
        ("normals.npy", npy_bytes(PTS[:2], "<f4")), ("points.npy", npy_bytes(PTS))]))
    put("npz", "xyz.npz", npz_bytes([("xyz.npy", npy_bytes(PTS[:3], "<f4", fortran=True)),
                                     ("ids.npy", npy_bytes(PTS[:1]))]))


if __name__ == "__main__":
    ply_seeds()
    pcd_seeds()
    xyz_seeds()
    off_seeds()
    kitti_seeds()
    vtk_seeds()
    npy_seeds()
    npz_seeds()
    total = 0
    for root, _, files in os.walk(OUT):
        for fn in files:
            total += os.path.getsize(os.path.join(root, fn))
    print("corpus: %d bytes in %s" % (total, OUT))
