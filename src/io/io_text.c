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

/* The state of one XYZ read: the rows so far and the optional count line. */
typedef struct xyz_state {
    double *out;
    size_t rows, cap, header, count_line;
    uint64_t count;
    int have_count, started;
} xyz_state;

/* Up to the first 3 tokens of a line; *more is set when a 4th follows.
 * @return the number of tokens kept (0 for a blank or comment line). */
static size_t xyz_tokens(const char *s, const char *e, const char *tok[3],
                         size_t tl[3], size_t *more)
{
    const char *t;
    size_t l, nt = 0;
    *more = 0;
    while (io_line_token(&s, e, 1, &t, &l)) {
        if (nt == 3) {
            *more = 1;
            break;
        }
        tok[nt] = t;
        tl[nt] = l;
        nt++;
    }
    return nt;
}

/* 1 if the line is a point row: exactly 3 leading tokens, all numbers. */
static int xyz_numeric(const char *tok[3], const size_t tl[3], size_t nt,
                       double v[3])
{
    size_t k;
    if (nt != 3)
        return 0;
    for (k = 0; k < 3; k++)
        if (io_parse_double(tok[k], tl[k], &v[k]) != 0)
            return 0;
    return 1;
}

/* Appends one point row. */
static pkss_status xyz_add_row(io_ctx *ctx, xyz_state *x, const double v[3],
                               size_t line_no)
{
    if (grow(&x->out, &x->cap, x->rows + 1) != 0)
        return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "XYZ: out of memory at line %lu",
                       (unsigned long)line_no);
    x->out[3 * x->rows] = v[0];
    x->out[3 * x->rows + 1] = v[1];
    x->out[3 * x->rows + 2] = v[2];
    x->rows++;
    x->started = 1;
    return PKSS_OK;
}

/* A line that is not a point row: after the first row an error; before it
 * the count line (one integer, first) or one more header line. */
static pkss_status xyz_non_row(io_ctx *ctx, xyz_state *x, const char *tok0,
                               size_t tl0, size_t nt, size_t more,
                               const char *line, size_t len, size_t line_no)
{
    char q[64];
    if (x->started)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: line %lu: expected 3 numeric columns, got "
                       "'%s'",
                       (unsigned long)line_no,
                       io_quote(line, len, q, sizeof q));
    if (nt == 1 && !more && !x->have_count && x->header == 0 &&
        io_parse_u64(tok0, tl0, &x->count) == 0) {
        x->have_count = 1; /* "N" first line: Go-ICP .txt, Leica .pts */
        x->count_line = line_no;
        return PKSS_OK;
    }
    if (++x->header > IO_MAX_HEADER_LINES)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: line %lu: no row of 3 numeric columns in "
                       "the first %d non-blank lines (last: '%s'); not "
                       "a point list",
                       (unsigned long)line_no, IO_MAX_HEADER_LINES,
                       io_quote(line, len, q, sizeof q));
    return PKSS_OK;
}

/* One line of the file: refused decimal commas, blank, row or header. */
static pkss_status xyz_line(io_ctx *ctx, xyz_state *x, const char *line,
                            size_t len, size_t line_no)
{
    const char *e = line + strip_comment(line, len);
    const char *tok[3] = {NULL, NULL, NULL};
    size_t tl[3] = {0, 0, 0}, nt, more;
    double v[3];
    char q[64];
    if (decimal_commas(line, e))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: line %lu: '%s' looks like decimal commas; "
                       "write numbers with '.' (columns may be separated "
                       "by blanks or commas)",
                       (unsigned long)line_no, io_quote(line, len, q, sizeof q));
    nt = xyz_tokens(line, e, tok, tl, &more);
    if (nt == 0)
        return PKSS_OK; /* blank or comment */
    if (xyz_numeric(tok, tl, nt, v))
        return xyz_add_row(ctx, x, v, line_no);
    return xyz_non_row(ctx, x, tok[0], tl[0], nt, more, line, len, line_no);
}

