/* SPDX-License-Identifier: MIT
 * io_npy.c -- NumPy .npy (format versions 1-3) and .npz (a zip of .npy
 * members, as np.savez writes it) readers.
 *
 * The .npy header is a Python dict literal; it is parsed by a small bounded
 * scanner (never eval'd), which accepts exactly the keys descr,
 * fortran_order and shape. A .npz is read from its central directory
 * (zip64 included, as np.savez forces zip64 member headers); members must
 * be stored: inflating would need a decompressor this library does not
 * carry, so a deflated member (np.savez_compressed) is refused by name.
 */
#include "io_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* numpy's reader refuses headers over 10000 bytes by default; 64 KB leaves
 * room for hand-written files and keeps the scan bounded. */
#define NPY_MAX_HEADER 65536u

static uint64_t le(const unsigned char *p, int nb)
{
    uint64_t v = 0;
    while (nb-- > 0)
        v = (v << 8) | p[nb];
    return v;
}

/* ------------------------------------------------------------ the header */

typedef struct npy_scan {
    const char *p, *end;
} npy_scan;

static void skip_ws(npy_scan *s)
{
    while (s->p < s->end && (*s->p == ' ' || *s->p == '\t' || *s->p == '\n' || *s->p == '\r'))
        s->p++;
}

/* A quoted string ('...' or "..."), no escapes (numpy writes none). */
static int scan_string(npy_scan *s, const char **str, size_t *len)
{
    char q;
    const char *b;
    skip_ws(s);
    if (s->p >= s->end || (*s->p != '\'' && *s->p != '"'))
        return -1;
    q = *s->p++;
    b = s->p;
    while (s->p < s->end && *s->p != q && *s->p != '\\')
        s->p++;
    if (s->p >= s->end || *s->p != q)
        return -1;
    *str = b;
    *len = (size_t)(s->p - b);
    s->p++;
    return 0;
}

static int scan_char(npy_scan *s, char c)
{
    skip_ws(s);
    if (s->p < s->end && *s->p == c) {
        s->p++;
        return 0;
    }
    return -1;
}

/* A word of letters/digits (True, False, an integer with an optional
 * Python 2 'L' suffix). */
static size_t scan_word(npy_scan *s, const char **w)
{
    const char *b;
    skip_ws(s);
    b = s->p;
    while (s->p < s->end && ((*s->p >= '0' && *s->p <= '9') || (*s->p >= 'a' && *s->p <= 'z') ||
                             (*s->p >= 'A' && *s->p <= 'Z') || *s->p == '+' || *s->p == '-'))
        s->p++;
    *w = b;
    return (size_t)(s->p - b);
}

typedef struct npy_header {
    io_type type;
    int big_endian;
    int fortran;
    uint64_t shape[2];
    int ndim;
} npy_header;

static pkss_status parse_descr(io_ctx *ctx, const char *d, size_t len, npy_header *h)
{
    char q[64];
    if (len == 3 && (d[0] == '<' || d[0] == '>' || d[0] == '=') && d[1] == 'f' &&
        (d[2] == '4' || d[2] == '8')) {
        h->type = d[2] == '4' ? IO_T_F32 : IO_T_F64;
        h->big_endian = d[0] == '>';
        if (d[0] == '=') { /* native order: that of this machine */
            const uint16_t one = 1;
            unsigned char b;
            memcpy(&b, &one, 1);
            h->big_endian = b != 1;
        }
        return PKSS_OK;
    }
    return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                   "NPY: dtype '%s' is not supported (float64 '<f8' or float32 '<f4' "
                   "only; convert with a.astype(np.float64))",
                   io_quote(d, len, q, sizeof q));
}

/* The value of 'descr': a quoted dtype string (a list is a structured
 * dtype, refused by name). */
static pkss_status npy_descr_value(io_ctx *ctx, npy_scan *s, npy_header *h)
{
    const char *d;
    size_t dl;
    if (s->p < s->end && *s->p == '[')
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "NPY: structured dtype (a list descr) is not supported; save "
                       "an (N, 3) float array");
    if (scan_string(s, &d, &dl) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: 'descr' is not a quoted string");
    return parse_descr(ctx, d, dl, h);
}

