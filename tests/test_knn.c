/* SPDX-License-Identifier: MIT
 * test_knn.c -- the kd-tree of src/common/knn.c against brute force.
 *
 * The tree promises the k nearest by (squared distance, index), ties to the
 * lowest index, so results must equal a brute-force sort exactly (indices
 * and distances), on every kind of cloud: uniform, clustered, full of
 * duplicates, on an integer grid (ties everywhere), collinear and planar;
 * n from 1 to 20k, k up to 32 (and k > n). Also pkss__kdtree_nearest with
 * and without a radius, pkss__kdtree_within (all points within a radius),
 * the `skip` argument, pkss__knn_all (padding when n - 1 < k), the argument
 * contract and clean out-of-memory failures.
 */
#include "support.h"

#include "pkss_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_knn";
static uint64_t g_seed;

/* ------------------------------------------------------------ clouds */

typedef enum cloud_kind {
    UNIFORM,
    CLUSTERED,
    DUPLICATES,
    GRID,
    COLLINEAR,
    PLANAR,
    N_KINDS
} cloud_kind;

static const char *KIND_NAME[N_KINDS] = {"uniform", "clustered", "duplicates",
                                         "grid", "collinear", "planar"};

static double *make_cloud(pkss_test_rng *r, cloud_kind kind, size_t n)
{
    double *x = malloc((n ? n : 1) * 3 * sizeof(double));
    assert_non_null(x);
    double dir[3] = {pkss_test_normal(r), pkss_test_normal(r),
                     pkss_test_normal(r)};
    double u[3] = {pkss_test_normal(r), pkss_test_normal(r),
                   pkss_test_normal(r)};
    double centres[8][3];
    for (int c = 0; c < 8; ++c)
        for (int d = 0; d < 3; ++d)
            centres[c][d] = 10.0 * pkss_test_uniform(r);
    size_t n_distinct = n / 40 + 1; /* stacks of ~40 copies, more than k */
    int side = (int)ceil(cbrt((double)n)) + 1;
    for (size_t i = 0; i < n; ++i) {
        double *p = x + 3 * i;
        switch (kind) {
        case UNIFORM:
            for (int d = 0; d < 3; ++d)
                p[d] = pkss_test_uniform(r);
            break;
        case CLUSTERED: {
            const double *c = centres[pkss_test_next(r) % 8];
            for (int d = 0; d < 3; ++d)
                p[d] = c[d] + 1e-3 * pkss_test_normal(r);
            break;
        }
        case DUPLICATES: {
            /* position j repeated; the repeat pattern is interleaved so the
             * copies of one position have scattered indices */
            uint64_t j = pkss_test_next(r) % n_distinct;
            pkss_test_rng pr = {j * 0x9E3779B97F4A7C15ull + 1};
            for (int d = 0; d < 3; ++d)
                p[d] = pkss_test_uniform(&pr);
            break;
        }
        case GRID: {
            /* integer lattice, exact in double: many equal distances */
            uint64_t j = pkss_test_next(r) % (uint64_t)(side * side * side);
            p[0] = (double)(j % (uint64_t)side);
            p[1] = (double)((j / (uint64_t)side) % (uint64_t)side);
            p[2] = (double)(j / (uint64_t)(side * side));
            break;
        }
        case COLLINEAR: {
            double t = floor(100.0 * pkss_test_uniform(r)); /* with repeats */
            for (int d = 0; d < 3; ++d)
                p[d] = 1.0 + t * dir[d];
            break;
        }
        case PLANAR: {
            double a = pkss_test_uniform(r), b = pkss_test_uniform(r);
            p[0] = a;
            p[1] = b;
            p[2] = 0.0;
            if (i % 2) { /* half of the set on a tilted plane */
                for (int d = 0; d < 3; ++d)
                    p[d] = a * dir[d] + b * u[d];
            }
            break;
        }
        default:
            break;
        }
    }
    return x;
}

/* ------------------------------------------------------- brute force */

typedef struct cand {
    double d2;
    uint32_t i;
} cand;

static int cand_cmp(const void *a, const void *b)
{
    const cand *x = a, *y = b;
    if (x->d2 != y->d2)
        return x->d2 < y->d2 ? -1 : 1;
    return (x->i > y->i) - (x->i < y->i);
}

