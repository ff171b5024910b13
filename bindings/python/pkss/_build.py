# SPDX-License-Identifier: MIT
"""Build-time helpers: the cffi declarations come from include/pkss.h and
include/pkss_io.h.

Each public header keeps the declarations a binding needs between the
``/* PKSS_CDEF_BEGIN */`` and ``/* PKSS_CDEF_END */`` markers, written so that
cffi can parse them once the ``PKSS_API`` export token is removed. This module
extracts that block (plus the header's plain integer ``#define`` lines, so
``lib.PKSS_VERSION_MAJOR`` is the version the binding was built against) and
emits the cffi ABI-mode module ``pkss._pkss``.

It imports nothing from the rest of the package: setup.py loads it by file path
before the package exists, and the test suite uses it to check that the cdef
bundled in an installed package still matches the header.
"""
from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Dict, Optional

BEGIN_MARKER = "/* PKSS_CDEF_BEGIN */"
END_MARKER = "/* PKSS_CDEF_END */"
MODULE_NAME = "pkss._pkss"
CDEF_FILE = "_cdef.h"  # the extracted text, bundled next to _pkss.py

# `#define PKSS_SOMETHING 123` (a plain integer, optionally followed by a
# comment): cffi accepts these in a cdef and exposes them on `lib`.
_INT_DEFINE = re.compile(r"^#define[ \t]+(PKSS_[A-Z0-9_]+)[ \t]+([0-9]+)[ \t]*(?:/\*.*\*/)?[ \t]*$",
                         re.MULTILINE)
_EXPORT_TOKEN = re.compile(r"\bPKSS_API\b[ \t]*")


def int_defines(header_text: str) -> Dict[str, int]:
    """The header's ``#define PKSS_X <integer>`` lines, in order."""
    return {m.group(1): int(m.group(2)) for m in _INT_DEFINE.finditer(header_text)}


def _block(header_text: str, name: str) -> str:
    begin = header_text.find(BEGIN_MARKER)
    end = header_text.find(END_MARKER)
    if begin < 0 or end < 0 or end < begin:
        raise ValueError("%s: the %s ... %s block is missing" % (name, BEGIN_MARKER, END_MARKER))
    return _EXPORT_TOKEN.sub("", header_text[begin + len(BEGIN_MARKER):end]).strip("\n") + "\n"


def extract_cdef(header_text: str, io_header_text: Optional[str] = None) -> str:
    """Return the cdef text cffi parses, derived from the text of pkss.h
    (followed by the block of pkss_io.h when its text is given).

    Raises ValueError if the markers are missing or out of order.
    """
    defines = int_defines(header_text)
    block = _block(header_text, "pkss.h")
    if io_header_text is not None:
        block += _block(io_header_text, "pkss_io.h")
    # Array sizes written with a macro name would not parse: use the values.
    for name, value in defines.items():
        block = re.sub(r"\[\s*%s\s*\]" % name, "[%d]" % value, block)
    lines = ["/* Generated from include/pkss.h by pkss/_build.py: do not edit. */"]
    lines += ["#define %s %d" % kv for kv in defines.items()]
    return "\n".join(lines) + "\n" + block.strip("\n") + "\n"


def cdef_for(include_dir: Path) -> str:
    """The cdef of the headers in `include_dir` (pkss.h, and pkss_io.h)."""
    io = include_dir / "pkss_io.h"
    return extract_cdef((include_dir / "pkss.h").read_text(encoding="utf-8"),
                        io.read_text(encoding="utf-8") if io.is_file() else None)


def version_from_header(header_text: str) -> str:
    d = int_defines(header_text)
    try:
        return "%d.%d.%d" % (d["PKSS_VERSION_MAJOR"], d["PKSS_VERSION_MINOR"], d["PKSS_VERSION_PATCH"])
    except KeyError as e:
        raise ValueError("pkss.h: #define %s not found" % e.args[0]) from None


def is_repo_root(path: Path) -> bool:
    """True if `path` holds the pkss C sources (header, CMake project, src/)."""
    return ((path / "include" / "pkss.h").is_file()
            and (path / "CMakeLists.txt").is_file()
            and (path / "src").is_dir())


#: Where an sdist carries the C sources (next to setup.py).
SDIST_SOURCES = "csrc"


def find_repo_root(start: Path) -> Optional[Path]:
    """The pkss source tree: $PKSS_SOURCE_DIR, else `start`/csrc (an unpacked
    sdist), else the closest ancestor of `start` (normally bindings/python,
    so ../..) that holds the C sources."""
    env = os.environ.get("PKSS_SOURCE_DIR")
    if env:
        p = Path(env).resolve()
        return p if is_repo_root(p) else None
    for p in [start.resolve() / SDIST_SOURCES, start.resolve(), *start.resolve().parents]:
        if is_repo_root(p):
            return p
    return None


def make_ffibuilder(cdef_text: str):
    """A cffi FFI set up for ABI mode (no C compiler involved)."""
    import cffi

    ffibuilder = cffi.FFI()
    ffibuilder.cdef(cdef_text)
    ffibuilder.set_source(MODULE_NAME, None)
    return ffibuilder


def write_module(header: Path, package_dir: Path) -> None:
    """Write pkss/_pkss.py (the ABI-mode module) and pkss/_cdef.h."""
    cdef = cdef_for(header.parent)
    package_dir.mkdir(parents=True, exist_ok=True)
    (package_dir / CDEF_FILE).write_text(cdef, encoding="utf-8")
    make_ffibuilder(cdef).emit_python_code(str(package_dir / "_pkss.py"))
