/* SPDX-License-Identifier: MIT
 * pkss_io.h -- point cloud files: the readers and writers of libpkss, shared
 * by the C API, the Python binding and the pkss-align tool (part of ABI 1.0;
 * the rules of docs/compatibility.md apply: formats and flags are appended,
 * signatures never change).
 *
 * A reader returns the x y z columns as a freshly malloc'd row-major n x 3
 * double array (free it with pkss_points_free), or a status from pkss.h and
 * a message in detail naming the problem (file, line or byte offset where it
 * helps). Readers never crash or hang on malformed input: sizes in headers
 * are checked against the data actually present before allocation. Reading
 * is bounded: the first 4 KB are checked against the format before the rest
 * is read (so /dev/zero or a huge file of another kind fails at once), a
 * regular file is mapped (only the pages the parser touches are read) and
 * a pipe, device or standard input is read up to 1 GiB, past which it is an
 * error. A UTF-8 byte order mark is accepted before every text format. A
 * file cut short says "truncated at byte N: expected M ..., got K". Data
 * after the points a header declares is an error where nothing else may
 * follow (PLY with vertex the last element, PCD ascii/binary, XYZ with a
 * count line, NPY). PLY: a second x/y/z property or a second vertex element
 * is an error. XYZ lines written with decimal commas ("1,5 2,5 3,5") are
 * refused rather than misread.
 *
 * NaN and Inf coordinates are NOT rejected: they are returned as read
 * (organized PCD clouds mark missing points with NaN). pkss_cloud_create()
 * fails with PKSS_ERR_NONFINITE unless PKSS_PARAM_DROP_NONFINITE is on.
 *
 * Statuses: a file that cannot be opened, read or written -> PKSS_ERR_IO;
 * a 0-byte file or one that declares 0 points -> PKSS_ERR_EMPTY_INPUT;
 * malformed content, truncated data or a header whose counts exceed the
 * bytes present -> PKSS_ERR_FORMAT; a valid variant no reader handles
 * (binary OFF, PCD F16, VTK STRUCTURED_POINTS, an .npy of another dtype or
 * shape, a compressed .npz) -> PKSS_ERR_UNSUPPORTED_FORMAT; NULL xyz or n
 * -> PKSS_ERR_NULL_ARGUMENT; an unknown format or a format that cannot be
 * told -> PKSS_ERR_INVALID_ARGUMENT; PKSS_ERR_OUT_OF_MEMORY. Messages of
 * pkss_read_points() start with the path.
 *
 * Formats. XYZ family (.xyz .txt .csv .pts .asc): the first three columns
 * of each line, blank- and/or comma-separated; '#' starts a comment; up to
 * 64 lines of non-numeric text before the first row are a header; a first
 * line holding a single integer is a point count and must match the rows.
 * PCD: ascii, binary, binary_compressed (LZF). NPY: format versions 1, 2
 * and 3, dtype '<f8' '>f8' '<f4' '>f4', shape (N, 3), C or Fortran order,
 * header at most 64 KB. NPZ (np.savez: a zip of .npy members, stored):
 * the array named by the caller, else the single array, else "points" or
 * "xyz"; np.savez_compressed (deflate) is refused with a message saying so.
 */
#ifndef PKSS_IO_H
#define PKSS_IO_H

#include <stddef.h>
#include <stdio.h>

#include "pkss.h"

