/* SPDX-License-Identifier: MIT
 * fuzz_off.c -- libFuzzer harness: pkss_read_points_buffer() as OFF. */
#define FUZZ_FORMAT PKSS_FORMAT_OFF
#include "fuzz_common.h"
