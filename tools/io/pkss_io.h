/* SPDX-License-Identifier: MIT
 * pkss_io.h -- point cloud file readers and a PLY writer for the pkss tools
 * and tests. Not part of the library ABI (libpkss does no I/O).
 *
 * Every reader returns the x y z columns as a freshly malloc'd row-major
 * n x 3 double array (free it with pkss_io_free), or a status and a message
 * in err naming the problem (file, line or byte offset where it helps).
 * Readers never crash or hang on malformed input: sizes in headers are
 * checked against the data actually present before allocation. Reading is
 * bounded: the first 4 KB are checked against the format before the rest
 * is read (so /dev/zero or a huge file of another kind fails at once), a
 * regular file is mapped (only the pages the parser touches are read) and
 * a pipe, device or standard input is read up to 1 GiB, past which it is
 * an error. A UTF-8 byte order mark is accepted before every text format.
 * A file cut short says "truncated at byte N: expected M ..., got K".
 * Data after the points a header declares is an error where nothing else
 * may follow (PLY with vertex the last element, PCD ascii/binary, XYZ
 * with a count line). PLY: a second x/y/z property or a second vertex
 * element is an error. XYZ lines written with decimal commas ("1,5 2,5
 * 3,5", "1,5;2,5;3,5") are refused rather than misread.
 *
 * NaN and Inf coordinates are NOT rejected: they are returned as read
 * (organized PCD clouds mark missing points with NaN). The library decides
 * what to do with them: pkss_cloud_create() fails with PKSS_ERR_NONFINITE
 * unless PKSS_PARAM_DROP_NONFINITE is on, and pkss-align reports that as
 * bad data (exit 4).
 *
 * Statuses: a file that cannot be opened or read -> PKSS_IO_ERR_OPEN; a
 * 0-byte file or one that declares 0 points -> PKSS_IO_ERR_EMPTY; malformed
 * content, truncated data or a header whose counts exceed the bytes
 * present -> PKSS_IO_ERR_FORMAT; a valid variant this reader does not
 * handle (binary OFF, 4D OFF, PCD F16, VTK STRUCTURED_POINTS)
 * -> PKSS_IO_ERR_UNSUPPORTED. Messages from pkss_io_read() start with the
 * path. PCD binary_compressed (LZF) is supported.
 *
 * Text formats: the XYZ family (.xyz .txt .csv .pts .asc) takes the first
 * three columns of each line, blank- and/or comma-separated; '#' starts a
 * comment; up to 64 lines of non-numeric text before the first row are a
 * header; a first line holding a single integer is a point count and must
 * match the rows read (Go-ICP .txt, Leica .pts).
 */
#ifndef PKSS_IO_H
#define PKSS_IO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pkss_io_format {
    PKSS_IO_AUTO = 0,  /* by file extension */
    PKSS_IO_PLY = 1,   /* ascii, binary_little_endian, binary_big_endian */
    PKSS_IO_PCD = 2,   /* ascii, binary, binary_compressed (LZF) */
    PKSS_IO_XYZ = 3,   /* .xyz .txt .csv .pts .asc: blank/comma, header ok */
    PKSS_IO_OFF = 4,   /* OFF vertices */
    PKSS_IO_KITTI = 5, /* .bin: float32 x y z intensity records */
    PKSS_IO_VTK = 6    /* legacy VTK POLYDATA/UNSTRUCTURED_GRID/STRUCTURED_GRID
                          POINTS (ascii/binary big-endian) */
} pkss_io_format;

typedef enum pkss_io_status {
    PKSS_IO_OK = 0,
    PKSS_IO_ERR_OPEN = 1,        /* cannot open / read the file */
    PKSS_IO_ERR_FORMAT = 2,      /* malformed content */
    PKSS_IO_ERR_UNSUPPORTED = 3, /* valid but unsupported variant */
    PKSS_IO_ERR_NOMEM = 4,
    PKSS_IO_ERR_ARGUMENT = 5,    /* NULL pointer, unknown format/extension */
    PKSS_IO_ERR_EMPTY = 6        /* no points */
} pkss_io_status;

/* "ply", "pcd", ... ; "auto" for PKSS_IO_AUTO; NULL if unknown. */
const char *pkss_io_format_name(pkss_io_format f);
/* Parses "ply", "pcd", "xyz", "txt", "csv", "off", "bin", "kitti", "vtk"
 * (also "pts", "asc", "auto"), case-insensitively. An unknown name gives a
 * value for which pkss_io_format_name() returns NULL. */
pkss_io_format pkss_io_format_from_name(const char *name);
/* Format from a path's extension, PKSS_IO_AUTO if none matches. */
pkss_io_format pkss_io_format_from_path(const char *path);
/* Format from the first bytes (ply / # vtk / PCD header / OFF keyword),
 * PKSS_IO_AUTO if none matches. pkss_io_read() with PKSS_IO_AUTO uses the
 * extension first and this when the extension is unknown. */
pkss_io_format pkss_io_format_from_content(const void *data, size_t size);
const char *pkss_io_status_name(pkss_io_status s);

/* path "-" reads standard input (then name the format). */
pkss_io_status pkss_io_read(const char *path, pkss_io_format fmt,
                            double **xyz, size_t *n, char *err,
                            size_t err_size);
/* The same parsers on a memory buffer (the data need not be NUL-terminated;
 * with PKSS_IO_AUTO the content decides, see pkss_io_format_from_content):
 * used by the fuzzers. */
pkss_io_status pkss_io_read_memory(const void *data, size_t size,
                                   pkss_io_format fmt, double **xyz,
                                   size_t *n, char *err, size_t err_size);
/* Writes x y z as PLY (binary little-endian doubles, or ascii). */
pkss_io_status pkss_io_write_ply(const char *path, const double *xyz,
                                 size_t n, int ascii, char *err,
                                 size_t err_size);
void pkss_io_free(double *xyz);

/* LZF decompression as used by PCD binary_compressed (liblzf format),
 * bounds-checked. @return the bytes written to out, or 0 on corrupt input
 * or if out_len is too small; *bad_at receives the input offset where
 * decoding failed. */
size_t pkss_io_lzf_decompress(const unsigned char *in, size_t in_len,
                              unsigned char *out, size_t out_len,
                              size_t *bad_at);

#ifdef __cplusplus
}
#endif
#endif