/* The value of 'fortran_order': True or False. */
static pkss_status npy_fortran_value(io_ctx *ctx, npy_scan *s, npy_header *h)
{
    const char *w;
    size_t wl = scan_word(s, &w);
    char q[64];
    if (io_tok_eq(w, wl, "True"))
        h->fortran = 1;
    else if (io_tok_eq(w, wl, "False"))
        h->fortran = 0;
    else
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: 'fortran_order' is '%s', not True or False",
                       io_quote(w, wl, q, sizeof q));
    return PKSS_OK;
}

/* The value of 'shape': a tuple of dimensions; the first two are kept and
 * ndim counts up to 64 (enough to name the wrong rank in a message). */
static pkss_status npy_shape_value(io_ctx *ctx, npy_scan *s, npy_header *h)
{
    const char *w;
    size_t wl;
    char q[64];
    if (scan_char(s, '(') != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: 'shape' is not a tuple");
    h->ndim = 0;
    for (;;) {
        uint64_t v;
        if (scan_char(s, ')') == 0)
            break;
        wl = scan_word(s, &w);
        if (wl > 0 && w[wl - 1] == 'L') /* Python 2 long */
            wl--;
        if (wl == 0 || io_parse_u64(w, wl, &v) != 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "NPY: 'shape' holds '%s', not a dimension",
                           io_quote(w, wl, q, sizeof q));
        if (h->ndim < 2)
            h->shape[h->ndim] = v;
        if (h->ndim < 64)
            h->ndim++;
        if (scan_char(s, ',') != 0) {
            if (scan_char(s, ')') != 0)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "NPY: 'shape': ',' or ')' expected");
            break;
        }
    }
    return PKSS_OK;
}

/* One "'key': value" entry; *seen collects the keys read (bits: 1 descr,
 * 2 fortran_order, 4 shape) so that none is given twice. */
static pkss_status npy_entry(io_ctx *ctx, npy_scan *s, const char *text, int *seen,
                             npy_header *h)
{
    const char *key;
    size_t klen;
    int bit;
    char q[64];
    if (scan_string(s, &key, &klen) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: header byte %llu: a quoted key or '}' expected",
                       (unsigned long long)(s->p - text));
    if (io_tok_eq(key, klen, "descr"))
        bit = 1;
    else if (io_tok_eq(key, klen, "fortran_order"))
        bit = 2;
    else if (io_tok_eq(key, klen, "shape"))
        bit = 4;
    else
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: unknown header key '%s'",
                       io_quote(key, klen, q, sizeof q));
    if (*seen & bit)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: header key '%s' given twice",
                       io_quote(key, klen, q, sizeof q));
    *seen |= bit;
    if (scan_char(s, ':') != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: ':' expected after '%s'",
                       io_quote(key, klen, q, sizeof q));
    skip_ws(s);
    if (bit == 1)
        return npy_descr_value(ctx, s, h);
    if (bit == 2)
        return npy_fortran_value(ctx, s, h);
    return npy_shape_value(ctx, s, h);
}

/* After the dict: all three keys, and a shape of (N, 3). */
static pkss_status npy_check_keys(io_ctx *ctx, int seen, const npy_header *h)
{
    if (seen != 7)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: the header lacks '%s'",
                       !(seen & 1) ? "descr" : !(seen & 2) ? "fortran_order" : "shape");
    if (h->ndim != 2 || h->shape[1] != 3) {
        if (h->ndim == 2)
            return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                           "NPY: shape (%llu, %llu): points must be an (N, 3) array",
                           (unsigned long long)h->shape[0], (unsigned long long)h->shape[1]);
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "NPY: a %d-dimensional array: points must be an (N, 3) array",
                       h->ndim);
    }
    return PKSS_OK;
}

