/* SPDX-License-Identifier: MIT
 * io_internal.h -- helpers shared by the format parsers of pkss_io.
 *
 * Every parser works on an in-memory buffer [data, data + size) that is NOT
 * NUL-terminated: all scanning is bounded by the end pointer, and numbers
 * are converted from a bounded copy of their token. Parsers report errors
 * through io_fail(); pkss_read_points() then prefixes the file name.
 */
#ifndef PKSS_IO_INTERNAL_H
#define PKSS_IO_INTERNAL_H

#include "pkss_io.h"

#include <stddef.h>
#include <stdint.h>

typedef struct io_ctx {
    const unsigned char *data;
    size_t size;
    char *err;
    size_t err_size;
    const char *array; /* NPZ: the member to read, or NULL */
} io_ctx;

/* Writes the formatted message into ctx->err and returns status. */
pkss_status io_fail(io_ctx *ctx, pkss_status status, const char *fmt,
                       ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Copies up to 40 bytes of a token into buf (size >= 48) for messages:
 * non-printable bytes become \xNN, and "..." marks a cut. */
const char *io_quote(const char *s, size_t len, char *buf, size_t buf_size);

/* -------------------------------------------------------------- numbers */
/* Parses the whole token [s, s+len) as a double (strtod syntax: also nan,
 * inf and hex floats). @return 0 on success, -1 if not a number. */
int io_parse_double(const char *s, size_t len, double *out);

/* Parses a decimal unsigned integer ("+" allowed). @return 0 on success,
 * -1 not an integer, -2 negative, -3 larger than UINT64_MAX. */
int io_parse_u64(const char *s, size_t len, uint64_t *out);

/* Overflow-checked a * b; @return 0 if it fits, -1 on overflow. */
int io_mul_u64(uint64_t a, uint64_t b, uint64_t *out);

/* ---------------------------------------------------------- binary data */
typedef enum io_type {
    IO_T_INVALID = 0,
    IO_T_I8, IO_T_U8, IO_T_I16, IO_T_U16, IO_T_I32, IO_T_U32,
    IO_T_I64, IO_T_U64, IO_T_F32, IO_T_F64
} io_type;

size_t io_type_size(io_type t);
int io_type_is_integer(io_type t);
/* Reads one value of type t at p (io_type_size(t) bytes must be present). */
double io_get_value(const unsigned char *p, io_type t, int big_endian);
/* Integer types only: reads a count; @return -1 if negative. */
int io_get_count(const unsigned char *p, io_type t, int big_endian,
                 uint64_t *out);

/* --------------------------------------------------------------- text */
typedef struct io_cursor {
    const char *p;
    const char *end;
    size_t line; /* 1-based line of p */
} io_cursor;

void io_cursor_init(io_cursor *c, const void *data, size_t size);
/* Next whitespace-separated token, across lines. @return 0 at the end. */
int io_next_token(io_cursor *c, const char **tok, size_t *len);
/* Next line without its terminator (\n, \r\n or \r). @return 0 at the
 * end. *line_no receives the 1-based line number. */
int io_next_line(io_cursor *c, const char **line, size_t *len,
                 size_t *line_no);
/* Token iteration inside one line [*s, end): whitespace separated, and
 * also comma separated if commas != 0. @return 0 when no token is left. */
int io_line_token(const char **s, const char *end, int commas,
                  const char **tok, size_t *len);
/* Case-insensitive comparison of a token with a NUL-terminated word. */
int io_tok_eq(const char *tok, size_t len, const char *word);
/* Bytes left after the cursor. */
size_t io_cursor_left(const io_cursor *c);

/* --------------------------------------------------------------- output */
/* Allocates n points (n >= 1); @return NULL on failure (error set). */
double *io_alloc_points(io_ctx *ctx, uint64_t n);

/* ------------------------------------------------------------- parsers */
/* Each sets *xyz (malloc'd) and *n on success; on failure *xyz stays NULL.
 * size > 0 is guaranteed by the caller. */
pkss_status io_read_ply(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_pcd(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_xyz(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_off(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_kitti(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_vtk(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_npy(io_ctx *ctx, double **xyz, size_t *n);
pkss_status io_read_npz(io_ctx *ctx, double **xyz, size_t *n);

/* 1 for the formats that are binary from their first byte (no BOM rule). */
int io_format_is_binary(pkss_format f);

/* LZF decompression as used by PCD binary_compressed (liblzf format),
 * bounds-checked. @return the bytes written to out, or 0 on corrupt input
 * or if out_len is too small; *bad_at receives the input offset where
 * decoding failed. */
size_t pkss__io_lzf_decompress(const unsigned char *in, size_t in_len,
                               unsigned char *out, size_t out_len,
                               size_t *bad_at);


#endif
