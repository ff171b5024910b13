/* SPDX-License-Identifier: MIT
 * fuzz_pcd.c -- libFuzzer harness: pkss_io_read_memory() as PCD. */
#define FUZZ_FORMAT PKSS_IO_PCD
#include "fuzz_common.h"
