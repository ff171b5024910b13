/* SPDX-License-Identifier: MIT
 * io_ply.c -- PLY reader (ascii, binary_little_endian, binary_big_endian).
 *
 * Reads x y z of the "vertex" element, of any scalar type. Every other
 * property and element (faces, range_grid, list properties), before or
 * after the vertex element, is skipped. Counts in the header are checked
 * against the bytes actually present before anything is allocated.
 */
#include "io_internal.h"

#include <stdlib.h>
#include <string.h>

#define PLY_MAX_ELEMENTS 1024
#define PLY_MAX_PROPS 4096

typedef struct ply_prop {
    io_type type;       /* scalar type, or item type of a list */
    io_type count_type; /* IO_T_INVALID for a scalar */
} ply_prop;

typedef struct ply_element {
    char name[48];
    uint64_t count;
    ply_prop *props;
    size_t n_props, cap_props;
    int ix, iy, iz;     /* indices of x, y, z, or -1 */
    int xyz_list;       /* one of x, y, z is a list property */
} ply_element;

typedef struct ply_header {
    int format;         /* 0 ascii, 1 binary LE, 2 binary BE */
    ply_element *el;
    size_t n_el, cap_el; /* elements used, allocated */
} ply_header;

static io_type ply_type(const char *t, size_t len)
{
    static const struct {
        const char *name;
        io_type type;
    } k[] = {
        {"char", IO_T_I8},     {"int8", IO_T_I8},     {"uchar", IO_T_U8},
        {"uint8", IO_T_U8},    {"short", IO_T_I16},   {"int16", IO_T_I16},
        {"ushort", IO_T_U16},  {"uint16", IO_T_U16},  {"int", IO_T_I32},
        {"int32", IO_T_I32},   {"uint", IO_T_U32},    {"uint32", IO_T_U32},
        {"float", IO_T_F32},   {"float32", IO_T_F32}, {"double", IO_T_F64},
        {"float64", IO_T_F64}, {"int64", IO_T_I64},   {"uint64", IO_T_U64},
    };
    size_t i;
    for (i = 0; i < sizeof k / sizeof k[0]; i++)
        if (len == strlen(k[i].name) && memcmp(t, k[i].name, len) == 0)
            return k[i].type;
    return IO_T_INVALID;
}

static void ply_free(ply_header *h)
{
    size_t i;
    for (i = 0; i < h->n_el; i++)
        free(h->el[i].props);
    free(h->el);
    h->el = NULL;
    h->n_el = 0;
}

#define MAX_TOK 8

/* One header line split into its first MAX_TOK tokens. */
typedef struct ply_line {
    const char *tok[MAX_TOK];
    size_t tlen[MAX_TOK], nt, line_no;
} ply_line;

/* "format ascii|binary_little_endian|binary_big_endian VERSION" */
static pkss_status ply_format_line(io_ctx *ctx, ply_header *h,
                                   const ply_line *L)
{
    char q[64];
    if (L->nt < 2)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: 'format' without a value",
                       (unsigned long)L->line_no);
    if (io_tok_eq(L->tok[1], L->tlen[1], "ascii"))
        h->format = 0;
    else if (io_tok_eq(L->tok[1], L->tlen[1], "binary_little_endian"))
        h->format = 1;
    else if (io_tok_eq(L->tok[1], L->tlen[1], "binary_big_endian"))
        h->format = 2;
    else
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: unknown format '%s' "
                       "(ascii, binary_little_endian or "
                       "binary_big_endian)",
                       (unsigned long)L->line_no,
                       io_quote(L->tok[1], L->tlen[1], q, sizeof q));
    return PKSS_OK;
}

/* The COUNT of "element NAME COUNT", with a message for each way it can be
 * wrong (negative, past 64 bits, not a number). */
