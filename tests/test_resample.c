/* SPDX-License-Identifier: MIT
 * test_resample.c -- farthest-point sampling (SPEC 2.4, src/preshape/resample.c) and
 * voxel thinning (SPEC 2.1, src/preshape/thin.c).
 *
 * FPS: the accelerated sampler returns exactly the index sequence of the
 * textbook O(n m) loop (ties to the lowest index) on random clouds full of
 * ties and duplicates and on a real scan; exactly min(m, n) distinct
 * indices; starts at the point farthest from the centroid; deterministic;
 * and on real scans the sample is an r-net (see test_fps_real_spread).
 * Timings 30k -> 3000 and 200k -> 3000 are printed.
 * Thinning: about `target` points (+-20 %) on real scans and random clouds,
 * only input positions, deterministic for a seed.
 */
#include "support.h"

#include "pkss_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const char *PROGRAM = "test_resample";
static uint64_t g_seed;

/* ------------------------------------------------------------ clouds */

enum { UNIFORM, CLUSTERED, DUPLICATES, GRID, COLLINEAR, PLANAR, N_KINDS };
static const char *KIND_NAME[N_KINDS] = {"uniform", "clustered", "duplicates",
                                         "grid", "collinear", "planar"};

static double *make_cloud(pkss_test_rng *r, int kind, size_t n)
{
    double *x = malloc((n ? n : 1) * 3 * sizeof(double));
    assert_non_null(x);
    double dir[3] = {pkss_test_normal(r), pkss_test_normal(r),
                     pkss_test_normal(r)};
    double centres[6][3];
    for (int c = 0; c < 6; ++c)
        for (int d = 0; d < 3; ++d)
            centres[c][d] = 10.0 * pkss_test_uniform(r);
    size_t n_distinct = n / 20 + 1;
    int side = (int)ceil(cbrt((double)n)) + 1;
    for (size_t i = 0; i < n; ++i) {
        double *p = x + 3 * i;
        switch (kind) {
        case UNIFORM:
            for (int d = 0; d < 3; ++d)
                p[d] = pkss_test_uniform(r);
            break;
        case CLUSTERED: {
            const double *c = centres[pkss_test_next(r) % 6];
            for (int d = 0; d < 3; ++d)
                p[d] = c[d] + 1e-2 * pkss_test_normal(r);
            break;
        }
        case DUPLICATES: {
            pkss_test_rng pr = {(pkss_test_next(r) % n_distinct) * 7919u + 3};
            for (int d = 0; d < 3; ++d)
                p[d] = pkss_test_uniform(&pr);
            break;
        }
        case GRID: { /* integer lattice: ties everywhere */
            uint64_t j = pkss_test_next(r) % (uint64_t)(side * side * side);
            p[0] = (double)(j % (uint64_t)side);
            p[1] = (double)((j / (uint64_t)side) % (uint64_t)side);
            p[2] = (double)(j / (uint64_t)(side * side));
            break;
        }
        case COLLINEAR: {
            double t = floor(1000.0 * pkss_test_uniform(r));
            for (int d = 0; d < 3; ++d)
                p[d] = t * dir[d];
            break;
        }
        case PLANAR: {
            double a = floor(64 * pkss_test_uniform(r)), b = pkss_test_uniform(r);
            p[0] = a;
            p[1] = b;
            p[2] = 0.0;
            break;
        }
        default:
            break;
        }
    }
    return x;
}