/* Same expression as the tree (point minus query, summed in x, y, z order),
 * so distances compare exactly. */
static double dist2(const double *p, const double *q)
{
    double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

/* The k first of all points (but skip) sorted by (d2, index): every
 * distance is computed, the k best are kept in a sorted array. For k up to
 * n the result equals a full qsort (checked once in test_brute_force). */
static size_t brute_knn(const double *x, size_t n, const double *q, size_t k,
                        size_t skip, cand *buf, uint32_t *idx, double *d2)
{
    (void)buf;
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
        if (i == skip)
            continue;
        cand c = {dist2(x + 3 * i, q), (uint32_t)i};
        if (m == k && cand_cmp(&c, &(cand){d2[k - 1], idx[k - 1]}) >= 0)
            continue;
        size_t j = m < k ? m++ : k - 1;
        while (j > 0 && cand_cmp(&c, &(cand){d2[j - 1], idx[j - 1]}) < 0) {
            d2[j] = d2[j - 1];
            idx[j] = idx[j - 1];
            --j;
        }
        d2[j] = c.d2;
        idx[j] = c.i;
    }
    return m;
}

/* The reference by a full sort, to check brute_knn itself. */
static size_t sort_knn(const double *x, size_t n, const double *q, size_t k,
                       size_t skip, cand *buf, uint32_t *idx, double *d2)
{
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
        if (i == skip)
            continue;
        buf[m].d2 = dist2(x + 3 * i, q);
        buf[m].i = (uint32_t)i;
        ++m;
    }
    qsort(buf, m, sizeof *buf, cand_cmp);
    size_t got = m < k ? m : k;
    for (size_t j = 0; j < got; ++j) {
        idx[j] = buf[j].i;
        d2[j] = buf[j].d2;
    }
    return got;
}

static void expect_same(const char *what, const char *kind, size_t n,
                        size_t k, size_t query, size_t got, size_t want,
                        const uint32_t *idx, const double *d2,
                        const uint32_t *ridx, const double *rd2)
{
    if (got != want)
        fail_msg("%s %s n=%zu k=%zu query %zu: %zu neighbours, expected %zu "
                 "(seed %llu)", what, kind, n, k, query, got, want,
                 (unsigned long long)g_seed);
    for (size_t j = 0; j < got; ++j)
        if (idx[j] != ridx[j] || d2[j] != rd2[j])
            fail_msg("%s %s n=%zu k=%zu query %zu rank %zu: (%u, %.17g), "
                     "expected (%u, %.17g) (seed %llu)", what, kind, n, k,
                     query, j, idx[j], d2[j], ridx[j], rd2[j],
                     (unsigned long long)g_seed);
}

/* ------------------------------------------------------------- tests */

static void test_knn_equals_brute_force(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed};
    const size_t sizes[] = {1, 2, 3, 5, 12, 13, 33, 100, 1000, 5000, 20000};
    const size_t ks[] = {1, 2, 5, 12, 32};
    uint32_t idx[40];
    double d2[40];
    long checks = 0;
    for (int kind = 0; kind < N_KINDS; ++kind) {
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; ++si) {
            size_t n = sizes[si];
            double *x = make_cloud(&rng, (cloud_kind)kind, n);
            cand *buf = malloc(n * sizeof *buf);
            assert_non_null(buf);
            pkss__kdtree *t = NULL;
            assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
            assert_int_equal(pkss__kdtree_size(t), n);
            /* at most ~150 queries per size: brute force is O(n) each */
            size_t n_q = n < 150 ? n : 150;
            /* The result for k is the k-prefix of the order by (d2, index),
             * so one reference with the largest k serves all k. */
            uint32_t rs[3][40];
            double rd[3][40];
            size_t rw[3];
            const size_t kmax = ks[sizeof ks / sizeof *ks - 1];
            for (size_t a = 0; a < n_q; ++a) {
                size_t i = n_q == n ? a : pkss_test_next(&rng) % n;
                double q[3]; /* an arbitrary point near or outside the cloud */
                for (int d = 0; d < 3; ++d)
                    q[d] = x[3 * i + d] +
                           (a % 3 == 0 ? 5.0 : 0.05) * pkss_test_normal(&rng);
                const double *qs[3] = {x + 3 * i, x + 3 * i, q};
                const size_t skips[3] = {i, SIZE_MAX, SIZE_MAX};
                static const char *what[3] = {"self", "noskip", "free"};
                for (int v = 0; v < 3; ++v)
                    rw[v] = brute_knn(x, n, qs[v], kmax, skips[v], buf, rs[v],
                                      rd[v]);
                for (size_t ki = 0; ki < sizeof ks / sizeof *ks; ++ki) {
                    size_t k = ks[ki];
                    for (int v = 0; v < 3; ++v) {
                        size_t got = pkss__kdtree_knn(t, qs[v], k, skips[v],
                                                      idx, d2);
                        size_t want = rw[v] < k ? rw[v] : k;
                        expect_same(what[v], KIND_NAME[kind], n, k, i, got,
                                    want, idx, d2, rs[v], rd[v]);
                        ++checks;
                    }
                    /* not excluded, the point itself (or a lower-indexed
                     * copy of it) comes first */
                    assert_true(rd[1][0] == 0.0);
                }
            }
            pkss__kdtree_free(t);
            free(buf);
            free(x);
        }
    }
    print_message("[%s] %ld kNN queries equal brute force\n", PROGRAM, checks);
}