static pkss_status ply_element_count(io_ctx *ctx, const ply_line *L,
                                     uint64_t *cnt)
{
    char q[64], q2[64];
    int r;
    if (L->nt != 3)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: expected 'element NAME "
                       "COUNT'",
                       (unsigned long)L->line_no);
    r = io_parse_u64(L->tok[2], L->tlen[2], cnt);
    if (r == -2)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: negative count %s for "
                       "element '%s'",
                       (unsigned long)L->line_no,
                       io_quote(L->tok[2], L->tlen[2], q, sizeof q),
                       io_quote(L->tok[1], L->tlen[1], q2, sizeof q2));
    if (r == -3)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: element count %s "
                       "overflows 64 bits",
                       (unsigned long)L->line_no,
                       io_quote(L->tok[2], L->tlen[2], q, sizeof q));
    if (r != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: element count '%s' is "
                       "not an integer",
                       (unsigned long)L->line_no,
                       io_quote(L->tok[2], L->tlen[2], q, sizeof q));
    return PKSS_OK;
}

/* "element NAME COUNT": appends an element without properties. */
static pkss_status ply_element_line(io_ctx *ctx, ply_header *h,
                                    const ply_line *L)
{
    ply_element *el;
    uint64_t cnt;
    pkss_status st = ply_element_count(ctx, L, &cnt);
    if (st != PKSS_OK)
        return st;
    if (h->n_el >= PLY_MAX_ELEMENTS)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "PLY: more than %d elements", PLY_MAX_ELEMENTS);
    if (h->n_el == h->cap_el) {
        size_t nc = h->cap_el ? 2 * h->cap_el : 4;
        ply_element *ne = (ply_element *)realloc(h->el, nc * sizeof *ne);
        if (!ne)
            return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                           "PLY: out of memory in the header");
        h->el = ne;
        h->cap_el = nc;
    }
    el = &h->el[h->n_el++];
    memset(el, 0, sizeof *el);
    io_quote(L->tok[1], L->tlen[1], el->name, sizeof el->name);
    el->count = cnt;
    el->ix = el->iy = el->iz = -1;
    return PKSS_OK;
}

/* The types and the name of "property list COUNT_TYPE ITEM_TYPE NAME" or
 * "property TYPE NAME". */
static pkss_status ply_prop_types(io_ctx *ctx, const ply_line *L,
                                  ply_prop *p, const char **name,
                                  size_t *nlen)
{
    char q[64];
    if (L->nt >= 2 && io_tok_eq(L->tok[1], L->tlen[1], "list")) {
        if (L->nt != 5)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PLY: header line %lu: expected 'property "
                           "list COUNT_TYPE ITEM_TYPE NAME'",
                           (unsigned long)L->line_no);
        p->count_type = ply_type(L->tok[2], L->tlen[2]);
        p->type = ply_type(L->tok[3], L->tlen[3]);
        if (p->count_type == IO_T_INVALID || p->type == IO_T_INVALID)
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PLY: header line %lu: unknown type '%s'",
                           (unsigned long)L->line_no,
                           p->count_type == IO_T_INVALID
                               ? io_quote(L->tok[2], L->tlen[2], q, sizeof q)
                               : io_quote(L->tok[3], L->tlen[3], q, sizeof q));
        if (!io_type_is_integer(p->count_type))
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PLY: header line %lu: list count type "
                           "must be an integer type",
                           (unsigned long)L->line_no);
        *name = L->tok[4];
        *nlen = L->tlen[4];
        return PKSS_OK;
    }
    if (L->nt != 3)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: expected 'property "
                       "TYPE NAME'",
                       (unsigned long)L->line_no);
    p->count_type = IO_T_INVALID;
    p->type = ply_type(L->tok[1], L->tlen[1]);
    if (p->type == IO_T_INVALID)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: unknown property "
                       "type '%s'",
                       (unsigned long)L->line_no,
                       io_quote(L->tok[1], L->tlen[1], q, sizeof q));
    *name = L->tok[2];
    *nlen = L->tlen[2];
    return PKSS_OK;
}