/* Parses {'descr': '<f8', 'fortran_order': False, 'shape': (N, 3), }. */
static pkss_status parse_header(io_ctx *ctx, const char *text, size_t len, npy_header *h)
{
    npy_scan s = {text, text + len};
    int seen = 0;
    if (memchr(text, '\0', len))
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: the header holds a NUL byte");
    if (scan_char(&s, '{') != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: the header is not a dict ('{' expected)");
    for (;;) {
        pkss_status st;
        skip_ws(&s);
        if (scan_char(&s, '}') == 0)
            break;
        st = npy_entry(ctx, &s, text, &seen, h);
        if (st != PKSS_OK)
            return st;
        if (scan_char(&s, ',') != 0) {
            if (scan_char(&s, '}') != 0)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "NPY: header byte %llu: ',' or '}' expected",
                               (unsigned long long)(s.p - text));
            break;
        }
    }
    skip_ws(&s);
    if (s.p != s.end)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: text after the header dict");
    return npy_check_keys(ctx, seen, h);
}

pkss_status io_read_npy(io_ctx *ctx, double **xyz, size_t *n)
{
    const unsigned char *d = ctx->data;
    size_t size = ctx->size, start;
    uint64_t hlen, need, count;
    npy_header h;
    double *out;
    size_t item, i;
    int major;

    if (size < 6 || memcmp(d, "\x93NUMPY", 6) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPY: not a .npy file (no \\x93NUMPY magic)");
    if (size < 10)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: truncated at byte %llu: the preamble needs 10 bytes",
                       (unsigned long long)size);
    major = d[6];
    if (major < 1 || major > 3)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "NPY: format version %d.%d is not supported (1.0, 2.0, 3.0)", major,
                       d[7]);
    if (major == 1) {
        hlen = le(d + 8, 2);
        start = 10;
    } else {
        if (size < 12)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "NPY: truncated at byte %llu: the preamble needs 12 bytes",
                           (unsigned long long)size);
        hlen = le(d + 8, 4);
        start = 12;
    }
    if (hlen > NPY_MAX_HEADER)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: header of %llu bytes (at most %u are read)",
                       (unsigned long long)hlen, NPY_MAX_HEADER);
    if (hlen > size - start)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: truncated at byte %llu: expected a header of %llu bytes, got %llu",
                       (unsigned long long)size, (unsigned long long)hlen,
                       (unsigned long long)(size - start));
    memset(&h, 0, sizeof h);
    {
        pkss_status st = parse_header(ctx, (const char *)d + start, (size_t)hlen, &h);
        if (st != PKSS_OK)
            return st;
    }
    start += (size_t)hlen;
    item = io_type_size(h.type);
    count = h.shape[0];
    if (count == 0) {
        *n = 0;
        return PKSS_OK; /* parse() reports "holds no points" */
    }
    if (io_mul_u64(count, 3 * item, &need) != 0 || need > size - start)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: truncated at byte %llu: expected %llu points (%s), got %llu",
                       (unsigned long long)size, (unsigned long long)count,
                       item == 8 ? "float64" : "float32",
                       (unsigned long long)((size - start) / (3 * item)));
    if (need < size - start)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPY: %llu bytes after the %llu x 3 array",
                       (unsigned long long)(size - start - need), (unsigned long long)count);
    out = io_alloc_points(ctx, count);
    if (!out)
        return PKSS_ERR_OUT_OF_MEMORY;
    d += start;
    for (i = 0; i < (size_t)count; i++)
        for (int k = 0; k < 3; k++) {
            size_t at = h.fortran ? (size_t)k * (size_t)count + i : 3 * i + (size_t)k;
            out[3 * i + (size_t)k] = io_get_value(d + at * item, h.type, h.big_endian);
        }
    *xyz = out;
    *n = (size_t)count;
    return PKSS_OK;
}

/* ------------------------------------------------------------------ zip */

