/* SPDX-License-Identifier: MIT
 * io_pcd.c -- PCL PCD reader (v0.5-v0.7 headers; DATA ascii, binary and
 * binary_compressed, the last with the LZF decoder below).
 *
 * binary: points stored one after the other (array of structures),
 * little-endian. binary_compressed: uint32 compressed size, uint32
 * uncompressed size, then LZF data that decompresses to one array per
 * field (structure of arrays). NaN coordinates (organized clouds) are
 * returned as they are.
 */
#include "io_internal.h"

#include <stdlib.h>
#include <string.h>

#define PCD_MAX_FIELDS 1024

typedef struct pcd_field {
    char name[48];
    io_type type;
    char type_char; /* 'F', 'I' or 'U' from the TYPE line */
    uint64_t size;  /* bytes of one element */
    uint64_t count; /* elements per point */
} pcd_field;

typedef struct pcd_header {
    pcd_field *f;
    size_t n_fields, cap; /* fields used, allocated */
    int have_size, have_type, have_count;
    uint64_t width, height, points;
    int have_width, have_height, have_points;
    int data; /* 0 ascii, 1 binary, 2 binary_compressed */
} pcd_header;

static io_type pcd_type(char t, uint64_t size)
{
    switch (t) {
    case 'F': case 'f':
        return size == 4 ? IO_T_F32 : size == 8 ? IO_T_F64 : IO_T_INVALID;
    case 'I': case 'i':
        return size == 1 ? IO_T_I8 : size == 2 ? IO_T_I16
             : size == 4 ? IO_T_I32 : size == 8 ? IO_T_I64 : IO_T_INVALID;
    case 'U': case 'u':
        return size == 1 ? IO_T_U8 : size == 2 ? IO_T_U16
             : size == 4 ? IO_T_U32 : size == 8 ? IO_T_U64 : IO_T_INVALID;
    default:
        return IO_T_INVALID;
    }
}

/* Parses one unsigned header value; reports errors with the key name. */
static pkss_status pcd_u64(io_ctx *ctx, const char *key, size_t line_no,
                              const char *t, size_t tl, uint64_t *out)
{
    char q[64];
    int r = io_parse_u64(t, tl, out);
    if (r == 0)
        return PKSS_OK;
    return io_fail(ctx, PKSS_ERR_FORMAT, "PCD: header line %lu: %s value "
                   "'%s' is %s", (unsigned long)line_no, key,
                   io_quote(t, tl, q, sizeof q),
                   r == -2 ? "negative" : r == -3 ? "too large"
                                                  : "not an integer");
}

/* FIELDS / COLUMNS: one field per name, with the ascii defaults (F, 4
 * bytes, COUNT 1) until SIZE / TYPE / COUNT say otherwise. */
static pkss_status pcd_fields(io_ctx *ctx, pcd_header *h, const char *s,
                              const char *e, size_t line_no)
{
    const char *t;
    size_t tl;
    if (h->n_fields)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: FIELDS given twice",
                       (unsigned long)line_no);
    while (io_line_token(&s, e, 0, &t, &tl)) {
        pcd_field *f;
        if (h->n_fields >= PCD_MAX_FIELDS)
            return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                           "PCD: more than %d fields", PCD_MAX_FIELDS);
        if (h->n_fields == h->cap) {
            size_t nc = h->cap ? 2 * h->cap : 8;
            pcd_field *nf = (pcd_field *)realloc(h->f, nc * sizeof *nf);
            if (!nf)
                return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                               "PCD: out of memory in the header");
            h->f = nf;
            h->cap = nc;
        }
        f = &h->f[h->n_fields++];
        io_quote(t, tl, f->name, sizeof f->name);
        f->type = IO_T_F32; /* ascii defaults if SIZE/TYPE absent */
        f->type_char = 'F';
        f->size = 4;
        f->count = 1;
    }
    if (h->n_fields == 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: FIELDS lists no field",
                       (unsigned long)line_no);
    return PKSS_OK;
}

enum { PCD_SIZE = 0, PCD_TYPE = 1, PCD_COUNT = 2 };
static const char *const pcd_per_field_key[] = {"SIZE", "TYPE", "COUNT"};