/* Records property number el->n_props as x, y or z; a second one of the
 * same name is refused (which would be read is a guess). */
static pkss_status ply_xyz_slot(io_ctx *ctx, ply_element *el,
                                const ply_prop *p, const char *name,
                                size_t nlen, size_t line_no)
{
    int *slot;
    if (nlen != 1 || (name[0] != 'x' && name[0] != 'y' && name[0] != 'z'))
        return PKSS_OK;
    slot = name[0] == 'x' ? &el->ix : name[0] == 'y' ? &el->iy : &el->iz;
    if (*slot >= 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: element '%s' has a "
                       "second property '%c'",
                       (unsigned long)line_no, el->name, name[0]);
    *slot = (int)el->n_props;
    if (p->count_type != IO_T_INVALID)
        el->xyz_list = 1;
    return PKSS_OK;
}

/* "property ...": appends a property to the last element. */
static pkss_status ply_property_line(io_ctx *ctx, ply_header *h,
                                     const ply_line *L)
{
    ply_element *el;
    ply_prop p;
    const char *name = NULL;
    size_t nlen = 0;
    pkss_status st;
    if (h->n_el == 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header line %lu: 'property' before any "
                       "'element'",
                       (unsigned long)L->line_no);
    el = &h->el[h->n_el - 1];
    st = ply_prop_types(ctx, L, &p, &name, &nlen);
    if (st != PKSS_OK)
        return st;
    if (el->n_props >= PLY_MAX_PROPS)
        return io_fail(ctx, PKSS_ERR_UNSUPPORTED_FORMAT,
                       "PLY: more than %d properties in element '%s'",
                       PLY_MAX_PROPS, el->name);
    if (el->n_props == el->cap_props) {
        size_t nc = el->cap_props ? 2 * el->cap_props : 8;
        ply_prop *np = (ply_prop *)realloc(el->props, nc * sizeof *np);
        if (!np)
            return io_fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                           "PLY: out of memory in the header");
        el->props = np;
        el->cap_props = nc;
    }
    st = ply_xyz_slot(ctx, el, &p, name, nlen, L->line_no);
    if (st != PKSS_OK)
        return st;
    el->props[el->n_props++] = p;
    return PKSS_OK;
}

/* Parses the header; *data_start receives the offset of the first data
 * byte. */
