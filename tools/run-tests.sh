#!/usr/bin/env bash
# The README's second command (and what CI runs): the whole test suite.
#   1. Release build, every ctest program (unit, device on PoCL, slow
#      end-to-end, CLI), warnings as errors under CI; then tools/gpu-check.sh
#      in its own build, which must pass on PoCL and say when no GPU is found;
#   2. the C package: libpkss.so's link surface (no NEEDED libOpenCL,
#      pkss_* exports only), `cmake --install` into build/prefix, and
#      programs built only from what was installed: a find_package(pkss)
#      CMake project, a pkg-config build, the add_subdirectory case and the
#      Rust example (examples/rust, when cargo is on PATH) (tests/package);
#   3. an AddressSanitizer + UndefinedBehaviorSanitizer build running the
#      same C tests, with the work counters on (PKSS_COUNT_WORK);
#   4. a ThreadSanitizer build running the tests that register through every
#      threaded path (pre-processing, candidates, correspondences, cancel);
#   5. the Python package installed with pip into a venv, and its pytest
#      suite; then every packaging route (sdist, manylinux wheel, editable;
#      tests/package/python_routes.sh);
#   6. the benchmark's own unit tests (tools/bench/test_bench.py) and its --quick smoke run.
# Needs the packages of tools/install-deps.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
JOBS=$(nproc)
WERROR=OFF
if [ "${CI:-}" = "true" ]; then WERROR=ON; fi
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$ROOT/build/pocl-cache}"
mkdir -p "$POCL_CACHE_DIR"

echo "== [1/6] release build + ctest"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPKSS_WERROR=$WERROR \
      -DPKSS_BUILD_STATIC=ON >/dev/null
cmake --build build -j"$JOBS"
ctest --test-dir build --output-on-failure -j"$JOBS"
bash tools/gpu-check.sh --build build-gpu-check

echo "== [2/6] C package: exports, install, CMake + pkg-config + Rust consumers"
bash tests/package/check_exports.sh build/src/libpkss.so
JOBS=$JOBS bash tests/package/run.sh build build/prefix build/package

echo "== [3/6] sanitizer build (ASan + UBSan) + ctest"
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPKSS_SANITIZE=ON \
      -DPKSS_COUNT_WORK=ON -DPKSS_WERROR=$WERROR >/dev/null
cmake --build build-asan -j"$JOBS"
# PoCL and the OpenCL ICD loader keep process-lifetime allocations that
# LeakSanitizer reports; only those are suppressed (tests/lsan.supp).
# PoCL's LLVM installs its own signal stack on the thread that starts the
# driver; ASan would unmap it at that thread's exit as if it were its own
# and abort ("unable to unmap"), so ASan sets none (use_sigaltstack=0).
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:use_sigaltstack=0 \
LSAN_OPTIONS=suppressions=$ROOT/tests/lsan.supp:print_suppressions=0 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$JOBS" -LE nosan

echo "== [4/6] ThreadSanitizer build + the threaded tests"
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPKSS_TSAN=ON \
      -DPKSS_BUILD_TOOLS=OFF -DPKSS_WERROR=$WERROR >/dev/null
cmake --build build-tsan -j"$JOBS" --target test_contract test_hostile test_stages \
      test_cl_first_call test_nn_field
for t in test_contract test_hostile test_stages test_cl_first_call test_nn_field; do
  TSAN_OPTIONS=halt_on_error=1 build-tsan/tests/$t > build-tsan/$t.log ||
    { cat build-tsan/$t.log; exit 1; }
done

echo "== [5/6] Python bindings (pip install) + pytest"
python3 -m venv build/venv
build/venv/bin/python -m pip install -q --upgrade pip
build/venv/bin/python -m pip install -q "./bindings/python[batch]" pytest
build/venv/bin/python -m pytest bindings/python/tests -q
# sdist, auditwheel-repaired wheel and editable install, each in a fresh venv
bash tests/package/python_routes.sh build/python-routes

echo "== [6/6] benchmark: its own unit tests and a smoke run (tools/bench/run.py --quick)"
if [ -f tools/bench/run.py ]; then
  build/venv/bin/python -m pip install -q -r tools/bench/requirements-quick.txt
  build/venv/bin/python -m pytest tools/bench/test_bench.py -q
  build/venv/bin/python tools/bench/run.py --quick --out build/bench-quick
fi
echo "== all test stages passed"
