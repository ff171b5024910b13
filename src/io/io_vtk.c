/* SPDX-License-Identifier: MIT
 * io_vtk.c -- legacy VTK (POLYDATA, UNSTRUCTURED_GRID, STRUCTURED_GRID
 * POINTS; ASCII or big-endian BINARY) and KITTI .bin readers.
 */
#include "io_internal.h"

#include <stdlib.h>
#include <string.h>

/* ----------------------------------------------------------------- KITTI */

pkss_status io_read_kitti(io_ctx *ctx, double **xyz, size_t *n)
{
    size_t i, np;
    double *out;
    if (ctx->size % 16 != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "KITTI: size %llu bytes is not a multiple of 16 (records "
                       "of float32 x y z intensity); truncated or not a KITTI "
                       ".bin",
                       (unsigned long long)ctx->size);
    np = ctx->size / 16;
    out = io_alloc_points(ctx, np);
    if (!out)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (i = 0; i < np; i++) {
        const unsigned char *r = ctx->data + 16 * i;
        out[3 * i] = io_get_value(r, IO_T_F32, 0);
        out[3 * i + 1] = io_get_value(r + 4, IO_T_F32, 0);
        out[3 * i + 2] = io_get_value(r + 8, IO_T_F32, 0);
    }
    *xyz = out;
    *n = np;
    return PKSS_OK;
}

/* ------------------------------------------------------------------- VTK */

static io_type vtk_type(const char *t, size_t len)
{
    static const struct {
        const char *name;
        io_type type;
    } k[] = {
        {"float", IO_T_F32},         {"double", IO_T_F64},
        {"char", IO_T_I8},           {"unsigned_char", IO_T_U8},
        {"short", IO_T_I16},         {"unsigned_short", IO_T_U16},
        {"int", IO_T_I32},           {"unsigned_int", IO_T_U32},
        {"long", IO_T_I64},          {"unsigned_long", IO_T_U64},
        {"vtktypeint64", IO_T_I64},  {"vtktypeuint64", IO_T_U64},
        {"vtkidtype", IO_T_I64},
    };
    size_t i;
    for (i = 0; i < sizeof k / sizeof k[0]; i++)
        if (io_tok_eq(t, len, k[i].name))
            return k[i].type;
    return IO_T_INVALID;
}

/* Lines 1-3: the "# vtk" magic, the title and ASCII/BINARY. */
static pkss_status vtk_preamble(io_ctx *ctx, io_cursor *c, int *binary)
{
    const char *line, *s, *e, *t;
    size_t len, line_no, l;
    char q[64];
    if (!io_next_line(c, &line, &len, &line_no) || len < 5 ||
        memcmp(line, "# vtk", 5) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: not a legacy VTK file (the first line is not "
                       "'# vtk DataFile Version x.x')");
    if (!io_next_line(c, &line, &len, &line_no)) /* title */
        return io_fail(ctx, PKSS_ERR_FORMAT, "VTK: the file ends after "
                       "line 1");
    if (!io_next_line(c, &line, &len, &line_no))
        return io_fail(ctx, PKSS_ERR_FORMAT, "VTK: the file ends after "
                       "line 2 (no ASCII/BINARY line)");
    s = line;
    e = line + len;
    if (!io_line_token(&s, e, 0, &t, &l) ||
        (!io_tok_eq(t, l, "ASCII") && !io_tok_eq(t, l, "BINARY")))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line 3 must be ASCII or BINARY, not '%s'",
                       io_quote(line, len, q, sizeof q));
    *binary = io_tok_eq(t, l, "BINARY");
    return PKSS_OK;
}

/* The DATASET line (its keyword token [t, t+l) already read): only the
 * dataset types that store explicit POINTS. */
static pkss_status vtk_dataset(io_ctx *ctx, const char *s, const char *e,
                               const char *t, size_t l, size_t line_no)
{
    char q[64];
    if (!io_tok_eq(t, l, "DATASET"))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: expected DATASET, got '%s'",
                       (unsigned long)line_no, io_quote(t, l, q, sizeof q));
    if (!io_line_token(&s, e, 0, &t, &l))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: DATASET without a type",
                       (unsigned long)line_no);
    if (!io_tok_eq(t, l, "POLYDATA") &&
        !io_tok_eq(t, l, "UNSTRUCTURED_GRID") &&
        !io_tok_eq(t, l, "STRUCTURED_GRID"))
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "VTK: DATASET %s has no explicit POINTS "
                       "(supported: POLYDATA, UNSTRUCTURED_GRID, "
                       "STRUCTURED_GRID)",
                       io_quote(t, l, q, sizeof q));
    return PKSS_OK;
}

/* The line after POINTS: where its arguments start and its number. */
typedef struct vtk_line {
    const char *s, *e;
    size_t line_no;
} vtk_line;

/* DATASET, then (DIMENSIONS) lines until POINTS; on success *pl holds the
 * rest of the POINTS line. */
