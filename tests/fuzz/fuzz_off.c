/* SPDX-License-Identifier: MIT
 * fuzz_off.c -- libFuzzer harness: pkss_io_read_memory() as OFF. */
#define FUZZ_FORMAT PKSS_IO_OFF
#include "fuzz_common.h"