/* One value of a SIZE / TYPE / COUNT line, for field f. The TYPE letter is
 * resolved with the size once the whole header is read. */
static pkss_status pcd_field_value(io_ctx *ctx, pcd_field *f, int which,
                                   size_t line_no, const char *t, size_t tl)
{
    uint64_t v = 0;
    char q[64];
    pkss_status st;
    if (which == PCD_TYPE) {
        if (tl != 1 || !strchr("FIUfiu", t[0]))
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PCD: header line %lu: TYPE '%s' is "
                           "not F, I or U",
                           (unsigned long)line_no,
                           io_quote(t, tl, q, sizeof q));
        f->type_char = t[0];
        return PKSS_OK;
    }
    st = pcd_u64(ctx, pcd_per_field_key[which], line_no, t, tl, &v);
    if (st != PKSS_OK)
        return st;
    if (which == PCD_SIZE) {
        if (v != 1 && v != 2 && v != 4 && v != 8)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PCD: header line %lu: SIZE %llu is "
                           "not 1, 2, 4 or 8",
                           (unsigned long)line_no, (unsigned long long)v);
        f->size = v;
        return PKSS_OK;
    }
    if (v == 0 || v > 1000000) /* bounds the ascii token count */
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: COUNT %llu "
                       "out of range 1..1000000",
                       (unsigned long)line_no, (unsigned long long)v);
    f->count = v;
    return PKSS_OK;
}

/* SIZE / TYPE / COUNT: exactly one value per field, after FIELDS. */
static pkss_status pcd_per_field(io_ctx *ctx, pcd_header *h, int which,
                                 const char *s, const char *e, size_t line_no)
{
    const char *t;
    size_t tl, i;
    const char *name = pcd_per_field_key[which];
    if (h->n_fields == 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: %s before FIELDS",
                       (unsigned long)line_no, name);
    for (i = 0; io_line_token(&s, e, 0, &t, &tl); i++) {
        pkss_status st;
        if (i >= h->n_fields)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PCD: header line %lu: %s has more values "
                           "than FIELDS has names (%lu)",
                           (unsigned long)line_no, name,
                           (unsigned long)h->n_fields);
        st = pcd_field_value(ctx, &h->f[i], which, line_no, t, tl);
        if (st != PKSS_OK)
            return st;
    }
    if (i != h->n_fields)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: %s has %lu values for "
                       "%lu fields",
                       (unsigned long)line_no, name, (unsigned long)i,
                       (unsigned long)h->n_fields);
    if (which == PCD_SIZE) h->have_size = 1;
    if (which == PCD_TYPE) h->have_type = 1;
    if (which == PCD_COUNT) h->have_count = 1;
    return PKSS_OK;
}

/* WIDTH / HEIGHT / POINTS: one unsigned value each (key names it). */
static pkss_status pcd_dimension(io_ctx *ctx, pcd_header *h, const char *key,
                                 size_t klen, const char *s, const char *e,
                                 size_t line_no)
{
    const char *t;
    size_t tl;
    uint64_t v;
    pkss_status st;
    int width = io_tok_eq(key, klen, "WIDTH");
    int height = io_tok_eq(key, klen, "HEIGHT");
    if (!io_line_token(&s, e, 0, &t, &tl))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: key without a value",
                       (unsigned long)line_no);
    st = pcd_u64(ctx, width ? "WIDTH" : height ? "HEIGHT" : "POINTS",
                 line_no, t, tl, &v);
    if (st != PKSS_OK)
        return st;
    if (width) {
        h->width = v;
        h->have_width = 1;
    } else if (height) {
        h->height = v;
        h->have_height = 1;
    } else {
        h->points = v;
        h->have_points = 1;
    }
    return PKSS_OK;
}

