/* SPDX-License-Identifier: MIT
 * pkss_io.c -- format names, bounded file reading, dispatch to the parsers
 * and the helpers declared in io_internal.h (writers: io_write.c).
 */
#define _POSIX_C_SOURCE 200809L /* fileno, fstat, mmap */
#include "io_internal.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>

/* ================================================================ errors */

pkss_status io_fail(io_ctx *ctx, pkss_status status, const char *fmt,
                       ...)
{
    if (ctx && ctx->err && ctx->err_size > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(ctx->err, ctx->err_size, fmt, ap);
        va_end(ap);
    }
    return status;
}

/* Non-printable bytes are shown as \xNN, so a message names them. */
const char *io_quote(const char *s, size_t len, char *buf, size_t buf_size)
{
    size_t i, o = 0, lim = len > 40 ? 40 : len;
    if (buf_size < 48)
        return "";
    for (i = 0; i < lim && o + 8 < buf_size; i++) {
        unsigned char ch = (unsigned char)s[i];
        if (ch >= 0x20 && ch < 0x7f)
            buf[o++] = (char)ch;
        else
            o += (size_t)snprintf(buf + o, buf_size - o, "\\x%02X", ch);
    }
    if (i < len && o + 4 <= buf_size) {
        memcpy(buf + o, "...", 3);
        o += 3;
    }
    buf[o] = '\0';
    return buf;
}

static void set_err(char *err, size_t err_size, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void set_err(char *err, size_t err_size, const char *fmt, ...)
{
    if (err && err_size > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, err_size, fmt, ap);
        va_end(ap);
    }
}

/* ============================================================== numbers */

int io_parse_double(const char *s, size_t len, double *out)
{
    char buf[128];
    char *end = NULL;
    double v;
    if (len == 0 || len >= sizeof buf)
        return -1;
    /* strtod would skip leading blanks: a token never has any, but be
     * strict so "  1" in a CSV cell is handled by the tokenizer only. */
    if (isspace((unsigned char)s[0]))
        return -1;
    memcpy(buf, s, len);
    buf[len] = '\0';
    v = strtod(buf, &end);
    if (end != buf + len)
        return -1;
    *out = v; /* overflow gives +-inf, which the reader passes through */
    return 0;
}

int io_parse_u64(const char *s, size_t len, uint64_t *out)
{
    size_t i = 0;
    uint64_t v = 0;
    int neg = 0;
    if (len == 0)
        return -1;
    if (s[0] == '+' || s[0] == '-') {
        neg = s[0] == '-';
        i = 1;
        if (len == 1)
            return -1;
    }
    for (; i < len; i++) {
        unsigned d;
        if (s[i] < '0' || s[i] > '9')
            return -1;
        d = (unsigned)(s[i] - '0');
        if (v > (UINT64_MAX - d) / 10) {
            /* keep scanning so "-999...9x" is "not an integer" */
            size_t j;
            for (j = i; j < len; j++)
                if (s[j] < '0' || s[j] > '9')
                    return -1;
            return neg ? -2 : -3;
        }
        v = v * 10 + d;
    }
    if (neg && v != 0)
        return -2;
    *out = v;
    return 0;
}

int io_mul_u64(uint64_t a, uint64_t b, uint64_t *out)
{
    if (a != 0 && b > UINT64_MAX / a)
        return -1;
    *out = a * b;
    return 0;
}

/* ========================================================== binary data */

size_t io_type_size(io_type t)
{
    switch (t) {
    case IO_T_I8: case IO_T_U8: return 1;
    case IO_T_I16: case IO_T_U16: return 2;
    case IO_T_I32: case IO_T_U32: case IO_T_F32: return 4;
    case IO_T_I64: case IO_T_U64: case IO_T_F64: return 8;
    default: return 0;
    }
}

int io_type_is_integer(io_type t)
{
    return t != IO_T_INVALID && t != IO_T_F32 && t != IO_T_F64;
}

static uint64_t load_bits(const unsigned char *p, size_t nb, int big_endian)
{
    uint64_t v = 0;
    size_t i;
    if (big_endian)
        for (i = 0; i < nb; i++)
            v = (v << 8) | p[i];
    else
        for (i = nb; i-- > 0;)
            v = (v << 8) | p[i];
    return v;
}

