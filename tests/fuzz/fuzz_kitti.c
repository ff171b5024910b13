/* SPDX-License-Identifier: MIT
 * fuzz_kitti.c -- libFuzzer harness: pkss_io_read_memory() as KITTI. */
#define FUZZ_FORMAT PKSS_IO_KITTI
#include "fuzz_common.h"
