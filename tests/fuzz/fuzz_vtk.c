/* SPDX-License-Identifier: MIT
 * fuzz_vtk.c -- libFuzzer harness: pkss_io_read_memory() as VTK. */
#define FUZZ_FORMAT PKSS_IO_VTK
#include "fuzz_common.h"
