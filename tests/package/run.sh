#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The package stage of tools/run-tests.sh: installs a configured and built
# pkss tree into PREFIX, then builds and runs programs that know pkss only
# through what was installed:
#   1. a CMake project using find_package(pkss 1.0 REQUIRED) + pkss::pkss
#      (and pkss::pkss_static when libpkss.a was installed);
#   1c. the same CMake project with pkss as a subproject (add_subdirectory:
#      the in-tree pkss::pkss alias; checks that no cmocka/LAPACKE is asked for);
#   2. the same consumer.c built with `cc ... $(pkg-config --cflags --libs pkss)`;
#   1/2 (io): consumer_io.c, the installed file I/O (pkss_io.h), both ways;
#   3. the Rust example (examples/rust, plain extern "C", no crates), when
#      cargo is on PATH.
# Each registers tests/data/airplane_0001_{s,t}.ply and checks the ground
# truth (rotation < 2 deg, scale within 1 %).
# usage: tests/package/run.sh BUILD_DIR PREFIX WORK_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:?usage: run.sh BUILD_DIR PREFIX WORK_DIR}
prefix=$(mkdir -p "$2" && cd "$2" && pwd)
work=$(mkdir -p "$3" && cd "$3" && pwd)
data=$root/tests/data
pair=("$data/airplane_0001_s.ply" "$data/airplane_0001_t.ply" "$data/gt_similarity_s_to_t.txt")
CC=${CC:-cc}

echo "-- install into $prefix"
case "$prefix" in
    / | /usr | /usr/local | "$HOME") echo "run.sh: refusing to empty $prefix"; exit 2 ;;
esac
rm -rf "$prefix" # a stale libpkss.a would turn the static consumer on
cmake --install "$build" --prefix "$prefix" >/dev/null
(cd "$prefix" && find . -type f -o -type l | sort | sed 's/^\.\//  /')
libdir=$(dirname "$(find "$prefix" -name 'libpkss.so' | head -1)")

echo "-- consumer 1: CMake find_package(pkss 1.0) + pkss::pkss"
static=OFF
[ -f "$libdir/libpkss.a" ] && static=ON
cmake -S "$here" -B "$work/cmake" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_BUILD_TYPE=Release -DPKSS_CONSUMER_STATIC=$static >/dev/null
cmake --build "$work/cmake" -j"${JOBS:-2}" >/dev/null
# not linked to the build tree: the rpath CMake set points into the prefix
readelf -d "$work/cmake/pkss-consumer" | grep -E 'R(UN)?PATH' | sed 's/^ */  /'
"$work/cmake/pkss-consumer" "${pair[@]}"
echo "-- consumer 1 (io): pkss_io.h, read / write .npy .pcd / register"
"$work/cmake/pkss-consumer-io" "${pair[0]}" "${pair[1]}" "$work"
if [ $static = ON ]; then
    echo "-- consumer 1b: pkss::pkss_static (libpkss.a)"
    if readelf -d "$work/cmake/pkss-consumer-static" | grep -q 'libpkss'; then
        echo "FAIL: the static consumer needs libpkss.so"; exit 1
    fi
    "$work/cmake/pkss-consumer-static" "${pair[@]}"
fi

echo "-- consumer 1c: add_subdirectory(pkss) + the in-tree alias pkss::pkss"
cmake -S "$here" -B "$work/subproject" -DPKSS_SOURCE_DIR="$root" \
      -DCMAKE_BUILD_TYPE=Release >/dev/null
if grep -qE '^(CMOCKA|LAPACKE|pkgcfg_lib_CMOCKA)' "$work/subproject/CMakeCache.txt"; then
    echo "FAIL: pkss as a subproject looked for the test dependencies (cmocka/LAPACKE)"; exit 1
fi
cmake --build "$work/subproject" -j"${JOBS:-2}" >/dev/null
"$work/subproject/pkss-consumer" "${pair[@]}"

echo "-- consumer 2: cc consumer.c \$(pkg-config --cflags --libs pkss)"
export PKG_CONFIG_PATH="$libdir/pkgconfig${PKG_CONFIG_PATH:+:$PKG_CONFIG_PATH}"
echo "  pkg-config --modversion pkss: $(pkg-config --modversion pkss)"
echo "  pkg-config --cflags --libs pkss: $(pkg-config --cflags --libs pkss)"
# shellcheck disable=SC2046  # word splitting of the flags is intended
$CC -std=c11 -O2 -Wall -Wextra -o "$work/pc-consumer" "$here/consumer.c" \
    $(pkg-config --cflags --libs pkss) -lm \
    -Wl,-rpath,"$(pkg-config --variable=libdir pkss)"
"$work/pc-consumer" "${pair[@]}"
$CC -std=c11 -O2 -Wall -Wextra -o "$work/pc-consumer-io" "$here/consumer_io.c" \
    $(pkg-config --cflags --libs pkss) -Wl,-rpath,"$(pkg-config --variable=libdir pkss)"
"$work/pc-consumer-io" "${pair[0]}" "${pair[1]}" "$work"

echo "-- consumer 3: Rust (examples/rust, extern \"C\", cargo --offline)"
if command -v cargo >/dev/null 2>&1; then
    PKSS_LIB_DIR="$libdir" CARGO_TARGET_DIR="$work/rust-target" \
        cargo run --offline --quiet --manifest-path "$root/examples/rust/Cargo.toml" -- "${pair[@]}"
else
    echo "SKIP: cargo not found on PATH (install rustc + cargo to run examples/rust)"
fi
echo "-- package stage passed"