static double dist2(const double *p, const double *q)
{
    double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

/* --------------------------------------------------- reference FPS */

/* The textbook loop: O(n m), same arithmetic as src/preshape/resample.c (centroid
 * summed in index order; distances as point minus sample), so the index
 * sequence must match exactly. Returns min(m, n). */
static size_t brute_fps(const double *x, size_t n, size_t m, uint32_t *out)
{
    if (m > n)
        m = n;
    if (m == 0)
        return 0;
    double c[3] = {0, 0, 0};
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d)
            c[d] += x[3 * i + d];
    for (int d = 0; d < 3; ++d)
        c[d] /= (double)n;
    size_t sel = 0;
    double best = -1.0;
    for (size_t i = 0; i < n; ++i) {
        double d2 = dist2(x + 3 * i, c);
        if (d2 > best) {
            best = d2;
            sel = i;
        }
    }
    double *mind = malloc(n * sizeof(double));
    assert_non_null(mind);
    for (size_t i = 0; i < n; ++i)
        mind[i] = INFINITY;
    for (size_t t = 0; t < m; ++t) {
        out[t] = (uint32_t)sel;
        mind[sel] = -1.0; /* taken: never chosen again */
        const double *q = x + 3 * sel;
        size_t next = 0;
        best = -2.0;
        for (size_t i = 0; i < n; ++i) {
            double d2 = dist2(x + 3 * i, q);
            if (d2 < mind[i])
                mind[i] = d2;
            if (mind[i] > best) {
                best = mind[i];
                next = i;
            }
        }
        sel = next;
    }
    free(mind);
    return m;
}

static void check_fps_indices(const uint32_t *idx, size_t m, size_t n)
{
    unsigned char *seen = calloc(n ? n : 1, 1);
    assert_non_null(seen);
    for (size_t t = 0; t < m; ++t) {
        assert_true(idx[t] < n);
        if (seen[idx[t]])
            fail_msg("index %u returned twice (seed %llu)", idx[t],
                     (unsigned long long)g_seed);
        seen[idx[t]] = 1;
    }
    free(seen);
}

/* ------------------------------------------------------------ FPS tests */

static void test_fps_equals_brute_force(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed};
    const size_t sizes[] = {1, 2, 3, 10, 100, 1000, 4000};
    long cases = 0;
    for (int kind = 0; kind < N_KINDS; ++kind) {
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; ++si) {
            size_t n = sizes[si];
            double *x = make_cloud(&rng, kind, n);
            const size_t ms[] = {1, 2, 17, 256, n > 1 ? n - 1 : 1, n, n + 5};
            uint32_t *a = malloc((n + 5) * sizeof(uint32_t));
            uint32_t *b = malloc((n + 5) * sizeof(uint32_t));
            for (size_t mi = 0; mi < sizeof ms / sizeof *ms; ++mi) {
                size_t m = ms[mi];
                if (n >= 1000 && m > 300 && m < n - 1)
                    continue;
                if (n == 4000 && m >= n - 1)
                    continue; /* brute force O(n^2): covered at n = 1000 */
                size_t got = 0;
                assert_int_equal(pkss__fps(x, n, m, a, &got), PKSS_OK);
                size_t want = brute_fps(x, n, m, b);
                assert_int_equal(got, want);
                assert_int_equal(got, m < n ? m : n);
                for (size_t t = 0; t < got; ++t)
                    if (a[t] != b[t])
                        fail_msg("FPS %s n=%zu m=%zu: sample %zu is %u, brute "
                                 "force %u (seed %llu)", KIND_NAME[kind], n, m,
                                 t, a[t], b[t], (unsigned long long)g_seed);
                check_fps_indices(a, got, n);
                ++cases;
            }
            free(a);
            free(b);
            free(x);
        }
    }
    print_message("[%s] %ld FPS runs equal the brute-force index sequence\n",
                  PROGRAM, cases);
}

/* 50 positions x 20 copies: the first 50 samples are the 50 positions, the
 * rest are copies (distinct indices, lowest first among equals). */
static void test_fps_duplicates(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 1};
    size_t n_pos = 50, copies = 20, n = n_pos * copies;
    double *pos = make_cloud(&rng, UNIFORM, n_pos);
    double *x = malloc(n * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i)
        memcpy(x + 3 * i, pos + 3 * (i % n_pos), 3 * sizeof(double));
    uint32_t idx[1000];
    size_t got = 0;
    assert_int_equal(pkss__fps(x, n, 120, idx, &got), PKSS_OK);
    assert_int_equal(got, 120);
    check_fps_indices(idx, got, n);
    unsigned char seen[50] = {0};
    for (size_t t = 0; t < n_pos; ++t) {
        size_t p = idx[t] % n_pos;
        assert_false(seen[p]);
        seen[p] = 1;
        assert_true(idx[t] < n_pos); /* the lowest-indexed copy */
    }
    /* after all positions: every remaining min-distance is 0, so the
     * lowest untaken indices follow in order */
    for (size_t t = n_pos; t < got; ++t)
        assert_int_equal(idx[t], n_pos + (t - n_pos));
    /* m = n: every index exactly once */
    uint32_t *all = malloc(n * sizeof(uint32_t));
    assert_int_equal(pkss__fps(x, n, n, all, &got), PKSS_OK);
    assert_int_equal(got, n);
    check_fps_indices(all, got, n);
    free(all);
    free(x);
    free(pos);
}

