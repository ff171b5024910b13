/* SPDX-License-Identifier: MIT
 * io_text.c -- line-based text readers: XYZ/TXT/CSV/PTS and OFF.
 *
 * XYZ family: one point per line, columns separated by blanks and/or
 * commas; the first three columns are x y z and the rest is ignored.
 * '#' starts a comment. Lines of text before the first numeric row are a
 * header (at most IO_MAX_HEADER_LINES). A first line holding one integer is
 * a point count (Go-ICP .txt, Leica .pts); it must match the rows read.
 *
 * OFF: [ST][C][N]OFF, optional counts on the same line (also glued, as in
 * "OFF490 518 0" from ModelNet), then NV NF [NE] and NV vertex lines whose
 * first three numbers are x y z. Faces are not read.
 */
#include "io_internal.h"

#include <stdlib.h>
#include <string.h>

#define IO_MAX_HEADER_LINES 64

/* Length of a line once a '#' comment is cut off. */
static size_t strip_comment(const char *line, size_t len)
{
    const char *h = (const char *)memchr(line, '#', len);
    return h ? (size_t)(h - line) : len;
}

static pkss_status check_nul(io_ctx *ctx, const char *what)
{
    const unsigned char *z =
        (const unsigned char *)memchr(ctx->data, '\0', ctx->size);
    if (z)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "%s: binary data (a NUL byte at offset %lu): not a "
                       "text file",
                       what, (unsigned long)(z - ctx->data));
    return PKSS_OK;
}

static int is_digit(char ch) { return ch >= '0' && ch <= '9'; }

/* A line written with decimal commas ("0,75 1,5 2,0" or "0,75;1,5;2,0"):
 * its first three fields, split at blanks or ';', each hold exactly one
 * comma, between digits, and no '.'. Read with commas between columns it
 * would give wrong numbers, so it is refused by name. A CSV row followed
 * by blank-separated columns ("1.0,2.0,3.0 255 0 0", "1,2,3 7") is not
 * one. */
static int decimal_commas(const char *s, const char *e)
{
    const char *p = s;
    int fields = 0;
    while (fields < 3) {
        int commas = 0, ok = 1;
        while (p < e && (*p == ' ' || *p == '\t' || *p == ';'))
            p++;
        if (p >= e)
            return 0;
        const char *f = p;
        while (p < e && *p != ' ' && *p != '\t' && *p != ';') {
            if (*p == '.')
                ok = 0;
            else if (*p == ',') {
                commas++;
                if (p == f || p + 1 >= e || !is_digit(p[-1]) || !is_digit(p[1]))
                    ok = 0;
            }
            p++;
        }
        if (!ok || commas != 1)
            return 0;
        fields++;
    }
    return 1;
}

/* Grows *buf to hold at least need points. */
static int grow(double **buf, size_t *cap, size_t need)
{
    size_t nc;
    double *nb;
    if (need <= *cap)
        return 0;
    nc = *cap ? *cap : 1024;
    while (nc < need) {
        if (nc > SIZE_MAX / 2 / (3 * sizeof(double)))
            return -1;
        nc *= 2;
    }
    nb = (double *)realloc(*buf, nc * 3 * sizeof(double));
    if (!nb)
        return -1;
    *buf = nb;
    *cap = nc;
    return 0;
}

