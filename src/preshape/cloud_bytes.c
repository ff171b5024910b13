/* SPDX-License-Identifier: MIT
 * cloud_bytes.c -- a prepared cloud to bytes and back (pkss.h, Batches).
 *
 * Layout, little-endian throughout (offsets in bytes):
 *    0  magic "PKSSCLD\0"            8  format version (u32)
 *   12  byte order (u32, 1 = LE)    16  library version number (u32)
 *   20  header size (u32)           24  total size (u64)
 *   32  FNV-1a 64 of every other byte (0..31, then 40..end)
 *   40  preparation parameters (56 bytes)
 *   96  payload: counts, sizes, frame and spacing scalars, then the arrays
 *       pre (3m f64), normal (3m f64), dense (3 m_dense f64), normal_dense
 *       (3 m_dense f64) and feat (n_feat u32).
 * The kd-trees are rebuilt from pre and dense on load: pkss__kdtree_build is
 * a pure function of its points, so the restored trees answer alike.
 */
#include "pkss_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define CB_MAGIC "PKSSCLD"
#define CB_FORMAT 2u
#define CB_LITTLE_ENDIAN 1u
#define CB_PARAMS_SIZE 56u
#define CB_HEADER_SIZE (40u + CB_PARAMS_SIZE)
#define CB_SCALARS (3 + 1 + 9 + 3 + 1 + 1 + 1 + 2) /* centroid .. validate_seconds */
#define CB_PAYLOAD_FIXED (8 * 8 + 4 * 8 + CB_SCALARS * 8)

/* ---------------------------------------------------- little-endian I/O */
typedef struct writer {
    unsigned char *p;
} writer;

static void put_u32(writer *w, uint32_t v)
{
    for (int i = 0; i < 4; ++i)
        *w->p++ = (unsigned char)(v >> (8 * i));
}

static void put_u64(writer *w, uint64_t v)
{
    for (int i = 0; i < 8; ++i)
        *w->p++ = (unsigned char)(v >> (8 * i));
}

static void put_f64(writer *w, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    put_u64(w, v);
}

/* The reader never passes `end`: callers check the room first. */
typedef struct reader {
    const unsigned char *p, *end;
} reader;

static uint32_t get_u32(reader *r)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i)
        v |= (uint32_t)r->p[i] << (8 * i);
    r->p += 4;
    return v;
}

static uint64_t get_u64(reader *r)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
        v |= (uint64_t)r->p[i] << (8 * i);
    r->p += 8;
    return v;
}

