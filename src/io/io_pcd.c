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
    size_t n_fields;
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

static pkss_status pcd_parse_header(io_ctx *ctx, pcd_header *h,
                                       size_t *data_start)
{
    io_cursor c;
    const char *line, *t;
    size_t len, tl, line_no, cap = 0;
    char q[64];
    pkss_status st;

    memset(h, 0, sizeof *h);
    h->data = -1;
    io_cursor_init(&c, ctx->data, ctx->size);
    while (io_next_line(&c, &line, &len, &line_no)) {
        const char *s = line, *e = line + len, *key;
        size_t klen, i;
        if (!io_line_token(&s, e, 0, &key, &klen) || key[0] == '#')
            continue;
        if (io_tok_eq(key, klen, "VERSION") ||
            io_tok_eq(key, klen, "VIEWPOINT"))
            continue;
        if (io_tok_eq(key, klen, "FIELDS") || io_tok_eq(key, klen, "COLUMNS")) {
            if (h->n_fields)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: header line %lu: FIELDS given twice",
                               (unsigned long)line_no);
            while (io_line_token(&s, e, 0, &t, &tl)) {
                pcd_field *f;
                if (h->n_fields >= PCD_MAX_FIELDS)
                    return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                                   "PCD: more than %d fields", PCD_MAX_FIELDS);
                if (h->n_fields == cap) {
                    size_t nc = cap ? 2 * cap : 8;
                    pcd_field *nf = (pcd_field *)realloc(h->f, nc * sizeof *nf);
                    if (!nf)
                        return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                                       "PCD: out of memory in the header");
                    h->f = nf;
                    cap = nc;
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
            continue;
        }
        if (io_tok_eq(key, klen, "SIZE") || io_tok_eq(key, klen, "TYPE") ||
            io_tok_eq(key, klen, "COUNT")) {
            int which = io_tok_eq(key, klen, "SIZE")   ? 0
                        : io_tok_eq(key, klen, "TYPE") ? 1
                                                       : 2;
            static const char *names[] = {"SIZE", "TYPE", "COUNT"};
            if (h->n_fields == 0)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: header line %lu: %s before FIELDS",
                               (unsigned long)line_no, names[which]);
            for (i = 0; io_line_token(&s, e, 0, &t, &tl); i++) {
                uint64_t v = 0;
                if (i >= h->n_fields)
                    return io_fail(ctx, PKSS_ERR_FORMAT,
                                   "PCD: header line %lu: %s has more values "
                                   "than FIELDS has names (%lu)",
                                   (unsigned long)line_no, names[which],
                                   (unsigned long)h->n_fields);
                if (which == 1) {
                    if (tl != 1 || !strchr("FIUfiu", t[0]))
                        return io_fail(ctx, PKSS_ERR_FORMAT,
                                       "PCD: header line %lu: TYPE '%s' is "
                                       "not F, I or U",
                                       (unsigned long)line_no,
                                       io_quote(t, tl, q, sizeof q));
                    h->f[i].type_char = t[0]; /* resolved below */
                    continue;
                }
                st = pcd_u64(ctx, names[which], line_no, t, tl, &v);
                if (st != PKSS_OK)
                    return st;
                if (which == 0) {
                    if (v != 1 && v != 2 && v != 4 && v != 8)
                        return io_fail(ctx, PKSS_ERR_FORMAT,
                                       "PCD: header line %lu: SIZE %llu is "
                                       "not 1, 2, 4 or 8",
                                       (unsigned long)line_no,
                                       (unsigned long long)v);
                    h->f[i].size = v;
                } else {
                    if (v == 0 || v > 1000000)
                        return io_fail(ctx, PKSS_ERR_FORMAT,
                                       "PCD: header line %lu: COUNT %llu "
                                       "out of range 1..1000000",
                                       (unsigned long)line_no,
                                       (unsigned long long)v);
                    h->f[i].count = v;
                }
            }
            if (i != h->n_fields)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: header line %lu: %s has %lu values for "
                               "%lu fields",
                               (unsigned long)line_no, names[which],
                               (unsigned long)i, (unsigned long)h->n_fields);
            if (which == 0) h->have_size = 1;
            if (which == 1) h->have_type = 1;
            if (which == 2) h->have_count = 1;
            continue;
        }
        if (io_tok_eq(key, klen, "WIDTH") || io_tok_eq(key, klen, "HEIGHT") ||
            io_tok_eq(key, klen, "POINTS")) {
            uint64_t v;
            if (!io_line_token(&s, e, 0, &t, &tl))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PCD: header line %lu: key without a value",
                               (unsigned long)line_no);
            st = pcd_u64(ctx, io_tok_eq(key, klen, "WIDTH")    ? "WIDTH"
                              : io_tok_eq(key, klen, "HEIGHT") ? "HEIGHT"
                                                               : "POINTS",
                         line_no, t, tl, &v);
            if (st != PKSS_OK)
                return st;
            if (io_tok_eq(key, klen, "WIDTH")) {
                h->width = v;
                h->have_width = 1;
            } else if (io_tok_eq(key, klen, "HEIGHT")) {
                h->height = v;
                h->have_height = 1;
            } else {
                h->points = v;
                h->have_points = 1;
            }
            continue;
        }
        if (io_tok_eq(key, klen, "DATA")) {
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
                               (unsigned long)line_no,
                               io_quote(t, tl, q, sizeof q));
            *data_start = (size_t)(c.p - (const char *)ctx->data);
            return PKSS_OK;
        }
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PCD: header line %lu: unknown key '%s'",
                       (unsigned long)line_no, io_quote(key, klen, q, sizeof q));
    }
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PCD: no DATA line: not a PCD file or a truncated header");
}