/* DATA ascii | binary | binary_compressed: the last header line. */
static pkss_status pcd_data_kind(io_ctx *ctx, pcd_header *h, const char *s,
                                 const char *e, size_t line_no)
{
    const char *t;
    size_t tl;
    char q[64];
    if (!io_line_token(&s, e, 0, &t, &tl))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: DATA without a value",
                       (unsigned long)line_no);
    if (io_tok_eq(t, tl, "ascii"))
        h->data = 0;
    else if (io_tok_eq(t, tl, "binary"))
        h->data = 1;
    else if (io_tok_eq(t, tl, "binary_compressed"))
        h->data = 2;
    else
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "PCD: header line %lu: unknown DATA kind '%s' "
                       "(ascii, binary, binary_compressed)",
                       (unsigned long)line_no, io_quote(t, tl, q, sizeof q));
    return PKSS_OK;
}

/* One header line, dispatched on its key; *is_data is set by DATA. */
static pkss_status pcd_header_line(io_ctx *ctx, pcd_header *h,
                                   const char *line, size_t len,
                                   size_t line_no, int *is_data)
{
    const char *s = line, *e = line + len, *key;
    size_t klen;
    char q[64];
    if (!io_line_token(&s, e, 0, &key, &klen) || key[0] == '#')
        return PKSS_OK;
    if (io_tok_eq(key, klen, "VERSION") || io_tok_eq(key, klen, "VIEWPOINT"))
        return PKSS_OK;
    if (io_tok_eq(key, klen, "FIELDS") || io_tok_eq(key, klen, "COLUMNS"))
        return pcd_fields(ctx, h, s, e, line_no);
    if (io_tok_eq(key, klen, "SIZE"))
        return pcd_per_field(ctx, h, PCD_SIZE, s, e, line_no);
    if (io_tok_eq(key, klen, "TYPE"))
        return pcd_per_field(ctx, h, PCD_TYPE, s, e, line_no);
    if (io_tok_eq(key, klen, "COUNT"))
        return pcd_per_field(ctx, h, PCD_COUNT, s, e, line_no);
    if (io_tok_eq(key, klen, "WIDTH") || io_tok_eq(key, klen, "HEIGHT") ||
        io_tok_eq(key, klen, "POINTS"))
        return pcd_dimension(ctx, h, key, klen, s, e, line_no);
    if (io_tok_eq(key, klen, "DATA")) {
        *is_data = 1;
        return pcd_data_kind(ctx, h, s, e, line_no);
    }
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PCD: header line %lu: unknown key '%s'",
                   (unsigned long)line_no, io_quote(key, klen, q, sizeof q));
}

static pkss_status pcd_parse_header(io_ctx *ctx, pcd_header *h,
                                       size_t *data_start)
{
    io_cursor c;
    const char *line;
    size_t len, line_no;

    memset(h, 0, sizeof *h);
    h->data = -1;
    io_cursor_init(&c, ctx->data, ctx->size);
    while (io_next_line(&c, &line, &len, &line_no)) {
        int is_data = 0;
        pkss_status st = pcd_header_line(ctx, h, line, len, line_no, &is_data);
        if (st != PKSS_OK)
            return st;
        if (is_data) {
            *data_start = (size_t)(c.p - (const char *)ctx->data);
            return PKSS_OK;
        }
    }
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PCD: no DATA line: not a PCD file or a truncated header");
}

/* The layout of one point, from the parsed header: x, y, z field indices,
 * bytes per point (binary) and values per point (ascii). */
typedef struct pcd_layout {
    int fi[3];
    uint64_t point_size, tokens, np;
} pcd_layout;

/* A field's type from its TYPE letter and SIZE; without a TYPE line
 * (ascii only) the values are parsed as text whatever the size. */
static pkss_status pcd_field_type(io_ctx *ctx, pcd_field *f, int have_type)
{
    if (have_type) {
        f->type = pcd_type(f->type_char, f->size);
        if (f->type == IO_T_INVALID)
            return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                           "PCD: field '%s' has an unsupported TYPE/SIZE "
                           "pair (F needs 4 or 8)",
                           f->name);
        return PKSS_OK;
    }
    f->type = pcd_type('F', f->size);
    if (f->type == IO_T_INVALID)
        f->type = IO_T_F32; /* ascii without TYPE: parse as text */
    return PKSS_OK;
}