double io_get_value(const unsigned char *p, io_type t, int big_endian)
{
    uint64_t b = load_bits(p, io_type_size(t), big_endian);
    switch (t) {
    case IO_T_I8: return (double)(int8_t)(uint8_t)b;
    case IO_T_U8: return (double)(uint8_t)b;
    case IO_T_I16: return (double)(int16_t)(uint16_t)b;
    case IO_T_U16: return (double)(uint16_t)b;
    case IO_T_I32: return (double)(int32_t)(uint32_t)b;
    case IO_T_U32: return (double)(uint32_t)b;
    case IO_T_I64: return (double)(int64_t)b;
    case IO_T_U64: return (double)b;
    case IO_T_F32: {
        uint32_t u = (uint32_t)b;
        float f;
        memcpy(&f, &u, sizeof f);
        return (double)f;
    }
    case IO_T_F64: {
        double d;
        memcpy(&d, &b, sizeof d);
        return d;
    }
    default: return 0.0;
    }
}

int io_get_count(const unsigned char *p, io_type t, int big_endian,
                 uint64_t *out)
{
    uint64_t b = load_bits(p, io_type_size(t), big_endian);
    switch (t) {
    case IO_T_I8: if ((int8_t)(uint8_t)b < 0) return -1; break;
    case IO_T_I16: if ((int16_t)(uint16_t)b < 0) return -1; break;
    case IO_T_I32: if ((int32_t)(uint32_t)b < 0) return -1; break;
    case IO_T_I64: if ((int64_t)b < 0) return -1; break;
    default: break;
    }
    *out = b;
    return 0;
}

/* ================================================================= text */

void io_cursor_init(io_cursor *c, const void *data, size_t size)
{
    c->p = (const char *)data;
    c->end = c->p + size;
    c->line = 1;
}

size_t io_cursor_left(const io_cursor *c)
{
    return (size_t)(c->end - c->p);
}

static int is_ws(char ch)
{
    return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' ||
           ch == '\v' || ch == '\f';
}

int io_next_token(io_cursor *c, const char **tok, size_t *len)
{
    const char *p = c->p, *end = c->end, *s;
    while (p < end && is_ws(*p)) {
        if (*p == '\n' || (*p == '\r' && (p + 1 >= end || p[1] != '\n')))
            c->line++;
        p++;
    }
    if (p >= end) {
        c->p = p;
        return 0;
    }
    s = p;
    while (p < end && !is_ws(*p))
        p++;
    *tok = s;
    *len = (size_t)(p - s);
    c->p = p;
    return 1;
}

int io_next_line(io_cursor *c, const char **line, size_t *len,
                 size_t *line_no)
{
    const char *p = c->p, *end = c->end, *s = p;
    if (p >= end)
        return 0;
    while (p < end && *p != '\n' && *p != '\r')
        p++;
    *line = s;
    *len = (size_t)(p - s);
    if (line_no)
        *line_no = c->line;
    if (p < end) {
        if (*p == '\r' && p + 1 < end && p[1] == '\n')
            p += 2;
        else
            p++;
        c->line++;
    }
    c->p = p;
    return 1;
}

int io_line_token(const char **sp, const char *end, int commas,
                  const char **tok, size_t *len)
{
    const char *p = *sp, *s;
    for (;;) {
        while (p < end && is_ws(*p))
            p++;
        if (p < end && commas && *p == ',') {
            /* an empty cell (",,") is skipped like blank space */
            p++;
            continue;
        }
        break;
    }
    if (p >= end) {
        *sp = p;
        return 0;
    }
    s = p;
    while (p < end && !is_ws(*p) && !(commas && *p == ','))
        p++;
    *tok = s;
    *len = (size_t)(p - s);
    if (p < end && commas && *p == ',')
        p++;
    *sp = p;
    return 1;
}

int io_tok_eq(const char *tok, size_t len, const char *word)
{
    size_t i;
    for (i = 0; i < len; i++) {
        if (word[i] == '\0')
            return 0;
        if (tolower((unsigned char)tok[i]) != tolower((unsigned char)word[i]))
            return 0;
    }
    return word[len] == '\0';
}

