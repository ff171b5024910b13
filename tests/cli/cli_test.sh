#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# cli_test.sh CASE -- one command-line test of pkss-align / pkss-info.
#
# Environment (set by tests/cli/CMakeLists.txt):
#   PKSS_ALIGN, PKSS_INFO   the built tools
#   PKSS_CHECK              the check_pose helper (check_pose.c)
#   CLI_WORK                scratch folder (one subfolder per case)
#   CLI_DATA_DEFAULT        the shared data folder; $PKSS_DATA_DIR wins
# Exit 0 pass, 1 fail, 77 skip (shared data absent).
#
# Run one by hand:  CLI_WORK=/tmp/w PKSS_ALIGN=... bash cli_test.sh missing_file
set -u

CASE=${1:?usage: cli_test.sh CASE}
ALIGN=${PKSS_ALIGN:?}
INFO=${PKSS_INFO:-}
CHECK=${PKSS_CHECK:-}
DATA=${PKSS_DATA_DIR:-${CLI_DATA_DEFAULT:-}}
WORK=${CLI_WORK:-${TMPDIR:-/tmp}/pkss_cli}/$CASE
rm -rf "$WORK" && mkdir -p "$WORK" || exit 1
OUT=$WORK/stdout
ERR=$WORK/stderr

fail() {
    echo "FAIL [$CASE]: $*"
    echo "--- stdout:"; head -c 4000 "$OUT" 2>/dev/null; echo
    echo "--- stderr:"; head -c 4000 "$ERR" 2>/dev/null; echo
    exit 1
}

# run EXPECTED_EXIT command args... : runs, checks the exit code and that a
# failing run printed exactly one "pkss-align: STATUS: detail" line.
run() {
    local want=$1; shift
    echo "+ $*"
    "$@" >"$OUT" 2>"$ERR" </dev/null
    local rc=$?
    echo "exit $rc"
    [ "$rc" -eq "$want" ] || fail "exit code $rc, expected $want"
    if [ "$want" -ne 0 ]; then
        grep -Eq '^pkss-(align|info): [A-Z_]+: .+' "$ERR" ||
            fail "stderr lacks a 'pkss-align: STATUS_NAME: detail' line"
    fi
    if [ "$rc" -gt 6 ]; then fail "undocumented exit code $rc"; fi
}

stderr_has() { grep -Eq -e "$1" "$ERR" || fail "stderr does not match /$1/"; }
stdout_has() { grep -Eq -e "$1" "$OUT" || fail "stdout does not match /$1/"; }

need_data() {
    local f
    for f in "$@"; do
        if [ -z "$DATA" ] || [ ! -f "$DATA/$f" ]; then
            echo "SKIP [$CASE]: shared data file $f not found (set PKSS_DATA_DIR)"
            exit 77
        fi
    done
}

# A smooth deterministic cloud of N points (a wavy sphere), as .xyz text.
make_cloud() { # file n [nan_at]
    awk -v n="$2" -v bad="${3:-0}" 'BEGIN {
        for (i = 1; i <= n; i++) {
            u = i * 2.399963; v = 1 - 2 * (i - 0.5) / n; r = sqrt(1 - v * v);
            s = 1 + 0.2 * sin(3 * u) * r;
            if (i == bad) print "nan 0 0";
            else printf "%.9f %.9f %.9f\n", s * r * cos(u), 1.3 * s * r * sin(u), 0.7 * s * v;
        }
    }' > "$1"
}