/* Resolves each field's TYPE letter and SIZE to a type and finds x, y, z. */
static pkss_status pcd_resolve_fields(io_ctx *ctx, pcd_header *h,
                                      pcd_layout *lay)
{
    size_t i;
    for (i = 0; i < h->n_fields; i++) {
        pcd_field *f = &h->f[i];
        uint64_t bytes;
        pkss_status st = pcd_field_type(ctx, f, h->have_type);
        if (st != PKSS_OK)
            return st;
        if (strcmp(f->name, "x") == 0 && lay->fi[0] < 0) lay->fi[0] = (int)i;
        if (strcmp(f->name, "y") == 0 && lay->fi[1] < 0) lay->fi[1] = (int)i;
        if (strcmp(f->name, "z") == 0 && lay->fi[2] < 0) lay->fi[2] = (int)i;
        if (io_mul_u64(f->size, f->count, &bytes) != 0 ||
            lay->point_size + bytes < lay->point_size)
            return io_fail(ctx, PKSS_ERR_FORMAT, "PCD: point size overflows");
        lay->point_size += bytes;
        lay->tokens += f->count;
    }
    if (lay->fi[0] < 0 || lay->fi[1] < 0 || lay->fi[2] < 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "PCD: no field '%s' in FIELDS",
                       lay->fi[0] < 0 ? "x" : lay->fi[1] < 0 ? "y" : "z");
    if (h->f[lay->fi[0]].count != 1 || h->f[lay->fi[1]].count != 1 ||
        h->f[lay->fi[2]].count != 1)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "PCD: x, y and z must have COUNT 1");
    return PKSS_OK;
}

/* The number of points: POINTS, which must agree with WIDTH x HEIGHT when
 * both are given (HEIGHT defaults to 1). */
static pkss_status pcd_point_count(io_ctx *ctx, pcd_header *h, uint64_t *np)
{
    if (h->have_width) {
        uint64_t wh;
        if (!h->have_height)
            h->height = 1;
        if (io_mul_u64(h->width, h->height, &wh) != 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PCD: WIDTH x HEIGHT overflows");
        if (!h->have_points) {
            h->points = wh;
            h->have_points = 1;
        } else if (h->points != wh) {
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PCD: POINTS %llu differs from WIDTH x HEIGHT = %llu",
                           (unsigned long long)h->points,
                           (unsigned long long)wh);
        }
    }
    if (!h->have_points)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: the header gives neither POINTS nor WIDTH");
    *np = h->points;
    if (*np == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "PCD: the header says 0 points");
    return PKSS_OK;
}

/* ASCII points: lay->tokens values per point, x y z taken by position;
 * data past the last point is refused (header and data disagree). */
static pkss_status pcd_read_ascii(io_ctx *ctx, const pcd_header *h,
                                  const pcd_layout *lay, size_t start,
                                  double **out)
{
    uint64_t p, k, need, ti = 0, np = lay->np, left = ctx->size - start;
    uint64_t off[3] = {0, 0, 0}; /* token index of x, y, z in a point */
    const char *t;
    size_t i, tl;
    char q[64];
    io_cursor ac;
    for (i = 0; i < h->n_fields; i++) {
        if ((int)i == lay->fi[0]) off[0] = ti;
        if ((int)i == lay->fi[1]) off[1] = ti;
        if ((int)i == lay->fi[2]) off[2] = ti;
        ti += h->f[i].count;
    }
    if (io_mul_u64(np, 2 * lay->tokens, &need) != 0 || need > left + 1)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: truncated at byte %llu: expected %llu points "
                       "of %llu values, got only %llu bytes of data",
                       (unsigned long long)ctx->size, (unsigned long long)np,
                       (unsigned long long)lay->tokens,
                       (unsigned long long)left);
    *out = io_alloc_points(ctx, np);
    if (!*out)
        return PKSS_ERR_OUT_OF_MEMORY;
    io_cursor_init(&ac, ctx->data, ctx->size);
    ac.p += start;
    for (p = 0; p < np; p++) {
        for (k = 0; k < lay->tokens; k++) {
            int axis = k == off[0] ? 0 : k == off[1] ? 1 : k == off[2] ? 2
                                                                        : -1;
            if (!io_next_token(&ac, &t, &tl))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: truncated at byte %llu: expected %llu "
                               "points, got %llu",
                               (unsigned long long)ctx->size,
                               (unsigned long long)np, (unsigned long long)p);
            if (axis >= 0 && io_parse_double(t, tl, &(*out)[3 * p + axis]))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: line %lu: point %llu: '%s' is not a "
                               "number",
                               (unsigned long)ac.line, (unsigned long long)p,
                               io_quote(t, tl, q, sizeof q));
        }
    }
    if (io_next_token(&ac, &t, &tl))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: data after the %llu points the header "
                       "declares (byte %llu)",
                       (unsigned long long)np,
                       (unsigned long long)(t - (const char *)ctx->data));
    return PKSS_OK;
}