double *io_alloc_points(io_ctx *ctx, uint64_t n)
{
    double *p;
    if (n == 0 || n > SIZE_MAX / (3 * sizeof(double))) {
        io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "cannot hold %llu points in memory",
                (unsigned long long)n);
        return NULL;
    }
    p = (double *)malloc((size_t)n * 3 * sizeof(double));
    if (!p)
        io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                "out of memory allocating %llu points (%llu bytes)",
                (unsigned long long)n,
                (unsigned long long)(n * 3 * sizeof(double)));
    return p;
}

/* ============================================================= formats */

static const struct {
    const char *name;
    pkss_format fmt;
} k_names[] = {
    {"auto", PKSS_FORMAT_AUTO}, {"ply", PKSS_FORMAT_PLY},     {"pcd", PKSS_FORMAT_PCD},
    {"xyz", PKSS_FORMAT_XYZ},   {"txt", PKSS_FORMAT_XYZ},     {"csv", PKSS_FORMAT_XYZ},
    {"pts", PKSS_FORMAT_XYZ},   {"asc", PKSS_FORMAT_XYZ},     {"off", PKSS_FORMAT_OFF},
    {"bin", PKSS_FORMAT_KITTI}, {"kitti", PKSS_FORMAT_KITTI}, {"vtk", PKSS_FORMAT_VTK},
    {"npy", PKSS_FORMAT_NPY},   {"npz", PKSS_FORMAT_NPZ},
};

const char *pkss_format_name(pkss_format f)
{
    switch (f) {
    case PKSS_FORMAT_AUTO: return "auto";
    case PKSS_FORMAT_PLY: return "ply";
    case PKSS_FORMAT_PCD: return "pcd";
    case PKSS_FORMAT_XYZ: return "xyz";
    case PKSS_FORMAT_OFF: return "off";
    case PKSS_FORMAT_KITTI: return "kitti";
    case PKSS_FORMAT_VTK: return "vtk";
    case PKSS_FORMAT_NPY: return "npy";
    case PKSS_FORMAT_NPZ: return "npz";
    default: return NULL;
    }
}

pkss_format pkss_format_from_name(const char *name)
{
    size_t i;
    if (!name)
        return PKSS_FORMAT_AUTO;
    for (i = 0; i < sizeof k_names / sizeof k_names[0]; i++)
        if (io_tok_eq(name, strlen(name), k_names[i].name))
            return k_names[i].fmt;
    return (pkss_format)-1;
}

pkss_format pkss_format_from_path(const char *path)
{
    const char *dot, *slash;
    size_t i;
    if (!path)
        return PKSS_FORMAT_AUTO;
    dot = strrchr(path, '.');
    slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash) || dot[1] == '\0')
        return PKSS_FORMAT_AUTO;
    if (io_tok_eq(dot + 1, 4, "npz:")) /* "scan.npz:points" */
        return PKSS_FORMAT_NPZ;
    for (i = 1; i < sizeof k_names / sizeof k_names[0]; i++) {
        if (k_names[i].fmt == PKSS_FORMAT_KITTI &&
            strcmp(k_names[i].name, "kitti") == 0)
            continue; /* "kitti" is a format name, not an extension */
        if (io_tok_eq(dot + 1, strlen(dot + 1), k_names[i].name))
            return k_names[i].fmt;
    }
    return PKSS_FORMAT_AUTO;
}

static int has_bom(const unsigned char *d, size_t n)
{
    return n >= 3 && memcmp(d, "\xEF\xBB\xBF", 3) == 0;
}

static int starts_with(const unsigned char *d, size_t n, const char *w)
{
    size_t l = strlen(w);
    return n >= l && memcmp(d, w, l) == 0;
}

pkss_format pkss_format_from_content(const void *data, size_t size)
{
    const unsigned char *d = (const unsigned char *)data;
    size_t i;
    if (!d || size == 0)
        return PKSS_FORMAT_AUTO;
    if (starts_with(d, size, "\x93NUMPY"))
        return PKSS_FORMAT_NPY;
    if (starts_with(d, size, "PK\x03\x04") || starts_with(d, size, "PK\x05\x06"))
        return PKSS_FORMAT_NPZ;
    if (has_bom(d, size)) {
        d += 3;
        size -= 3;
    }
    if (starts_with(d, size, "ply\n") || starts_with(d, size, "ply\r\n"))
        return PKSS_FORMAT_PLY;
    if (starts_with(d, size, "# vtk DataFile"))
        return PKSS_FORMAT_VTK;
    if (starts_with(d, size, "# .PCD") || starts_with(d, size, "VERSION") ||
        starts_with(d, size, "FIELDS"))
        return PKSS_FORMAT_PCD;
    for (i = 0; i < size && i < 8 && isupper(d[i]); i++)
        ;
    if (i >= 3 && i < size && memcmp(d + i - 3, "OFF", 3) == 0 &&
        (isspace(d[i]) || isdigit(d[i])))
        return PKSS_FORMAT_OFF;
    return PKSS_FORMAT_AUTO;
}