# ---------------------------------------------------------- usage (2)
case_usage_no_args()        { run 2 "$ALIGN"; stderr_has 'PKSS_ERR_INVALID_ARGUMENT'; }
case_usage_one_arg()        { run 2 "$ALIGN" a.ply; }
case_usage_unknown_option() { run 2 "$ALIGN" a.ply b.ply --frobnicate; stderr_has "unknown option"; }
case_usage_missing_value()  { run 2 "$ALIGN" a.ply b.ply --steps; stderr_has "needs a value"; }
case_usage_not_integer()    { run 2 "$ALIGN" a.ply b.ply --steps twelve; stderr_has "not an integer"; }
case_usage_out_of_range()   { run 2 "$ALIGN" a.ply b.ply --points 10; stderr_has '^pkss-align: PKSS_ERR_INVALID_ARGUMENT: --points 10'; }
case_usage_odd_steps()      { run 2 "$ALIGN" a.ply b.ply --steps 7; }
case_usage_bad_backend()    { run 2 "$ALIGN" a.ply b.ply --backend gpu; }
case_usage_bad_format()     { run 2 "$ALIGN" a.ply b.ply --format obj; stderr_has "unknown format"; }
case_usage_unknown_param()  { run 2 "$ALIGN" a.ply b.ply --set warp=9; stderr_has PKSS_ERR_UNKNOWN_PARAMETER; }
case_usage_unknown_extension() {
    make_cloud "$WORK/cloud.dat" 100
    run 2 "$ALIGN" "$WORK/cloud.dat" "$WORK/cloud.dat"
    stderr_has PKSS_ERR_INVALID_ARGUMENT
}
case_help() {
    run 0 "$ALIGN" --help
    stdout_has '^Usage: pkss-align SOURCE TARGET'
    stdout_has 'Exit codes'
    stdout_has '^  130 +interrupted'
    stdout_has '--points N +default [0-9]+, integer in \[' # from pkss_param_at
}
case_version() { run 0 "$ALIGN" --version; stdout_has 'runtime libpkss [0-9]+\.[0-9]+\.[0-9]+'; }
case_info() {
    [ -n "$INFO" ] || fail "PKSS_INFO not set"
    run 0 "$INFO"
    stdout_has '^pkss library: [0-9]+\.[0-9]+\.[0-9]+'
    stdout_has '^build: '
    stdout_has '^OpenCL devices: '
    stdout_has 'rotation_steps'
    run 0 "$INFO" --params
    stdout_has '^name	id	type	default	lower	upper	unit	choices	constraint	option	doc$'
    stdout_has '^drop_nonfinite	132	switch	off	'
}

# ------------------------------------------------------------- I/O (3)
case_missing_file() {
    make_cloud "$WORK/t.xyz" 100
    run 3 "$ALIGN" "$WORK/nope.ply" "$WORK/t.xyz"
    stderr_has "^pkss-align: PKSS_ERR_IO: .*nope\.ply"
}
case_directory_input() { make_cloud "$WORK/t.xyz" 100; run 3 "$ALIGN" "$WORK" "$WORK/t.xyz" --format xyz; }
case_unwritable_output() {
    run 3 "$ALIGN" a.ply b.ply -o "$WORK/no/such/dir/out.ply"
    stderr_has PKSS_ERR_IO
}
case_unwritable_json() { run 3 "$ALIGN" a.ply b.ply --json "$WORK"; }

