# SPDX-License-Identifier: MIT
"""Shared helpers: the shared data folder, a tiny PLY reader, random
similarities and pose errors (the same definitions as tests/support.c)."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Dict, Tuple

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
HEADER = REPO / "include" / "pkss.h"
DATA = Path(os.environ.get("PKSS_DATA_DIR") or REPO.parent / "shared" / "data")

# A quick configuration for tests that check the API, not accuracy.
FAST = dict(points=256, rotation_steps=8, offset_steps=1, top_k=2, backend="reference")


def data_file(relative: str) -> Path:
    p = DATA / relative
    if not p.is_file():
        pytest.skip("%s not found: the shared data folder (../shared/data next to the "
                    "repository, or $PKSS_DATA_DIR) is absent" % relative)
    return p


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4",
              "double": "f8", "float64": "f8"}


def read_ply(path: Path) -> np.ndarray:
    """x, y, z of the vertex element of an ascii or binary_little_endian PLY
    whose first element is the vertices (all our data files)."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError("%s: not a PLY file" % path)
        fmt, n, props, in_vertex, seen_element = None, None, [], False, False
        while True:
            line = f.readline()
            if not line:
                raise ValueError("%s: no end_header" % path)
            words = line.decode("ascii").split()
            if not words:
                continue
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                in_vertex = words[1] == "vertex"
                if in_vertex:
                    if seen_element:
                        raise ValueError("%s: vertex is not the first element" % path)
                    n = int(words[2])
                seen_element = True
            elif words[0] == "property" and in_vertex:
                if words[1] == "list":
                    raise ValueError("%s: list property in vertex element" % path)
                props.append((words[2], _PLY_TYPES[words[1]]))
            elif words[0] == "end_header":
                break
        names = [p[0] for p in props]
        cols = [names.index(c) for c in ("x", "y", "z")]
        if fmt == "ascii":
            rows = [f.readline().split() for _ in range(n)]
            return np.array([[float(r[c]) for c in cols] for r in rows], dtype=np.float64)
        if fmt == "binary_little_endian":
            dtype = np.dtype([(name, "<" + t) for name, t in props])
            rec = np.frombuffer(f.read(dtype.itemsize * n), dtype=dtype, count=n)
            return np.stack([rec[c].astype(np.float64) for c in ("x", "y", "z")], axis=1)
        raise ValueError("%s: unsupported PLY format %s" % (path, fmt))


def load(relative: str) -> np.ndarray:
    return read_ply(data_file(relative))


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    w, x, y, z = rng.normal(size=4)
    n = np.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def random_similarity(rng: np.random.Generator, max_t: float) -> np.ndarray:
    """Scale log-uniform in [0.5, 2], uniform rotation, |t_i| <= max_t."""
    T = np.eye(4)
    T[:3, :3] = np.exp(rng.uniform(np.log(0.5), np.log(2.0))) * random_rotation(rng)
    T[:3, 3] = rng.uniform(-max_t, max_t, size=3)
    return T


def apply(T: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    return xyz @ T[:3, :3].T + T[:3, 3]


def decompose(T: np.ndarray) -> Tuple[float, np.ndarray]:
    s = float(np.cbrt(np.linalg.det(T[:3, :3])))
    return s, T[:3, :3] / s


def pose_error(T_est: np.ndarray, T_gt: np.ndarray, at: np.ndarray) -> Dict[str, float]:
    """Rotation angle (degrees), relative scale error, and the distance
    between where the two transforms put the point `at`."""
    se, Re = decompose(T_est)
    sg, Rg = decompose(T_gt)
    c = np.clip((np.sum(Re * Rg) - 1.0) / 2.0, -1.0, 1.0)
    return {"rot_deg": float(np.degrees(np.arccos(c))), "scale_rel": abs(se / sg - 1.0),
            "trans": float(np.linalg.norm(apply(T_est, at[None]) - apply(T_gt, at[None])))}


def diameter(xyz: np.ndarray) -> float:
    return float(np.linalg.norm(xyz.max(axis=0) - xyz.min(axis=0)))


def shape(n: int = 600, seed: int = 3) -> np.ndarray:
    """A small asymmetric synthetic cloud: three blobs of different sizes
    and a bar, so the pose is unique."""
    rng = np.random.default_rng(seed)
    parts = [rng.normal([0, 0, 0], [1.0, 0.5, 0.3], size=(n // 2, 3)),
             rng.normal([2.5, 0.5, 0], [0.4, 0.4, 0.4], size=(n // 6, 3)),
             rng.normal([0, 2.0, 0.8], [0.2, 0.6, 0.2], size=(n // 6, 3))]
    bar = np.zeros((n - sum(len(p) for p in parts), 3))
    bar[:, 0] = np.linspace(-2, 1, len(bar))
    bar[:, 2] = -1 + 0.05 * rng.normal(size=len(bar))
    return np.concatenate(parts + [bar])


class LibSpy:
    """Stands in for pkss.lib: records calls of chosen C functions.
    `wrap` maps a function name to a factory taking the real function."""

    def __init__(self, lib: Any, wrap: Dict[str, Callable[[Any], Any]]) -> None:
        self._lib = lib
        self._wrapped = {name: factory(getattr(lib, name)) for name, factory in wrap.items()}

    def __getattr__(self, name: str) -> Any:
        if name in self._wrapped:
            return self._wrapped[name]
        return getattr(self._lib, name)


@pytest.fixture
def header_text() -> str:
    if not HEADER.is_file():
        pytest.skip("include/pkss.h not found: the tests are not run from a pkss checkout")
    return HEADER.read_text(encoding="utf-8")


@pytest.fixture(scope="session")
def small() -> np.ndarray:
    return shape()