/* binary_compressed: uint32 compressed and uncompressed sizes, checked
 * against the header and the bytes left before decoding into *raw. */
static pkss_status pcd_decompress(io_ctx *ctx, size_t start, uint64_t left,
                                  uint64_t total, unsigned char **raw)
{
    uint64_t csize, usize;
    size_t got, bad = 0;
    if (left < 8)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: binary_compressed data lacks its 8-byte "
                       "size header");
    csize = (uint64_t)io_get_value(ctx->data + start, IO_T_U32, 0);
    usize = (uint64_t)io_get_value(ctx->data + start + 4, IO_T_U32, 0);
    if (csize > left - 8)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: compressed size %llu but only %llu bytes "
                       "follow",
                       (unsigned long long)csize,
                       (unsigned long long)(left - 8));
    if (usize != total)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: uncompressed size %llu differs from "
                       "POINTS x point size = %llu",
                       (unsigned long long)usize, (unsigned long long)total);
    /* One LZF back-reference (3 bytes) yields at most 264 bytes. */
    if (usize / 88 > csize + 1)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: %llu compressed bytes cannot hold %llu "
                       "bytes of LZF data (header lies)",
                       (unsigned long long)csize, (unsigned long long)usize);
    *raw = (unsigned char *)malloc(usize ? (size_t)usize : 1);
    if (!*raw)
        return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "PCD: out of memory for %llu bytes",
                       (unsigned long long)usize);
    got = pkss__io_lzf_decompress(ctx->data + start + 8, (size_t)csize, *raw,
                                  (size_t)usize, &bad);
    if (got != usize)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: corrupt LZF data (decoding failed at "
                       "compressed byte %lu, %lu of %llu bytes out)",
                       (unsigned long)bad, (unsigned long)got,
                       (unsigned long long)usize);
    return PKSS_OK;
}

/* Copies x, y, z out of the binary data at base: points one after the
 * other (binary, AoS) or one block per field (decompressed, SoA). */
static pkss_status pcd_gather(io_ctx *ctx, const pcd_header *h,
                              const pcd_layout *lay,
                              const unsigned char *base, double **out)
{
    uint64_t p, stride[3], start3[3], np = lay->np;
    size_t i;
    for (i = 0; i < 3; i++) {
        uint64_t before = 0;
        int j;
        for (j = 0; j < lay->fi[i]; j++)
            before += h->f[j].size * h->f[j].count;
        if (h->data == 1) { /* AoS */
            start3[i] = before;
            stride[i] = lay->point_size;
        } else {           /* SoA: field blocks one after another */
            start3[i] = before * np;
            stride[i] = h->f[lay->fi[i]].size;
        }
    }
    *out = io_alloc_points(ctx, np);
    if (!*out)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (p = 0; p < np; p++)
        for (i = 0; i < 3; i++)
            (*out)[3 * p + i] = io_get_value(base + start3[i] + p * stride[i],
                                             h->f[lay->fi[i]].type, 0);
    return PKSS_OK;
}

/* binary and binary_compressed points; for binary, bytes past the last
 * point are refused as in ascii. *raw holds the decompressed data. */
