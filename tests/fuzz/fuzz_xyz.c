/* SPDX-License-Identifier: MIT
 * fuzz_xyz.c -- libFuzzer harness: pkss_read_points_buffer() as XYZ. */
#define FUZZ_FORMAT PKSS_FORMAT_XYZ
#include "fuzz_common.h"