static uint32_t crc32_of(const unsigned char *p, size_t n)
{
    uint32_t table[256], c = 0xFFFFFFFFu;
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t v = i;
        for (int k = 0; k < 8; k++)
            v = (v & 1) ? 0xEDB88320u ^ (v >> 1) : v >> 1;
        table[i] = v;
    }
    for (size_t i = 0; i < n; i++)
        c = table[(c ^ p[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

typedef struct zip_entry {
    const char *name;
    size_t name_len;
    unsigned method, flags;
    uint32_t crc;
    uint64_t csize, usize, offset;
} zip_entry;

/* The zip64 extra field (id 1) replaces the 32-bit fields that are all ones,
 * in the order usize, csize, offset. */
static int zip64_extra(const unsigned char *x, size_t xlen, zip_entry *e)
{
    while (xlen >= 4) {
        unsigned id = (unsigned)le(x, 2);
        size_t len = (size_t)le(x + 2, 2), o = 4;
        if (len > xlen - 4)
            return -1;
        if (id == 1) {
            uint64_t *f[3] = {&e->usize, &e->csize, &e->offset};
            for (int k = 0; k < 3; k++)
                if (*f[k] == 0xFFFFFFFFu) {
                    if (o + 8 > 4 + len)
                        return -1;
                    *f[k] = le(x + o, 8);
                    o += 8;
                }
            return 0;
        }
        x += 4 + len;
        xlen -= 4 + len;
    }
    return 0;
}

/* Is the member name "array" or "array.npy"? */
static int name_is(const zip_entry *e, const char *array, size_t alen)
{
    return (e->name_len == alen && memcmp(e->name, array, alen) == 0) ||
           (e->name_len == alen + 4 && memcmp(e->name, array, alen) == 0 &&
            memcmp(e->name + alen, ".npy", 4) == 0);
}

/* The end-of-central-directory record: 22 bytes plus a comment of up to
 * 64 KB, whose length must reach the end of the file. */
static pkss_status npz_find_eocd(io_ctx *ctx, size_t *eocd)
{
    const unsigned char *d = ctx->data;
    size_t size = ctx->size, p, lo;
    if (size < 22)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPZ: truncated: %llu bytes cannot hold a zip directory",
                       (unsigned long long)size);
    lo = size > 22 + 65535 ? size - 22 - 65535 : 0;
    for (p = size - 22 + 1; p-- > lo;)
        if (memcmp(d + p, "PK\x05\x06", 4) == 0 && p + 22 + le(d + p + 20, 2) == size) {
            *eocd = p;
            return PKSS_OK;
        }
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "NPZ: no zip end-of-directory record (truncated, or not an .npz)");
}

/* The central directory's place and entry count (from the zip64 record
 * when the 32-bit fields are saturated), checked to fit before eocd. */
typedef struct npz_dir {
    uint64_t entries, cd_size, cd_off;
} npz_dir;

static pkss_status npz_directory(io_ctx *ctx, size_t eocd, npz_dir *dir)
{
    const unsigned char *d = ctx->data;
    dir->entries = le(d + eocd + 10, 2);
    dir->cd_size = le(d + eocd + 12, 4);
    dir->cd_off = le(d + eocd + 16, 4);
    if (dir->entries == 0xFFFF || dir->cd_size == 0xFFFFFFFFu || dir->cd_off == 0xFFFFFFFFu) {
        uint64_t z;
        if (eocd < 20 || memcmp(d + eocd - 20, "PK\x06\x07", 4) != 0)
            return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: zip64 locator missing");
        z = le(d + eocd - 20 + 8, 8);
        if (z > eocd - 20 || eocd - 20 - z < 56 || memcmp(d + z, "PK\x06\x06", 4) != 0)
            return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: bad zip64 end-of-directory record");
        dir->entries = le(d + z + 32, 8);
        dir->cd_size = le(d + z + 40, 8);
        dir->cd_off = le(d + z + 48, 8);
    }
    if (dir->cd_off > eocd || dir->cd_size > eocd - dir->cd_off ||
        dir->entries > dir->cd_size / 46) /* 46: the fixed part of an entry */
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPZ: the zip directory (%llu entries, %llu bytes at %llu) does not "
                       "fit the file",
                       (unsigned long long)dir->entries, (unsigned long long)dir->cd_size,
                       (unsigned long long)dir->cd_off);
    return PKSS_OK;
}

