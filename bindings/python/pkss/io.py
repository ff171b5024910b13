# SPDX-License-Identifier: MIT
"""Point cloud files through the C library's readers and writers
(include/pkss_io.h): the same fuzzed code as the pkss-align tool.

    xyz = pkss.read_points("scan.ply")             # (N, 3) float64
    xyz = pkss.read_points("clouds.npz:target")    # one array of an .npz
    pkss.write_points("aligned.pcd", result.apply(xyz))

Read: PLY, PCD (ascii/binary/LZF), XYZ/TXT/CSV/PTS/ASC, OFF, KITTI .bin,
legacy VTK, NumPy .npy (float64/float32, (N, 3), C or Fortran order) and
.npz (np.savez; the array ``file.npz:NAME``, else the only one, else
"points" or "xyz"). Written: PLY (binary, or ``ascii=True``), PCD, XYZ and
.npy; every written double reads back bit-identically.

Errors: a file that cannot be opened, read or written raises
:class:`FileError` (also an ``OSError``); malformed, truncated, empty or
unsupported content raises :class:`pkss.InvalidArgument` (a ``ValueError``)
whose ``name`` says which (``PKSS_ERR_FORMAT``, ``PKSS_ERR_EMPTY_INPUT``,
``PKSS_ERR_UNSUPPORTED_FORMAT``) and whose ``detail`` names the file and
the byte or line.
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from typing import Any, Optional, Union

import numpy as np

from . import Error, _as_points, _invalid
from ._lib import ffi, lib

__all__ = ["read_points", "write_points", "FileError", "FORMATS", "WRITABLE_FORMATS"]

#: Names accepted by ``format=`` when reading (extensions work as well).
FORMATS = ("ply", "pcd", "xyz", "off", "kitti", "vtk", "npy", "npz")
#: Formats :func:`write_points` can write.
WRITABLE_FORMATS = ("ply", "pcd", "xyz", "npy")

_DETAIL = 1024
PathLike = Union[str, bytes, "os.PathLike[str]"]


class FileError(Error, OSError):
    """A file that cannot be opened, read or written (``PKSS_ERR_IO``)."""

    def __str__(self) -> str:  # Error's form, not OSError's "[Errno 101]"
        return Error.__str__(self)


def _fail(status: int, detail: Any) -> Error:
    text = ffi.string(detail).decode("utf-8", errors="replace")
    if status == lib.PKSS_ERR_IO:
        return FileError(status, text)
    return Error.class_for(status)(status, text)


def _format_code(format: Optional[str]) -> int:
    if format is None:
        return lib.PKSS_FORMAT_AUTO
    if not isinstance(format, str):
        raise _invalid("format: expected a name such as 'ply', got %r" % (format,))
    code = lib.pkss_format_from_name(format.lstrip(".").encode())
    if lib.pkss_format_name(code) == ffi.NULL:
        raise _invalid("format: unknown format %r (known: %s)" % (format, ", ".join(FORMATS)))
    return code


def _take(xyz: Any, n: Any) -> np.ndarray:
    try:
        return np.frombuffer(ffi.buffer(xyz[0], n[0] * 24), dtype=np.float64).reshape(-1, 3).copy()
    finally:
        lib.pkss_points_free(xyz[0])


def read_points(path: Union[PathLike, Any], format: Optional[str] = None,
                array: Optional[str] = None) -> np.ndarray:
    """Read a point cloud file into an (N, 3) float64 array (x, y, z).

    ``path``: a file name (``"-"`` is standard input), or a binary file
    object (anything with ``.read()``, e.g. ``io.BytesIO``). ``format``: a
    name from :data:`FORMATS`, or None to go by the extension, else by the
    content. ``array``: the member of an .npz to read (same as
    ``"file.npz:NAME"``). NaN/Inf coordinates are returned as read."""
    code = _format_code(format)
    xyz = ffi.new("double **")
    n = ffi.new("size_t *")
    detail = ffi.new("char[]", _DETAIL)
    if hasattr(path, "read"):
        data = path.read()
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise _invalid("path: the file object must be opened in binary mode ('rb')")
        buf = ffi.from_buffer(data)
        st = lib.pkss_read_points_buffer(buf, len(buf), code,
                                         array.encode() if array else ffi.NULL,
                                         xyz, n, detail, _DETAIL)
    else:
        name = os.fsencode(path)
        if array is not None:
            name += b":" + array.encode()
            if code == lib.PKSS_FORMAT_AUTO:
                code = lib.PKSS_FORMAT_NPZ
        st = lib.pkss_read_points(name, code, xyz, n, detail, _DETAIL)
    if st != lib.PKSS_OK:
        raise _fail(st, detail)
    return _take(xyz, n)


def write_points(path: Union[PathLike, Any], xyz: Any, format: Optional[str] = None,
                 ascii: bool = False) -> None:
    """Write (N, 3) points (any array-like, Open3D clouds and tensors too).

    ``format``: one of :data:`WRITABLE_FORMATS`, or None for the extension
    (needed for ``"-"``, standard output, and for file objects). ``ascii``:
    PLY as text. An existing file is replaced only once the new one is
    complete."""
    a = _as_points(xyz, "xyz", finite=False)
    code = _format_code(format)
    detail = ffi.new("char[]", _DETAIL)
    to_stream = hasattr(path, "write") or (isinstance(path, str) and path == "-")
    if to_stream:
        if code == lib.PKSS_FORMAT_AUTO:
            raise _invalid("format: give the format when writing to a stream")
        stream = path if hasattr(path, "write") else sys.stdout.buffer
        # The C writer takes a path: write a private file, then copy it, so
        # Python's own buffering of the stream stays in order.
        with tempfile.TemporaryDirectory(prefix="pkss-") as d:
            tmp = os.path.join(d, "points")
            _write(tmp.encode(), code, a, ascii, detail)
            with open(tmp, "rb") as f:
                shutil.copyfileobj(f, stream)
        if hasattr(stream, "flush"):
            stream.flush()
        return
    _write(os.fsencode(path), code, a, ascii, detail)


def _write(name: bytes, code: int, a: np.ndarray, ascii: bool, detail: Any) -> None:
    st = lib.pkss_write_points(name, code, ffi.from_buffer("double[]", a), a.shape[0],
                               lib.PKSS_WRITE_ASCII if ascii else 0, detail, _DETAIL)
    if st != lib.PKSS_OK:
        raise _fail(st, detail)
