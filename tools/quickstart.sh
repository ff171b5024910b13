#!/usr/bin/env bash
# The README's first command: install dependencies, build pkss, and register
# the bundled sample pair (tests/data), printing T_target_source and its
# error against the known ground truth.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" >/dev/null
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$PWD/build/pocl-cache}"
./build/pkss-demo