static void test_fps_contract(void **state)
{
    (void)state;
    double x[9] = {0, 0, 0, 1, 0, 0, 5, 0, 0};
    uint32_t idx[3];
    size_t got = 99;
    assert_int_equal(pkss__fps(NULL, 3, 2, idx, &got), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(got, 0);
    assert_int_equal(pkss__fps(x, 3, 2, NULL, &got), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss__fps(x, 3, 2, idx, NULL), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss__fps(x, 3, 0, idx, &got), PKSS_OK);
    assert_int_equal(got, 0);
    assert_int_equal(pkss__fps(x, 0, 5, idx, &got), PKSS_OK);
    assert_int_equal(got, 0);
    /* centroid x = 2: farthest is index 2 (x = 5), then 0, then 1 */
    assert_int_equal(pkss__fps(x, 3, 10, idx, &got), PKSS_OK);
    assert_int_equal(got, 3);
    assert_int_equal(idx[0], 2);
    assert_int_equal(idx[1], 0);
    assert_int_equal(idx[2], 1);
}

static void test_fps_out_of_memory(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 2};
    size_t n = 5000;
    double *x = make_cloud(&rng, UNIFORM, n);
    uint32_t *idx = malloc(300 * sizeof(uint32_t));
    int ok = 0;
    for (long long budget = 0; budget < 40 && !ok; ++budget) {
        pkss__test_set_alloc_budget(budget);
        size_t got = 77;
        pkss_status st = pkss__fps(x, n, 300, idx, &got);
        pkss__test_set_alloc_budget(-1);
        if (st == PKSS_OK) {
            assert_int_equal(got, 300);
            ok = 1;
        } else {
            assert_int_equal(st, PKSS_ERR_OUT_OF_MEMORY);
            assert_int_equal(got, 0);
        }
    }
    assert_true(ok);
    free(idx);
    free(x);
}

/* Spread on real scans. FPS picks sample t at distance r_t from samples
 * 0..t-1, and r_t never increases; r = r_{m-1} (the last pick) therefore
 * bounds (a) every pairwise distance of the sample from below (separation)
 * and (b) the distance of every input point to its nearest sample from
 * above (covering: otherwise that point would have been picked instead).
 * Both are checked exactly. On a connected surface a sample s then has
 * another sample within 2r (a surface point just beyond r from s is
 * within r of some other sample s'), so NN(s) <= 2r while min NN >= r:
 * min NN >= 0.5 mean NN. Clean object scans are connected at the sample
 * spacing, so 0.5 is the bound asserted there; scans with isolated far
 * pieces (LiDAR) can exceed 2r locally, so theirs is only reported. */
