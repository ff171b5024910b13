/* SPDX-License-Identifier: MIT
 * thin.c -- voxel thinning of huge inputs (SPEC 2.1).
 *
 * A cubic grid of edge h is laid over the cloud and each occupied voxel
 * keeps one input point: the one closest to the voxel centre (squared
 * distances compared in float; lowest index on ties). No new positions appear, and the survivors come out in input
 * order. The grid origin is shifted by a seeded sub-voxel offset, so the
 * result is a deterministic function of (points, target, seed).
 *
 * h is found by a short secant search in log-log space on the number of
 * occupied voxels (counted with a hash set of packed voxel keys, which
 * keeps each voxel's pick in the same pass): typically 2-3 passes over
 * the points. It stops within 5 % of target when the step function
 * allows; otherwise it uses the evaluated h whose count was closest.
 *
 * Voxel coordinates are packed 21 bits per axis, so h is never smaller than
 * extent / 2^20. Clouds that would need a finer grid (a few tight clusters
 * a million cluster sizes apart) get fewer points than target.
 */
#include "pkss_internal.h"

#include <math.h>
#include <string.h>

#define THIN_CELLS ((double)(1u << (THIN_BITS - 1))) /* extent / h max */
#define THIN_EMPTY UINT64_MAX

/* One slot: a voxel key and, for the voxel, the point closest to its
 * centre so far (one cache line holds four slots, so a point costs one
 * miss: counting and picking happen in the same pass). */
typedef struct thin_slot {
    uint64_t key;
    uint32_t rep;
    float d2;          /* rep's squared distance to the voxel centre */
} thin_slot;

typedef struct thin_grid {
    double lo[3];
    double off[3];     /* seeded origin shift, in voxels, [0, 1) */
    thin_slot *table;  /* open addressing set of keys */
    size_t mask;
    size_t limit;      /* most keys held */
    double h;          /* edge of the counts and picks in table; 0: none */
    int complete;      /* table holds every voxel of edge h */
} thin_grid;

static inline uint64_t hash_key(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xFF51AFD7ED558CCDull;
    k ^= k >> 33;
    k *= 0xC4CEB9FE1A85EC53ull;
    k ^= k >> 33;
    return k;
}

/* Packed voxel key of p and p's squared distance to the voxel centre. */
static inline uint64_t voxel_key(const thin_grid *g, const double *p,
                                 double h, double inv_h, float *d2)
{
    uint64_t c[3];
    double e2 = 0.0;
    for (int d = 0; d < 3; ++d) {
        double f = (p[d] - g->lo[d]) * inv_h + g->off[d];
        c[d] = (uint64_t)f; /* f >= 0: truncation is floor */
        if (c[d] > (1u << THIN_BITS) - 1)
            c[d] = (1u << THIN_BITS) - 1;
        double e = p[d] - (g->lo[d] + ((double)c[d] + 0.5 - g->off[d]) * h);
        e2 += e * e;
    }
    *d2 = (float)e2;
    return (c[0] << (2 * THIN_BITS)) | (c[1] << THIN_BITS) | c[2];
}


/* Inserts one point's key; 0 when the set is full (count == limit). */
static inline int insert(thin_grid *g, uint64_t key, size_t s, uint32_t i,
                         float d2, size_t *count)
{
    while (g->table[s].key != THIN_EMPTY && g->table[s].key != key)
        s = (s + 1) & g->mask;
    thin_slot *slot = &g->table[s];
    if (slot->key == THIN_EMPTY) {
        if (*count == g->limit)
            return 0;
        slot->key = key;
        slot->rep = i;
        slot->d2 = d2;
        ++*count;
    } else if (d2 < slot->d2) {
        slot->rep = i;
        slot->d2 = d2;
    }
    return 1;
}

/* Number of occupied voxels at edge h (limit + 1: more than the set
 * holds), and each voxel's point closest to the centre (lowest index on
 * ties). Points are inserted in index order. */
