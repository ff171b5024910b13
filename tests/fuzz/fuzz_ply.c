/* SPDX-License-Identifier: MIT
 * fuzz_ply.c -- libFuzzer harness: pkss_read_points_buffer() as PLY. */
#define FUZZ_FORMAT PKSS_FORMAT_PLY
#include "fuzz_common.h"