static void fps_spread(const char *rel, size_t m, int assert_ratio)
{
    size_t n = 0;
    double *x = pkss_test_load(rel, &n);
    assert_non_null(x); /* unreadable: reason printed */
    uint32_t *idx = malloc(m * sizeof(uint32_t));
    uint32_t *idx2 = malloc(m * sizeof(uint32_t));
    size_t got = 0, got2 = 0;
    assert_int_equal(pkss__fps(x, n, m, idx, &got), PKSS_OK);
    assert_int_equal(got, m < n ? m : n);
    check_fps_indices(idx, got, n);
    /* deterministic across runs */
    assert_int_equal(pkss__fps(x, n, m, idx2, &got2), PKSS_OK);
    assert_int_equal(got, got2);
    assert_memory_equal(idx, idx2, got * sizeof(uint32_t));
    /* starts at the point farthest from the centroid */
    double c[3];
    pkss_test_centroid(x, n, c);
    double far = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double d2 = dist2(x + 3 * i, c);
        if (d2 > far)
            far = d2;
    }
    double d0 = dist2(x + 3 * (size_t)idx[0], c);
    assert_true(d0 >= far * (1.0 - 1e-12));

    double *s = malloc(got * 3 * sizeof(double));
    for (size_t t = 0; t < got; ++t)
        memcpy(s + 3 * t, x + 3 * (size_t)idx[t], 3 * sizeof(double));
    /* r^2: distance^2 of the last pick to the samples before it */
    double r2 = INFINITY;
    for (size_t t = 0; t + 1 < got; ++t) {
        double d2 = dist2(s + 3 * t, s + 3 * (got - 1));
        if (d2 < r2)
            r2 = d2;
    }
    pkss__kdtree *tree = NULL;
    assert_int_equal(pkss__kdtree_build(s, got, &tree), PKSS_OK);
    double min_nn = INFINITY, sum_nn = 0.0, max_nn = 0.0;
    for (size_t t = 0; t < got; ++t) {
        uint32_t j;
        double d2;
        assert_int_equal(pkss__kdtree_knn(tree, s + 3 * t, 1, t, &j, &d2), 1);
        if (d2 < r2)
            fail_msg("%s: samples %zu and %u are closer (%.9g) than the last "
                     "pick distance %.9g", rel, t, j, sqrt(d2), sqrt(r2));
        double d = sqrt(d2);
        min_nn = d < min_nn ? d : min_nn;
        max_nn = d > max_nn ? d : max_nn;
        sum_nn += d;
    }
    double cover = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double d2;
        pkss__kdtree_nearest(tree, x + 3 * i, INFINITY, &d2);
        cover = d2 > cover ? d2 : cover;
    }
    if (cover > r2)
        fail_msg("%s: an input point is %.9g from the sample, more than the "
                 "last pick distance %.9g", rel, sqrt(cover), sqrt(r2));
    double mean_nn = sum_nn / (double)got;
    print_message("[%s] FPS %s: %zu -> %zu, r = %.4g, covering radius %.4g, "
                  "NN min %.4g mean %.4g max %.4g, min/mean = %.3f%s\n",
                  PROGRAM, rel, n, got, sqrt(r2), sqrt(cover), min_nn, mean_nn,
                  max_nn, min_nn / mean_nn,
                  assert_ratio ? " (asserted >= 0.5)" : " (reported)");
    if (assert_ratio)
        assert_true(min_nn >= 0.5 * mean_nn);
    pkss__kdtree_free(tree);
    free(s);
    free(idx);
    free(idx2);
    free(x);
}

static void test_fps_real_spread(void **state)
{
    (void)state;
    fps_spread("stanford_bunny/reconstruction/bun_zipper_res2.ply", 3000, 1);
    fps_spread("stanford_dragon_stand/converted/dragonStandRight_0.ply", 3000, 1);
    fps_spread("modelnet40_pkss/airplane_0001_t.ply", 3000, 1);
    fps_spread("libpointmatcher/converted/car_cloud400.ply", 3000, 0);
    fps_spread("kitti_patchworkpp/000000.bin", 3000, 0);
}

static double median3(double a, double b, double c)
{
    return a > b ? (b > c ? b : (a > c ? c : a)) : (a > c ? a : (b > c ? c : b));
}

/* Medians of three runs of pkss__fps, in seconds: wall clock and process
 * CPU time (the machine may be shared; CPU time is what the code costs). */
static void time_fps(const double *x, size_t n, size_t m, uint32_t *idx,
                     double *wall, double *cpu)
{
    double w[3], c[3];
    for (int r = 0; r < 3; ++r) {
        size_t got = 0;
        double t0 = pkss__now();
        clock_t c0 = clock();
        assert_int_equal(pkss__fps(x, n, m, idx, &got), PKSS_OK);
        c[r] = (double)(clock() - c0) / CLOCKS_PER_SEC;
        w[r] = pkss__now() - t0;
        assert_int_equal(got, m);
    }
    *wall = median3(w[0], w[1], w[2]);
    *cpu = median3(c[0], c[1], c[2]);
}

/* 30k -> 3000: also the exact brute-force sequence on a real scan, and the
 * speed-up over it (both timed here, so machine load affects both);
 * 200k -> 3000 (the 3DMatch fragment thinned to 200k: the size the
 * pipeline caps at). */
