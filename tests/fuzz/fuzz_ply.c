/* SPDX-License-Identifier: MIT
 * fuzz_ply.c -- libFuzzer harness: pkss_io_read_memory() as PLY. */
#define FUZZ_FORMAT PKSS_IO_PLY
#include "fuzz_common.h"