pkss_status io_read_xyz(io_ctx *ctx, double **xyz, size_t *n)
{
    io_cursor c;
    const char *line;
    size_t len, line_no, rows = 0, cap = 0, header = 0;
    size_t count_line = 0;
    uint64_t count = 0;
    int have_count = 0, started = 0;
    double *out = NULL;
    char q[64];
    pkss_status st = check_nul(ctx, "XYZ");
    if (st != PKSS_OK)
        return st;

    io_cursor_init(&c, ctx->data, ctx->size);
    while (io_next_line(&c, &line, &len, &line_no)) {
        const char *s = line, *e = line + strip_comment(line, len);
        if (decimal_commas(s, e)) {
            free(out);
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "XYZ: line %lu: '%s' looks like decimal commas; "
                           "write numbers with '.' (columns may be separated "
                           "by blanks or commas)",
                           (unsigned long)line_no, io_quote(line, len, q, sizeof q));
        }
        const char *tok[3];
        size_t tl[3], nt = 0, more = 0;
        double v[3];
        const char *t;
        size_t l;
        int numeric = 1;
        while (io_line_token(&s, e, 1, &t, &l)) {
            if (nt < 3) {
                tok[nt] = t;
                tl[nt] = l;
                nt++;
            } else {
                more = 1;
                break;
            }
        }
        if (nt == 0)
            continue; /* blank or comment */
        if (nt == 3) {
            size_t k;
            for (k = 0; k < 3 && numeric; k++)
                if (io_parse_double(tok[k], tl[k], &v[k]) != 0)
                    numeric = 0;
        } else {
            numeric = 0;
        }
        if (numeric) {
            if (grow(&out, &cap, rows + 1) != 0) {
                free(out);
                return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                               "XYZ: out of memory at line %lu",
                               (unsigned long)line_no);
            }
            out[3 * rows] = v[0];
            out[3 * rows + 1] = v[1];
            out[3 * rows + 2] = v[2];
            rows++;
            started = 1;
            continue;
        }
        if (started) {
            free(out);
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "XYZ: line %lu: expected 3 numeric columns, got "
                           "'%s'",
                           (unsigned long)line_no,
                           io_quote(line, len, q, sizeof q));
        }
        if (nt == 1 && !more && !have_count && header == 0 &&
            io_parse_u64(tok[0], tl[0], &count) == 0) {
            have_count = 1; /* "N" first line: Go-ICP .txt, Leica .pts */
            count_line = line_no;
            continue;
        }
        if (++header > IO_MAX_HEADER_LINES) {
            free(out);
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "XYZ: line %lu: no row of 3 numeric columns in "
                           "the first %d non-blank lines (last: '%s'); not "
                           "a point list",
                           (unsigned long)line_no, IO_MAX_HEADER_LINES,
                           io_quote(line, len, q, sizeof q));
        }
    }
    if (rows == 0) {
        if (header > 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "XYZ: no row of 3 numeric columns (%lu header "
                           "line%s only)",
                           (unsigned long)header, header == 1 ? "" : "s");
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "XYZ: no points (only blank, comment or count lines)");
    }
    if (have_count && count > rows) {
        free(out);
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: truncated at byte %llu: line %lu says %llu "
                       "points but %lu rows follow",
                       (unsigned long long)ctx->size,
                       (unsigned long)count_line, (unsigned long long)count,
                       (unsigned long)rows);
    }
    if (have_count && count != rows) {
        free(out);
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: line %lu says %llu points but %lu rows follow",
                       (unsigned long)count_line, (unsigned long long)count,
                       (unsigned long)rows);
    }
    if (cap > rows) { /* give back the slack */
        double *nb = (double *)realloc(out, rows * 3 * sizeof(double));
        if (nb)
            out = nb;
    }
    *xyz = out;
    *n = rows;
    return PKSS_OK;
}

/* ---------------------------------------------------------------- OFF */

/* Next non-blank line with comments cut. */
static int next_content_line(io_cursor *c, const char **s, const char **e,
                             size_t *line_no)
{
    const char *line, *t;
    size_t len, l;
    while (io_next_line(c, &line, &len, line_no)) {
        const char *p = line, *end = line + strip_comment(line, len);
        if (io_line_token(&p, end, 0, &t, &l)) {
            *s = line;
            *e = end;
            return 1;
        }
    }
    return 0;
}