# -------------------------------------------------------- bad data (4)
case_malformed_lying_header() {
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0123456789ab' > "$WORK/lie.ply"
    make_cloud "$WORK/t.xyz" 100
    run 4 "$ALIGN" "$WORK/lie.ply" "$WORK/t.xyz"
    stderr_has 'PKSS_ERR_FORMAT: .*lie\.ply.*1000000000000 vertices'
}
case_malformed_truncated() {
    { printf 'ply\nformat ascii 1.0\nelement vertex 100\nproperty float x\nproperty float y\nproperty float z\nend_header\n'
      awk 'BEGIN { for (i = 0; i < 60; i++) print i, i * 2, i * 3 }'; } > "$WORK/cut.ply"
    make_cloud "$WORK/t.xyz" 100
    run 4 "$ALIGN" "$WORK/t.xyz" "$WORK/cut.ply"
    stderr_has PKSS_ERR_FORMAT
}
case_malformed_garbage() {
    awk 'BEGIN { for (i = 0; i < 300; i++) printf "%c", (i * 37 + 1) % 256 }' > "$WORK/garbage.pcd"
    make_cloud "$WORK/t.xyz" 100
    run 4 "$ALIGN" "$WORK/garbage.pcd" "$WORK/t.xyz"
}
case_malformed_text() {
    make_cloud "$WORK/s.xyz" 100
    echo "1.0 2.0 three" >> "$WORK/s.xyz"
    run 4 "$ALIGN" "$WORK/s.xyz" "$WORK/s.xyz"
    stderr_has 'line 101'
}
case_empty_file() {
    : > "$WORK/empty.ply"
    make_cloud "$WORK/t.xyz" 100
    run 4 "$ALIGN" "$WORK/empty.ply" "$WORK/t.xyz"
    stderr_has PKSS_ERR_EMPTY_INPUT
}
case_nan_file() {
    make_cloud "$WORK/s.xyz" 400 17
    make_cloud "$WORK/t.xyz" 400
    run 4 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz"
    stderr_has '^pkss-align: PKSS_ERR_NONFINITE: '
}
case_nan_stdin() {
    make_cloud "$WORK/s.xyz" 400 5
    make_cloud "$WORK/t.xyz" 400
    echo "+ $ALIGN - t.xyz --source-format xyz < s.xyz"
    "$ALIGN" - "$WORK/t.xyz" --source-format xyz <"$WORK/s.xyz" >"$OUT" 2>"$ERR"
    rc=$?
    [ "$rc" -eq 4 ] || fail "exit code $rc, expected 4"
    stderr_has PKSS_ERR_NONFINITE
}
case_too_few_points() {
    make_cloud "$WORK/s.xyz" 5
    make_cloud "$WORK/t.xyz" 400
    run 4 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz"
    stderr_has '^pkss-align: PKSS_ERR_TOO_FEW_POINTS: '
}
case_min_points_option() {
    make_cloud "$WORK/s.xyz" 200
    run 4 "$ALIGN" "$WORK/s.xyz" "$WORK/s.xyz" --min-points 500
    stderr_has PKSS_ERR_TOO_FEW_POINTS
}
case_degenerate() {
    awk 'BEGIN { for (i = 0; i < 200; i++) print i * 0.01, 2 * i * 0.01, 0 }' > "$WORK/line.xyz"
    make_cloud "$WORK/t.xyz" 400
    run 4 "$ALIGN" "$WORK/line.xyz" "$WORK/t.xyz"
    stderr_has PKSS_ERR_DEGENERATE
}

# ------------------------------------------- registration failure (5)
case_device_not_found() {
    make_cloud "$WORK/s.xyz" 400
    run 5 "$ALIGN" "$WORK/s.xyz" "$WORK/s.xyz" --backend opencl --device no-such-device-xyz \
        --json "$WORK/r.json"
    # NO_DEVICE, or UNSUPPORTED when libpkss was built without OpenCL
    stderr_has '^pkss-align: PKSS_ERR_(NO_DEVICE|UNSUPPORTED): '
    grep -q '"status": "PKSS_ERR_' "$WORK/r.json" || fail "JSON lacks the failure status"
}

