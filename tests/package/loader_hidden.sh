#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# A machine without the OpenCL ICD loader, simulated with
# PKSS_OPENCL_LIBRARY=/nonexistent (ctest package_loader_hidden): pkss-info
# still runs and says why there is no device, and pkss-align registers the
# bundled pair on the reference backend (AUTO falls back) within the
# ground-truth bars (check_pose: rotation 2 deg, scale and translation 1 %).
# usage: loader_hidden.sh PKSS_INFO PKSS_ALIGN CHECK_POSE DATA_DIR WORK_DIR
set -euo pipefail
info=$1 align=$2 check=$3 data=$4 work=$5
mkdir -p "$work"
export PKSS_OPENCL_LIBRARY=/nonexistent/libOpenCL.so.1
out=$("$info")
echo "$out" | sed -n '/OpenCL devices/,+1p'
grep -q '^OpenCL devices: none' <<< "$out" ||
    { echo "FAIL: pkss-info lists devices without the loader"; exit 1; }
grep -q 'the OpenCL ICD loader (libOpenCL.so.1) could not be loaded: /nonexistent/libOpenCL.so.1: ' <<< "$out" ||
    { echo "FAIL: pkss-info does not say that the loader is missing"; exit 1; }
grep -q 'install ocl-icd-libopencl1 and pocl-opencl-icd' <<< "$out" ||
    { echo "FAIL: pkss-info does not say what to install"; exit 1; }
"$align" "$data/airplane_0001_s.ply" "$data/airplane_0001_t.ply" \
    --matrix "$work/T.txt" --json "$work/result.json" 2>"$work/stderr.txt"
cat "$work/stderr.txt"
grep -q '"backend": "reference"' "$work/result.json" ||
    { echo "FAIL: the registration did not run on the reference backend"; exit 1; }
"$check" pose "$work/T.txt" "$data/gt_similarity_s_to_t.txt" \
    "$data/airplane_0001_s.ply" "$data/airplane_0001_t.ply" 2 0.01 0.01
echo "PASS: without libOpenCL, pkss-info says why and AUTO registers on the reference backend"