/* ============================================================= reading */

/* The prefix the parsers use in their messages. */
static const char *display_name(pkss_format f)
{
    switch (f) {
    case PKSS_FORMAT_PLY: return "PLY";
    case PKSS_FORMAT_PCD: return "PCD";
    case PKSS_FORMAT_XYZ: return "XYZ";
    case PKSS_FORMAT_OFF: return "OFF";
    case PKSS_FORMAT_KITTI: return "KITTI";
    case PKSS_FORMAT_VTK: return "VTK";
    case PKSS_FORMAT_NPY: return "NPY";
    case PKSS_FORMAT_NPZ: return "NPZ";
    default: return "?";
    }
}

static pkss_status parse(io_ctx *ctx, pkss_format fmt, double **xyz,
                            size_t *n)
{
    pkss_status st;
    /* A UTF-8 byte order mark is accepted before every text header alike
     * (KITTI, NPY and NPZ are binary from their first byte). */
    if (!io_format_is_binary(fmt) && ctx->size >= 3 &&
        memcmp(ctx->data, "\xEF\xBB\xBF", 3) == 0) {
        ctx->data += 3;
        ctx->size -= 3;
    }
    if (ctx->size == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "%s: the file is empty (0 bytes)",
                       display_name(fmt));
    switch (fmt) {
    case PKSS_FORMAT_PLY: st = io_read_ply(ctx, xyz, n); break;
    case PKSS_FORMAT_PCD: st = io_read_pcd(ctx, xyz, n); break;
    case PKSS_FORMAT_XYZ: st = io_read_xyz(ctx, xyz, n); break;
    case PKSS_FORMAT_OFF: st = io_read_off(ctx, xyz, n); break;
    case PKSS_FORMAT_KITTI: st = io_read_kitti(ctx, xyz, n); break;
    case PKSS_FORMAT_VTK: st = io_read_vtk(ctx, xyz, n); break;
    case PKSS_FORMAT_NPY: st = io_read_npy(ctx, xyz, n); break;
    case PKSS_FORMAT_NPZ: st = io_read_npz(ctx, xyz, n); break;
    default:
        return io_fail(ctx, PKSS_ERR_INVALID_ARGUMENT, "unknown format code %d",
                       (int)fmt);
    }
    if (st != PKSS_OK) {
        free(*xyz);
        *xyz = NULL;
        *n = 0;
    } else if (*n == 0) {
        free(*xyz);
        *xyz = NULL;
        st = io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "%s: the file holds no points",
                     display_name(fmt));
    }
    return st;
}

int io_format_is_binary(pkss_format f)
{
    return f == PKSS_FORMAT_KITTI || f == PKSS_FORMAT_NPY || f == PKSS_FORMAT_NPZ;
}

pkss_status pkss_read_points_buffer(const void *data, size_t size,
                                    pkss_format fmt, const char *array,
                                    double **xyz, size_t *n, char *err,
                                    size_t err_size)
{
    io_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.data = (const unsigned char *)data;
    ctx.size = size;
    ctx.err = err;
    ctx.err_size = err_size;
    ctx.array = array;
    if (err && err_size)
        err[0] = '\0';
    if (!xyz || !n)
        return io_fail(&ctx, PKSS_ERR_NULL_ARGUMENT, "xyz and n must not be NULL");
    *xyz = NULL;
    *n = 0;
    if (!data && size > 0)
        return io_fail(&ctx, PKSS_ERR_NULL_ARGUMENT, "data is NULL");
    if (fmt == PKSS_FORMAT_AUTO)
        fmt = pkss_format_from_content(data, size);
    if (fmt == PKSS_FORMAT_AUTO || pkss_format_name(fmt) == NULL)
        return io_fail(&ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "cannot tell the format: give one explicitly");
    if (array && fmt != PKSS_FORMAT_NPZ)
        return io_fail(&ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "an array name (\"%.64s\") only selects a member of an .npz, "
                       "not of a %s file", array, display_name(fmt));
    return parse(&ctx, fmt, xyz, n);
}

