# SPDX-License-Identifier: MIT
"""The C tools bundled in the wheel (pkss/bin/pkss-align, pkss/bin/pkss-info),
run in place of the Python process so that their options, output and exit
codes are the tools' own (see tools/README.md)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import List, Optional, Sequence

BIN = Path(__file__).resolve().parent / "bin"


def tool_path(tool: str) -> Optional[Path]:
    """The bundled executable, or None (a source checkout without a build)."""
    p = BIN / tool
    return p if p.is_file() and os.access(p, os.X_OK) else None


def run(tool: str, args: Sequence[str], replace: bool = True) -> int:
    """Run a bundled tool with `args`. replace=True execs it (never returns
    on success); otherwise waits and returns its exit code."""
    path = tool_path(tool)
    if path is None:
        sys.stderr.write(
            "pkss: the %s tool is not bundled in this installation (%s missing): install "
            "the package with `pip install ./bindings/python` or from the wheel, or build "
            "the C tools with CMake (build/tools/%s)\n" % (tool, BIN / tool, tool))
        return 2
    argv: List[str] = [tool, *args]
    sys.stdout.flush()
    sys.stderr.flush()
    if replace and hasattr(os, "execv"):
        os.execv(str(path), argv)
    return subprocess.call(argv, executable=str(path))


def align_main() -> int:
    """Console script ``pkss-align``."""
    return run("pkss-align", sys.argv[1:])


def info_main() -> int:
    """Console script ``pkss-info``."""
    return run("pkss-info", sys.argv[1:])
