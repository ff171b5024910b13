# SPDX-License-Identifier: MIT
"""Finds and loads libpkss (cffi ABI mode) and checks its version.

Loader order:
  1. the library bundled in this package by ``pip install`` (lib/libpkss.so.1);
  2. the file named by the ``PKSS_LIBRARY`` environment variable;
  3. ``ctypes.util.find_library("pkss")`` (a system-wide install).
"""
from __future__ import annotations

import ctypes.util
import os
import sys
from pathlib import Path
from typing import List, Tuple

_HERE = Path(__file__).resolve().parent

# lib/ holds the library under the name the bundled tools (bin/) link to.
if sys.platform == "darwin":
    BUNDLED_NAMES = ("lib/libpkss.1.dylib",)
elif sys.platform == "win32":
    BUNDLED_NAMES = ("pkss.dll",)
else:
    BUNDLED_NAMES = ("lib/libpkss.so.1",)


def _load_ffi():
    try:
        from ._pkss import ffi  # generated at build time from include/pkss.h
        return ffi
    except ImportError:
        pass
    # Running from a source checkout (PYTHONPATH=bindings/python): build the
    # same declarations from the header in the tree.
    from . import _build

    root = _build.find_repo_root(_HERE)
    if root is None:
        raise ImportError(
            "pkss: the generated module pkss._pkss is missing and no pkss source tree was "
            "found; install the package with `pip install ./bindings/python`")
    import cffi

    ffi = cffi.FFI()
    ffi.cdef(_build.cdef_for(root / "include"))
    return ffi


def _candidates() -> List[Tuple[str, str]]:
    """(how it was found, path or name) in loader order."""
    out = []
    for name in BUNDLED_NAMES:
        p = _HERE / name
        if p.is_file():
            out.append(("bundled", str(p)))
    env = os.environ.get("PKSS_LIBRARY")
    if env:
        out.append(("PKSS_LIBRARY", env))
    found = ctypes.util.find_library("pkss")
    if found:
        out.append(("find_library", found))
    return out


def check_version(runtime_number: int, cdef_major: int) -> None:
    """Raise ImportError if the loaded library's major version differs from
    the header the binding was built from (the ABI may have changed)."""
    if runtime_number // 10000 != cdef_major:
        raise ImportError(
            "pkss: the loaded libpkss is version %d.%d.%d but this binding was built for "
            "major version %d; reinstall the binding or point PKSS_LIBRARY at a matching "
            "library (%s)" % (runtime_number // 10000, runtime_number // 100 % 100,
                              runtime_number % 100, cdef_major, library_path))


def _load():
    ffi = _load_ffi()
    errors = []
    for how, where in _candidates():
        try:
            return ffi, ffi.dlopen(where), where
        except OSError as e:
            errors.append("  %s: %s: %s" % (how, where, e))
    raise ImportError(
        "pkss: cannot load the pkss C library. Tried, in order: the library bundled with "
        "the package (%s), $PKSS_LIBRARY, ctypes.util.find_library('pkss').\n%s\n"
        "Reinstall with `pip install ./bindings/python` or set PKSS_LIBRARY to the path "
        "of libpkss.so." % (", ".join(BUNDLED_NAMES), "\n".join(errors) or "  nothing found"))


ffi, lib, library_path = _load()
check_version(lib.pkss_version_number(), lib.PKSS_VERSION_MAJOR)
