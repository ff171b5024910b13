/* SPDX-License-Identifier: MIT
 * fuzz_kitti.c -- libFuzzer harness: pkss_read_points_buffer() as KITTI. */
#define FUZZ_FORMAT PKSS_FORMAT_KITTI
#include "fuzz_common.h"