/* The test's own reference: the bounded insertion equals a full sort. */
static void test_brute_force(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 4};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        size_t n = 700;
        double *x = make_cloud(&rng, (cloud_kind)kind, n);
        cand *buf = malloc(n * sizeof *buf);
        uint32_t a[40], b[40];
        double da[40], db[40];
        for (size_t i = 0; i < n; i += 13) {
            size_t ga = brute_knn(x, n, x + 3 * i, 32, i, buf, a, da);
            size_t gb = sort_knn(x, n, x + 3 * i, 32, i, buf, b, db);
            assert_int_equal(ga, gb);
            assert_memory_equal(a, b, ga * sizeof *a);
            assert_memory_equal(da, db, ga * sizeof *da);
        }
        free(buf);
        free(x);
    }
}

static void test_knn_all(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 1};
    const size_t sizes[] = {1, 2, 7, 13, 14, 500, 3000};
    const size_t ks[] = {1, 12, 32};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; ++si) {
            size_t n = sizes[si];
            double *x = make_cloud(&rng, (cloud_kind)kind, n);
            cand *buf = malloc(n * sizeof *buf);
            pkss__kdtree *t = NULL;
            assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
            for (size_t ki = 0; ki < sizeof ks / sizeof *ks; ++ki) {
                size_t k = ks[ki];
                uint32_t *idx = malloc(n * k * sizeof(uint32_t));
                double *d2 = malloc(n * k * sizeof(double));
                assert_int_equal(pkss__knn_all(t, x, n, k, idx, d2), PKSS_OK);
                uint32_t ridx[32];
                double rd2[32];
                for (size_t i = 0; i < n; i += (n > 500 ? 7 : 1)) {
                    size_t want = brute_knn(x, n, x + 3 * i, k, i, buf, ridx, rd2);
                    expect_same("knn_all", KIND_NAME[kind], n, k, i, want, want,
                                idx + k * i, d2 + k * i, ridx, rd2);
                    /* rows are padded with the last neighbour (or i itself
                     * when there is none) */
                    for (size_t j = want; j < k; ++j) {
                        uint32_t pad = want ? ridx[want - 1] : (uint32_t)i;
                        assert_int_equal(idx[k * i + j], pad);
                    }
                }
                free(idx);
                free(d2);
            }
            pkss__kdtree_free(t);
            free(buf);
            free(x);
        }
    }
}

/* A query near a random point of x: on it (scale 0), just off it or far
 * off it, by a normal step of that scale. */
static void query_near(pkss_test_rng *rng, const double *x, size_t n, double scale,
                       double q[3])
{
    size_t i = pkss_test_next(rng) % n;
    for (int d = 0; d < 3; ++d)
        q[d] = x[3 * i + d] + scale * pkss_test_normal(rng);
}