static pkss_status vtk_find_points(io_ctx *ctx, io_cursor *c, vtk_line *pl)
{
    const char *line, *t;
    size_t len, l;
    int have_dataset = 0;
    char q[64];
    for (;;) {
        pkss_status st;
        if (!io_next_line(c, &line, &len, &pl->line_no))
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "VTK: the file ends before %s",
                           have_dataset ? "the POINTS section"
                                        : "the DATASET line");
        pl->s = line;
        pl->e = line + len;
        if (!io_line_token(&pl->s, pl->e, 0, &t, &l))
            continue;
        if (!have_dataset) {
            st = vtk_dataset(ctx, pl->s, pl->e, t, l, pl->line_no);
            if (st != PKSS_OK)
                return st;
            have_dataset = 1;
            continue;
        }
        if (io_tok_eq(t, l, "DIMENSIONS"))
            continue;
        if (io_tok_eq(t, l, "POINTS"))
            return PKSS_OK;
        if (io_tok_eq(t, l, "FIELD"))
            return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                           "VTK: line %lu: FIELD data before POINTS is not "
                           "supported",
                           (unsigned long)pl->line_no);
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: expected POINTS, got '%s'",
                       (unsigned long)pl->line_no, io_quote(t, l, q, sizeof q));
    }
}

/* "POINTS n type": the count and the data type. */
static pkss_status vtk_points_args(io_ctx *ctx, vtk_line *pl, uint64_t *np,
                                   io_type *type)
{
    const char *t;
    size_t l;
    char q[64];
    int r;
    if (!io_line_token(&pl->s, pl->e, 0, &t, &l))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: POINTS without a count",
                       (unsigned long)pl->line_no);
    r = io_parse_u64(t, l, np);
    if (r != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: POINTS count '%s' is %s",
                       (unsigned long)pl->line_no, io_quote(t, l, q, sizeof q),
                       r == -2   ? "negative"
                       : r == -3 ? "too large"
                                 : "not an integer");
    if (!io_line_token(&pl->s, pl->e, 0, &t, &l) ||
        (*type = vtk_type(t, l)) == IO_T_INVALID)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: line %lu: POINTS needs a data type (float, "
                       "double, int, ...)",
                       (unsigned long)pl->line_no);
    return PKSS_OK;
}

/* Refuses a count the remaining left bytes cannot hold, before any
 * allocation (binary: exact size; ASCII: at least 6 bytes a point). */
static pkss_status vtk_check_size(io_ctx *ctx, uint64_t np, io_type type,
                                  int binary, uint64_t left)
{
    uint64_t need;
    if (binary) {
        if (io_mul_u64(np, 3 * io_type_size(type), &need) != 0 ||
            need > left)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "VTK: truncated at byte %llu: expected %llu points "
                           "(%lu bytes each), got %llu bytes of data",
                           (unsigned long long)ctx->size,
                           (unsigned long long)np,
                           (unsigned long)(3 * io_type_size(type)),
                           (unsigned long long)left);
    } else if (io_mul_u64(np, 6, &need) != 0 || need > left + 1) {
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "VTK: truncated at byte %llu: expected %llu points "
                       "(at least 6 bytes each in ASCII), got %llu bytes of "
                       "data",
                       (unsigned long long)ctx->size, (unsigned long long)np,
                       (unsigned long long)left);
    }
    return PKSS_OK;
}

/* ASCII POINTS: 3 * np numbers, across lines. */
static pkss_status vtk_ascii_values(io_ctx *ctx, io_cursor *c, uint64_t np,
                                    double *out)
{
    const char *t;
    size_t l;
    uint64_t i;
    char q[64];
    for (i = 0; i < 3 * np; i++) {
        if (!io_next_token(c, &t, &l))
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "VTK: truncated at byte %llu: expected %llu "
                           "points, got %llu",
                           (unsigned long long)ctx->size,
                           (unsigned long long)np,
                           (unsigned long long)(i / 3));
        if (io_parse_double(t, l, &out[i]) != 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "VTK: line %lu: point %llu: '%s' is not a "
                           "number",
                           (unsigned long)c->line,
                           (unsigned long long)(i / 3),
                           io_quote(t, l, q, sizeof q));
    }
    return PKSS_OK;
}

pkss_status io_read_vtk(io_ctx *ctx, double **xyz, size_t *n)
{
    io_cursor c;
    vtk_line pl;
    size_t start;
    int binary = 0;
    uint64_t np = 0, i;
    io_type type = IO_T_INVALID;
    double *out;
    pkss_status st;

    io_cursor_init(&c, ctx->data, ctx->size);
    st = vtk_preamble(ctx, &c, &binary);
    if (st == PKSS_OK)
        st = vtk_find_points(ctx, &c, &pl);
    if (st == PKSS_OK)
        st = vtk_points_args(ctx, &pl, &np, &type);
    if (st != PKSS_OK)
        return st;
    if (np == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "VTK: POINTS 0");
    start = (size_t)(c.p - (const char *)ctx->data);
    st = vtk_check_size(ctx, np, type, binary, ctx->size - start);
    if (st != PKSS_OK)
        return st;
    out = io_alloc_points(ctx, np);
    if (!out)
        return PKSS_ERR_OUT_OF_MEMORY;
    if (binary) { /* legacy VTK binary is big-endian */
        size_t ts = io_type_size(type);
        const unsigned char *b = ctx->data + start;
        for (i = 0; i < 3 * np; i++)
            out[i] = io_get_value(b + i * ts, type, 1);
    } else if ((st = vtk_ascii_values(ctx, &c, np, out)) != PKSS_OK) {
        free(out);
        return st;
    }
    *xyz = out;
    *n = (size_t)np;
    return PKSS_OK;
}
