/* SPDX-License-Identifier: MIT
 * fuzz_vtk.c -- libFuzzer harness: pkss_read_points_buffer() as VTK. */
#define FUZZ_FORMAT PKSS_FORMAT_VTK
#include "fuzz_common.h"