static double get_f64(reader *r)
{
    uint64_t v = get_u64(r);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

static uint64_t fnv1a64(uint64_t h, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

/* The checksum of a whole serialised cloud: all bytes but its own field. */
static uint64_t checksum(const unsigned char *b, size_t total)
{
    return fnv1a64(fnv1a64(0xcbf29ce484222325ull, b, 32), b + 40, total - 40);
}

/* ------------------------------------------------ preparation parameters */
/* Every parameter pkss__cloud_build reads (use_features only for
 * counts.features). Written as 9 fields in CB_PARAMS_SIZE bytes. */
static void put_params(writer *w, const pkss__params *p)
{
    put_u32(w, (uint32_t)p->points);
    put_u32(w, (uint32_t)p->cull_mutual);
    put_u32(w, (uint32_t)p->cull_stat);
    put_u32(w, (uint32_t)p->use_features);
    put_u32(w, (uint32_t)p->drop_nonfinite);
    put_u32(w, (uint32_t)p->min_points);
    put_f64(w, p->feature_frac);
    put_u64(w, (uint64_t)p->seed);
    put_u64(w, (uint64_t)p->max_raw_points);
    put_u64(w, 0); /* reserved */
}

/* Names the first preparation parameter that differs from ctx's. */
static pkss_status check_params(pkss_context *ctx, reader *r)
{
    const pkss__params *p = &ctx->params;
    static const char *const names[6] = {"points",         "cull_mutual",
                                         "cull_stat",      "use_features",
                                         "drop_nonfinite", "min_points"};
    const int have[6] = {p->points,       p->cull_mutual,    p->cull_stat,
                         p->use_features, p->drop_nonfinite, p->min_points};
    for (int i = 0; i < 6; ++i) {
        uint32_t v = get_u32(r);
        PKSS_RETURN_IF(v != (uint32_t)have[i], ctx, PKSS_ERR_STALE_DATA,
                       "serialised cloud was prepared with %s = %lu, this "
                       "context has %d: prepare it again or set %s",
                       names[i], (unsigned long)v, have[i], names[i]);
    }
    double frac = get_f64(r);
    long long seed = (long long)get_u64(r);
    long long max_raw = (long long)get_u64(r);
    uint64_t reserved = get_u64(r);
    PKSS_RETURN_IF(reserved != 0, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: reserved header field is %llu, not 0",
                   (unsigned long long)reserved);
    PKSS_RETURN_IF(memcmp(&frac, &p->feature_frac, sizeof frac) != 0, ctx,
                   PKSS_ERR_STALE_DATA,
                   "serialised cloud was prepared with feature_frac = %.17g, "
                   "this context has %.17g", frac, p->feature_frac);
    PKSS_RETURN_IF(seed != p->seed, ctx, PKSS_ERR_STALE_DATA,
                   "serialised cloud was prepared with seed = %lld, this "
                   "context has %lld", seed, p->seed);
    PKSS_RETURN_IF(max_raw != p->max_raw_points, ctx, PKSS_ERR_STALE_DATA,
                   "serialised cloud was prepared with max_raw_points = %lld, "
                   "this context has %lld", max_raw, p->max_raw_points);
    return PKSS_OK;
}

/* ---------------------------------------------------------------- size */
static int payload_size(size_t m, size_t n_feat, size_t m_dense, size_t *out)
{
    /* m, m_dense <= 2^31 and n_feat <= m (checked on load), so no overflow
     * here on 64-bit size_t; guard the 32-bit case anyway. */
    if (m > (SIZE_MAX - CB_PAYLOAD_FIXED) / 128 || n_feat > m ||
        m_dense > (SIZE_MAX - CB_PAYLOAD_FIXED) / 128)
        return 0;
    *out = CB_PAYLOAD_FIXED + 2 * 3 * 8 * m + 4 * n_feat + 2 * 3 * 8 * m_dense;
    return 1;
}

pkss_status pkss_cloud_serialize(const pkss_cloud *cloud, void *buf,
                                 size_t capacity, size_t *needed)
{
    if (!cloud || !needed)
        return PKSS_ERR_NULL_ARGUMENT;
    size_t payload;
    if (!payload_size(cloud->m, cloud->n_feat, cloud->m_dense, &payload))
        return PKSS_ERR_INTERNAL;
    size_t total = CB_HEADER_SIZE + payload;
    *needed = total;
    if (!buf)
        return PKSS_OK;
    if (capacity < total)
        return PKSS_ERR_INVALID_ARGUMENT;
    unsigned char *base = buf;
    writer w = {base};
    memcpy(w.p, CB_MAGIC, 8);
    w.p += 8;
    put_u32(&w, CB_FORMAT);
    put_u32(&w, CB_LITTLE_ENDIAN);
    put_u32(&w, PKSS_VERSION_NUMBER);
    put_u32(&w, CB_HEADER_SIZE);
    put_u64(&w, (uint64_t)total);
    put_u64(&w, 0); /* checksum, below */
    put_params(&w, &cloud->prep);
    const pkss_counts *k = &cloud->counts;
    const uint64_t counts[8] = {k->input,      k->nonfinite, k->thinned,
                                k->after_mutual, k->after_stat, k->resampled,
                                k->features,   k->duplicates};
    for (int i = 0; i < 8; ++i)
        put_u64(&w, counts[i]);
    put_u64(&w, cloud->m);
    put_u64(&w, cloud->n_feat);
    put_u64(&w, cloud->m_coarse);
    put_u64(&w, cloud->m_dense);
    for (int d = 0; d < 3; ++d)
        put_f64(&w, cloud->centroid[d]);
    put_f64(&w, cloud->sigma);
    for (int i = 0; i < 9; ++i)
        put_f64(&w, cloud->axes[i]);
    for (int d = 0; d < 3; ++d)
        put_f64(&w, cloud->half_extent[d]);
    put_f64(&w, cloud->spacing);
    put_f64(&w, cloud->spacing_coarse);
    put_f64(&w, cloud->spacing_dense);
    put_f64(&w, cloud->prep_seconds);
    put_f64(&w, cloud->validate_seconds);
    for (size_t i = 0; i < 3 * cloud->m; ++i)
        put_f64(&w, cloud->pre[i]);
    for (size_t i = 0; i < 3 * cloud->m; ++i)
        put_f64(&w, cloud->normal[i]);
    for (size_t i = 0; i < 3 * cloud->m_dense; ++i)
        put_f64(&w, cloud->dense[i]);
    for (size_t i = 0; i < 3 * cloud->m_dense; ++i)
        put_f64(&w, cloud->normal_dense[i]);
    for (size_t i = 0; i < cloud->n_feat; ++i)
        put_u32(&w, cloud->feat[i]);
    if ((size_t)(w.p - base) != total)
        return PKSS_ERR_INTERNAL;
    writer c = {base + 32};
    put_u64(&c, checksum(base, total));
    return PKSS_OK;
}

/* ---------------------------------------------------------------- load */
static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* The payload into c (sizes checked against the byte count first). */
static pkss_status read_payload(pkss_context *ctx, reader *r, size_t total,
                                pkss_cloud *c)
{
    PKSS_RETURN_IF((size_t)(r->end - r->p) < CB_PAYLOAD_FIXED, ctx,
                   PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: the payload (%zu bytes) is shorter "
                   "than its fixed part (%u bytes)",
                   (size_t)(r->end - r->p), (unsigned)CB_PAYLOAD_FIXED);
    pkss_counts *k = &c->counts;
    uint64_t *counts[8] = {&k->input,      &k->nonfinite, &k->thinned,
                           &k->after_mutual, &k->after_stat, &k->resampled,
                           &k->features,   &k->duplicates};
    for (int i = 0; i < 8; ++i)
        *counts[i] = get_u64(r);
    uint64_t m = get_u64(r), n_feat = get_u64(r), m_coarse = get_u64(r),
             m_dense = get_u64(r);
    PKSS_RETURN_IF(m < 4 || m > 0x7fffffffu || n_feat == 0 || n_feat > m ||
                       m_coarse == 0 || m_coarse > m || k->resampled != m ||
                       m_dense < m || m_dense > 0x7fffffffu,
                   ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: inconsistent sizes (m = %llu, features "
                   "= %llu, coarse = %llu, resampled = %llu, dense = %llu)",
                   (unsigned long long)m, (unsigned long long)n_feat,
                   (unsigned long long)m_coarse,
                   (unsigned long long)k->resampled, (unsigned long long)m_dense);
    size_t payload = 0;
    PKSS_RETURN_IF(!payload_size((size_t)m, (size_t)n_feat, (size_t)m_dense, &payload) ||
                       CB_HEADER_SIZE + payload != total,
                   ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: %llu points and %llu features need "
                   "%zu bytes, the header says %zu",
                   (unsigned long long)m, (unsigned long long)n_feat,
                   CB_HEADER_SIZE + payload, total);
    c->m = (size_t)m;
    c->n_feat = (size_t)n_feat;
    c->m_coarse = (size_t)m_coarse;
    c->m_dense = (size_t)m_dense;
    for (int d = 0; d < 3; ++d)
        c->centroid[d] = get_f64(r);
    c->sigma = get_f64(r);
    for (int i = 0; i < 9; ++i)
        c->axes[i] = get_f64(r);
    for (int d = 0; d < 3; ++d)
        c->half_extent[d] = get_f64(r);
    c->spacing = get_f64(r);
    c->spacing_coarse = get_f64(r);
    c->spacing_dense = get_f64(r);
    c->prep_seconds = get_f64(r);
    c->validate_seconds = get_f64(r);
    c->pre = pkss__malloc(3 * c->m * sizeof(double));
    c->normal = pkss__malloc(3 * c->m * sizeof(double));
    c->feat = pkss__malloc(c->n_feat * sizeof(uint32_t));
    c->dense = pkss__malloc(3 * c->m_dense * sizeof(double));
    c->normal_dense = pkss__malloc(3 * c->m_dense * sizeof(double));
    PKSS_RETURN_IF(!c->pre || !c->normal || !c->feat || !c->dense || !c->normal_dense, ctx,
                   PKSS_ERR_OUT_OF_MEMORY,
                   "out of memory restoring a cloud of %zu points", c->m);
    for (size_t i = 0; i < 3 * c->m; ++i)
        c->pre[i] = get_f64(r);
    for (size_t i = 0; i < 3 * c->m; ++i)
        c->normal[i] = get_f64(r);
    for (size_t i = 0; i < 3 * c->m_dense; ++i)
        c->dense[i] = get_f64(r);
    for (size_t i = 0; i < 3 * c->m_dense; ++i)
        c->normal_dense[i] = get_f64(r);
    for (size_t i = 0; i < c->n_feat; ++i) {
        c->feat[i] = get_u32(r);
        PKSS_RETURN_IF(c->feat[i] >= c->m, ctx, PKSS_ERR_CORRUPT_DATA,
                       "serialised cloud: feature %zu indexes point %lu of %zu",
                       i, (unsigned long)c->feat[i], c->m);
    }
    double scalars[CB_SCALARS - 2];
    memcpy(scalars, c->centroid, sizeof c->centroid);
    scalars[3] = c->sigma;
    memcpy(scalars + 4, c->axes, sizeof c->axes);
    memcpy(scalars + 13, c->half_extent, sizeof c->half_extent);
    scalars[16] = c->spacing;
    scalars[17] = c->spacing_coarse;
    scalars[18] = c->spacing_dense;
    PKSS_RETURN_IF(!all_finite(scalars, CB_SCALARS - 2) || !(c->sigma > 0) ||
                       !all_finite(c->pre, 3 * c->m) ||
                       !all_finite(c->normal, 3 * c->m) ||
                       !all_finite(c->dense, 3 * c->m_dense) ||
                       !all_finite(c->normal_dense, 3 * c->m_dense),
                   ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: a coordinate, normal or frame value is "
                   "not finite (or sigma <= 0)");
    return PKSS_OK;
}

pkss_status pkss_cloud_deserialize(pkss_context *ctx, const void *buf,
                                   size_t size, pkss_cloud **out)
{
    if (out)
        *out = NULL;
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_NULL_ARGUMENT, "out is NULL");
    PKSS_RETURN_IF(!buf, ctx, PKSS_ERR_NULL_ARGUMENT, "buf is NULL");
    const unsigned char *b = buf;
    PKSS_RETURN_IF(size < 8 || memcmp(b, CB_MAGIC, 8) != 0, ctx,
                   PKSS_ERR_CORRUPT_DATA,
                   "not a serialised pkss cloud (%zu bytes; the magic "
                   "\"PKSSCLD\" is missing)", size);
    PKSS_RETURN_IF(size < 12, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud truncated: %zu bytes, the header alone "
                   "has %u", size, (unsigned)CB_HEADER_SIZE);
    reader r = {b + 8, b + size};
    uint32_t format = get_u32(&r);
    PKSS_RETURN_IF(format != CB_FORMAT, ctx, PKSS_ERR_STALE_DATA,
                   "serialised cloud has format version %lu; this library "
                   "(%s) reads version %u: prepare the cloud again",
                   (unsigned long)format, pkss_version_string(), CB_FORMAT);
    PKSS_RETURN_IF(size < CB_HEADER_SIZE, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud truncated: %zu bytes, the header alone "
                   "has %u", size, (unsigned)CB_HEADER_SIZE);
    uint32_t order = get_u32(&r);
    uint32_t version = get_u32(&r);
    uint32_t header = get_u32(&r);
    uint64_t total = get_u64(&r);
    uint64_t sum = get_u64(&r);
    PKSS_RETURN_IF(order != CB_LITTLE_ENDIAN || header != CB_HEADER_SIZE, ctx,
                   PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: unknown byte order %lu or header size "
                   "%lu (expected %u and %u)", (unsigned long)order,
                   (unsigned long)header, CB_LITTLE_ENDIAN,
                   (unsigned)CB_HEADER_SIZE);
    PKSS_RETURN_IF(total > size, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud truncated: %zu of its %llu bytes", size,
                   (unsigned long long)total);
    PKSS_RETURN_IF(total < size, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud: %zu bytes given, the header says %llu "
                   "(trailing data)", size, (unsigned long long)total);
    uint64_t have = checksum(b, size);
    PKSS_RETURN_IF(have != sum, ctx, PKSS_ERR_CORRUPT_DATA,
                   "serialised cloud is corrupt: checksum %016llx, expected "
                   "%016llx", (unsigned long long)have,
                   (unsigned long long)sum);
    PKSS_RETURN_IF(version != PKSS_VERSION_NUMBER, ctx, PKSS_ERR_STALE_DATA,
                   "serialised cloud comes from pkss %lu.%lu.%lu, this is %s: "
                   "prepare it again (preparation may differ between versions)",
                   (unsigned long)(version / 10000),
                   (unsigned long)(version / 100 % 100),
                   (unsigned long)(version % 100), pkss_version_string());
    PKSS_FORWARD(check_params(ctx, &r));
    pkss_cloud *c = pkss__calloc(1, sizeof *c);
    PKSS_RETURN_IF(!c, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    c->prep = ctx->params;
    pkss_status st = read_payload(ctx, &r, size, c);
    if (st == PKSS_OK) {
        st = pkss__kdtree_build(c->pre, c->m, &c->tree);
        if (st == PKSS_OK)
            st = pkss__kdtree_build(c->pre, c->m_coarse, &c->tree_coarse);
        if (st == PKSS_OK)
            st = pkss__kdtree_build(c->dense, c->m_dense, &c->tree_dense);
        if (st != PKSS_OK)
            st = pkss__fail(ctx, st, "out of memory rebuilding the kd-trees "
                            "of a cloud of %zu points", c->m);
    }
    if (st != PKSS_OK) {
        pkss_cloud_destroy(c);
        return st;
    }
    *out = c;
    return PKSS_OK;
}