static pkss_status ply_parse_header(io_ctx *ctx, ply_header *h,
                                       size_t *data_start)
{
    io_cursor c;
    const char *line;
    size_t len;
    ply_line L;
    int have_format = 0;
    char q[64];

    h->format = -1;
    h->el = NULL;
    h->n_el = 0;
    h->cap_el = 0;
    io_cursor_init(&c, ctx->data, ctx->size);
    if (!io_next_line(&c, &line, &len, &L.line_no) || len != 3 ||
        memcmp(line, "ply", 3) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: not a PLY file (the first line is not 'ply')");

    while (io_next_line(&c, &line, &len, &L.line_no)) {
        const char *s = line, *e = line + len;
        pkss_status st;
        L.nt = 0;
        while (L.nt < MAX_TOK &&
               io_line_token(&s, e, 0, &L.tok[L.nt], &L.tlen[L.nt]))
            L.nt++;
        if (L.nt == 0)
            continue; /* blank line: tolerated */
        if (io_tok_eq(L.tok[0], L.tlen[0], "comment") ||
            io_tok_eq(L.tok[0], L.tlen[0], "obj_info"))
            continue;
        if (io_tok_eq(L.tok[0], L.tlen[0], "end_header")) {
            if (!have_format)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PLY: the header has no 'format' line");
            *data_start = (size_t)(c.p - (const char *)ctx->data);
            return PKSS_OK;
        }
        if (io_tok_eq(L.tok[0], L.tlen[0], "format")) {
            st = ply_format_line(ctx, h, &L);
            have_format = 1;
        } else if (io_tok_eq(L.tok[0], L.tlen[0], "element")) {
            st = ply_element_line(ctx, h, &L);
        } else if (io_tok_eq(L.tok[0], L.tlen[0], "property")) {
            st = ply_property_line(ctx, h, &L);
        } else {
            return io_fail(ctx, PKSS_ERR_FORMAT,
                           "PLY: header line %lu: unknown keyword '%s'",
                           (unsigned long)L.line_no,
                           io_quote(L.tok[0], L.tlen[0], q, sizeof q));
        }
        if (st != PKSS_OK)
            return st;
    }
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PLY: the header has no 'end_header' line (file ends at "
                   "line %lu)",
                   (unsigned long)c.line);
}

/* Smallest number of bytes one row of el takes (binary: scalars + list
 * counts; ascii: one digit and one separator per scalar or count). */
static uint64_t row_min_bytes(const ply_element *el, int ascii)
{
    uint64_t b = 0;
    size_t i;
    for (i = 0; i < el->n_props; i++) {
        const ply_prop *p = &el->props[i];
        if (ascii)
            b += 2;
        else
            b += io_type_size(p->count_type != IO_T_INVALID ? p->count_type
                                                            : p->type);
    }
    return b;
}

static int row_is_fixed(const ply_element *el)
{
    size_t i;
    for (i = 0; i < el->n_props; i++)
        if (el->props[i].count_type != IO_T_INVALID)
            return 0;
    return 1;
}

/* ------------------------------------------------------------- binary */

static pkss_status skip_binary(io_ctx *ctx, const ply_element *el,
                                  int be, size_t *pos)
{
    const size_t size = ctx->size;
    uint64_t r, rmin = row_min_bytes(el, 0), need;
    size_t i;
    if (el->n_props == 0 || el->count == 0)
        return PKSS_OK;
    if (io_mul_u64(el->count, rmin, &need) != 0 || need > size - *pos)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: header says %llu '%s' elements (at least %llu "
                       "bytes each) but only %llu bytes are left at offset "
                       "%llu",
                       (unsigned long long)el->count, el->name,
                       (unsigned long long)rmin,
                       (unsigned long long)(size - *pos),
                       (unsigned long long)*pos);
    if (row_is_fixed(el)) {
        *pos += (size_t)need;
        return PKSS_OK;
    }
    for (r = 0; r < el->count; r++) {
        for (i = 0; i < el->n_props; i++) {
            const ply_prop *p = &el->props[i];
            size_t ts = io_type_size(p->type);
            if (p->count_type == IO_T_INVALID) {
                if (size - *pos < ts)
                    goto truncated;
                *pos += ts;
            } else {
                size_t cs = io_type_size(p->count_type);
                uint64_t k, kb;
                if (size - *pos < cs)
                    goto truncated;
                if (io_get_count(ctx->data + *pos, p->count_type, be, &k) != 0)
                    return io_fail(ctx, PKSS_ERR_FORMAT,
                                   "PLY: negative list length in element "
                                   "'%s' row %llu (offset %llu)",
                                   el->name, (unsigned long long)r,
                                   (unsigned long long)*pos);
                *pos += cs;
                if (io_mul_u64(k, ts, &kb) != 0 || kb > size - *pos)
                    return io_fail(ctx, PKSS_ERR_FORMAT,
                                   "PLY: list of %llu items in element '%s' "
                                   "row %llu runs past the end of the file",
                                   (unsigned long long)k, el->name,
                                   (unsigned long long)r);
                *pos += (size_t)kb;
            }
        }
    }
    return PKSS_OK;
truncated:
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PLY: truncated at byte %llu: expected %llu '%s' rows, "
                   "got %llu",
                   (unsigned long long)ctx->size,
                   (unsigned long long)el->count, el->name,
                   (unsigned long long)r);
}

/* One coordinate; doubles in the host's byte order are copied as they are
 * (the common case, and the one that matters for huge files). */