# ---------------------------------------- real data, ground truth (0)
# pose CASE: registers SOURCE onto TARGET and compares with the GT.
pose() { # source target gt max_rot max_scale max_trans [labels...] -- [options]
    local s=$1 t=$2 g=$3 r=$4 sc=$5 tr=$6; shift 6
    local labels=()
    while [ $# -gt 0 ] && [ "$1" != "--" ]; do labels+=("$1"); shift; done
    [ $# -gt 0 ] && shift
    need_data "$s" "$t" "$g"
    run 0 "$ALIGN" "$DATA/$s" "$DATA/$t" --matrix "$WORK/T.txt" --json "$WORK/result.json" -v "$@"
    cat "$OUT"
    grep -m1 'times' "$ERR"
    "$CHECK" pose "$WORK/T.txt" "$DATA/$g" "$DATA/$s" "$DATA/$t" "$r" "$sc" "$tr" "${labels[@]}" ||
        fail "pose differs from the ground truth"
}
case_gt_airplane() {
    pose modelnet40_pkss/airplane_0001_s.ply modelnet40_pkss/airplane_0001_t.ply \
         modelnet40_pkss/gt_similarity_s_to_t.txt 2 0.01 0.01
}
case_gt_car_scaled() {
    pose libpointmatcher/car_cloud400.csv libpointmatcher/car_cloud400_scaled.csv \
         libpointmatcher/car_cloud400_scaled_T.txt 2 0.01 0.01
}
# Partial overlap (bun045 sees 91% of bun000): looser rotation bar of 5 deg.
case_gt_bunny_partial() {
    pose stanford_bunny/bun045.ply stanford_bunny/bun000.ply \
         stanford_bunny/gt_poses_4x4.txt 5 0.01 0.01 bun045.ply bun000.ply
}
# NaN points dropped on request; outputs: aligned PLY, matrix, JSON.
case_outputs_drop_nonfinite() {
    need_data modelnet40_pkss/airplane_0001_s.ply modelnet40_pkss/airplane_0001_t.ply
    "$CHECK" count "$DATA/modelnet40_pkss/airplane_0001_s.ply" 10001 >/dev/null || fail "cannot read the airplane"
    awk '{ sub(/\r$/, "") } /end_header/ { body = 1; next } body && NF >= 3 { print $1, $2, $3 }' \
        "$DATA/modelnet40_pkss/airplane_0001_s.ply" > "$WORK/s.xyz"
    echo "nan nan nan" >> "$WORK/s.xyz"
    run 4 "$ALIGN" "$WORK/s.xyz" "$DATA/modelnet40_pkss/airplane_0001_t.ply"
    run 0 "$ALIGN" "$WORK/s.xyz" "$DATA/modelnet40_pkss/airplane_0001_t.ply" \
        --drop-nonfinite -o "$WORK/aligned.ply" --ascii --matrix "$WORK/T.txt" --json "$WORK/r.json"
    head -n 4 "$OUT" > "$WORK/stdout_T.txt"
    "$CHECK" same "$WORK/stdout_T.txt" "$WORK/T.txt" 1e-7 || fail "printed and written matrices differ"
    "$CHECK" count "$WORK/aligned.ply" 10002 || fail "aligned cloud"
    grep -q '"nonfinite": 1' "$WORK/r.json" || fail "JSON lacks source_counts.nonfinite = 1"
    for key in T_target_source scale rotation translation candidates source_counts timings device; do
        grep -q "\"$key\"" "$WORK/r.json" || fail "JSON lacks $key"
    done
    grep -q '"stage": "refined"' "$WORK/r.json" || fail "JSON lacks a refined candidate's stage"
    if command -v python3 >/dev/null 2>&1; then
        python3 -m json.tool "$WORK/r.json" >/dev/null || fail "invalid JSON"
    fi
    "$CHECK" pose "$WORK/T.txt" "$DATA/modelnet40_pkss/gt_similarity_s_to_t.txt" \
        "$DATA/modelnet40_pkss/airplane_0001_s.ply" "$DATA/modelnet40_pkss/airplane_0001_t.ply" 2 0.01 0.01 ||
        fail "pose differs from the ground truth"
    run 0 "$ALIGN" "$WORK/s.xyz" "$DATA/modelnet40_pkss/airplane_0001_t.ply" --drop-nonfinite -q
    [ "$(wc -l < "$OUT")" -eq 4 ] || fail "-q must print the 4 matrix lines only"
}

# ------------------------------------- CLI conventions (#20, #21, #22)
# A source and a target that differ by a similarity, as .xyz text.
make_pair() { # dir
    make_cloud "$1/s.xyz" 400
    awk '{ printf "%.9f %.9f %.9f\n", 2 * $2 + 1, -2 * $1, 2 * $3 + 0.5 }' "$1/s.xyz" > "$1/t.xyz"
}
FAST=(--backend reference)

# --min-confidence X: exit 6 with one PKSS_LOW_CONFIDENCE line when the
# result's confidence is below X, every requested output written all the
# same; at or under the confidence, exit 0. Bad values are usage errors.
case_min_confidence() {
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --json "$WORK/r.json"
    stdout_has ' confidence=[01]\.[0-9]{3} ambiguous=(yes|no) symmetry=[a-z]+ '
    local c
    c=$(sed -n 's/^  "confidence": \([0-9.eE+-]*\),$/\1/p' "$WORK/r.json")
    [ -n "$c" ] || fail "no confidence in the JSON"
    grep -q '"ambiguous": \(true\|false\)' "$WORK/r.json" || fail "no ambiguous in the JSON"
    grep -q '"alternatives": \[' "$WORK/r.json" || fail "no alternatives in the JSON"
    local above below
    above=$(awk -v c="$c" 'BEGIN { printf "%.17g", c + (1 - c) / 2 + 1e-12 }')
    below=$(awk -v c="$c" 'BEGIN { printf "%.17g", c / 2 }')
    awk -v a="$above" 'BEGIN { exit !(a <= 1) }' || fail "confidence $c leaves no room above"
    run 6 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --min-confidence "$above" \
        --json "$WORK/low.json" --matrix "$WORK/low.txt" -o "$WORK/low.ply"
    stderr_has '^pkss-align: PKSS_LOW_CONFIDENCE: confidence [0-9.]+ is below --min-confidence'
    [ "$(grep -c . "$ERR")" -eq 1 ] || fail "more than one stderr line"
    stdout_has '^[-0-9.e]+ [-0-9.e]+ [-0-9.e]+ [-0-9.e]+$'
    [ -s "$WORK/low.json" ] && [ -s "$WORK/low.txt" ] && [ -s "$WORK/low.ply" ] ||
        fail "an output was not written"
    grep -q '"status": "PKSS_OK"' "$WORK/low.json" || fail "the JSON lacks the result"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --min-confidence "$below" -q
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --min-confidence 0 -q
    run 2 "$ALIGN" a.ply b.ply --min-confidence 1.5
    stderr_has 'min-confidence.*not a number in \[0, 1\]'
    run 2 "$ALIGN" a.ply b.ply --min-confidence high
    run 2 "$ALIGN" a.ply b.ply --min-confidence
    run 0 "$ALIGN" --help
    stdout_has '^  6 +the result.s confidence is below --min-confidence'
}

# Every write is checked, standard output's too.
case_stdout_full() {
    [ -n "$INFO" ] || fail "PKSS_INFO not set"
    make_pair "$WORK"
    local flags rc
    for flags in "" -q -v -qv; do
        echo "+ $ALIGN s.xyz t.xyz ${FAST[*]} $flags > /dev/full"
        "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" $flags >/dev/full 2>"$ERR"
        rc=$?
        [ "$rc" -eq 3 ] || fail "exit $rc with stdout on /dev/full ($flags), expected 3"
        stderr_has '^pkss-align: PKSS_ERR_IO: .*standard output'
    done
    for flags in "" --params --version; do
        echo "+ $INFO $flags > /dev/full"
        "$INFO" $flags >/dev/full 2>"$ERR"
        rc=$?
        [ "$rc" -eq 3 ] || fail "pkss-info $flags > /dev/full: exit $rc, expected 3"
        stderr_has '^pkss-info: PKSS_ERR_IO: .*standard output'
    done
}

# An output naming an input is refused before anything is written.
case_output_is_input() {
    make_pair "$WORK"
    local before after
    before=$(sha256sum < "$WORK/s.xyz")
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -o "$WORK/s.xyz"
    stderr_has "output -o '.*s\.xyz' is the same file as SOURCE"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --json "$WORK/../$CASE/t.xyz"
    stderr_has "output --json .* is the same file as TARGET"
    ln "$WORK/s.xyz" "$WORK/hard.xyz" && ln -s s.xyz "$WORK/link.xyz" || fail "cannot link"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --matrix "$WORK/hard.xyz"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -o "$WORK/link.xyz"
    after=$(sha256sum < "$WORK/s.xyz")
    [ "$before" = "$after" ] || fail "the source changed"
}

# Two outputs naming one file are refused, naming both.
case_output_alias() {
    make_pair "$WORK"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --json "$WORK/X.ply" -o "$WORK/X.ply"
    stderr_has "output --json '.*X\.ply' is the same file as output -o '.*X\.ply'"
    [ ! -e "$WORK/X.ply" ] || fail "X.ply was created"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --json - --matrix -
    stderr_has "same file"
}

# A FIFO output is a stream: no open before the run (that would block).
case_output_fifo() {
    make_pair "$WORK"
    mkfifo "$WORK/fifo.ply" || fail "mkfifo"
    timeout 120 cat "$WORK/fifo.ply" > "$WORK/got.ply" &
    local reader=$! rc
    echo "+ timeout 120 $ALIGN s.xyz t.xyz -o fifo.ply"
    timeout 120 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -o "$WORK/fifo.ply" >"$OUT" 2>"$ERR"
    rc=$?
    wait "$reader"
    [ "$rc" -eq 0 ] || fail "exit $rc (124 = hung)"
    [ -p "$WORK/fifo.ply" ] || fail "the FIFO was replaced"
    "$CHECK" count "$WORK/got.ply" 400 || fail "the reader did not get the cloud"
}

# '-' is stdout: only the JSON is printed there, and it parses.
case_json_stdout() {
    command -v python3 >/dev/null 2>&1 || { echo "SKIP [$CASE]: no python3"; exit 77; }
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" --json -
    python3 -c 'import json,sys; d = json.load(sys.stdin); assert d["schema_version"] == 1' < "$OUT" ||
        fail "stdout is not the JSON document"
}

# JSON: schema_version, parameters by name with symbolic values, stages.
case_json_symbolic() {
    command -v python3 >/dev/null 2>&1 || { echo "SKIP [$CASE]: no python3"; exit 77; }
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" --backend reference --drop-nonfinite off \
        --no-refine --rotations uniform --rotation-count 500 --set top_k=3 --json "$WORK/r.json"
    python3 - "$WORK/r.json" <<'PY' || fail "JSON content"
import json, sys
d = json.load(open(sys.argv[1]))
p = d["parameters"]
assert d["schema_version"] == 1, d["schema_version"]
want = {"drop_nonfinite": "off", "backend": "reference", "refine": "off",
        "rotation_set": "uniform", "rotation_count": 500, "top_k": 3,
        "cull_mutual": "on", "device": None}
for k, v in want.items():
    assert p[k] == v, (k, p[k], v)
assert d["status"] == "PKSS_OK"
assert len(d["candidates"]) == d["n_candidates"] >= 1
assert all(c["stage"] == "search" and c["search"] in (0, 1) for c in d["candidates"])
assert "flags" not in d or d["flags"] and d["note"]
PY
}

# backend auto without a matching device falls back, says so and why.
case_fell_back() {
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" --device no-such-device-xyz --json "$WORK/r.json"
    stderr_has '^pkss-align: warning: .*reference'
    grep -q '"flags": \["fell_back"\]' "$WORK/r.json" || fail "JSON lacks flags"
    grep -q '"note": ".' "$WORK/r.json" || fail "JSON lacks the note"
    grep -q '"backend": "reference"' "$WORK/r.json" || fail "JSON backend"
}

# An unwritable POCL_CACHE_DIR hides PoCL's devices: the reason names it.
case_pocl_cache() {
    [ -n "$INFO" ] || return 0
    POCL_CACHE_DIR=/proc/pkss-no-cache run 0 "$INFO"
    grep -q "POCL_CACHE_DIR names a folder that cannot be written" "$OUT" ||
        grep -q "ICD loader" "$OUT" || fail "the reason does not name POCL_CACHE_DIR"
}

# Output format follows the extension; PCD and XYZ read back bit-identically.
case_output_formats() {
    make_pair "$WORK"
    local ext
    for ext in ply pcd xyz; do
        run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -q -o "$WORK/out.$ext"
    done
    "$CHECK" cloud_same "$WORK/out.pcd" "$WORK/out.ply" || fail "PCD differs from PLY"
    "$CHECK" cloud_same "$WORK/out.xyz" "$WORK/out.ply" || fail "XYZ differs from PLY"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -o - --output-format pcd
    cp "$OUT" "$WORK/stdout.pcd"
    "$CHECK" cloud_same "$WORK/stdout.pcd" "$WORK/out.ply" || fail "-o - PCD differs"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" -o "$WORK/out.foo"
    stderr_has 'output format'
    [ ! -e "$WORK/out.foo" ] || fail "out.foo was written"
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" -o -
    run 2 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" -o "$WORK/o.ply" --output-format obj
}

# getopt_long style: bundled short options; -v reports progress as it runs.
case_short_bundle() {
    make_pair "$WORK"
    run 0 "$ALIGN" -qv "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -o"$WORK/o.xyz"
    [ "$(wc -l < "$OUT")" -eq 4 ] || fail "-q must print the 4 matrix lines only"
    stderr_has '^pkss-align: \[ *[0-9.]+ s\] preprocess'
    stderr_has '^pkss-align: \[ *[0-9.]+ s\] search'
    stderr_has '^pkss-align: times'
    "$CHECK" count "$WORK/o.xyz" 400 || fail "-oFILE"
    run 2 "$ALIGN" -qx "$WORK/s.xyz" "$WORK/t.xyz"
    stderr_has "unknown option '-x'"
}

# Standard input: PLY is recognised from the content, XYZ needs a format.
case_stdin_input() {
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" "${FAST[@]}" -q -o "$WORK/s.ply" --ascii
    echo "+ $ALIGN - t.xyz < s.ply"
    "$ALIGN" - "$WORK/t.xyz" "${FAST[@]}" -q < "$WORK/s.ply" >"$OUT" 2>"$ERR" || fail "PLY on stdin: exit $?"
    echo "+ $ALIGN - t.xyz < s.xyz"
    "$ALIGN" - "$WORK/t.xyz" "${FAST[@]}" < "$WORK/s.xyz" >"$OUT" 2>"$ERR"
    [ $? -eq 2 ] || fail "XYZ on stdin without --source-format must be a usage error"
    stderr_has 'source-format'
}

# Every parameter of the library's table is an option in --help, with its
# default (pkss-info --params is the machine-readable table).
case_help_params() {
    [ -n "$INFO" ] || fail "PKSS_INFO not set"
    "$INFO" --params > "$WORK/params.tsv" || fail "pkss-info --params"
    "$ALIGN" --help > "$OUT" 2>"$ERR" || fail "--help"
    local n=0 name id type def lo hi unit choices constraint opt doc
    # tab is whitespace to `read` (empty fields would merge): use \x1f
    while IFS=$'\x1f' read -r name id type def lo hi unit choices constraint opt doc; do
        [ "$name" = name ] && continue
        n=$((n + 1))
        grep -Eq -e "^  $opt( |\[|$)" "$OUT" || fail "--help lacks $opt"
        if [ "$type" != string ]; then
            grep -A1 -E -e "^  $opt( |\[|$)" "$OUT" | grep -Fq "default $def" ||
                fail "--help gives no 'default $def' for $opt"
        fi
        grep -Fq -- "$doc" "$OUT" || fail "--help lacks the doc of $name"
    done < <(tr '\t' '\037' < "$WORK/params.tsv")
    [ "$n" -ge 10 ] || fail "only $n parameters listed"
    echo "$n parameters checked"
    # and each option works with a symbolic value where it has one
    make_pair "$WORK"
    run 0 "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" --backend=reference --cull-stat off \
        --use-features=on --pca-prealign default --rotation-set euler --rotation-steps 8 -q
}

# kill -9 while -o is written: the final path holds the old content or the
# complete new cloud, never a partial file.
case_kill9_output() {
    make_cloud "$WORK/big.xyz" 1000000
    make_cloud "$WORK/t.xyz" 2000
    local n pid i seen=0 old
    for n in 0 1 2; do # 2: mid-write with no old file
        echo "old content" > "$WORK/out.xyz"
        [ "$n" -eq 2 ] && rm -f "$WORK/out.xyz"
        old=$(sha256sum < "$WORK/out.xyz" 2>/dev/null)
        rm -f "$WORK"/.out.xyz.*
        "$ALIGN" "$WORK/big.xyz" "$WORK/t.xyz" "${FAST[@]}" --points 256 --rotation-steps 4 \
            --offset-steps 1 -q -o "$WORK/out.xyz" >/dev/null 2>&1 &
        pid=$!
        seen=0
        if [ "$n" -eq 0 ]; then
            sleep 0.2 # right after the start
        else
            for i in $(seq 1 3000); do # mid-write: the temporary file exists
                if compgen -G "$WORK/.out.xyz.*" >/dev/null; then seen=1; break; fi
                kill -0 "$pid" 2>/dev/null || break
                sleep 0.01
            done
        fi
        kill -9 "$pid" 2>/dev/null
        wait "$pid" 2>/dev/null
        if [ "$n" -eq 2 ] && [ ! -e "$WORK/out.xyz" ]; then
            echo "kill -9 ($n): no file at the final path"
            continue
        fi
        [ -e "$WORK/out.xyz" ] || fail "kill -9 ($n) removed the old file"
        if [ "$(sha256sum < "$WORK/out.xyz")" != "$old" ]; then
            [ "$(wc -l < "$WORK/out.xyz")" -eq 1000000 ] ||
                fail "kill -9 ($n) left a partial file at the final path"
            echo "kill -9 ($n) came after the rename: complete new file"
        else
            echo "kill -9 ($n): old content kept"
        fi
        [ "$n" -eq 0 ] || [ "$seen" -eq 1 ] ||
            echo "note: the temporary file was not seen (the write was too quick)"
    done
}

# SIGINT cancels the run through the progress callback: exit 130, no output.
case_sigint() {
    make_pair "$WORK"
    echo "old" > "$WORK/r.json"
    "$ALIGN" "$WORK/s.xyz" "$WORK/t.xyz" --backend reference --rotation-set uniform \
        --rotation-count 20000 --top-k 32 -v --json "$WORK/r.json" -o "$WORK/new.ply" >"$OUT" 2>"$ERR" &
    local pid=$! rc i
    for i in $(seq 1 500); do # wait until the search runs
        grep -q '\] search' "$ERR" && break
        sleep 0.02
    done
    kill -INT "$pid"
    wait "$pid"
    rc=$?
    echo "exit $rc"
    [ "$rc" -eq 130 ] || fail "exit $rc after SIGINT, expected 130"
    stderr_has 'PKSS_ERR_CANCELLED'
    [ "$(cat "$WORK/r.json")" = old ] || fail "the JSON was changed"
    [ ! -e "$WORK/new.ply" ] || fail "new.ply was written"
    ! compgen -G "$WORK/.*.ply.*" >/dev/null || fail "a temporary file was left"
}

if ! declare -F "case_$CASE" >/dev/null; then
    echo "unknown case '$CASE'"; exit 2
fi
"case_$CASE"
echo "PASS [$CASE]"
exit 0
