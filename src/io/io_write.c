/* SPDX-License-Identifier: MIT
 * io_write.c -- pkss_write_points(): PLY (binary little-endian or ascii),
 * PCD (ascii), XYZ and NPY ('<f8', version 1.0). Text is printed with
 * %.17g, so every double reads back bit-identically; NPY and binary PLY
 * store the doubles themselves. A file is written next to its final name
 * and renamed into place once complete, so a failed write never leaves a
 * half file where the user's file was.
 */
#define _POSIX_C_SOURCE 200809L /* fdopen, open */
#include "io_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static pkss_status fail(char *err, size_t err_size, pkss_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static pkss_status fail(char *err, size_t err_size, pkss_status st, const char *fmt, ...)
{
    if (err && err_size > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, err_size, fmt, ap);
        va_end(ap);
    }
    return st;
}

static int host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

/* 24 bytes of one point as little-endian doubles. */
static void point_le(const double *p, unsigned char rec[24])
{
    memcpy(rec, p, 24);
    if (!host_is_little_endian())
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 4; j++) {
                unsigned char t = rec[8 * k + j];
                rec[8 * k + j] = rec[8 * k + 7 - j];
                rec[8 * k + 7 - j] = t;
            }
}

static int write_text_rows(FILE *f, const double *xyz, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (fprintf(f, "%.17g %.17g %.17g\n", xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) < 0)
            return -1;
    return 0;
}

static int write_le_rows(FILE *f, const double *xyz, size_t n)
{
    unsigned char rec[24];
    for (size_t i = 0; i < n; i++) {
        point_le(xyz + 3 * i, rec);
        if (fwrite(rec, 1, 24, f) != 24)
            return -1;
    }
    return 0;
}

static int write_ply(FILE *f, const double *xyz, size_t n, int ascii)
{
    if (fprintf(f,
                "ply\nformat %s 1.0\ncomment written by pkss\n"
                "element vertex %llu\nproperty double x\nproperty double y\n"
                "property double z\nend_header\n",
                ascii ? "ascii" : "binary_little_endian", (unsigned long long)n) < 0)
        return -1;
    return ascii ? write_text_rows(f, xyz, n) : write_le_rows(f, xyz, n);
}

static int write_pcd(FILE *f, const double *xyz, size_t n)
{
    if (fprintf(f,
                "# .PCD v0.7 - Point Cloud Data file format (written by pkss)\n"
                "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\n"
                "COUNT 1 1 1\nWIDTH %llu\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
                "POINTS %llu\nDATA ascii\n",
                (unsigned long long)n, (unsigned long long)n) < 0)
        return -1;
    return write_text_rows(f, xyz, n);
}

/* Version 1.0: the preamble plus the header padded with blanks to a
 * multiple of 64 bytes and ended by '\n', as numpy writes it. */
static int write_npy(FILE *f, const double *xyz, size_t n)
{
    char dict[160];
    unsigned char pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, 0, 0};
    int len = snprintf(dict, sizeof dict,
                       "{'descr': '<f8', 'fortran_order': False, 'shape': (%llu, 3), }",
                       (unsigned long long)n);
    size_t total = 10 + (size_t)len + 1, padded = (total + 63) / 64 * 64;
    size_t hlen = padded - 10;
    pre[8] = (unsigned char)(hlen & 0xFF);
    pre[9] = (unsigned char)(hlen >> 8);
    if (fwrite(pre, 1, 10, f) != 10 || fwrite(dict, 1, (size_t)len, f) != (size_t)len)
        return -1;
    for (size_t i = 0; i < padded - total; i++)
        if (fputc(' ', f) == EOF)
            return -1;
    if (fputc('\n', f) == EOF)
        return -1;
    return write_le_rows(f, xyz, n);
}

static pkss_status check_args(pkss_format format, const double *xyz, size_t n, char *err,
                              size_t err_size)
{
    if (!xyz)
        return fail(err, err_size, PKSS_ERR_NULL_ARGUMENT, "xyz must not be NULL");
    if (n == 0)
        return fail(err, err_size, PKSS_ERR_EMPTY_INPUT, "no points to write (n = 0)");
    if (format != PKSS_FORMAT_PLY && format != PKSS_FORMAT_PCD &&
        format != PKSS_FORMAT_XYZ && format != PKSS_FORMAT_NPY)
        return fail(err, err_size, PKSS_ERR_INVALID_ARGUMENT,
                    "cannot write format '%s' (writable: ply pcd xyz npy)",
                    pkss_format_name(format) ? pkss_format_name(format) : "unknown");
    return PKSS_OK;
}