pkss_status io_read_off(io_ctx *ctx, double **xyz, size_t *n)
{
    io_cursor c;
    const char *s, *e, *t, *off;
    size_t l, line_no, pre, k, ncounts = 0;
    uint64_t counts[3] = {0, 0, 0}, need, left, i;
    const char *glued = NULL;
    size_t glued_len = 0;
    double *out;
    char q[64];
    pkss_status st = check_nul(ctx, "OFF");
    if (st != PKSS_OK)
        return st;

    io_cursor_init(&c, ctx->data, ctx->size);
    if (!next_content_line(&c, &s, &e, &line_no))
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "OFF: no content (only blank or comment lines)");
    io_line_token(&s, e, 0, &t, &l);
    /* keyword: [ST][C][N][4][n]OFF, possibly followed by glued digits */
    off = NULL;
    for (k = 0; k + 3 <= l; k++)
        if (memcmp(t + k, "OFF", 3) == 0) {
            off = t + k;
            break;
        }
    pre = off ? (size_t)(off - t) : 0;
    for (k = 0; off && k < pre; k++)
        if (!strchr("STCN4n", t[k]))
            off = NULL;
    if (!off)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "OFF: line %lu: '%s' is not an OFF keyword (OFF, "
                       "COFF, NOFF, ...)",
                       (unsigned long)line_no, io_quote(t, l, q, sizeof q));
    if (memchr(t, '4', pre) || memchr(t, 'n', pre))
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "OFF: 4D / nD OFF ('%s') is not supported",
                       io_quote(t, l, q, sizeof q));
    if (pre + 3 < l) {
        glued = t + pre + 3;
        glued_len = l - pre - 3;
    }
    /* counts: glued digits, then the rest of the line, else the next line */
    for (;;) {
        const char *ct;
        size_t cl;
        if (glued) {
            ct = glued;
            cl = glued_len;
            glued = NULL;
        } else if (!io_line_token(&s, e, 0, &ct, &cl)) {
            if (ncounts > 0)
                break;
            if (!next_content_line(&c, &s, &e, &line_no))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: the file ends before the vertex count");
            continue;
        }
        if (ncounts == 0 && io_tok_eq(ct, cl, "BINARY"))
            return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                           "OFF: binary OFF is not supported");
        if (ncounts < 3) {
            int r = io_parse_u64(ct, cl, &counts[ncounts]);
            if (r != 0)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: line %lu: count '%s' is %s",
                               (unsigned long)line_no,
                               io_quote(ct, cl, q, sizeof q),
                               r == -2   ? "negative"
                               : r == -3 ? "too large"
                                         : "not an integer");
            ncounts++;
        }
    }
    if (counts[0] == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "OFF: the header declares 0 vertices");
    left = io_cursor_left(&c);
    if (io_mul_u64(counts[0], 6, &need) != 0 || need > left + 1)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "OFF: header says %llu vertices but only %llu bytes "
                       "follow (at least 6 per vertex line)",
                       (unsigned long long)counts[0], (unsigned long long)left);
    out = io_alloc_points(ctx, counts[0]);
    if (!out)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (i = 0; i < counts[0]; i++) {
        size_t a;
        if (!next_content_line(&c, &s, &e, &line_no)) {
            free(out);
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "OFF: truncated at byte %llu: expected %llu "
                           "vertices, got %llu",
                           (unsigned long long)ctx->size,
                           (unsigned long long)counts[0],
                           (unsigned long long)i);
        }
        for (a = 0; a < 3; a++) {
            if (!io_line_token(&s, e, 0, &t, &l)) {
                free(out);
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: line %lu: vertex %llu has fewer than 3 "
                               "coordinates",
                               (unsigned long)line_no, (unsigned long long)i);
            }
            if (io_parse_double(t, l, &out[3 * i + a]) != 0) {
                free(out);
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: line %lu: vertex %llu: '%s' is not a "
                               "number",
                               (unsigned long)line_no, (unsigned long long)i,
                               io_quote(t, l, q, sizeof q));
            }
        }
    }
    *xyz = out;
    *n = (size_t)counts[0];
    return PKSS_OK;
}