static void test_fps_timing(void **state)
{
    (void)state;
    size_t n = 0;
    double *x = pkss_test_load("stanford_dragon_stand/converted/dragonStandRight_0.ply", &n);
    assert_non_null(x); /* unreadable: reason printed */
    double *t30 = NULL;
    size_t n30 = 0;
    assert_int_equal(pkss__thin_voxel(x, n, 30000, 0, &t30, &n30), PKSS_OK);
    uint32_t *a = malloc(3000 * sizeof(uint32_t));
    uint32_t *b = malloc(3000 * sizeof(uint32_t));
    double fast, fast_cpu;
    time_fps(t30, n30, 3000, a, &fast, &fast_cpu);
    clock_t c0 = clock();
    brute_fps(t30, n30, 3000, b);
    double slow_cpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
    assert_memory_equal(a, b, 3000 * sizeof(uint32_t));
    print_message("[%s] FPS %zu -> 3000 (dragon thinned): %.1f ms CPU, %.1f ms "
                  "wall (brute force %.1f ms CPU, same sequence)\n", PROGRAM,
                  n30, 1e3 * fast_cpu, 1e3 * fast, 1e3 * slow_cpu);
    assert_true(fast_cpu * 3.0 < slow_cpu);
    pkss__free(t30);
    free(x);

    x = pkss_test_load("3dmatch/7-scenes-redkitchen/cloud_bin_4.ply", &n);
    assert_non_null(x); /* unreadable: reason printed */
    double *t200 = NULL;
    size_t n200 = 0;
    assert_int_equal(pkss__thin_voxel(x, n, 200000, 0, &t200, &n200), PKSS_OK);
    double big, big_cpu;
    time_fps(t200, n200, 3000, a, &big, &big_cpu);
    print_message("[%s] FPS %zu -> 3000 (3DMatch fragment thinned): %.1f ms "
                  "CPU, %.1f ms wall\n", PROGRAM, n200, 1e3 * big_cpu, 1e3 * big);
    /* brute force would take 6e8 distance evaluations (several seconds) */
    assert_true(big_cpu < 1.5);
    pkss__free(t200);
    free(x);
    free(a);
    free(b);
}

/* ------------------------------------------------------- thinning */

/* Every output point is an input position (nearest input at distance 0)
 * and no input point is used twice. */
static void check_subset(const double *x, size_t n, const double *y, size_t m)
{
    pkss__kdtree *tree = NULL;
    assert_int_equal(pkss__kdtree_build(x, n, &tree), PKSS_OK);
    for (size_t i = 0; i < m; ++i) {
        double d2 = -1.0;
        pkss__kdtree_nearest(tree, y + 3 * i, INFINITY, &d2);
        if (d2 != 0.0)
            fail_msg("thinned point %zu is not an input point (%.3g away)", i,
                     sqrt(d2));
    }
    pkss__kdtree_free(tree);
}

static void thin_case(const char *name, const double *x, size_t n,
                      size_t target)
{
    double *y = NULL, *y2 = NULL, *y3 = NULL;
    size_t m = 0, m2 = 0, m3 = 0;
    double t0 = pkss__now();
    assert_int_equal(pkss__thin_voxel(x, n, target, 7, &y, &m), PKSS_OK);
    double sec = pkss__now() - t0;
    if (n <= target)
        print_message("[%s] thin %s: %zu -> %zu (target %zu: no thinning)\n",
                      PROGRAM, name, n, m, target);
    else
        print_message("[%s] thin %s: %zu -> %zu (target %zu, %+.1f %%) %.1f "
                      "ms\n", PROGRAM, name, n, m, target,
                      100.0 * ((double)m / (double)target - 1.0), 1e3 * sec);
    if (n <= target) {
        assert_int_equal(m, n);
        assert_memory_equal(x, y, n * 3 * sizeof(double));
    } else {
        assert_true((double)m >= 0.8 * (double)target);
        assert_true((double)m <= 1.2 * (double)target);
    }
    check_subset(x, n, y, m);
    /* same seed: same output */
    assert_int_equal(pkss__thin_voxel(x, n, target, 7, &y2, &m2), PKSS_OK);
    assert_int_equal(m, m2);
    assert_memory_equal(y, y2, m * 3 * sizeof(double));
    /* another seed shifts the grid: still a valid thinning */
    assert_int_equal(pkss__thin_voxel(x, n, target, 8, &y3, &m3), PKSS_OK);
    if (n > target) {
        assert_true((double)m3 >= 0.8 * (double)target);
        assert_true((double)m3 <= 1.2 * (double)target);
    }
    check_subset(x, n, y3, m3);
    pkss__free(y);
    pkss__free(y2);
    pkss__free(y3);
}

