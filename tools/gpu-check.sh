#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# gpu-check.sh -- one look at pkss on a machine's GPU: builds pkss (Release)
# in its own folder, lists the OpenCL devices (pkss-info, clinfo -l), then,
# on the first GPU and on the first CPU device (PoCL, for comparison), runs
# the device-labelled tests (ctest -L device) and bench_search --quick, and
# prints a short report. Meant to finish in under 5 minutes.
#
#   tools/gpu-check.sh [--build DIR] [--no-build] [--full]
#
#   --build DIR  build folder (default: build-gpu-check beside the sources)
#   --no-build   use the folder as it is (it must hold a complete build)
#   --full       also run the end-to-end registration tests on each device
#                (test_e2e_registration_opencl; several minutes on a CPU)
#
# Devices are chosen with PKSS_DEVICE=<index> (src/device/device.c: an
# index or a name substring; the library's default is the first GPU, then
# the first CPU). Exit status:
#   0  every test passed on every device tried -- also when no GPU was
#      found (the report says "no GPU found" and shows the PoCL run alone)
#   1  the build failed
#   2  a test or the benchmark failed on a device
#   3  no OpenCL device at all (nothing could be compared)
set -u
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD="$ROOT/build-gpu-check"
DO_BUILD=1
FULL=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build) BUILD="$2"; shift 2 ;;
    --no-build) DO_BUILD=0; shift ;;
    --full) FULL=1; shift ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "gpu-check: unknown option '$1' (see --help)" >&2; exit 64 ;;
  esac
done
mkdir -p "$BUILD" || exit 1
BUILD="$(cd "$BUILD" && pwd)"
LOG="$BUILD/gpu-check-logs"
mkdir -p "$LOG"
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$BUILD/pocl-cache}"
export PKSS_CACHE_DIR="${PKSS_CACHE_DIR:-$BUILD/pkss-cache}"
mkdir -p "$POCL_CACHE_DIR" "$PKSS_CACHE_DIR"
JOBS="$(nproc 2>/dev/null || echo 2)"
T0=$(date +%s)
say() { printf '%s\n' "gpu-check: $*"; }

# ------------------------------------------------------------------ build
# The programs of the device-labelled tests, by tests/CMakeLists.txt's own
# rule (every tests/test_cl_*.c, and the end-to-end program it runs again on
# the device): a device test added there is built here too.
device_programs() {
  for f in "$ROOT"/tests/test_cl_*.c; do basename "$f" .c; done
  echo test_e2e_registration
}
if [ "$DO_BUILD" = 1 ]; then
  say "building in $BUILD (log: $LOG/build.log)"
  if ! { cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE=Release \
           -DPKSS_BUILD_TESTS=ON -DPKSS_BUILD_TOOLS=ON &&
         PROGRAMS="$(device_programs)" && [ -n "$PROGRAMS" ] &&
         # shellcheck disable=SC2086
         cmake --build "$BUILD" -j "$JOBS" --target pkss-info bench_search $PROGRAMS; \
       } > "$LOG/build.log" 2>&1; then
    tail -20 "$LOG/build.log"
    say "FAILED: the build (see $LOG/build.log)"
    exit 1
  fi
fi
INFO="$BUILD/tools/pkss-info"
BENCH="$BUILD/tools/bench_search"
for t in "$INFO" "$BENCH" $(device_programs | sed "s|^|$BUILD/tests/|"); do
  [ -x "$t" ] || { say "FAILED: $t is missing (build first, without --no-build)"; exit 1; }
done

# ---------------------------------------------------------------- devices
say "OpenCL devices as pkss sees them:"
"$INFO" > "$LOG/pkss-info.txt" 2>&1
sed -n '/^OpenCL devices/,/^PKSS_DEVICE/p' "$LOG/pkss-info.txt" | sed '$d'
if command -v clinfo > /dev/null 2>&1; then
  say "clinfo -l:"
  clinfo -l 2>&1 | sed 's/^/  /'