static pkss_status pcd_read_binary(io_ctx *ctx, const pcd_header *h,
                                   const pcd_layout *lay, size_t start,
                                   double **out, unsigned char **raw)
{
    uint64_t total, np = lay->np, ps = lay->point_size;
    uint64_t left = ctx->size - start;
    const unsigned char *base = ctx->data + start;
    pkss_status st;
    if (io_mul_u64(np, ps, &total) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header says %llu points of %llu bytes: size "
                       "overflows",
                       (unsigned long long)np, (unsigned long long)ps);
    if (h->data == 1 && total > left)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: truncated at byte %llu: expected %llu "
                       "points of %llu bytes, got %llu (%llu bytes of "
                       "data)",
                       (unsigned long long)ctx->size, (unsigned long long)np,
                       (unsigned long long)ps,
                       (unsigned long long)(left / ps),
                       (unsigned long long)left);
    if (h->data == 2) {
        st = pcd_decompress(ctx, start, left, total, raw);
        if (st != PKSS_OK)
            return st;
        base = *raw;
    }
    st = pcd_gather(ctx, h, lay, base, out);
    if (st != PKSS_OK)
        return st;
    if (h->data == 1 && np * ps < left)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: data after the %llu points the header declares "
                       "(byte %llu, %llu bytes more)",
                       (unsigned long long)np,
                       (unsigned long long)(start + np * ps),
                       (unsigned long long)(left - np * ps));
    return PKSS_OK;
}

/* The header's own consistency, before any point is read. */
static pkss_status pcd_check_header(io_ctx *ctx, pcd_header *h,
                                    pcd_layout *lay)
{
    pkss_status st;
    if (h->n_fields == 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "PCD: the header has no FIELDS");
    if (h->data != 0 && (!h->have_size || !h->have_type))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: binary data needs SIZE and TYPE header lines");
    st = pcd_resolve_fields(ctx, h, lay);
    if (st != PKSS_OK)
        return st;
    return pcd_point_count(ctx, h, &lay->np);
}

pkss_status io_read_pcd(io_ctx *ctx, double **xyz, size_t *n)
{
    pcd_header h;
    pcd_layout lay = {{-1, -1, -1}, 0, 0, 0};
    size_t start = 0;
    double *out = NULL;
    unsigned char *raw = NULL;
    pkss_status st = pcd_parse_header(ctx, &h, &start);

    if (st == PKSS_OK)
        st = pcd_check_header(ctx, &h, &lay);
    if (st == PKSS_OK)
        st = h.data == 0 ? pcd_read_ascii(ctx, &h, &lay, start, &out)
                         : pcd_read_binary(ctx, &h, &lay, start, &out, &raw);
    if (st == PKSS_OK) {
        *xyz = out;
        *n = (size_t)lay.np;
        out = NULL;
    }
    free(out);
    free(raw);
    free(h.f);
    return st;
}

/* LZF decoder (format of liblzf's lzf_d.c, used by PCL), bounds-checked. */
size_t pkss__io_lzf_decompress(const unsigned char *in, size_t in_len,
                         unsigned char *out, size_t out_len, size_t *bad_at)
{
    size_t ip = 0, op = 0;
    while (ip < in_len) {
        unsigned ctrl = in[ip++];
        if (ctrl < 32) { /* literal run of ctrl + 1 bytes */
            size_t len = (size_t)ctrl + 1;
            if (len > in_len - ip || len > out_len - op) {
                *bad_at = ip - 1;
                return 0;
            }
            memcpy(out + op, in + ip, len);
            ip += len;
            op += len;
        } else { /* back reference */
            size_t len = ctrl >> 5, back, k;
            if (len == 7) {
                if (ip >= in_len) {
                    *bad_at = ip;
                    return 0;
                }
                len += in[ip++];
            }
            if (ip >= in_len) {
                *bad_at = ip;
                return 0;
            }
            back = ((size_t)(ctrl & 0x1f) << 8) + in[ip++] + 1;
            len += 2;
            if (back > op || len > out_len - op) {
                *bad_at = ip - 1;
                return 0;
            }
            for (k = 0; k < len; k++, op++)
                out[op] = out[op - back];
        }
    }
    return op;
}