pkss_status io_read_pcd(io_ctx *ctx, double **xyz, size_t *n)
{
    pcd_header h;
    size_t start = 0, i;
    pkss_status st;
    int fx = -1, fy = -1, fz = -1;
    uint64_t point_size = 0, tokens = 0, left, need, np;
    uint64_t off[3] = {0, 0, 0}; /* byte offset (AoS) or token index */
    double *out = NULL;
    unsigned char *raw = NULL;
    io_cursor ac; /* ascii data; still used after the last point */

    st = pcd_parse_header(ctx, &h, &start);
    if (st != PKSS_OK)
        goto done;
    if (h.n_fields == 0) {
        st = io_fail(ctx, PKSS_ERR_FORMAT, "PCD: the header has no FIELDS");
        goto done;
    }
    if (h.data != 0 && (!h.have_size || !h.have_type)) {
        st = io_fail(ctx, PKSS_ERR_FORMAT,
                     "PCD: binary data needs SIZE and TYPE header lines");
        goto done;
    }
    for (i = 0; i < h.n_fields; i++) {
        pcd_field *f = &h.f[i];
        uint64_t bytes;
        if (h.have_type) {
            f->type = pcd_type(f->type_char, f->size);
            if (f->type == IO_T_INVALID) {
                st = io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                             "PCD: field '%s' has an unsupported TYPE/SIZE "
                             "pair (F needs 4 or 8)",
                             f->name);
                goto done;
            }
        } else {
            f->type = pcd_type('F', f->size);
            if (f->type == IO_T_INVALID)
                f->type = IO_T_F32; /* ascii without TYPE: parse as text */
        }
        if (strcmp(f->name, "x") == 0 && fx < 0) fx = (int)i;
        if (strcmp(f->name, "y") == 0 && fy < 0) fy = (int)i;
        if (strcmp(f->name, "z") == 0 && fz < 0) fz = (int)i;
        if (io_mul_u64(f->size, f->count, &bytes) != 0 ||
            point_size + bytes < point_size) {
            st = io_fail(ctx, PKSS_ERR_FORMAT, "PCD: point size overflows");
            goto done;
        }
        point_size += bytes;
        tokens += f->count;
    }
    if (fx < 0 || fy < 0 || fz < 0) {
        st = io_fail(ctx, PKSS_ERR_FORMAT, "PCD: no field '%s' in FIELDS",
                     fx < 0 ? "x" : fy < 0 ? "y" : "z");
        goto done;
    }
    if (h.f[fx].count != 1 || h.f[fy].count != 1 || h.f[fz].count != 1) {
        st = io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                     "PCD: x, y and z must have COUNT 1");
        goto done;
    }
    /* POINTS must agree with WIDTH x HEIGHT when both are given. */
    if (h.have_width) {
        uint64_t wh;
        if (!h.have_height)
            h.height = 1;
        if (io_mul_u64(h.width, h.height, &wh) != 0) {
            st = io_fail(ctx, PKSS_ERR_FORMAT,
                         "PCD: WIDTH x HEIGHT overflows");
            goto done;
        }
        if (!h.have_points) {
            h.points = wh;
            h.have_points = 1;
        } else if (h.points != wh) {
            st = io_fail(ctx, PKSS_ERR_FORMAT,
                         "PCD: POINTS %llu differs from WIDTH x HEIGHT = %llu",
                         (unsigned long long)h.points, (unsigned long long)wh);
            goto done;
        }
    }
    if (!h.have_points) {
        st = io_fail(ctx, PKSS_ERR_FORMAT,
                     "PCD: the header gives neither POINTS nor WIDTH");
        goto done;
    }
    np = h.points;
    if (np == 0) {
        st = io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "PCD: the header says 0 points");
        goto done;
    }
    left = ctx->size - start;

    if (h.data == 0) { /* ------------------------------------- ascii */
        uint64_t p, k;
        char q[64];
        /* token index of x, y, z within a point */
        uint64_t ti = 0;
        for (i = 0; i < h.n_fields; i++) {
            if ((int)i == fx) off[0] = ti;
            if ((int)i == fy) off[1] = ti;
            if ((int)i == fz) off[2] = ti;
            ti += h.f[i].count;
        }
        if (io_mul_u64(np, 2 * tokens, &need) != 0 || need > left + 1) {
            st = io_fail(ctx, PKSS_ERR_FORMAT,
                         "PCD: truncated at byte %llu: expected %llu points "
                         "of %llu values, got only %llu bytes of data",
                         (unsigned long long)ctx->size,
                         (unsigned long long)np, (unsigned long long)tokens,
                         (unsigned long long)left);
            goto done;
        }
        out = io_alloc_points(ctx, np);
        if (!out) {
            st = PKSS_ERR_OUT_OF_MEMORY;
            goto done;
        }
        io_cursor_init(&ac, ctx->data, ctx->size);
        ac.p += start;
        for (p = 0; p < np; p++) {
            for (k = 0; k < tokens; k++) {
                const char *t;
                size_t tl;
                int axis = k == off[0] ? 0 : k == off[1] ? 1 : k == off[2] ? 2
                                                                            : -1;
                if (!io_next_token(&ac, &t, &tl)) {
                    st = io_fail(ctx, PKSS_ERR_FORMAT,
                                 "PCD: truncated at byte %llu: expected %llu "
                                 "points, got %llu",
                                 (unsigned long long)ctx->size,
                                 (unsigned long long)np,
                                 (unsigned long long)p);
                    goto done;
                }
                if (axis >= 0 && io_parse_double(t, tl, &out[3 * p + axis])) {
                    st = io_fail(ctx, PKSS_ERR_FORMAT,
                                 "PCD: line %lu: point %llu: '%s' is not a "
                                 "number",
                                 (unsigned long)ac.line, (unsigned long long)p,
                                 io_quote(t, tl, q, sizeof q));
                    goto done;
                }
            }
        }
    } else { /* --------------------------------- binary (compressed) */
        const unsigned char *base;
        uint64_t p, total;
        uint64_t stride[3], start3[3];
        int fi[3];
        if (io_mul_u64(np, point_size, &total) != 0) {
            st = io_fail(ctx, PKSS_ERR_FORMAT,
                         "PCD: header says %llu points of %llu bytes: size "
                         "overflows",
                         (unsigned long long)np,
                         (unsigned long long)point_size);
            goto done;
        }
        if (h.data == 1) {
            if (total > left) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: truncated at byte %llu: expected %llu "
                             "points of %llu bytes, got %llu (%llu bytes of "
                             "data)",
                             (unsigned long long)ctx->size,
                             (unsigned long long)np,
                             (unsigned long long)point_size,
                             (unsigned long long)(left / point_size),
                             (unsigned long long)left);
                goto done;
            }
            base = ctx->data + start;
        } else {
            uint64_t csize, usize;
            size_t got, bad = 0;
            if (left < 8) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: binary_compressed data lacks its 8-byte "
                             "size header");
                goto done;
            }
            csize = (uint64_t)io_get_value(ctx->data + start, IO_T_U32, 0);
            usize = (uint64_t)io_get_value(ctx->data + start + 4, IO_T_U32, 0);
            if (csize > left - 8) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: compressed size %llu but only %llu bytes "
                             "follow",
                             (unsigned long long)csize,
                             (unsigned long long)(left - 8));
                goto done;
            }
            if (usize != total) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: uncompressed size %llu differs from "
                             "POINTS x point size = %llu",
                             (unsigned long long)usize,
                             (unsigned long long)total);
                goto done;
            }
            /* One LZF back-reference (3 bytes) yields at most 264 bytes. */
            if (usize / 88 > csize + 1) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: %llu compressed bytes cannot hold %llu "
                             "bytes of LZF data (header lies)",
                             (unsigned long long)csize,
                             (unsigned long long)usize);
                goto done;
            }
            raw = (unsigned char *)malloc(usize ? (size_t)usize : 1);
            if (!raw) {
                st = io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                             "PCD: out of memory for %llu bytes",
                             (unsigned long long)usize);
                goto done;
            }
            got = pkss__io_lzf_decompress(ctx->data + start + 8, (size_t)csize, raw,
                                    (size_t)usize, &bad);
            if (got != usize) {
                st = io_fail(ctx, PKSS_ERR_FORMAT,
                             "PCD: corrupt LZF data (decoding failed at "
                             "compressed byte %lu, %lu of %llu bytes out)",
                             (unsigned long)bad, (unsigned long)got,
                             (unsigned long long)usize);
                goto done;
            }
            base = raw;
        }
        fi[0] = fx;
        fi[1] = fy;
        fi[2] = fz;
        for (i = 0; i < 3; i++) {
            uint64_t before = 0;
            int j;
            for (j = 0; j < fi[i]; j++)
                before += h.f[j].size * h.f[j].count;
            if (h.data == 1) { /* AoS */
                start3[i] = before;
                stride[i] = point_size;
            } else {           /* SoA: field blocks one after another */
                start3[i] = before * np;
                stride[i] = h.f[fi[i]].size;
            }
        }
        out = io_alloc_points(ctx, np);
        if (!out) {
            st = PKSS_ERR_OUT_OF_MEMORY;
            goto done;
        }
        for (p = 0; p < np; p++)
            for (i = 0; i < 3; i++)
                out[3 * p + i] = io_get_value(
                    base + start3[i] + p * stride[i], h.f[fi[i]].type, 0);
    }
    /* Data past POINTS means the header and the data disagree (as in PLY):
     * refuse rather than guess. */
    if (h.data == 0) {
        const char *t;
        size_t tl;
        if (io_next_token(&ac, &t, &tl)) {
            st = io_fail(ctx, PKSS_ERR_FORMAT,
                         "PCD: data after the %llu points the header "
                         "declares (byte %llu)",
                         (unsigned long long)np,
                         (unsigned long long)(t - (const char *)ctx->data));
            goto done;
        }
    } else if (h.data == 1 && np * point_size < left) {
        st = io_fail(ctx, PKSS_ERR_FORMAT,
                     "PCD: data after the %llu points the header declares "
                     "(byte %llu, %llu bytes more)",
                     (unsigned long long)np,
                     (unsigned long long)(start + np * point_size),
                     (unsigned long long)(left - np * point_size));
        goto done;
    }
    *xyz = out;
    *n = (size_t)np;
    out = NULL;
    st = PKSS_OK;
done:
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