/* Directory entry k at *p (the directory ends at end); *p moves past it. */
static pkss_status npz_entry(io_ctx *ctx, size_t *p, size_t end, size_t k, zip_entry *e)
{
    const unsigned char *d = ctx->data;
    size_t nl, xl, cl, at = *p;
    if (end - at < 46 || memcmp(d + at, "PK\x01\x02", 4) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: zip directory entry %llu is damaged",
                       (unsigned long long)k);
    memset(e, 0, sizeof *e);
    e->flags = (unsigned)le(d + at + 8, 2);
    e->method = (unsigned)le(d + at + 10, 2);
    e->crc = (uint32_t)le(d + at + 16, 4);
    e->csize = le(d + at + 20, 4);
    e->usize = le(d + at + 24, 4);
    nl = (size_t)le(d + at + 28, 2);
    xl = (size_t)le(d + at + 30, 2);
    cl = (size_t)le(d + at + 32, 2);
    e->offset = le(d + at + 42, 4);
    if (end - at - 46 < nl + xl + cl)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: zip directory entry %llu is damaged",
                       (unsigned long long)k);
    e->name = (const char *)d + at + 46;
    e->name_len = nl;
    if (zip64_extra(d + at + 46 + nl, xl, e) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: bad zip64 field in entry %llu",
                       (unsigned long long)k);
    *p = at + 46 + nl + xl + cl;
    return PKSS_OK;
}

/* What the directory walk has seen: the members (their names listed for
 * messages, cut with "..."), the first one and the one picked so far. */
typedef struct npz_scan {
    zip_entry pick, first;
    size_t members, npick;
    int have; /* the member named by ctx->array was found */
    char names[256];
    size_t names_len;
} npz_scan;

/* Appends a member's name to the list shown in messages. */
static void npz_list_name(npz_scan *sc, const zip_entry *e)
{
    size_t nl = e->name_len;
    if (sc->names_len + nl + 3 < sizeof sc->names - 4) {
        snprintf(sc->names + sc->names_len, sizeof sc->names - sc->names_len, "%s%.*s",
                 sc->names_len ? ", " : "", (int)nl, e->name);
        /* a hostile name's control bytes must not reach a terminal */
        for (size_t k = sc->names_len; sc->names[k]; ++k)
            if ((unsigned char)sc->names[k] < 0x20 || (unsigned char)sc->names[k] == 0x7f)
                sc->names[k] = '?';
        sc->names_len = strlen(sc->names);
    } else if (sc->names_len < sizeof sc->names - 5) {
        memcpy(sc->names + sc->names_len, ", ...", 6);
        sc->names_len += 5;
    }
}

/* One member (not a directory): the one named by ctx->array, else
 * "points" (which wins over "xyz"), else "xyz". */
static void npz_note_member(const io_ctx *ctx, npz_scan *sc, const zip_entry *e)
{
    sc->members++;
    if (sc->members == 1)
        sc->first = *e;
    npz_list_name(sc, e);
    if (ctx->array) {
        if (!sc->have && name_is(e, ctx->array, strlen(ctx->array))) {
            sc->pick = *e;
            sc->have = 1;
        }
    } else if (name_is(e, "points", 6) || name_is(e, "xyz", 3)) {
        if (!sc->npick++ || name_is(e, "points", 6))
            sc->pick = *e; /* "points" wins over "xyz" */
    }
}

/* Walks the directory and settles sc->pick: the named member, else the
 * only one, else "points" / "xyz". */