static inline double get_coordinate(const unsigned char *p, io_type t, int be)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (t == IO_T_F64 && !be) {
        double d;
        memcpy(&d, p, sizeof d);
        return d;
    }
#endif
    return io_get_value(p, t, be);
}

/* Rows of scalars only, all present: x, y and z sit at fixed offsets. */
static void read_fixed_vertices(const ply_element *el, int be,
                                const unsigned char *row, double *out)
{
    const int axis[3] = {el->ix, el->iy, el->iz};
    size_t off[3] = {0, 0, 0}, stride = 0;
    io_type type[3] = {IO_T_F64, IO_T_F64, IO_T_F64};
    for (size_t i = 0; i < el->n_props; i++) {
        for (int d = 0; d < 3; d++)
            if ((int)i == axis[d]) {
                off[d] = stride;
                type[d] = el->props[i].type;
            }
        stride += io_type_size(el->props[i].type);
    }
    for (uint64_t r = 0; r < el->count; r++, row += stride)
        for (int d = 0; d < 3; d++)
            out[3 * r + d] = get_coordinate(row + off[d], type[d], be);
}

static pkss_status read_binary_vertices(io_ctx *ctx,
                                           const ply_element *el, int be,
                                           size_t pos, double *out)
{
    const size_t size = ctx->size;
    uint64_t r, need;
    size_t i;
    if (row_is_fixed(el) &&
        io_mul_u64(el->count, row_min_bytes(el, 0), &need) == 0 &&
        need <= size - pos) {
        read_fixed_vertices(el, be, ctx->data + pos, out);
        return PKSS_OK;
    }
    for (r = 0; r < el->count; r++) {
        for (i = 0; i < el->n_props; i++) {
            const ply_prop *p = &el->props[i];
            size_t ts = io_type_size(p->type);
            if (p->count_type == IO_T_INVALID) {
                if (size - pos < ts)
                    goto truncated;
                if ((int)i == el->ix)
                    out[3 * r] = io_get_value(ctx->data + pos, p->type, be);
                else if ((int)i == el->iy)
                    out[3 * r + 1] = io_get_value(ctx->data + pos, p->type, be);
                else if ((int)i == el->iz)
                    out[3 * r + 2] = io_get_value(ctx->data + pos, p->type, be);
                pos += ts;
            } else {
                size_t cs = io_type_size(p->count_type);
                uint64_t k, kb;
                if (size - pos < cs)
                    goto truncated;
                if (io_get_count(ctx->data + pos, p->count_type, be, &k) != 0)
                    return io_fail(ctx, PKSS_ERR_FORMAT,
                                   "PLY: negative list length in vertex %llu",
                                   (unsigned long long)r);
                pos += cs;
                if (io_mul_u64(k, ts, &kb) != 0 || kb > size - pos)
                    goto truncated;
                pos += (size_t)kb;
            }
        }
    }
    return PKSS_OK;
truncated:
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PLY: truncated at byte %llu: expected %llu vertices, got "
                   "%llu",
                   (unsigned long long)ctx->size,
                   (unsigned long long)el->count, (unsigned long long)r);
}

/* -------------------------------------------------------------- ascii */

static pkss_status ascii_end(io_ctx *ctx, const ply_element *el,
                                uint64_t r, const io_cursor *c)
{
    return io_fail(ctx, PKSS_ERR_FORMAT,
                   "PLY: truncated at byte %llu (line %lu): expected %llu "
                   "'%s' rows, got %llu",
                   (unsigned long long)ctx->size, (unsigned long)c->line,
                   (unsigned long long)el->count, el->name,
                   (unsigned long long)r);
}

