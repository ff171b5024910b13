/* SPDX-License-Identifier: MIT
 * fuzz_common.h -- the libFuzzer entry point shared by every fuzz_<fmt>.c:
 * define FUZZ_FORMAT, then include this file.
 *
 * Beyond "no crash, no sanitizer report", it checks the reader's contract:
 * success gives n >= 1 points that can all be read; failure gives
 * xyz == NULL, n == 0, a known status and a non-empty message.
 */
#include "pkss_io.h"

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#ifndef FUZZ_FORMAT
#error "define FUZZ_FORMAT before including fuzz_common.h"
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    double *xyz = NULL, sum = 0.0;
    size_t n = 12345, i;
    char err[512];
    pkss_io_status st;

    memset(err, 'x', sizeof err);
    st = pkss_io_read_memory(data, size, FUZZ_FORMAT, &xyz, &n, err,
                             sizeof err);
    if (memchr(err, '\0', sizeof err) == NULL)
        __builtin_trap(); /* message not terminated */
    if (st == PKSS_IO_OK) {
        if (xyz == NULL || n == 0)
            __builtin_trap();
        for (i = 0; i < 3 * n; i++) /* ASan: every point is really there */
            sum += xyz[i];
        (void)sum;
    } else {
        if (xyz != NULL || n != 0 || err[0] == '\0')
            __builtin_trap();
        if (strcmp(pkss_io_status_name(st), "PKSS_IO_UNKNOWN_STATUS") == 0)
            __builtin_trap();
    }
    pkss_io_free(xyz);
    return 0;
}
