# SPDX-License-Identifier: MIT
"""Builds the pkss wheel: CMake builds libpkss from the repository root
(../.. of this file), cffi (ABI mode) turns include/pkss.h into pkss/_pkss.py,
and both go into the package. The wheel has no compiled Python extension, so
it is tagged py3-none-<platform>: one wheel per OS/architecture serves every
Python 3.

Environment:
  PKSS_SOURCE_DIR   the pkss source tree, if this file is not inside it
  PKSS_CMAKE_ARGS   extra CMake configure arguments, e.g. "-DPKSS_WITH_OPENCL=OFF"
  CMAKE_BUILD_PARALLEL_LEVEL   build jobs (default: 2)
"""
import importlib.util
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

try:
    from setuptools.command.bdist_wheel import bdist_wheel  # setuptools >= 70.1
except ImportError:  # pragma: no cover - older setuptools
    from wheel.bdist_wheel import bdist_wheel

HERE = Path(__file__).resolve().parent


def _load_build_helpers():
    # By file path: importing the package would try to load libpkss.
    spec = importlib.util.spec_from_file_location("_pkss_build", HERE / "pkss" / "_build.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


_build = _load_build_helpers()


def repo_root() -> Path:
    root = _build.find_repo_root(HERE)
    if root is None:
        where = os.environ.get("PKSS_SOURCE_DIR") or "any parent of %s" % HERE
        sys.exit(
            "pkss: the C sources (include/pkss.h, CMakeLists.txt, src/) were not found in %s.\n"
            "Install from a checkout of the pkss repository (`pip install ./bindings/python` "
            "from its root), or set PKSS_SOURCE_DIR to the repository root." % where)
    return root


def _library_file(build_dir: Path) -> Path:
    for name in ("libpkss.so", "libpkss.dylib"):
        p = build_dir / "src" / name
        if p.exists():
            return p.resolve()  # the real file behind the SONAME links
    sys.exit("pkss: CMake finished but %s/src/libpkss.so was not produced" % build_dir)


class BuildPy(build_py):
    """Standard build_py, then libpkss (CMake) and the cffi module."""

    def run(self):
        super().run()
        root = repo_root()
        package_dir = Path(self.build_lib) / "pkss"
        if shutil.which("cmake") is None:
            sys.exit("pkss: cmake not found. Install the build dependencies first "
                     "(Debian: apt-get install cmake gcc ocl-icd-opencl-dev opencl-headers "
                     "pocl-opencl-icd liblapacke-dev).")
        build_temp = self.get_finalized_command("build").build_temp
        build_dir = Path(os.path.abspath(build_temp)) / "pkss-cmake"
        configure = ["cmake", "-S", str(root), "-B", str(build_dir),
                     "-DCMAKE_BUILD_TYPE=Release", "-DPKSS_BUILD_TESTS=OFF",
                     "-DPKSS_BUILD_TOOLS=OFF"]
        configure += shlex.split(os.environ.get("PKSS_CMAKE_ARGS", ""))
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
        for cmd in (configure, ["cmake", "--build", str(build_dir), "--target", "pkss",
                                "--parallel", jobs]):
            print("pkss:", " ".join(shlex.quote(c) for c in cmd), flush=True)
            subprocess.check_call(cmd)
        lib = _library_file(build_dir)
        package_dir.mkdir(parents=True, exist_ok=True)
        dest = package_dir / ("libpkss" + (".dylib" if lib.name.endswith(".dylib") else ".so"))
        shutil.copyfile(lib, dest)
        _check_loads(dest)
        _build.write_module(root / "include" / "pkss.h", package_dir)


def _check_loads(path: Path) -> None:
    """Fail the install, not the first import, if the library cannot load."""
    import ctypes

    try:
        ctypes.CDLL(str(path), mode=getattr(os, "RTLD_NOW", 2))
    except OSError as e:
        sys.exit("pkss: the freshly built %s does not load: %s\n(a problem of the C library "
                 "build; PKSS_CMAKE_ARGS=-DPKSS_WITH_OPENCL=OFF builds the reference backend "
                 "only)" % (path.resolve(), e))


class BdistWheel(bdist_wheel):
    """Platform wheel (it bundles libpkss) that any Python 3 can use."""

    def finalize_options(self):
        super().finalize_options()
        self.root_is_pure = False

    def get_tag(self):
        _, _, plat = super().get_tag()
        return "py3", "none", plat


def _version() -> str:
    root = _build.find_repo_root(HERE)
    if root is None:  # let `repo_root()` report it when the build starts
        return "0"
    return _build.version_from_header((root / "include" / "pkss.h").read_text(encoding="utf-8"))


setup(
    version=_version(),
    cmdclass={"build_py": BuildPy, "bdist_wheel": BdistWheel},
)