static pkss_status ascii_list_len(io_ctx *ctx, const ply_element *el,
                                     uint64_t r, io_cursor *c, uint64_t *k)
{
    const char *t;
    size_t tl;
    char q[64];
    if (!io_next_token(c, &t, &tl))
        return ascii_end(ctx, el, r, c);
    if (io_parse_u64(t, tl, k) != 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: line %lu: list length '%s' in element '%s' is "
                       "not a non-negative integer",
                       (unsigned long)c->line, io_quote(t, tl, q, sizeof q),
                       el->name);
    return PKSS_OK;
}

static pkss_status ascii_rows(io_ctx *ctx, const ply_element *el,
                                 io_cursor *c, double *out)
{
    uint64_t r, j, k;
    size_t i;
    const char *t;
    size_t tl;
    char q[64];
    pkss_status st;
    if (el->n_props == 0)
        return PKSS_OK;
    for (r = 0; r < el->count; r++) {
        for (i = 0; i < el->n_props; i++) {
            const ply_prop *p = &el->props[i];
            if (p->count_type != IO_T_INVALID) {
                st = ascii_list_len(ctx, el, r, c, &k);
                if (st != PKSS_OK)
                    return st;
                for (j = 0; j < k; j++)
                    if (!io_next_token(c, &t, &tl))
                        return ascii_end(ctx, el, r, c);
                continue;
            }
            if (!io_next_token(c, &t, &tl))
                return ascii_end(ctx, el, r, c);
            if (out && ((int)i == el->ix || (int)i == el->iy ||
                        (int)i == el->iz)) {
                double v;
                int axis = (int)i == el->ix ? 0 : (int)i == el->iy ? 1 : 2;
                if (io_parse_double(t, tl, &v) != 0)
                    return io_fail(ctx, PKSS_ERR_FORMAT,
                                   "PLY: line %lu: vertex %llu: '%s' is not "
                                   "a number",
                                   (unsigned long)c->line,
                                   (unsigned long long)r,
                                   io_quote(t, tl, q, sizeof q));
                out[3 * r + axis] = v;
            }
        }
    }
    return PKSS_OK;
}

/* --------------------------------------------------------------- main */

/* The one 'vertex' element, with scalar x, y, z and at least one row. */
static pkss_status ply_find_vertex(io_ctx *ctx, const ply_header *h,
                                   size_t *vi)
{
    const ply_element *v = NULL;
    size_t e;
    for (e = 0; e < h->n_el; e++)
        if (strcmp(h->el[e].name, "vertex") == 0) {
            if (v)
                return io_fail(ctx, PKSS_ERR_FORMAT,
                               "PLY: the header declares a second 'vertex' element");
            v = &h->el[e];
            *vi = e;
        }
    if (!v)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: the header declares no 'vertex' element");
    if (v->ix < 0 || v->iy < 0 || v->iz < 0)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: element 'vertex' lacks property '%s'",
                       v->ix < 0 ? "x" : v->iy < 0 ? "y" : "z");
    if (v->xyz_list)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: vertex x, y and z must be scalar properties, not "
                       "lists");
    if (v->count == 0)
        return io_fail(ctx, PKSS_ERR_EMPTY_INPUT,
                       "PLY: the header declares 0 vertices");
    return PKSS_OK;
}

/* Where the data is being read: the ascii cursor, or the binary offset. */
typedef struct ply_data {
    io_cursor c;
    size_t pos;
    int ascii, be;
} ply_data;

/* Skips the elements before the vertex element; d->pos then points at the
 * vertex data in both encodings. */
static pkss_status ply_skip_before(io_ctx *ctx, const ply_header *h,
                                   size_t vi, ply_data *d)
{
    size_t e;
    for (e = 0; e < vi; e++) {
        pkss_status st = d->ascii ? ascii_rows(ctx, &h->el[e], &d->c, NULL)
                                  : skip_binary(ctx, &h->el[e], d->be, &d->pos);
        if (st != PKSS_OK)
            return st;
    }
    if (d->ascii)
        d->pos = (size_t)(d->c.p - (const char *)ctx->data);
    return PKSS_OK;
}