/* The first bytes, read and checked before the rest. */
#define IO_PREFIX 4096
/* Pipes, devices and standard input are read up to this many bytes; a
 * regular file up to its size (st_size), never more. */
#define IO_STREAM_CAP ((size_t)1 << 30)

/* First occurrence of w (wl bytes) in d[0..n). */
static const unsigned char *find_bytes(const unsigned char *d, size_t n,
                                       const char *w, size_t wl)
{
    for (size_t i = 0; i + wl <= n; ++i)
        if (d[i] == (unsigned char)w[0] && memcmp(d + i, w, wl) == 0)
            return d + i;
    return NULL;
}

/* 0 when the first bytes cannot begin a file of format fmt: a text format
 * with a NUL byte, or a header without its magic. Conservative: 1 when in
 * doubt (the parser decides). */
static int prefix_fits(pkss_format fmt, const unsigned char *d, size_t n)
{
    if (fmt == PKSS_FORMAT_NPY)
        return n < 6 ? memcmp(d, "\x93NUMPY", n) == 0 : starts_with(d, n, "\x93NUMPY");
    if (fmt == PKSS_FORMAT_NPZ)
        return n < 2 || starts_with(d, n, "PK");
    if (has_bom(d, n) && !io_format_is_binary(fmt)) {
        d += 3;
        n -= 3;
    }
    if (fmt == PKSS_FORMAT_KITTI || n == 0)
        return 1;
    if (fmt == PKSS_FORMAT_PLY)
        return n < 5 ? memcmp(d, "ply\n", n < 4 ? n : 4) == 0
                     : starts_with(d, n, "ply\n") || starts_with(d, n, "ply\r\n");
    if (fmt == PKSS_FORMAT_VTK)
        return n < 14 || starts_with(d, n, "# vtk DataFile");
    /* text formats: the header (PCD: up to its DATA line) has no NUL */
    const unsigned char *data = fmt == PKSS_FORMAT_PCD
        ? find_bytes(d, n, "\nDATA binary", 12) : NULL;
    size_t upto = data ? (size_t)(data - d) : n;
    return memchr(d, 0, upto) == NULL;
}

/* The state of one bounded read: the buffer so far, the most that may be
 * read (limit) and whether the prefix was checked. */
typedef struct io_reader {
    FILE *f;
    const char *path;
    char *err;
    size_t err_size;
    unsigned char *b;
    size_t cap, len, limit;
    int regular, checked;
} io_reader;

/* What read_bounded does once the prefix is checked. */
enum { RB_GO_ON, RB_STOP, RB_MAPPED };

/* Refuses a directory and a file too large for size_t; sets the limit
 * (regular: st_size, stream: IO_STREAM_CAP) and the first buffer. */