/* After the last line: at least one row, and as many as the count line
 * says. */
static pkss_status xyz_check_rows(io_ctx *ctx, const xyz_state *x)
{
    if (x->rows == 0) {
        if (x->header > 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "XYZ: no row of 3 numeric columns (%lu header "
                           "line%s only)",
                           (unsigned long)x->header, x->header == 1 ? "" : "s");
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "XYZ: no points (only blank, comment or count lines)");
    }
    if (x->have_count && x->count > x->rows)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: truncated at byte %llu: line %lu says %llu "
                       "points but %lu rows follow",
                       (unsigned long long)ctx->size,
                       (unsigned long)x->count_line,
                       (unsigned long long)x->count, (unsigned long)x->rows);
    if (x->have_count && x->count != x->rows)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "XYZ: line %lu says %llu points but %lu rows follow",
                       (unsigned long)x->count_line,
                       (unsigned long long)x->count, (unsigned long)x->rows);
    return PKSS_OK;
}

pkss_status io_read_xyz(io_ctx *ctx, double **xyz, size_t *n)
{
    io_cursor c;
    const char *line;
    size_t len, line_no;
    xyz_state x;
    pkss_status st = check_nul(ctx, "XYZ");
    if (st != PKSS_OK)
        return st;

    memset(&x, 0, sizeof x);
    io_cursor_init(&c, ctx->data, ctx->size);
    while (st == PKSS_OK && io_next_line(&c, &line, &len, &line_no))
        st = xyz_line(ctx, &x, line, len, line_no);
    if (st == PKSS_OK)
        st = xyz_check_rows(ctx, &x);
    if (st != PKSS_OK) {
        free(x.out);
        return st;
    }
    if (x.cap > x.rows) { /* give back the slack */
        double *nb = (double *)realloc(x.out, x.rows * 3 * sizeof(double));
        if (nb)
            x.out = nb;
    }
    *xyz = x.out;
    *n = x.rows;
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

/* Checks the keyword token [ST][C][N][4][n]OFF; *pre receives the length
 * of its prefix (the letters before "OFF"). */
static pkss_status off_keyword(io_ctx *ctx, const char *t, size_t l,
                               size_t line_no, size_t *pre)
{
    const char *off = NULL;
    size_t k;
    char q[64];
    for (k = 0; k + 3 <= l; k++)
        if (memcmp(t + k, "OFF", 3) == 0) {
            off = t + k;
            break;
        }
    *pre = off ? (size_t)(off - t) : 0;
    for (k = 0; off && k < *pre; k++)
        if (!strchr("STCN4n", t[k]))
            off = NULL;
    if (!off)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "OFF: line %lu: '%s' is not an OFF keyword (OFF, "
                       "COFF, NOFF, ...)",
                       (unsigned long)line_no, io_quote(t, l, q, sizeof q));
    if (memchr(t, '4', *pre) || memchr(t, 'n', *pre))
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "OFF: 4D / nD OFF ('%s') is not supported",
                       io_quote(t, l, q, sizeof q));
    return PKSS_OK;
}

/* Where the header is being read: the cursor and the rest of the current
 * line [s, e). */
typedef struct off_header {
    io_cursor c;
    const char *s, *e;
    size_t line_no;
} off_header;

/* One count token: "BINARY" in place of the first is refused by name;
 * after three counts the rest of the line is ignored. */
static pkss_status off_count(io_ctx *ctx, const off_header *h, const char *ct,
                             size_t cl, uint64_t counts[3], size_t *ncounts)
{
    char q[64];
    int r;
    if (*ncounts == 0 && io_tok_eq(ct, cl, "BINARY"))
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "OFF: binary OFF is not supported");
    if (*ncounts >= 3)
        return PKSS_OK;
    r = io_parse_u64(ct, cl, &counts[*ncounts]);
    if (r != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "OFF: line %lu: count '%s' is %s",
                       (unsigned long)h->line_no,
                       io_quote(ct, cl, q, sizeof q),
                       r == -2   ? "negative"
                       : r == -3 ? "too large"
                                 : "not an integer");
    (*ncounts)++;
    return PKSS_OK;
}

