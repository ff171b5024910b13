/* SPDX-License-Identifier: MIT
 * fuzz_xyz.c -- libFuzzer harness: pkss_io_read_memory() as XYZ. */
#define FUZZ_FORMAT PKSS_IO_XYZ
#include "fuzz_common.h"
