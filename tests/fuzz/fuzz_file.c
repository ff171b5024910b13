/* SPDX-License-Identifier: MIT
 * fuzz_file.c -- libFuzzer harness: pkss_read_points() on a file of the
 * fuzzer's bytes with the format told from the content. */
#define FUZZ_FORMAT PKSS_FORMAT_AUTO
#define FUZZ_BY_PATH
#include "fuzz_common.h"