/* The counts NV NF [NE]: digits glued to the keyword, then the rest of
 * the keyword's line, else the next content line (which holds them all). */
static pkss_status off_counts(io_ctx *ctx, off_header *h, const char *glued,
                              size_t glued_len, uint64_t counts[3])
{
    size_t ncounts = 0;
    pkss_status st = PKSS_OK;
    while (st == PKSS_OK) {
        const char *ct;
        size_t cl;
        if (glued) {
            ct = glued;
            cl = glued_len;
            glued = NULL;
        } else if (!io_line_token(&h->s, h->e, 0, &ct, &cl)) {
            if (ncounts > 0)
                break;
            if (!next_content_line(&h->c, &h->s, &h->e, &h->line_no))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: the file ends before the vertex count");
            continue;
        }
        st = off_count(ctx, h, ct, cl, counts, &ncounts);
    }
    return st;
}

/* Reads nv vertex lines into out: the first 3 numbers of each. */
static pkss_status off_vertices(io_ctx *ctx, off_header *h, uint64_t nv,
                                double *out)
{
    const char *t;
    size_t l, a;
    uint64_t i;
    char q[64];
    for (i = 0; i < nv; i++) {
        if (!next_content_line(&h->c, &h->s, &h->e, &h->line_no))
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "OFF: truncated at byte %llu: expected %llu "
                           "vertices, got %llu",
                           (unsigned long long)ctx->size,
                           (unsigned long long)nv, (unsigned long long)i);
        for (a = 0; a < 3; a++) {
            if (!io_line_token(&h->s, h->e, 0, &t, &l))
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: line %lu: vertex %llu has fewer than 3 "
                               "coordinates",
                               (unsigned long)h->line_no,
                               (unsigned long long)i);
            if (io_parse_double(t, l, &out[3 * i + a]) != 0)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "OFF: line %lu: vertex %llu: '%s' is not a "
                               "number",
                               (unsigned long)h->line_no,
                               (unsigned long long)i,
                               io_quote(t, l, q, sizeof q));
        }
    }
    return PKSS_OK;
}

pkss_status io_read_off(io_ctx *ctx, double **xyz, size_t *n)
{
    off_header h;
    const char *t, *glued = NULL;
    size_t l, pre, glued_len = 0;
    uint64_t counts[3] = {0, 0, 0}, need, left;
    double *out;
    pkss_status st = check_nul(ctx, "OFF");
    if (st != PKSS_OK)
        return st;

    io_cursor_init(&h.c, ctx->data, ctx->size);
    if (!next_content_line(&h.c, &h.s, &h.e, &h.line_no))
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "OFF: no content (only blank or comment lines)");
    io_line_token(&h.s, h.e, 0, &t, &l);
    st = off_keyword(ctx, t, l, h.line_no, &pre);
    if (st != PKSS_OK)
        return st;
    if (pre + 3 < l) { /* "OFF490 518 0" (ModelNet) */
        glued = t + pre + 3;
        glued_len = l - pre - 3;
    }
    st = off_counts(ctx, &h, glued, glued_len, counts);
    if (st != PKSS_OK)
        return st;
    if (counts[0] == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "OFF: the header declares 0 vertices");
    left = io_cursor_left(&h.c);
    if (io_mul_u64(counts[0], 6, &need) != 0 || need > left + 1)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "OFF: header says %llu vertices but only %llu bytes "
                       "follow (at least 6 per vertex line)",
                       (unsigned long long)counts[0], (unsigned long long)left);
    out = io_alloc_points(ctx, counts[0]);
    if (!out)
        return PKSS_ERR_OUT_OF_MEMORY;
    st = off_vertices(ctx, &h, counts[0], out);
    if (st != PKSS_OK) {
        free(out);
        return st;
    }
    *xyz = out;
    *n = (size_t)counts[0];
    return PKSS_OK;
}
