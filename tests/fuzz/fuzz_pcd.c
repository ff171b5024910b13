/* SPDX-License-Identifier: MIT
 * fuzz_pcd.c -- libFuzzer harness: pkss_read_points_buffer() as PCD. */
#define FUZZ_FORMAT PKSS_FORMAT_PCD
#include "fuzz_common.h"