static void test_nearest(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 2};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        size_t n = 2000;
        double *x = make_cloud(&rng, (cloud_kind)kind, n);
        cand *buf = malloc(n * sizeof *buf);
        pkss__kdtree *t = NULL;
        assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
        for (int a = 0; a < 500; ++a) {
            double q[3];
            query_near(&rng, x, n, a % 4 == 0 ? 0.0 : (a % 4 == 1 ? 0.01 : 3.0), q);
            uint32_t ridx;
            double rd2;
            brute_knn(x, n, q, 1, SIZE_MAX, buf, &ridx, &rd2);
            /* no radius */
            double d2 = -1.0;
            uint32_t got = pkss__kdtree_nearest(t, q, INFINITY, &d2);
            if (got != ridx || d2 != rd2)
                fail_msg("nearest %s query %d: (%u, %.17g), expected (%u, %.17g) "
                         "(seed %llu)", KIND_NAME[kind], a, got, d2, ridx, rd2,
                         (unsigned long long)g_seed);
            /* a radius that contains the nearest point */
            got = pkss__kdtree_nearest(t, q, 2.0 * rd2 + 1e-12, &d2);
            assert_int_equal(got, ridx);
            assert_true(d2 == rd2);
            /* a radius exactly at the nearest distance: "within" is strict */
            got = pkss__kdtree_nearest(t, q, rd2, &d2);
            assert_int_equal(got, UINT32_MAX);
            assert_true(d2 == rd2); /* max_d2 comes back */
            /* a radius below it: nothing, and max_d2 comes back */
            if (rd2 > 0.0) {
                got = pkss__kdtree_nearest(t, q, 0.5 * rd2, &d2);
                assert_int_equal(got, UINT32_MAX);
                assert_true(d2 == 0.5 * rd2);
            }
            /* out_d2 may be NULL */
            assert_int_equal(pkss__kdtree_nearest(t, q, INFINITY, NULL), ridx);
        }
        pkss__kdtree_free(t);
        free(buf);
        free(x);
    }
}

/* pkss__kdtree_any_within answers "is the nearest point within the
 * radius" (strictly), as pkss__kdtree_nearest does, on every cloud kind
 * (stacks of identical points included) and at radii around the nearest
 * distance. */
static void test_any_within(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 5};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        size_t n = 2000;
        double *x = make_cloud(&rng, (cloud_kind)kind, n);
        pkss__kdtree *t = NULL;
        assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
        size_t inside = 0, asked = 0;
        for (int a = 0; a < 500; ++a) {
            double q[3];
            query_near(&rng, x, n, a % 4 == 0 ? 0.0 : (a % 4 == 1 ? 0.01 : 3.0), q);
            double rd2 = 0.0;
            pkss__kdtree_nearest(t, q, INFINITY, &rd2);
            const double radii[] = {INFINITY, 2.0 * rd2 + 1e-12, rd2, 0.5 * rd2,
                                    nextafter(rd2, INFINITY), 0.01, 0.1, 1.0};
            for (size_t k = 0; k < sizeof radii / sizeof radii[0]; ++k) {
                int want = pkss__kdtree_nearest(t, q, radii[k], NULL) != UINT32_MAX;
                int got = pkss__kdtree_any_within(t, q, radii[k]);
                if (got != want)
                    fail_msg("any_within %s query %d radius^2 %.17g: %d, nearest says %d "
                             "(seed %llu)", KIND_NAME[kind], a, radii[k], got, want,
                             (unsigned long long)g_seed);
                inside += (size_t)got;
                ++asked;
            }
        }
        /* both answers occur */
        assert_true(inside > asked / 8 && inside < asked - asked / 8);
        pkss__kdtree_free(t);
        free(x);
    }
    double q[3] = {0, 0, 0};
    assert_int_equal(pkss__kdtree_any_within(NULL, q, INFINITY), 0);
}

/* pkss__kdtree_within: exactly the points within the radius (inclusive),
 * each once, as tree positions that map back to their indices and
 * coordinates, with their squared distances; a cap writes only the first. */
