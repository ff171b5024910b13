#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The shared library's link surface (ctest package_exports):
#   - no NEEDED libOpenCL: the OpenCL ICD loader is dlopen()ed at first use
#     (src/device/cl_loader.c), so libpkss loads on a machine without it;
#   - only the public API is exported: every dynamic symbol it defines is
#     pkss_<name>, none is an internal pkss__<name> (e.g. the test hook
#     pkss__test_set_alloc_budget, reachable from libpkss.a only).
# usage: check_exports.sh path/to/libpkss.so
set -euo pipefail
lib=${1:?usage: check_exports.sh libpkss.so}
fail=0
echo "NEEDED of $lib:"
readelf -d "$lib" | grep NEEDED | sed 's/^/  /'
if readelf -d "$lib" | grep NEEDED | grep -qi opencl; then
    echo "FAIL: $lib links the OpenCL loader (must be dlopen()ed at run time)"
    fail=1
fi
defined=$(nm -D --defined-only "$lib" | awk '{print $NF}' | sed 's/@.*//' | sort -u)
echo "exported: $(echo "$defined" | wc -l) symbols"
bad=$(echo "$defined" | grep -v '^pkss_' || true)
internal=$(echo "$defined" | grep '^pkss__' || true)
if [ -n "$bad$internal" ]; then
    echo "FAIL: exported symbols outside the public pkss_* API:"
    echo "$bad$internal" | sed 's/^/  /'
    fail=1
fi
[ $fail -eq 0 ] && echo "PASS: no libOpenCL dependency; exports are pkss_* only"
exit $fail