static size_t occupied(thin_grid *g, const double *xyz, size_t n, double h)
{
    double inv_h = 1.0 / h;
    size_t count = 0;
    for (size_t s = 0; s <= g->mask; ++s)
        g->table[s].key = THIN_EMPTY;
    g->h = h;
    g->complete = 0;
    uint64_t key[THIN_BATCH];
    size_t slot[THIN_BATCH];
    float d2[THIN_BATCH];
    for (size_t i0 = 0; i0 < n; i0 += THIN_BATCH) {
        size_t b = n - i0 < THIN_BATCH ? n - i0 : THIN_BATCH;
        for (size_t j = 0; j < b; ++j) {
            key[j] = voxel_key(g, xyz + 3 * (i0 + j), h, inv_h, &d2[j]);
            slot[j] = (size_t)hash_key(key[j]) & g->mask;
#if defined(__GNUC__)
            __builtin_prefetch(&g->table[slot[j]], 1);
#endif
        }
        for (size_t j = 0; j < b; ++j)
            if (!insert(g, key[j], slot[j], (uint32_t)(i0 + j), d2[j], &count))
                return count + 1; /* more than limit: "too many" */
    }
    g->complete = 1;
    return count;
}

/* A voxel set for up to `keys` keys (any earlier one freed). */
static int grid_alloc(thin_grid *g, size_t keys)
{
    size_t cap = 16;
    while ((double)cap * THIN_LOAD < (double)keys)
        cap *= 2;
    pkss__free(g->table);
    g->mask = cap - 1;
    g->limit = (size_t)((double)cap * THIN_LOAD);
    g->table = pkss__malloc(cap * sizeof(thin_slot));
    g->h = 0.0;
    g->complete = 0;
    return g->table != NULL;
}

static size_t absdiff(size_t a, size_t b) { return a > b ? a - b : b - a; }

/* Bounding box corner (g->lo), seeded origin shift; returns the extent
 * and, in *area, the area of the box's faces. */
static double grid_frame(thin_grid *g, const double *xyz, size_t n,
                         uint64_t seed, double *area)
{
    double hi[3];
    for (int d = 0; d < 3; ++d)
        g->lo[d] = hi[d] = xyz[d];
    for (size_t i = 1; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = xyz[3 * i + d];
            g->lo[d] = v < g->lo[d] ? v : g->lo[d];
            hi[d] = v > hi[d] ? v : hi[d];
        }
    double extent = 0.0, e[3];
    for (int d = 0; d < 3; ++d) {
        e[d] = hi[d] - g->lo[d];
        if (e[d] > extent)
            extent = e[d];
    }
    *area = 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]);
    uint64_t rs = seed;
    for (int d = 0; d < 3; ++d)
        g->off[d] = pkss__splitmix64_unit(&rs);
    return extent;
}

/* The secant search's state: brackets and the last two passes. */
typedef struct h_search {
    double h_prev, h_under, h_over; /* under: count >= target; over: < */
    size_t c_prev;
} h_search;

/* Next edge after a pass at h gave count c: count ~ h^-a with a from the
 * last two passes (clamped to [0.5, 3]), kept inside the brackets. */
static double next_h(h_search *s, double h, size_t c, size_t target)
{
    double a = 2.0;
    if (s->h_prev > 0.0 && s->c_prev > 0 && c > 0 && s->h_prev != h) {
        a = -log((double)c / (double)s->c_prev) / log(h / s->h_prev);
        if (!(a >= 0.5))
            a = 0.5;
        if (a > 3.0)
            a = 3.0;
    }
    double hn = h * pow((double)(c ? c : 1) / (double)target, 1.0 / a);
    if (s->h_over < HUGE_VAL && s->h_under > 0.0 &&
        !(hn > s->h_under && hn < s->h_over))
        hn = sqrt(s->h_under * s->h_over);
    s->h_prev = h;
    s->c_prev = c;
    return hn;
}

/* The edge whose count comes closest to target (within 1/THIN_CLOSE when
 * the step function allows), searched in log-log space. */