static pkss_status rb_start(io_reader *r)
{
    struct stat st;
    r->regular = fstat(fileno(r->f), &st) == 0 && S_ISREG(st.st_mode);
    if (fstat(fileno(r->f), &st) == 0 && S_ISDIR(st.st_mode)) {
        set_err(r->err, r->err_size, "%s: is a directory", r->path);
        return PKSS_ERR_IO;
    }
    if (r->regular && (uintmax_t)st.st_size >= (uintmax_t)SIZE_MAX) {
        set_err(r->err, r->err_size, "%s: file too large", r->path);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    r->limit = r->regular ? (size_t)st.st_size : IO_STREAM_CAP;
    r->cap = r->limit < IO_PREFIX ? r->limit + 1 : IO_PREFIX;
    r->len = 0;
    r->b = (unsigned char *)malloc(r->cap);
    if (!r->b) {
        set_err(r->err, r->err_size, "%s: out of memory", r->path);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    return PKSS_OK;
}

/* The prefix is in: resolves *fmt and stops when it cannot fit (the parser
 * then names what is wrong from these bytes). A regular file larger than
 * the prefix is then mapped (*action RB_MAPPED, with *buf and *size), else
 * given one block for all of it. */
static pkss_status rb_after_prefix(io_reader *r, pkss_format *fmt,
                                   unsigned char **buf, size_t *size,
                                   int *action)
{
    r->checked = 1;
    *action = RB_GO_ON;
    if (*fmt == PKSS_FORMAT_AUTO)
        *fmt = pkss_format_from_content(r->b, r->len);
    if (*fmt == PKSS_FORMAT_AUTO || !prefix_fits(*fmt, r->b, r->len)) {
        *action = RB_STOP;
        return PKSS_OK;
    }
    if (!r->regular || r->cap >= r->limit + 1)
        return PKSS_OK;
    /* Map a regular file rather than copy it: only the pages the parser
     * touches become resident, so a huge or sparse file whose header
     * declares a few points costs a few pages. A failed map falls back to
     * reading it whole. (Shrinking the file while it is read raises
     * SIGBUS.) */
    void *m = mmap(NULL, r->limit, PROT_READ, MAP_PRIVATE, fileno(r->f), 0);
    if (m != MAP_FAILED) {
        free(r->b);
        *buf = (unsigned char *)m;
        *size = r->limit;
        *action = RB_MAPPED;
        return PKSS_OK;
    }
    unsigned char *nb = (unsigned char *)realloc(r->b, r->limit + 1);
    if (!nb) {
        free(r->b);
        set_err(r->err, r->err_size, "%s: out of memory reading %zu bytes",
                r->path, r->limit);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    r->b = nb;
    r->cap = r->limit + 1;
    return PKSS_OK;
}

/* A full buffer doubles (a stream's size is not known), up to limit + 1. */
static pkss_status rb_make_room(io_reader *r)
{
    if (r->len != r->cap)
        return PKSS_OK;
    size_t grow = r->cap * 2 < r->limit + 1 ? r->cap * 2 : r->limit + 1;
    unsigned char *nb = (unsigned char *)realloc(r->b, grow);
    if (!nb) {
        free(r->b);
        set_err(r->err, r->err_size, "%s: out of memory after %zu bytes",
                r->path, r->len);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    r->b = nb;
    r->cap = grow;
    return PKSS_OK;
}

/* One fread, no further than the prefix until it is checked; *stop is set
 * at the end of the input once the prefix is checked. */
static pkss_status rb_read_some(io_reader *r, int *stop)
{
    size_t want = r->cap - r->len;
    if (!r->checked && r->len + want > IO_PREFIX)
        want = IO_PREFIX - r->len;
    size_t got = fread(r->b + r->len, 1, want, r->f);
    r->len += got;
    *stop = 0;
    if (got == 0) {
        if (ferror(r->f)) {
            int e = errno;
            free(r->b);
            set_err(r->err, r->err_size, "%s: read error: %s", r->path,
                    e ? strerror(e) : "unknown error");
            return PKSS_ERR_IO;
        }
        if (r->checked)
            *stop = 1;
    }
    return PKSS_OK;
}

/* Reads a file or stream whole, bounded: a regular file by its size, a
 * stream by IO_STREAM_CAP. The first IO_PREFIX bytes are checked against
 * the format first, so a wrong file (/dev/zero, a huge file of another
 * kind) is refused after reading them. *fmt is resolved from the content
 * when it is PKSS_FORMAT_AUTO. *buf is malloc'd, or mapped when *mapped is
 * set (a regular file larger than the prefix). */
static pkss_status read_bounded(FILE *f, const char *path,
                                   pkss_format *fmt, unsigned char **buf,
                                   size_t *size, int *mapped, char *err,
                                   size_t err_size)
{
    io_reader r;
    pkss_status rc;
    int stop = 0, action;
    memset(&r, 0, sizeof r);
    r.f = f;
    r.path = path;
    r.err = err;
    r.err_size = err_size;
    rc = rb_start(&r);
    while (rc == PKSS_OK && !stop) {
        if (!r.checked && (r.len >= IO_PREFIX || r.len == r.limit || feof(f))) {
            rc = rb_after_prefix(&r, fmt, buf, size, &action);
            if (rc != PKSS_OK)
                return rc;
            if (action == RB_MAPPED) {
                *mapped = 1;
                return PKSS_OK;
            }
            if (action == RB_STOP)
                break;
        }
        if (r.len == r.limit)
            break;
        rc = rb_make_room(&r);
        if (rc == PKSS_OK)
            rc = rb_read_some(&r, &stop);
    }
    if (rc != PKSS_OK)
        return rc;
    if (!r.regular && r.len == r.limit && fgetc(f) != EOF) {
        free(r.b);
        set_err(err, err_size,
                "%s: more than %zu bytes from a pipe or device (the limit for "
                "streams); read it from a regular file",
                path, (size_t)IO_STREAM_CAP);
        return PKSS_ERR_FORMAT;
    }
    *buf = r.b;
    *size = r.len;
    return PKSS_OK;
}

static void release(unsigned char *buf, size_t size, int mapped)
{
    if (mapped)
        munmap(buf, size);
    else
        free(buf);
}

/* "scan.npz:name" -> the file "scan.npz" and the member "name", unless a
 * file of the whole name exists. @return the file part (malloc'd) with
 * *member set, NULL with *member NULL when there is nothing to split, or
 * NULL with *member set to path itself when out of memory. */
static char *split_member(const char *path, const char **member)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *colon = strrchr(base, ':');
    struct stat st;
    char *file;
    *member = NULL;
    if (!colon || colon - base < 4 || !io_tok_eq(colon - 4, 4, ".npz") ||
        stat(path, &st) == 0)
        return NULL;
    file = (char *)malloc((size_t)(colon - path) + 1);
    if (!file) {
        *member = path;
        return NULL;
    }
    memcpy(file, path, (size_t)(colon - path));
    file[colon - path] = '\0';
    *member = colon + 1;
    return file;
}

pkss_status pkss_read_points(const char *path, pkss_format fmt,
                             double **xyz, size_t *n, char *err,
                             size_t err_size)
{
    int mapped = 0;
    FILE *f;
    unsigned char *buf = NULL;
    size_t size = 0;
    pkss_status st;
    char msg[1024];
    int is_stdin;
    io_ctx ctx;
    const char *member = NULL;
    char *file = NULL;

    if (err && err_size)
        err[0] = '\0';
    if (!xyz || !n || !path) {
        set_err(err, err_size, "path, xyz and n must not be NULL");
        return PKSS_ERR_NULL_ARGUMENT;
    }
    *xyz = NULL;
    *n = 0;
    if (pkss_format_name(fmt) == NULL) {
        set_err(err, err_size, "%s: unknown format code %d", path, (int)fmt);
        return PKSS_ERR_INVALID_ARGUMENT;
    }
    is_stdin = strcmp(path, "-") == 0;
    if (fmt == PKSS_FORMAT_AUTO)
        fmt = pkss_format_from_path(path);
    if (fmt == PKSS_FORMAT_NPZ && !is_stdin) {
        file = split_member(path, &member);
        if (!file && member) {
            set_err(err, err_size, "%s: out of memory", path);
            return PKSS_ERR_OUT_OF_MEMORY;
        }
    }

    errno = 0;
    f = is_stdin ? stdin : fopen(file ? file : path, "rb");
    if (!f) {
        set_err(err, err_size, "%s: cannot open: %s", file ? file : path,
                errno ? strerror(errno) : "unknown error");
        free(file);
        return PKSS_ERR_IO;
    }
    errno = 0;
    st = read_bounded(f, path, &fmt, &buf, &size, &mapped, err, err_size);
    if (!is_stdin)
        fclose(f);
    if (st != PKSS_OK) {
        free(file);
        return st;
    }

    if (fmt == PKSS_FORMAT_AUTO) { /* read_bounded looked at the content */
        release(buf, size, mapped);
        free(file);
        set_err(err, err_size,
                "%s: cannot tell the format from the extension or the "
                "content (known: .ply .pcd .xyz .txt .csv .pts .off .bin "
                ".vtk .npy .npz); name it explicitly",
                path);
        return PKSS_ERR_INVALID_ARGUMENT;
    }
    msg[0] = '\0';
    memset(&ctx, 0, sizeof ctx);
    ctx.data = buf;
    ctx.size = size;
    ctx.err = msg;
    ctx.err_size = sizeof msg;
    ctx.array = fmt == PKSS_FORMAT_NPZ ? member : NULL;
    st = parse(&ctx, fmt, xyz, n);
    release(buf, size, mapped);
    if (st != PKSS_OK)
        set_err(err, err_size, "%s: %s", path, msg);
    free(file);
    return st;
}

void pkss_points_free(double *xyz)
{
    free(xyz);
}
