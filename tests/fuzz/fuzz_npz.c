/* SPDX-License-Identifier: MIT
 * fuzz_npz.c -- libFuzzer harness: pkss_read_points_buffer() as NPZ. */
#define FUZZ_FORMAT PKSS_FORMAT_NPZ
#include "fuzz_common.h"