static void test_within_radius(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 8};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        size_t n = 2000;
        double *x = make_cloud(&rng, (cloud_kind)kind, n);
        pkss__kdtree *t = NULL;
        assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
        const double *tp = pkss__kdtree_points(t);
        const uint32_t *order = pkss__kdtree_order(t);
        uint32_t *pos = malloc(n * sizeof *pos);
        double *d2 = malloc(n * sizeof *d2);
        unsigned char *seen = malloc(n);
        assert_true(pos && d2 && seen);
        for (int a = 0; a < 200; ++a) {
            double q[3], rd2 = 0.0;
            query_near(&rng, x, n, a % 3 == 0 ? 0.0 : 0.05, q);
            uint32_t near[8];
            double nd[8];
            pkss__kdtree_knn(t, q, 8, SIZE_MAX, near, nd);
            rd2 = nd[a % 8]; /* a radius on a point: the bound is inclusive */
            size_t got = pkss__kdtree_within(t, q, rd2, n, pos, d2);
            memset(seen, 0, n);
            for (size_t i = 0; i < got; ++i) {
                uint32_t ix = order[pos[i]];
                assert_true(ix < n && !seen[ix]);
                seen[ix] = 1;
                assert_memory_equal(tp + 3 * (size_t)pos[i], x + 3 * (size_t)ix,
                                    3 * sizeof(double));
                assert_true(d2[i] == dist2(x + 3 * (size_t)ix, q));
            }
            for (size_t i = 0; i < n; ++i)
                if (!seen[i] && dist2(x + 3 * i, q) <= rd2)
                    fail_msg("within %s query %d: point %zu at %.17g missed (r^2 %.17g)",
                             KIND_NAME[kind], a, i, dist2(x + 3 * i, q), rd2);
            assert_true(got >= (size_t)(a % 8) + 1);
            /* capped: the count all the same, only the first written */
            size_t capped = pkss__kdtree_within(t, q, rd2, 1, pos, d2);
            assert_int_equal(capped, got);
        }
        free(seen);
        free(d2);
        free(pos);
        pkss__kdtree_free(t);
        free(x);
    }
    double q[3] = {0, 0, 0};
    uint32_t p;
    double d;
    assert_int_equal(pkss__kdtree_within(NULL, q, 1.0, 1, &p, &d), 0);
    assert_null(pkss__kdtree_points(NULL));
    assert_null(pkss__kdtree_order(NULL));
}

/* pkss__kdtree_knn_within: the unbounded k nearest cut at the bound
 * (inclusive), bit for bit, for bounds below, at and around the k-th
 * distance, on every kind of cloud (stacks of identical points, ties). */
static void test_knn_within(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 6};
    enum { K = 4 };
    size_t cut = 0, full = 0;
    for (int kind = 0; kind < N_KINDS; ++kind) {
        size_t n = 1500;
        double *x = make_cloud(&rng, (cloud_kind)kind, n);
        pkss__kdtree *t = NULL;
        assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
        for (int a = 0; a < 300; ++a) {
            double q[3];
            query_near(&rng, x, n, a % 3 == 0 ? 0.0 : (a % 3 == 1 ? 0.01 : 3.0), q);
            uint32_t wi[K], gi[K];
            double wd[K], gd[K];
            size_t all = pkss__kdtree_knn(t, q, K, SIZE_MAX, wi, wd);
            const double bounds[] = {INFINITY, 0.0, 0.5 * wd[0], wd[0], wd[1],
                                     nextafter(wd[K - 1], 0.0), wd[K - 1],
                                     nextafter(wd[K - 1], INFINITY), 4.0 * wd[K - 1]};
            for (size_t b = 0; b < sizeof bounds / sizeof bounds[0]; ++b) {
                size_t want = 0;
                while (want < all && wd[want] <= bounds[b])
                    ++want;
                size_t got = pkss__kdtree_knn_within(t, q, K, SIZE_MAX, bounds[b], gi, gd);
                if (got != want || memcmp(gi, wi, got * sizeof *gi) ||
                    memcmp(gd, wd, got * sizeof *gd))
                    fail_msg("knn_within %s query %d bound %.17g: %zu found, %zu expected "
                             "(seed %llu)", KIND_NAME[kind], a, bounds[b], got, want,
                             (unsigned long long)g_seed);
                cut += want < K;
                full += want == K;
            }
        }
        pkss__kdtree_free(t);
        free(x);
    }
    assert_true(cut > 0 && full > 0); /* both outcomes occur */
}