#ifdef __cplusplus
extern "C" {
#endif

/* PKSS_CDEF_BEGIN */
typedef enum pkss_format {
    PKSS_FORMAT_AUTO = 0,  /* by extension, else by content */
    PKSS_FORMAT_PLY = 1,   /* ascii, binary_little_endian, binary_big_endian */
    PKSS_FORMAT_PCD = 2,   /* ascii, binary, binary_compressed (LZF) */
    PKSS_FORMAT_XYZ = 3,   /* .xyz .txt .csv .pts .asc */
    PKSS_FORMAT_OFF = 4,   /* OFF vertices (read only) */
    PKSS_FORMAT_KITTI = 5, /* .bin float32 x y z intensity records (read only) */
    PKSS_FORMAT_VTK = 6,   /* legacy VTK POINTS, ascii/binary (read only) */
    PKSS_FORMAT_NPY = 7,   /* NumPy .npy, (N, 3) float64 or float32 */
    PKSS_FORMAT_NPZ = 8    /* NumPy .npz of .npy members, stored (read only) */
} pkss_format;

/* Flags of pkss_write_points(). */
typedef enum pkss_write_flag {
    PKSS_WRITE_ASCII = 1   /* PLY: ascii instead of binary little-endian */
} pkss_write_flag;

/** "ply", "pcd", "xyz", "off", "kitti", "vtk", "npy", "npz"; "auto" for
 *  PKSS_FORMAT_AUTO; NULL for an unknown value. */
PKSS_API const char *pkss_format_name(pkss_format format);
/** Parses a format name or extension ("ply", "txt", "csv", "pts", "asc",
 *  "bin", "kitti", "npy", "npz", "auto", ...), case-insensitively. An
 *  unknown name gives a value for which pkss_format_name() returns NULL. */
PKSS_API pkss_format pkss_format_from_name(const char *name);
/** The format of a path's extension (".npz:name" counts as .npz),
 *  PKSS_FORMAT_AUTO if none matches. */
PKSS_API pkss_format pkss_format_from_path(const char *path);
/** The format from the first bytes (ply / # vtk / PCD header / OFF / NumPy
 *  magic / zip), PKSS_FORMAT_AUTO if none matches. */
PKSS_API pkss_format pkss_format_from_content(const void *data, size_t size);

/** Reads a point cloud file. path "-" reads standard input (the format is
 *  then given or told from the content). With PKSS_FORMAT_AUTO the
 *  extension decides, else the content. "scan.npz:name" reads the array
 *  "name" of scan.npz (unless a file of that exact name exists).
 *  @param xyz receives n x 3 doubles to free with pkss_points_free().
 *  @param detail receives a message on failure ("" on success); may be NULL.
 *  @return PKSS_OK or a status listed above; on failure *xyz = NULL, *n = 0. */
PKSS_API pkss_status pkss_read_points(const char *path, pkss_format format,
                                      double **xyz, size_t *n, char *detail,
                                      size_t detail_size);
/** The same parsers on a memory buffer (need not be NUL-terminated; with
 *  PKSS_FORMAT_AUTO the content decides). array selects the member of an
 *  .npz (NULL: the single array, else "points" or "xyz"); it must be NULL
 *  for every other format. */
PKSS_API pkss_status pkss_read_points_buffer(const void *data, size_t size,
                                             pkss_format format,
                                             const char *array, double **xyz,
                                             size_t *n, char *detail,
                                             size_t detail_size);
/** Writes n points (n >= 1) as PLY (binary little-endian doubles, or ascii
 *  with PKSS_WRITE_ASCII), PCD (ascii), XYZ (text) or NPY ('<f8', C order,
 *  version 1.0). Text formats print %.17g, so every double reads back
 *  bit-identically. path "-" writes standard output. PKSS_FORMAT_AUTO takes
 *  the format from the extension; a format that cannot be written (OFF,
 *  KITTI, VTK, NPZ, unknown) is PKSS_ERR_INVALID_ARGUMENT before anything is
 *  created. An existing file is replaced only once the new one is complete
 *  (written next to it, then renamed); a failed write leaves it untouched.
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT, PKSS_ERR_INVALID_ARGUMENT,
 *          PKSS_ERR_EMPTY_INPUT (n = 0) or PKSS_ERR_IO. */
PKSS_API pkss_status pkss_write_points(const char *path, pkss_format format,
                                       const double *xyz, size_t n,
                                       unsigned flags, char *detail,
                                       size_t detail_size);
/** Frees an array returned by a reader (NULL is ignored). */
PKSS_API void pkss_points_free(double *xyz);
/* PKSS_CDEF_END */

/** pkss_write_points() into an open stream (not closed; flushed). format
 *  must name a writable format (no AUTO). @return as pkss_write_points(). */
PKSS_API pkss_status pkss_write_points_stream(FILE *stream, pkss_format format,
                                              const double *xyz, size_t n,
                                              unsigned flags, char *detail,
                                              size_t detail_size);

#ifdef __cplusplus
}
#endif
#endif
