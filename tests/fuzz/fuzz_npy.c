/* SPDX-License-Identifier: MIT
 * fuzz_npy.c -- libFuzzer harness: pkss_read_points_buffer() as NPY. */
#define FUZZ_FORMAT PKSS_FORMAT_NPY
#include "fuzz_common.h"