/* The skip argument excludes exactly one index, also inside a stack of
 * identical points, and indices that are not in the tree change nothing. */
static void test_skip(void **state)
{
    (void)state;
    size_t n = 200;
    double *x = calloc(n * 3, sizeof(double));
    assert_non_null(x);
    for (size_t i = 100; i < n; ++i)
        x[3 * i] = (double)(i - 99); /* 100 copies of the origin, then a line */
    pkss__kdtree *t = NULL;
    assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
    uint32_t idx[12];
    double d2[12];
    const double origin[3] = {0, 0, 0};
    assert_int_equal(pkss__kdtree_knn(t, origin, 12, 5, idx, d2), 12);
    uint32_t expect = 0;
    for (size_t j = 0; j < 12; ++j, ++expect) {
        if (expect == 5)
            ++expect;
        assert_int_equal(idx[j], expect);
        assert_true(d2[j] == 0.0);
    }
    assert_int_equal(pkss__kdtree_knn(t, origin, 12, SIZE_MAX, idx, d2), 12);
    for (size_t j = 0; j < 12; ++j)
        assert_int_equal(idx[j], j);
    assert_int_equal(pkss__kdtree_knn(t, origin, 12, 100000, idx, d2), 12);
    assert_int_equal(idx[11], 11);
    /* from the line (x = 3, itself skipped): x = 2 and 4, x = 1 and 5,
     * then distance 3 is shared by x = 6 (index 105) and the whole stack
     * at the origin, whose indices are lower */
    const double q[3] = {3.0, 0, 0};
    assert_int_equal(pkss__kdtree_knn(t, q, 12, 102, idx, d2), 12);
    const uint32_t want[12] = {101, 103, 100, 104, 0, 1, 2, 3, 4, 5, 6, 7};
    for (size_t j = 0; j < 12; ++j)
        assert_int_equal(idx[j], want[j]);
    /* k larger than the cloud */
    uint32_t big[300];
    double bd[300];
    assert_int_equal(pkss__kdtree_knn(t, q, 300, 7, big, bd), n - 1);
    assert_int_equal(pkss__kdtree_knn(t, q, 300, SIZE_MAX, big, bd), n);
    pkss__kdtree_free(t);
    free(x);
}

/* A stack of identical points must not make queries O(stack size): LiDAR
 * files carry thousands of (0,0,0) no-return records. */
static void test_duplicate_stack_speed(void **state)
{
    (void)state;
    size_t n = 100000;
    double *x = calloc(n * 3, sizeof(double));
    assert_non_null(x);
    for (size_t i = n / 2; i < n; ++i) /* half of them in one stack */
        for (int d = 0; d < 3; ++d)
            x[3 * i + d] = (double)(i % 97) + 0.01 * (double)d;
    size_t k = 12;
    uint32_t *idx = malloc(n * k * sizeof(uint32_t));
    double *d2 = malloc(n * k * sizeof(double));
    double t0 = pkss__now();
    pkss__kdtree *t = NULL;
    assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
    assert_int_equal(pkss__knn_all(t, x, n, k, idx, d2), PKSS_OK);
    double sec = pkss__now() - t0;
    print_message("[%s] 100k points, 50k in one stack: build + 12-NN of all "
                  "%.3f s\n", PROGRAM, sec);
    /* the stack members see the 12 lowest indices of the stack */
    for (size_t j = 0; j < k; ++j)
        assert_int_equal(idx[k * 0 + j], j + 1);
    for (size_t j = 0; j < k; ++j)
        assert_int_equal(idx[k * 40000 + j], j);
    /* O(n * stack) would be 5e9 distance evaluations (tens of seconds) */
    assert_true(sec < 5.0);
    pkss__kdtree_free(t);
    free(idx);
    free(d2);
    free(x);
}

