/* SPDX-License-Identifier: MIT
 * thin.c -- voxel thinning of huge inputs (SPEC 2.1).
 *
 * A cubic grid of edge h is laid over the cloud and each occupied voxel
 * keeps one input point: the one closest to the voxel centre (lowest index
 * on ties). No new positions appear, and the survivors come out in input
 * order. The grid origin is shifted by a seeded sub-voxel offset, so the
 * result is a deterministic function of (points, target, seed).
 *
 * h is found by a short secant search in log-log space on the number of
 * occupied voxels (counted with a hash set of packed voxel keys): about
 * n * (5-10 passes). It stops within 5 % of target when the step function
 * allows; otherwise it uses the evaluated h whose count was closest.
 *
 * Voxel coordinates are packed 21 bits per axis, so h is never smaller than
 * extent / 2^20. Clouds that would need a finer grid (a few tight clusters
 * a million cluster sizes apart) get fewer points than target.
 */
#include "pkss_internal.h"

#include <math.h>
#include <string.h>

#define THIN_BITS 21
#define THIN_CELLS ((double)(1u << (THIN_BITS - 1))) /* extent / h max */
#define THIN_EMPTY UINT64_MAX
#define THIN_MAX_PASSES 40
/* The voxel set holds up to this many times target keys: counts beyond
 * only tell the search "too many" (it needs exact counts near target), so
 * its memory follows target, not n. */
#define THIN_TRACK 4

typedef struct thin_grid {
    double lo[3];
    double off[3];     /* seeded origin shift, in voxels, [0, 1) */
    uint64_t *table;   /* open addressing set of keys */
    uint32_t *rep;     /* per slot: representative point (final pass) */
    double *rep_d2;    /* per slot: its distance^2 to the voxel centre */
    size_t mask;
    size_t limit;      /* most keys held (half the slots) */
} thin_grid;

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static inline uint64_t hash_key(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xFF51AFD7ED558CCDull;
    k ^= k >> 33;
    k *= 0xC4CEB9FE1A85EC53ull;
    k ^= k >> 33;
    return k;
}

/* Packed voxel key of p and the voxel's integer coordinates. */
static inline uint64_t voxel_key(const thin_grid *g, const double *p,
                                 double inv_h, uint64_t c[3])
{
    for (int d = 0; d < 3; ++d) {
        double f = (p[d] - g->lo[d]) * inv_h + g->off[d];
        c[d] = (uint64_t)f; /* f >= 0: truncation is floor */
        if (c[d] > (1u << THIN_BITS) - 1)
            c[d] = (1u << THIN_BITS) - 1;
    }
    return (c[0] << (2 * THIN_BITS)) | (c[1] << THIN_BITS) | c[2];
}

/* Number of occupied voxels at edge h; with `pick`, also each voxel's
 * point closest to the centre. */
static size_t occupied(thin_grid *g, const double *xyz, size_t n, double h,
                       int pick)
{
    double inv_h = 1.0 / h;
    size_t count = 0;
    for (size_t s = 0; s <= g->mask; ++s)
        g->table[s] = THIN_EMPTY;
    for (size_t i = 0; i < n; ++i) {
        const double *p = xyz + 3 * i;
        uint64_t c[3];
        uint64_t key = voxel_key(g, p, inv_h, c);
        size_t s = (size_t)hash_key(key) & g->mask;
        while (g->table[s] != THIN_EMPTY && g->table[s] != key)
            s = (s + 1) & g->mask;
        double d2 = 0.0;
        if (pick) {
            for (int d = 0; d < 3; ++d) {
                double centre =
                    g->lo[d] + ((double)c[d] + 0.5 - g->off[d]) * h;
                double e = p[d] - centre;
                d2 += e * e;
            }
        }
        if (g->table[s] == THIN_EMPTY) {
            if (count == g->limit)
                return count + 1; /* more than limit: "too many" */
            g->table[s] = key;
            ++count;
            if (pick) {
                g->rep[s] = (uint32_t)i;
                g->rep_d2[s] = d2;
            }
        } else if (pick && d2 < g->rep_d2[s]) {
            g->rep[s] = (uint32_t)i;
            g->rep_d2[s] = d2;
        }
    }
    return count;
}

/* A voxel set for up to `keys` keys at load 1/2 (any earlier one freed). */
static int grid_alloc(thin_grid *g, size_t keys)
{
    size_t cap = 16;
    while (cap < 2 * keys)
        cap *= 2;
    pkss__free(g->table);
    pkss__free(g->rep);
    pkss__free(g->rep_d2);
    g->mask = cap - 1;
    g->limit = cap / 2;
    g->table = pkss__malloc(cap * sizeof(uint64_t));
    g->rep = pkss__malloc(cap * sizeof(uint32_t));
    g->rep_d2 = pkss__malloc(cap * sizeof(double));
    return g->table && g->rep && g->rep_d2;
}