fi
# "  [i] name" lines, then "      type:     GPU, ..." (tools/pkss_info.c)
DEVICES="$(awk '/^  \[[0-9]+\] /{i=substr($1,2,length($1)-2); $1=""; name=substr($0,2)}
               /^      type:/{t=$2; sub(/,$/,"",t); print i "\t" t "\t" name}' \
           "$LOG/pkss-info.txt")"
GPU="$(printf '%s\n' "$DEVICES" | awk -F'\t' '$2 ~ /^GPU/ {print $1; exit}')"
CPU="$(printf '%s\n' "$DEVICES" | awk -F'\t' '$2 ~ /^CPU/ {print $1; exit}')"
if [ -z "$GPU" ] && [ -z "$CPU" ]; then
  say "no OpenCL device found: $(grep -i -m1 'reason\|no opencl' "$LOG/pkss-info.txt" || true)"
  say "REPORT: no GPU found, and no CPU device (PoCL) to compare with: install a GPU's OpenCL ICD or pocl-opencl-icd"
  exit 3
fi
[ -n "$GPU" ] || say "no GPU found: running the PoCL/CPU comparison only"

# ------------------------------------------------------------- per device
STATUS=0
REPORT=""
run_device() { # index label
  local idx="$1" label="$2" name tests bench t1 t2 tst bst line
  name="$(printf '%s\n' "$DEVICES" | awk -F'\t' -v i="$idx" '$1==i {print $3}')"
  say "--- $label: device $idx, $name"
  t1=$(date +%s)
  local sel="-L device"
  [ "$FULL" = 1 ] || sel="-L device -E test_e2e_registration_opencl"
  # shellcheck disable=SC2086
  if PKSS_DEVICE="$idx" ctest --test-dir "$BUILD" $sel --output-on-failure \
       --timeout 240 > "$LOG/ctest-$label.log" 2>&1; then
    tst="passed"
  else
    tst="FAILED (see $LOG/ctest-$label.log)"
    STATUS=2
  fi
  tests="$(grep -E 'tests passed|tests failed' "$LOG/ctest-$label.log" | tail -1)"
  t2=$(date +%s)
  if PKSS_DEVICE="$idx" "$BENCH" --quick --runs 3 > "$LOG/bench-$label.md" 2>&1; then
    bst="ok"
  else
    bst="FAILED (see $LOG/bench-$label.md)"
    STATUS=2
  fi
  # the OpenCL rows: default search, wide search, end to end
  line="$(awk -F'|' '$2 ~ /OpenCL/ && $5 ~ /^ *5 *$/ {gsub(/ /,"",$10); s=$10}
                     $2 ~ /OpenCL/ && $5 ~ /wide/ {gsub(/ /,"",$10); w=$10}
                     $3 ~ /OpenCL/ {gsub(/[ *]/,"",$10); e=$10}
                     /prepare \(program build\)/ {p=$0; sub(/.*build\) /,"",p)}
                     END {printf "search %s s, wide search %s s, register end to end %s s, prepare %s", s, w, e, p}' \
          "$LOG/bench-$label.md")"
  say "$label tests: $tst ($tests; $((t2 - t1)) s); bench_search: $bst"
  say "$label timings: $line"
  REPORT="$REPORT
  $label (device $idx: $name): tests $tst; bench_search $bst; $line"
}
[ -n "$GPU" ] && run_device "$GPU" GPU
[ -n "$CPU" ] && run_device "$CPU" PoCL

# ----------------------------------------------------------------- report
echo
echo "gpu-check report ($(date -u '+%Y-%m-%d %H:%M UTC'), $(( $(date +%s) - T0 )) s, commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?'))"
if [ -n "$GPU" ]; then
  echo "  GPU found: device $GPU"
else
  echo "  no GPU found (OpenCL devices: $(printf '%s\n' "$DEVICES" | awk -F'\t' '{printf "%s%s: %s (%s)", (NR > 1 ? "; " : ""), $1, $3, $2}'))"
fi
printf '%s\n' "$REPORT" | sed '/^$/d'
echo "  logs: $LOG"
exit "$STATUS"
