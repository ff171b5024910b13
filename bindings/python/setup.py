# SPDX-License-Identifier: MIT
"""Builds the pkss wheel: CMake builds libpkss and the pkss-align / pkss-info
tools from the C sources, cffi (ABI mode) turns include/pkss.h and
include/pkss_io.h into pkss/_pkss.py, and all of it goes into the package:

    pkss/lib/libpkss.so.1   the library (the name the tools are linked to)
    pkss/bin/pkss-align     the C tools, RPATH $ORIGIN/../lib, run by
    pkss/bin/pkss-info      `python -m pkss` and the pkss-align/pkss-info scripts

The wheel has no compiled Python extension, so it is tagged
py3-none-<platform>: one wheel per OS/architecture serves every Python 3.

The C sources are looked for in $PKSS_SOURCE_DIR, in ./csrc (an sdist: the
sdist command copies them there) or in the enclosing checkout (../..).

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

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

try:
    from setuptools.command.bdist_wheel import bdist_wheel  # setuptools >= 70.1
except ImportError:  # pragma: no cover - older setuptools
    from wheel.bdist_wheel import bdist_wheel

HERE = Path(__file__).resolve().parent
TOOLS = ("pkss-align", "pkss-info")
# What the CMake build of the library and the tools reads (tests, docs and
# benchmarks results stay out of the sdist).
SDIST_TREES = ("include", "src", "kernels", "cmake", "tools/cli")
SDIST_GLOBS = ("CMakeLists.txt", "LICENSE", "tools/CMakeLists.txt", "tools/*.cmake",
               "tools/*.c", "tools/*.cpp")


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
        where = os.environ.get("PKSS_SOURCE_DIR") or "%s/csrc or any parent of %s" % (HERE, HERE)
        sys.exit(
            "pkss: the C sources (include/pkss.h, CMakeLists.txt, src/) were not found in %s.\n"
            "Install from a checkout of the pkss repository (`pip install ./bindings/python` "
            "from its root) or from the sdist, or set PKSS_SOURCE_DIR to the repository "
            "root." % where)
    return root


def _library_file(build_dir: Path) -> Path:
    for name in ("libpkss.so", "libpkss.dylib"):
        p = build_dir / "src" / name
        if p.exists():
            return p.resolve()  # the real file behind the SONAME links
    sys.exit("pkss: CMake finished but %s/src/libpkss.so was not produced" % build_dir)


class BuildPy(build_py):
    """Standard build_py, then libpkss and the tools (CMake) and the cffi
    module. An editable install gets them in the source package folder, so
    `import pkss` works from the checkout without PKSS_LIBRARY."""

    def run(self):
        super().run()
        root = repo_root()
        if getattr(self, "editable_mode", False):
            package_dir = HERE / "pkss"
        else:
            package_dir = Path(self.build_lib) / "pkss"
        if shutil.which("cmake") is None:
            sys.exit("pkss: cmake not found. Install the build dependencies first "
                     "(Debian: apt-get install cmake gcc opencl-headers; at run time "
                     "ocl-icd-libopencl1 pocl-opencl-icd for OpenCL devices).")
        build_temp = self.get_finalized_command("build").build_temp
        build_dir = Path(os.path.abspath(build_temp)) / "pkss-cmake"
        # The tools get their install RPATH ($ORIGIN/../lib) at build time:
        # bin/ and lib/ sit side by side in the package.
        configure = ["cmake", "-S", str(root), "-B", str(build_dir),
                     "-DCMAKE_BUILD_TYPE=Release", "-DPKSS_BUILD_TESTS=OFF",
                     "-DPKSS_BUILD_TOOLS=ON", "-DPKSS_INSTALL=OFF",
                     "-DCMAKE_BUILD_WITH_INSTALL_RPATH=ON", "-DCMAKE_INSTALL_LIBDIR=lib"]
        configure += shlex.split(os.environ.get("PKSS_CMAKE_ARGS", ""))
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
        for cmd in (configure, ["cmake", "--build", str(build_dir), "--target", "pkss",
                                *TOOLS, "--parallel", jobs]):
            print("pkss:", " ".join(shlex.quote(c) for c in cmd), flush=True)
            subprocess.check_call(cmd)
        lib = _library_file(build_dir)
        for sub in ("lib", "bin"):
            shutil.rmtree(package_dir / sub, ignore_errors=True)
            (package_dir / sub).mkdir(parents=True)
        dest = package_dir / "lib" / ("libpkss.1.dylib" if lib.name.endswith(".dylib")
                                      else "libpkss.so.1")
        shutil.copyfile(lib, dest)
        _check_loads(dest)
        for tool in TOOLS:
            shutil.copy2(build_dir / "tools" / tool, package_dir / "bin" / tool)
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


class Sdist(sdist):
    """The sdist carries the C sources it needs in csrc/ (the binding lives
    two folders below them in the repository, out of reach of MANIFEST.in)."""

    def make_release_tree(self, base_dir, files):
        super().make_release_tree(base_dir, files)
        root = repo_root()
        dest = Path(base_dir) / _build.SDIST_SOURCES
        for tree in SDIST_TREES:
            shutil.copytree(root / tree, dest / tree,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        for pattern in SDIST_GLOBS:
            for f in sorted(root.glob(pattern)):
                (dest / f.relative_to(root)).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(f, dest / f.relative_to(root))


class BinaryDistribution(Distribution):
    """Binaries inside (libpkss, the tools): installed to platlib, a platform
    wheel, though no Python extension is compiled."""

    def has_ext_modules(self):
        return True


class BdistWheel(bdist_wheel):
    """Platform wheel (it bundles libpkss) that any Python 3 can use."""

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
    distclass=BinaryDistribution,
    cmdclass={"build_py": BuildPy, "bdist_wheel": BdistWheel, "sdist": Sdist},
)