static size_t absdiff(size_t a, size_t b) { return a > b ? a - b : b - a; }

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
    if (n <= target) {
        *out = pkss__malloc((n ? n : 1) * 3 * sizeof(double));
        if (!*out)
            return PKSS_ERR_OUT_OF_MEMORY;
        if (n)
            memcpy(*out, xyz, n * 3 * sizeof(double));
        *n_out = n;
        return PKSS_OK;
    }

    thin_grid g;
    memset(&g, 0, sizeof g);
    double hi[3];
    for (int d = 0; d < 3; ++d)
        g.lo[d] = hi[d] = xyz[d];
    for (size_t i = 1; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = xyz[3 * i + d];
            if (v < g.lo[d])
                g.lo[d] = v;
            if (v > hi[d])
                hi[d] = v;
        }
    double extent = 0.0;
    for (int d = 0; d < 3; ++d)
        if (hi[d] - g.lo[d] > extent)
            extent = hi[d] - g.lo[d];
    uint64_t rs = seed;
    for (int d = 0; d < 3; ++d)
        g.off[d] = (double)(splitmix64(&rs) >> 11) * 0x1.0p-53;

    size_t track = target < n / THIN_TRACK ? THIN_TRACK * target : n;
    unsigned char *chosen = pkss__calloc(n, 1);
    pkss_status st = PKSS_OK;
    if (!chosen || !grid_alloc(&g, track)) {
        st = PKSS_ERR_OUT_OF_MEMORY;
        goto cleanup;
    }

    double h_min = extent / THIN_CELLS;
    double best_h;
    if (!(extent > 0.0)) {
        best_h = 1.0; /* all points identical: one voxel */
    } else {
        /* Start as if the cloud were a surface filling its box face. */
        double h = extent / sqrt((double)target);
        double h_prev = 0.0;
        size_t c_prev = 0;
        double h_under = 0.0, h_over = HUGE_VAL; /* count >= / < target */
        best_h = h;
        size_t best_err = SIZE_MAX;
        for (int pass = 0; pass < THIN_MAX_PASSES; ++pass) {
            if (h < h_min)
                h = h_min;
            size_t c = occupied(&g, xyz, n, h, 0);
            size_t err = absdiff(c, target);
            if (err < best_err) {
                best_err = err;
                best_h = h;
            }
            if (err * 20 <= target)
                break;
            if (c > target && h > h_under)
                h_under = h;
            if (c < target && h < h_over)
                h_over = h;
            if (h_under > 0.0 && h_over < HUGE_VAL &&
                h_over / h_under < 1.0 + 1e-9)
                break; /* the count jumps over target here: take the best */
            if (c > target && h <= h_min)
                break; /* cannot go finer */
            /* count ~ h^-a: estimate a from the last two passes */
            double a = 2.0;
            if (h_prev > 0.0 && c_prev > 0 && c > 0 && h_prev != h) {
                a = -log((double)c / (double)c_prev) / log(h / h_prev);
                if (!(a >= 0.5))
                    a = 0.5;
                if (a > 3.0)
                    a = 3.0;
            }
            double hn = h * pow((double)(c ? c : 1) / (double)target, 1.0 / a);
            if (h_over < HUGE_VAL && h_under > 0.0 &&
                !(hn > h_under && hn < h_over))
                hn = sqrt(h_under * h_over);
            h_prev = h;
            c_prev = c;
            h = hn;
        }
    }

    if (occupied(&g, xyz, n, best_h, 1) > g.limit) {
        /* no pass came near target (a grid at its finest): hold them all */
        if (!grid_alloc(&g, n)) {
            st = PKSS_ERR_OUT_OF_MEMORY;
            goto cleanup;
        }
        occupied(&g, xyz, n, best_h, 1);
    }
    for (size_t s = 0; s <= g.mask; ++s)
        if (g.table[s] != THIN_EMPTY)
            chosen[g.rep[s]] = 1;
    size_t m = 0;
    for (size_t i = 0; i < n; ++i)
        m += chosen[i];
    *out = pkss__malloc(m * 3 * sizeof(double));
    if (!*out) {
        st = PKSS_ERR_OUT_OF_MEMORY;
        goto cleanup;
    }
    m = 0;
    for (size_t i = 0; i < n; ++i)
        if (chosen[i]) {
            memcpy(*out + 3 * m, xyz + 3 * i, 3 * sizeof(double));
            ++m;
        }
    *n_out = m;

cleanup:
    pkss__free(g.table);
    pkss__free(g.rep);
    pkss__free(g.rep_d2);
    pkss__free(chosen);
    return st;
}
