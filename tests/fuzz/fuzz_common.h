/* SPDX-License-Identifier: MIT
 * fuzz_common.h -- the libFuzzer entry point shared by every fuzz_<fmt>.c:
 * define FUZZ_FORMAT, then include this file. It feeds the public entry
 * point pkss_read_points_buffer(); with FUZZ_BY_PATH defined it writes the
 * bytes to an in-memory file and calls pkss_read_points() on its path (the
 * bounded file reading and the format sniffing).
 *
 * Beyond "no crash, no sanitizer report", it checks the reader's contract:
 * success gives n >= 1 points that can all be read; failure gives
 * xyz == NULL, n == 0, a known status and a non-empty message.
 */
#ifdef FUZZ_BY_PATH
#define _GNU_SOURCE /* memfd_create */
#include <sys/mman.h>
#include <unistd.h>
#endif
#include "pkss_io.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
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
    pkss_status st;

    memset(err, 'x', sizeof err);
#ifdef FUZZ_BY_PATH
    {
        static int fd = -1;
        char path[64];
        if (fd < 0)
            fd = memfd_create("fuzz", 0);
        if (fd < 0 || ftruncate(fd, 0) != 0 ||
            (size && pwrite(fd, data, size, 0) != (ssize_t)size))
            __builtin_trap();
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
        st = pkss_read_points(path, FUZZ_FORMAT, &xyz, &n, err, sizeof err);
    }
#else
    st = pkss_read_points_buffer(data, size, FUZZ_FORMAT, NULL, &xyz, &n, err,
                                 sizeof err);
#endif
    if (memchr(err, '\0', sizeof err) == NULL)
        __builtin_trap(); /* message not terminated */
    if (st == PKSS_OK) {
        if (xyz == NULL || n == 0)
            __builtin_trap();
        for (i = 0; i < 3 * n; i++) /* ASan: every point is really there */
            sum += xyz[i];
        (void)sum;
    } else {
        if (xyz != NULL || n != 0 || err[0] == '\0')
            __builtin_trap();
        if (strcmp(pkss_status_name(st), "PKSS_UNKNOWN_STATUS") == 0)
            __builtin_trap();
    }
    pkss_points_free(xyz);
    return 0;
}