static double search_h(thin_grid *g, const double *xyz, size_t n,
                       size_t target, double extent, double area)
{
    if (!(extent > 0.0))
        return 1.0; /* all points identical: one voxel */
    double h_min = extent / THIN_CELLS;
    /* Start as if the cloud were a surface of THIN_AREA times its box's
     * face area (a closed surface inside its box; a flat scan's two faces
     * count one, since it lies in one of them). */
    double h = sqrt(THIN_AREA * area / (double)target), best_h = h;
    h_search s = {0.0, 0.0, HUGE_VAL, 0};
    size_t best_err = SIZE_MAX;
    for (int pass = 0; pass < THIN_MAX_PASSES; ++pass) {
        if (h < h_min)
            h = h_min;
        size_t c = occupied(g, xyz, n, h);
        size_t err = absdiff(c, target);
        if (err < best_err) {
            best_err = err;
            best_h = h;
        }
        if (err * THIN_CLOSE <= target)
            break;
        if (c > target && h > s.h_under)
            s.h_under = h;
        if (c < target && h < s.h_over)
            s.h_over = h;
        if (s.h_under > 0.0 && s.h_over < HUGE_VAL &&
            s.h_over / s.h_under < 1.0 + 1e-9)
            break; /* the count jumps over target here: take the best */
        if (c > target && h <= h_min)
            break; /* cannot go finer */
        h = next_h(&s, h, c, target);
    }
    return best_h;
}

/* Copies the voxels' representatives, in input order, into *out. */
static pkss_status gather(const thin_grid *g, const double *xyz, size_t n,
                          double **out, size_t *n_out)
{
    unsigned char *chosen = pkss__calloc(n, 1);
    if (!chosen)
        return PKSS_ERR_OUT_OF_MEMORY;
    size_t m = 0;
    for (size_t s = 0; s <= g->mask; ++s)
        if (g->table[s].key != THIN_EMPTY) {
            chosen[g->table[s].rep] = 1;
            ++m;
        }
    *out = pkss__malloc((m ? m : 1) * 3 * sizeof(double));
    if (!*out) {
        pkss__free(chosen);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    m = 0;
    for (size_t i = 0; i < n; ++i)
        if (chosen[i]) {
            memcpy(*out + 3 * m, xyz + 3 * i, 3 * sizeof(double));
            ++m;
        }
    *n_out = m;
    pkss__free(chosen);
    return PKSS_OK;
}

static pkss_status copy_all(const double *xyz, size_t n, double **out,
                            size_t *n_out)
{
    *out = pkss__malloc((n ? n : 1) * 3 * sizeof(double));
    if (!*out)
        return PKSS_ERR_OUT_OF_MEMORY;
    if (n)
        memcpy(*out, xyz, n * 3 * sizeof(double));
    *n_out = n;
    return PKSS_OK;
}

pkss_status pkss__thin_voxel(const double *xyz, size_t n, size_t target,
                             uint64_t seed, double **out, size_t *n_out)
{
    if (out)
        *out = NULL;
    if (n_out)
        *n_out = 0;
    if (!xyz || !out || !n_out)
        return PKSS_ERR_NULL_ARGUMENT;
    if (target == 0 || n >= UINT32_MAX)
        return PKSS_ERR_INVALID_ARGUMENT;
    if (n <= target)
        return copy_all(xyz, n, out, n_out);

    thin_grid g;
    memset(&g, 0, sizeof g);
    double area = 0.0, extent = grid_frame(&g, xyz, n, seed, &area);
    double track = THIN_TRACK * (double)target;
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    if (!grid_alloc(&g, track < (double)n ? (size_t)track : n))
        goto cleanup;
    double h = search_h(&g, xyz, n, target, extent, area);
    /* The last pass is usually the one chosen: its picks are in place. */
    if (!(g.h == h && g.complete) && occupied(&g, xyz, n, h) > g.limit) {
        /* no pass came near target (a grid at its finest): hold them all */
        if (!grid_alloc(&g, n))
            goto cleanup;
        occupied(&g, xyz, n, h);
    }
    st = gather(&g, xyz, n, out, n_out);
cleanup:
    pkss__free(g.table);
    return st;
}