/* Checks the declared vertex count against the bytes left, before the
 * allocation; *need receives the smallest size of the vertex rows. */
static pkss_status ply_check_room(io_ctx *ctx, const ply_element *v,
                                  const ply_data *d, uint64_t *need)
{
    uint64_t left = ctx->size - d->pos, rmin = row_min_bytes(v, d->ascii);
    if (io_mul_u64(v->count, rmin, need) != 0 ||
        *need > left + (d->ascii ? 1 : 0))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: truncated at byte %llu: expected %llu vertices "
                       "(%s%llu bytes each), got %llu bytes of vertex data "
                       "(%s%llu vertices)",
                       (unsigned long long)ctx->size,
                       (unsigned long long)v->count,
                       d->ascii ? "at least " : "", (unsigned long long)rmin,
                       (unsigned long long)left, d->ascii ? "at most " : "",
                       (unsigned long long)(left / rmin));
    return PKSS_OK;
}

/* Rows past the declared count (vertex the last element; ascii: any
 * token, binary with fixed rows: any byte) mean the header and the data
 * disagree: refuse rather than guess. */
static pkss_status ply_check_trailing(io_ctx *ctx, const ply_header *h,
                                      size_t vi, ply_data *d, uint64_t need)
{
    const ply_element *v = &h->el[vi];
    uint64_t left = ctx->size - d->pos;
    const char *tok;
    size_t tlen;
    if (vi + 1 != h->n_el)
        return PKSS_OK;
    if (d->ascii && io_next_token(&d->c, &tok, &tlen))
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: data after the %llu vertices the header declares "
                       "(byte %llu)",
                       (unsigned long long)v->count,
                       (unsigned long long)(tok - (const char *)ctx->data));
    if (!d->ascii && row_is_fixed(v) && need < left)
        return io_fail(ctx, PKSS_ERR_FORMAT,
                       "PLY: data after the %llu vertices the header declares "
                       "(byte %llu, %llu bytes more)",
                       (unsigned long long)v->count,
                       (unsigned long long)(d->pos + need),
                       (unsigned long long)(left - need));
    return PKSS_OK;
}

/* Reads the vertex rows into a new array *out (freed by the caller). */
static pkss_status ply_read_vertices(io_ctx *ctx, const ply_header *h,
                                     size_t vi, ply_data *d, double **out)
{
    const ply_element *v = &h->el[vi];
    uint64_t need = 0;
    pkss_status st = ply_check_room(ctx, v, d, &need);
    if (st != PKSS_OK)
        return st;
    *out = io_alloc_points(ctx, v->count);
    if (!*out)
        return PKSS_ERR_OUT_OF_MEMORY;
    st = d->ascii ? ascii_rows(ctx, v, &d->c, *out)
                  : read_binary_vertices(ctx, v, d->be, d->pos, *out);
    if (st != PKSS_OK)
        return st;
    return ply_check_trailing(ctx, h, vi, d, need);
}

pkss_status io_read_ply(io_ctx *ctx, double **xyz, size_t *n)
{
    ply_header h;
    ply_data d;
    size_t vi = 0;
    double *out = NULL;
    pkss_status st;

    d.pos = 0;
    st = ply_parse_header(ctx, &h, &d.pos);
    if (st == PKSS_OK)
        st = ply_find_vertex(ctx, &h, &vi);
    if (st == PKSS_OK) {
        d.ascii = h.format == 0;
        d.be = h.format == 2;
        io_cursor_init(&d.c, ctx->data, ctx->size);
        d.c.p += d.pos;
        st = ply_skip_before(ctx, &h, vi, &d);
    }
    if (st == PKSS_OK)
        st = ply_read_vertices(ctx, &h, vi, &d, &out);
    if (st == PKSS_OK) {
        *xyz = out;
        *n = (size_t)h.el[vi].count;
    } else {
        free(out);
    }
    ply_free(&h);
    return st;
}