static void test_thin_real(void **state)
{
    (void)state;
    size_t n = 0;
    double *x = pkss_test_load("3dmatch/7-scenes-redkitchen/cloud_bin_4.ply", &n);
    assert_non_null(x); /* unreadable: reason printed */
    thin_case("3dmatch cloud_bin_4", x, n, 200000);
    thin_case("3dmatch cloud_bin_4", x, n, 20000);
    free(x);
    x = pkss_test_load("kitti_patchworkpp/000000.bin", &n);
    assert_non_null(x); /* unreadable: reason printed */
    thin_case("kitti 000000", x, n, 200000); /* smaller: unchanged */
    thin_case("kitti 000000", x, n, 50000);
    thin_case("kitti 000000", x, n, 5000);
    free(x);
    x = pkss_test_load("stanford_dragon_stand/converted/dragonStandRight_0.ply", &n);
    assert_non_null(x); /* unreadable: reason printed */
    thin_case("dragon", x, n, 3000);
    free(x);
}

static void test_thin_synthetic(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed + 3};
    double *x = make_cloud(&rng, UNIFORM, 100000);
    thin_case("uniform cube", x, 100000, 10000);
    free(x);
    x = make_cloud(&rng, CLUSTERED, 50000);
    thin_case("clusters", x, 50000, 2000);
    free(x);
    x = make_cloud(&rng, PLANAR, 50000);
    thin_case("planar strips", x, 50000, 5000);
    free(x);
    /* all points identical: one voxel, one point */
    x = calloc(3000, sizeof(double));
    double *y = NULL;
    size_t m = 0;
    assert_int_equal(pkss__thin_voxel(x, 1000, 10, 0, &y, &m), PKSS_OK);
    assert_int_equal(m, 1);
    pkss__free(y);
    free(x);
}

static void test_thin_contract(void **state)
{
    (void)state;
    double x[6] = {0, 0, 0, 1, 1, 1};
    double *y = (double *)x;
    size_t m = 5;
    assert_int_equal(pkss__thin_voxel(NULL, 2, 1, 0, &y, &m),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_null(y);
    assert_int_equal(m, 0);
    assert_int_equal(pkss__thin_voxel(x, 2, 1, 0, NULL, &m),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss__thin_voxel(x, 2, 0, 0, &y, &m),
                     PKSS_ERR_INVALID_ARGUMENT);
    /* OOM: only clean failures until it succeeds */
    pkss_test_rng rng = {g_seed + 4};
    double *c = make_cloud(&rng, UNIFORM, 5000);
    int ok = 0;
    for (long long budget = 0; budget < 20 && !ok; ++budget) {
        pkss__test_set_alloc_budget(budget);
        y = NULL;
        pkss_status st = pkss__thin_voxel(c, 5000, 500, 0, &y, &m);
        pkss__test_set_alloc_budget(-1);
        if (st == PKSS_OK) {
            ok = 1;
            pkss__free(y);
        } else {
            assert_int_equal(st, PKSS_ERR_OUT_OF_MEMORY);
            assert_null(y);
        }
    }
    assert_true(ok);
    free(c);
}

int main(void)
{
    g_seed = pkss_test_seed(PROGRAM, 20240612);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fps_equals_brute_force),
        cmocka_unit_test(test_fps_duplicates),
        cmocka_unit_test(test_fps_contract),
        cmocka_unit_test(test_fps_out_of_memory),
        cmocka_unit_test(test_fps_real_spread),
        cmocka_unit_test(test_fps_timing),
        cmocka_unit_test(test_thin_real),
        cmocka_unit_test(test_thin_synthetic),
        cmocka_unit_test(test_thin_contract),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