static pkss_status npz_choose(io_ctx *ctx, const npz_dir *dir, npz_scan *sc)
{
    size_t p = (size_t)dir->cd_off, k, end = (size_t)(dir->cd_off + dir->cd_size);
    char q[64];
    for (k = 0; k < (size_t)dir->entries; k++) {
        zip_entry e;
        pkss_status st = npz_entry(ctx, &p, end, k, &e);
        if (st != PKSS_OK)
            return st;
        if (e.name_len == 0 || e.name[e.name_len - 1] == '/')
            continue; /* a directory */
        npz_note_member(ctx, sc, &e);
    }
    if (sc->members == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT, "NPZ: the archive holds no arrays");
    if (ctx->array && !sc->have)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: no array '%s' (members: %s)",
                       io_quote(ctx->array, strlen(ctx->array), q, sizeof q), sc->names);
    if (!ctx->array) {
        if (sc->members == 1)
            sc->pick = sc->first;
        else if (sc->npick == 0)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "NPZ: %llu arrays and none named 'points' or 'xyz' (members: %s); "
                           "name one as file.npz:NAME",
                           (unsigned long long)sc->members, sc->names);
    }
    return PKSS_OK;
}

/* The picked member's data: stored (not encrypted, not deflated), its
 * local header present, its bytes in the file and its CRC-32 right.
 * q is the member's quoted name; *at receives the data offset. */
static pkss_status npz_member_data(io_ctx *ctx, const zip_entry *pick, const char *q,
                                   size_t *at)
{
    const unsigned char *d = ctx->data;
    size_t size = ctx->size, p;
    if (pick->flags & 1)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT, "NPZ: member '%s' is encrypted", q);
    if (pick->method == 8)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "NPZ: member '%s' is deflate-compressed (np.savez_compressed), which "
                       "this reader does not inflate; save with np.savez, or np.save the "
                       "array as .npy", q);
    if (pick->method != 0)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "NPZ: member '%s' uses zip compression method %u (only stored, 0)", q,
                       pick->method);
    if (pick->csize != pick->usize)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPZ: stored member '%s' has sizes %llu and %llu", q,
                       (unsigned long long)pick->csize, (unsigned long long)pick->usize);
    if (size < 30 || pick->offset > size - 30 ||
        memcmp(d + pick->offset, "PK\x03\x04", 4) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPZ: member '%s': no local header at byte %llu", q,
                       (unsigned long long)pick->offset);
    p = (size_t)pick->offset + 30 + (size_t)le(d + pick->offset + 26, 2) +
        (size_t)le(d + pick->offset + 28, 2);
    if (p > size || pick->csize > size - p)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "NPZ: member '%s': truncated at byte %llu: expected %llu bytes of data",
                       q, (unsigned long long)size, (unsigned long long)pick->csize);
    if (crc32_of(d + p, (size_t)pick->csize) != pick->crc)
        return io_fail(ctx, PKSS_ERR_FORMAT, "NPZ: member '%s': CRC-32 mismatch (damaged)", q);
    *at = p;
    return PKSS_OK;
}

pkss_status io_read_npz(io_ctx *ctx, double **xyz, size_t *n)
{
    size_t eocd = 0, p = 0;
    npz_dir dir;
    npz_scan sc;
    char q[64], msg[1024];
    io_ctx sub;
    pkss_status st = npz_find_eocd(ctx, &eocd);

    memset(&sc, 0, sizeof sc);
    if (st == PKSS_OK)
        st = npz_directory(ctx, eocd, &dir);
    if (st == PKSS_OK)
        st = npz_choose(ctx, &dir, &sc);
    if (st != PKSS_OK)
        return st;
    io_quote(sc.pick.name, sc.pick.name_len, q, sizeof q);
    st = npz_member_data(ctx, &sc.pick, q, &p);
    if (st != PKSS_OK)
        return st;
    /* The member is a .npy; its own message is kept after the name. */
    sub = *ctx;
    sub.data = ctx->data + p;
    sub.size = (size_t)sc.pick.csize;
    sub.err = msg;
    sub.err_size = sizeof msg;
    sub.array = NULL;
    msg[0] = '\0';
    st = io_read_npy(&sub, xyz, n);
    if (st != PKSS_OK)
        return io_fail(ctx, st, "NPZ: member '%s': %s", q, msg);
    return PKSS_OK;
}