pkss_status pkss_write_points_stream(FILE *f, pkss_format format, const double *xyz,
                                     size_t n, unsigned flags, char *err, size_t err_size)
{
    pkss_status st;
    int rc;
    if (err && err_size)
        err[0] = '\0';
    if (!f)
        return fail(err, err_size, PKSS_ERR_NULL_ARGUMENT, "stream must not be NULL");
    st = check_args(format, xyz, n, err, err_size);
    if (st != PKSS_OK)
        return st;
    errno = 0;
    switch (format) {
    case PKSS_FORMAT_PLY: rc = write_ply(f, xyz, n, (flags & PKSS_WRITE_ASCII) != 0); break;
    case PKSS_FORMAT_PCD: rc = write_pcd(f, xyz, n); break;
    case PKSS_FORMAT_XYZ: rc = write_text_rows(f, xyz, n); break;
    default: rc = write_npy(f, xyz, n); break;
    }
    if (fflush(f) != 0 || ferror(f))
        rc = -1;
    if (rc != 0)
        return fail(err, err_size, PKSS_ERR_IO, "write failed: %s",
                    errno ? strerror(errno) : "unknown error");
    return PKSS_OK;
}

pkss_status pkss_write_points(const char *path, pkss_format format, const double *xyz,
                              size_t n, unsigned flags, char *err, size_t err_size)
{
    char msg[512];
    char *tmp;
    size_t plen;
    int fd = -1;
    FILE *f;
    pkss_status st;

    if (err && err_size)
        err[0] = '\0';
    if (!path)
        return fail(err, err_size, PKSS_ERR_NULL_ARGUMENT, "path must not be NULL");
    if (format == PKSS_FORMAT_AUTO) {
        format = pkss_format_from_path(path);
        if (format == PKSS_FORMAT_AUTO)
            return fail(err, err_size, PKSS_ERR_INVALID_ARGUMENT,
                        "%s: no format given and the extension names none "
                        "(writable: .ply .pcd .xyz .npy)", path);
    }
    st = check_args(format, xyz, n, msg, sizeof msg);
    if (st != PKSS_OK)
        return fail(err, err_size, st, "%s: %s", path, msg);
    if (strcmp(path, "-") == 0) {
        st = pkss_write_points_stream(stdout, format, xyz, n, flags, msg, sizeof msg);
        return st == PKSS_OK ? st : fail(err, err_size, st, "standard output: %s", msg);
    }
    plen = strlen(path);
    tmp = (char *)malloc(plen + 32);
    if (!tmp)
        return fail(err, err_size, PKSS_ERR_OUT_OF_MEMORY, "%s: out of memory", path);
    /* O_EXCL on a fresh name next to the target (same file system, so the
     * rename is atomic); mode 0666 lets the umask decide, as fopen would. */
    for (unsigned k = 0; k < 100 && fd < 0; k++) {
        snprintf(tmp, plen + 32, "%s.tmp-%ld-%u", path, (long)getpid(), k);
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL, 0666);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) {
        int e = errno;
        free(tmp);
        return fail(err, err_size, PKSS_ERR_IO, "%s: cannot create: %s", path, strerror(e));
    }
    f = fdopen(fd, "wb");
    if (!f) {
        int e = errno;
        close(fd);
        unlink(tmp);
        free(tmp);
        return fail(err, err_size, PKSS_ERR_IO, "%s: cannot create: %s", path, strerror(e));
    }
    st = pkss_write_points_stream(f, format, xyz, n, flags, msg, sizeof msg);
    if (fclose(f) != 0 && st == PKSS_OK)
        st = fail(msg, sizeof msg, PKSS_ERR_IO, "write failed: %s", strerror(errno));
    if (st == PKSS_OK && rename(tmp, path) != 0)
        st = fail(msg, sizeof msg, PKSS_ERR_IO, "cannot rename the finished file into "
                  "place: %s", strerror(errno));
    if (st != PKSS_OK) {
        unlink(tmp);
        fail(err, err_size, st, "%s: %s", path, msg);
    }
    free(tmp);
    return st;
}