static void test_contract(void **state)
{
    (void)state;
    double x[6] = {0, 0, 0, 1, 1, 1};
    pkss__kdtree *t = (pkss__kdtree *)x; /* must be reset */
    assert_int_equal(pkss__kdtree_build(x, 0, &t), PKSS_ERR_INVALID_ARGUMENT);
    assert_null(t);
    assert_int_equal(pkss__kdtree_build(NULL, 2, &t), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss__kdtree_build(x, 2, NULL), PKSS_ERR_NULL_ARGUMENT);
    pkss__kdtree_free(NULL);
    assert_int_equal(pkss__kdtree_size(NULL), 0);
    assert_int_equal(pkss__kdtree_build(x, 2, &t), PKSS_OK);
    uint32_t idx[2];
    double d2[2];
    assert_int_equal(pkss__kdtree_knn(t, x, 0, SIZE_MAX, idx, d2), 0);
    assert_int_equal(pkss__kdtree_knn(NULL, x, 2, SIZE_MAX, idx, d2), 0);
    assert_int_equal(pkss__kdtree_nearest(NULL, x, INFINITY, d2), UINT32_MAX);
    assert_int_equal(pkss__knn_all(t, x, 3, 1, idx, d2),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss__knn_all(t, x, 2, 1, NULL, d2),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss__knn_all(t, x, 2, 1, idx, d2), PKSS_OK);
    assert_int_equal(idx[0], 1);
    assert_int_equal(idx[1], 0);
    pkss__kdtree_free(t);
}

/* Every allocation failure comes back as OUT_OF_MEMORY with nothing
 * returned; with enough budget the build succeeds. */
static void test_out_of_memory(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 3};
    double *x = make_cloud(&rng, UNIFORM, 500);
    int ok = 0;
    for (long long budget = 0; budget < 20 && !ok; ++budget) {
        pkss__test_set_alloc_budget(budget);
        pkss__kdtree *t = NULL;
        pkss_status st = pkss__kdtree_build(x, 500, &t);
        pkss__test_set_alloc_budget(-1);
        if (st == PKSS_OK) {
            assert_non_null(t);
            ok = 1;
        } else {
            assert_int_equal(st, PKSS_ERR_OUT_OF_MEMORY);
            assert_null(t);
        }
        pkss__kdtree_free(t);
    }
    assert_true(ok);
    free(x);
}

/* Timing on a real scan (reported, not asserted: the machine is shared). */
static void test_real_scan_timing(void **state)
{
    (void)state;
    size_t n = 0;
    double *x = pkss_test_load("stanford_dragon_stand/converted/dragonStandRight_0.ply", &n);
    assert_non_null(x); /* unreadable: reason printed */
    size_t k = 12;
    uint32_t *idx = malloc(n * k * sizeof(uint32_t));
    double *d2 = malloc(n * k * sizeof(double));
    double t0 = pkss__now();
    pkss__kdtree *t = NULL;
    assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
    double t1 = pkss__now();
    assert_int_equal(pkss__knn_all(t, x, n, k, idx, d2), PKSS_OK);
    double t2 = pkss__now();
    print_message("[%s] dragonStandRight_0 (%zu points): build %.1f ms, "
                  "12-NN of all %.1f ms (%.2f us/query)\n", PROGRAM, n,
                  1e3 * (t1 - t0), 1e3 * (t2 - t1), 1e6 * (t2 - t1) / (double)n);
    /* spot-check against brute force */
    cand *buf = malloc(n * sizeof *buf);
    uint32_t ridx[12];
    double rd2[12];
    for (size_t i = 0; i < n; i += n / 50) {
        size_t want = brute_knn(x, n, x + 3 * i, k, i, buf, ridx, rd2);
        expect_same("dragon", "real", n, k, i, want, want, idx + k * i,
                    d2 + k * i, ridx, rd2);
    }
    free(buf);
    pkss__kdtree_free(t);
    free(idx);
    free(d2);
    free(x);
}

int main(void)
{
    g_seed = pkss_test_seed(PROGRAM, 20240611);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_brute_force),
        cmocka_unit_test(test_knn_equals_brute_force),
        cmocka_unit_test(test_knn_all),
        cmocka_unit_test(test_nearest),
        cmocka_unit_test(test_any_within),
        cmocka_unit_test(test_knn_within),
        cmocka_unit_test(test_within_radius),
        cmocka_unit_test(test_skip),
        cmocka_unit_test(test_duplicate_stack_speed),
        cmocka_unit_test(test_contract),
        cmocka_unit_test(test_out_of_memory),
        cmocka_unit_test(test_real_scan_timing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
