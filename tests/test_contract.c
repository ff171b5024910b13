/* SPDX-License-Identifier: MIT
 * test_contract.c -- the API contract: every bad input of SPEC 1 gives its
 * documented status and a message naming the problem; NULL handling;
 * status names and sentences; parameters (bounds, defaults, types, reset);
 * out-of-memory at every allocation gives a clean status; contexts in
 * parallel threads; determinism; the subset that culling sees (the struct
 * growth rule: test_abi.c).
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "pkss_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_contract";

/* A small, well-conditioned 3-D cloud: points on a noisy ellipsoid-like
 * blob with a bump (asymmetric), n points. */
static double *make_cloud(size_t n, uint64_t seed)
{
    pkss_test_rng rng = {seed};
    double *p = malloc(n * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i) {
        double v[3] = {pkss_test_normal(&rng), pkss_test_normal(&rng), pkss_test_normal(&rng)};
        double r = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        double bump = v[0] / r > 0.7 ? 0.6 : 0.0;
        p[3 * i] = 3.0 * v[0] / r * (1 + bump);
        p[3 * i + 1] = 2.0 * v[1] / r;
        p[3 * i + 2] = 1.0 * v[2] / r + 0.3 * (v[1] / r) * (v[1] / r);
    }
    return p;
}

static pkss_context *ref_context(void)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 500), PKSS_OK);
    return ctx;
}

/* status must be `want` and the detail must contain `needle`. */
static void expect(pkss_context *ctx, pkss_status got, pkss_status want, const char *needle)
{
    const char *detail = pkss_context_last_error(ctx);
    if (got != want || !strstr(detail, needle))
        fail_msg("expected %s with \"%s\" in the detail; got %s: \"%s\"", pkss_status_name(want),
                 needle, pkss_status_name(got), detail);
    printf("  %-28s %s\n", pkss_status_name(got), detail);
}

static void test_bad_inputs(void **state)
{
    (void)state;
    pkss_context *ctx = ref_context();
    size_t n = 800;
    double *good = make_cloud(n, 1);
    double *bad = malloc(n * 3 * sizeof(double));
    pkss_result res;
    pkss_result_init(&res, sizeof res);

    expect(ctx, pkss_register(ctx, NULL, n, good, n, &res), PKSS_ERR_NULL_ARGUMENT, "source");
    expect(ctx, pkss_register(ctx, good, n, NULL, n, &res), PKSS_ERR_NULL_ARGUMENT, "target");
    assert_int_equal(pkss_register(ctx, good, n, good, n, NULL), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_register(NULL, good, n, good, n, &res), PKSS_ERR_NULL_ARGUMENT);
    expect(ctx, pkss_register(ctx, good, 0, good, n, &res), PKSS_ERR_EMPTY_INPUT, "empty");
    expect(ctx, pkss_register(ctx, good, n, good, 10, &res), PKSS_ERR_TOO_FEW_POINTS, "10 finite points");

    memcpy(bad, good, n * 3 * sizeof(double));
    bad[3 * 17 + 1] = NAN;
    expect(ctx, pkss_register(ctx, bad, n, good, n, &res), PKSS_ERR_NONFINITE, "point 17");
    bad[3 * 17 + 1] = 1.0;
    bad[3 * 5 + 2] = -INFINITY;
    expect(ctx, pkss_register(ctx, good, n, bad, n, &res), PKSS_ERR_NONFINITE, "target point 5");
    /* drop_nonfinite: the same input registers and the count is reported */
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_DROP_NONFINITE, PKSS_SWITCH_ON), PKSS_OK);
    assert_int_equal(pkss_register(ctx, good, n, bad, n, &res), PKSS_OK);
    assert_int_equal(res.target_counts.nonfinite, 1);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_DROP_NONFINITE, PKSS_SWITCH_OFF), PKSS_OK);

    /* exact duplicates are dropped and counted (also -0.0 == +0.0) */
    double *dup = malloc(2 * n * 3 * sizeof(double));
    memcpy(dup, good, n * 3 * sizeof(double));
    memcpy(dup + 3 * n, good, n * 3 * sizeof(double));
    dup[3 * n] = good[0] == 0.0 ? -0.0 : good[0];
    assert_int_equal(pkss_register(ctx, dup, 2 * n, good, n, &res), PKSS_OK);
    assert_int_equal(res.source_counts.duplicates, n);
    assert_int_equal(res.source_counts.thinned, n);
    assert_int_equal(res.target_counts.duplicates, 0);
    /* 40 distinct points, each repeated 20 times: too few after dropping */
    for (size_t i = 0; i < n; ++i)
        memcpy(dup + 3 * i, good + 3 * (i % 20), 3 * sizeof(double));
    expect(ctx, pkss_register(ctx, dup, n, good, n, &res), PKSS_ERR_TOO_FEW_POINTS,
           "20 distinct points");
    free(dup);
    /* identical, collinear, coplanar */
    for (size_t i = 0; i < n; ++i) {
        bad[3 * i] = 1.5; bad[3 * i + 1] = -2; bad[3 * i + 2] = 7;
    }
    expect(ctx, pkss_register(ctx, bad, n, good, n, &res), PKSS_ERR_DEGENERATE, "identical");
    for (size_t i = 0; i < n; ++i) {
        double t = (double)i / n;
        bad[3 * i] = 1 + 2 * t; bad[3 * i + 1] = 3 * t; bad[3 * i + 2] = -t;
    }
    expect(ctx, pkss_register(ctx, good, n, bad, n, &res), PKSS_ERR_DEGENERATE, "collinear");
    for (size_t i = 0; i < n; ++i) {
        bad[3 * i] = good[3 * i]; bad[3 * i + 1] = good[3 * i + 1];
        bad[3 * i + 2] = 0.5 * good[3 * i] - 2 * good[3 * i + 1] + 4;
    }
    expect(ctx, pkss_register(ctx, bad, n, good, n, &res), PKSS_ERR_DEGENERATE, "coplanar");
    /* magnitudes that overflow the arithmetic */
    memcpy(bad, good, n * 3 * sizeof(double));
    bad[3 * 3] = 1e200;
    expect(ctx, pkss_register(ctx, bad, n, good, n, &res), PKSS_ERR_OUT_OF_RANGE, "too large");
    /* georeferenced coordinates with a sub-precision spread */
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d)
            bad[3 * i + d] = 1e9 + good[3 * i + d] * 1e-3;
    expect(ctx, pkss_register(ctx, bad, n, good, n, &res), PKSS_ERR_DEGENERATE, "precision");
    /* result not initialised */
    pkss_result raw;
    memset(&raw, 0, sizeof raw);
    expect(ctx, pkss_register(ctx, good, n, good, n, &raw), PKSS_ERR_INVALID_ARGUMENT,
           "pkss_result_init");
    /* on failure the result holds no pose */
    assert_int_equal(res.n_candidates, 0);
    assert_float_equal(res.T_target_source[15], 0.0, 0);
    /* caller memory is never modified */
    double *copy = malloc(n * 3 * sizeof(double));
    memcpy(copy, good, n * 3 * sizeof(double));
    assert_int_equal(pkss_register(ctx, good, n, good, n, &res), PKSS_OK);
    assert_memory_equal(copy, good, n * 3 * sizeof(double));
    /* clouds: NULLs */
    pkss_cloud *c = (pkss_cloud *)1;
    assert_int_equal(pkss_cloud_create(ctx, good, n, NULL), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_cloud_create(NULL, good, n, &c), PKSS_ERR_NULL_ARGUMENT);
    assert_null(c);
    expect(ctx, pkss_cloud_create(ctx, NULL, n, &c), PKSS_ERR_NULL_ARGUMENT, "NULL");
    assert_int_equal(pkss_register_clouds(ctx, NULL, NULL, &res), PKSS_ERR_NULL_ARGUMENT);
    free(copy);
    free(good);
    free(bad);
    pkss_context_destroy(ctx);
}

static void test_null_and_status_strings(void **state)
{
    (void)state;
    pkss_context_destroy(NULL);
    pkss_cloud_destroy(NULL);
    pkss_result_init(NULL, sizeof(pkss_result));
    pkss_candidate_init(NULL, sizeof(pkss_candidate));
    assert_int_equal(pkss_context_create(NULL), PKSS_ERR_NULL_ARGUMENT);
    assert_non_null(pkss_context_last_error(NULL));
    const pkss_status all[] = {PKSS_OK, PKSS_ERR_NULL_ARGUMENT, PKSS_ERR_INVALID_ARGUMENT,
                               PKSS_ERR_EMPTY_INPUT, PKSS_ERR_TOO_FEW_POINTS, PKSS_ERR_NONFINITE,
                               PKSS_ERR_DEGENERATE, PKSS_ERR_OUT_OF_RANGE,
                               PKSS_ERR_UNKNOWN_PARAMETER, PKSS_ERR_WRONG_PARAMETER_TYPE,
                               PKSS_ERR_CANCELLED, PKSS_ERR_FORMAT,
                               PKSS_ERR_UNSUPPORTED_FORMAT, PKSS_ERR_CORRUPT_DATA,
                               PKSS_ERR_STALE_DATA,
                               PKSS_ERR_OUT_OF_MEMORY, PKSS_ERR_IO, PKSS_ERR_NO_DEVICE, PKSS_ERR_DEVICE,
                               PKSS_ERR_KERNEL_BUILD, PKSS_ERR_UNSUPPORTED,
                               PKSS_ERR_NO_CONSENSUS, PKSS_ERR_INTERNAL};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i) {
        const char *name = pkss_status_name(all[i]);
        const char *text = pkss_status_string(all[i]);
        assert_true(strncmp(name, "PKSS_", 5) == 0);
        assert_true(strlen(text) > 5);
        assert_string_not_equal(text, pkss_status_string((pkss_status)12345));
    }
    assert_string_equal(pkss_status_name((pkss_status)12345), "PKSS_UNKNOWN_STATUS");
    assert_string_equal(pkss_status_name(PKSS_ERR_DEGENERATE), "PKSS_ERR_DEGENERATE");
    assert_int_equal(pkss_version_number(), PKSS_VERSION_NUMBER);
    char v[32];
    snprintf(v, sizeof v, "%d.%d.%d", PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR, PKSS_VERSION_PATCH);
    assert_string_equal(pkss_version_string(), v);
    assert_int_equal(pkss_max_candidates(), PKSS_MAX_CANDIDATES);
    assert_non_null(strstr(pkss_build_info(), v));
}

static void test_parameters(void **state)
{
    (void)state;
    pkss_context *ctx;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    long long v;
    double d, lo, hi, def;
    /* defaults of SPEC */
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_POINTS, &v), PKSS_OK);
    assert_int_equal(v, 3000);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_ROTATION_STEPS, &v), PKSS_OK);
    assert_int_equal(v, 12);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_CELL_STEPS, &v), PKSS_OK);
    assert_int_equal(v, 12);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_OFFSET_STEPS, &v), PKSS_OK);
    assert_int_equal(v, 5);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_TOP_K, &v), PKSS_OK);
    assert_int_equal(v, 10);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_CULL_STAT, &v), PKSS_OK);
    assert_int_equal(v, PKSS_SWITCH_ON);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_DROP_NONFINITE, &v), PKSS_OK);
    assert_int_equal(v, PKSS_SWITCH_OFF);
    assert_int_equal(pkss_context_get_double(ctx, PKSS_PARAM_FEATURE_FRAC, &d), PKSS_OK);
    assert_float_equal(d, 0.10, 1e-12);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_FEATURE_FRAC, &v), PKSS_ERR_WRONG_PARAMETER_TYPE);
    /* bounds and names for every parameter; 0 restores the default */
    const pkss_param numeric[] = {
        PKSS_PARAM_POINTS, PKSS_PARAM_ROTATION_STEPS, PKSS_PARAM_OFFSET_STEPS,
        PKSS_PARAM_CELL_STEPS, PKSS_PARAM_CULL_MUTUAL, PKSS_PARAM_CULL_STAT,
        PKSS_PARAM_USE_FEATURES, PKSS_PARAM_FEATURE_FRAC, PKSS_PARAM_PCA_PREALIGN,
        PKSS_PARAM_ROTATION_SET, PKSS_PARAM_ROTATION_COUNT, PKSS_PARAM_TOP_K,
        PKSS_PARAM_REFINE, PKSS_PARAM_SEED, PKSS_PARAM_MAX_RAW_POINTS,
        PKSS_PARAM_DROP_NONFINITE, PKSS_PARAM_MIN_POINTS, PKSS_PARAM_BACKEND};
    for (size_t i = 0; i < sizeof numeric / sizeof numeric[0]; ++i) {
        pkss_param p = numeric[i];
        assert_non_null(pkss_param_name(p));
        assert_int_equal(pkss_param_bounds(p, &lo, &hi, &def), PKSS_OK);
        assert_true(lo <= def && def <= hi);
        expect(ctx, pkss_context_set_double(ctx, p, hi + 1), PKSS_ERR_INVALID_ARGUMENT,
               pkss_param_name(p));
        assert_int_equal(pkss_context_set_double(ctx, p, 0), PKSS_OK);
        assert_int_equal(pkss_context_get_double(ctx, p, &d), PKSS_OK);
        if (p != PKSS_PARAM_CELL_STEPS)
            assert_float_equal(d, def, 1e-12);
    }
    expect(ctx, pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_STEPS, 13), PKSS_ERR_INVALID_ARGUMENT, "even");
    expect(ctx, pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 4), PKSS_ERR_INVALID_ARGUMENT, "odd");
    expect(ctx, pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 100), PKSS_ERR_INVALID_ARGUMENT, "[256, 20000]");
    expect(ctx, pkss_context_set_double(ctx, PKSS_PARAM_POINTS, 1000.5), PKSS_ERR_WRONG_PARAMETER_TYPE, "integer");
    expect(ctx, pkss_context_set_double(ctx, PKSS_PARAM_FEATURE_FRAC, NAN), PKSS_ERR_INVALID_ARGUMENT, "finite");
    expect(ctx, pkss_context_set_int(ctx, PKSS_PARAM_REFINE, 3), PKSS_ERR_INVALID_ARGUMENT, "switch");
    expect(ctx, pkss_context_set_int(ctx, (pkss_param)999, 1), PKSS_ERR_UNKNOWN_PARAMETER, "999");
    expect(ctx, pkss_context_set_int(ctx, PKSS_PARAM_DEVICE, 1), PKSS_ERR_WRONG_PARAMETER_TYPE, "string");
    expect(ctx, pkss_context_set_string(ctx, PKSS_PARAM_POINTS, "1"), PKSS_ERR_WRONG_PARAMETER_TYPE, "numeric");
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, "cpu"), PKSS_OK);
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, NULL), PKSS_OK);
    assert_int_equal(pkss_param_bounds((pkss_param)999, &lo, &hi, &def), PKSS_ERR_UNKNOWN_PARAMETER);
    assert_null(pkss_param_name((pkss_param)999));
    /* sticky until reset */
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 1000), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_REFINE, PKSS_SWITCH_OFF), PKSS_OK);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_POINTS, &v), PKSS_OK);
    assert_int_equal(v, 1000);
    assert_int_equal(pkss_context_reset(ctx, (pkss_reset)7), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_context_reset(ctx, PKSS_RESET_PARAMS), PKSS_OK);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_POINTS, &v), PKSS_OK);
    assert_int_equal(v, 3000);
    assert_int_equal(pkss_context_get_int(ctx, PKSS_PARAM_REFINE, &v), PKSS_OK);
    assert_int_equal(v, PKSS_SWITCH_ON);
    pkss_context_destroy(ctx);
}

/* Out of memory at the k-th allocation, for every k: only clean
 * PKSS_ERR_OUT_OF_MEMORY until the call succeeds (libuv test-loop-oom). */
static void test_out_of_memory(void **state)
{
    (void)state;
    size_t n = 600;
    double *a = make_cloud(n, 3), *b = make_cloud(n, 4);
    int failures = 0;
    for (long long budget = 0;; ++budget) {
        pkss__test_set_alloc_budget(budget);
        pkss_context *ctx = NULL;
        pkss_status st = pkss_context_create(&ctx);
        if (st == PKSS_OK) {
            pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE);
            pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 300);
            pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 3);
            pkss_result res;
            pkss_result_init(&res, sizeof res);
            st = pkss_register(ctx, a, n, b, n, &res);
        }
        pkss__test_set_alloc_budget(-1);
        pkss_context_destroy(ctx);
        if (st == PKSS_OK) {
            printf("  register succeeded with %lld allocations; %d earlier budgets failed "
                   "cleanly\n", budget, failures);
            break;
        }
        if (st != PKSS_ERR_OUT_OF_MEMORY)
            fail_msg("allocation budget %lld: got %s, expected PKSS_ERR_OUT_OF_MEMORY", budget,
                     pkss_status_name(st));
        ++failures;
        assert_true(budget < 100000);
    }
    free(a);
    free(b);
}

typedef struct job {
    const double *src, *tgt;
    size_t n;
    pkss_status st;
    double T[16];
    char detail[256];
} job;

static void *worker(void *arg)
{
    job *j = arg;
    pkss_context *ctx = NULL;
    j->st = pkss_context_create(&ctx);
    if (j->st == PKSS_OK) {
        pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE);
        pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 500);
        pkss_result res;
        pkss_result_init(&res, sizeof res);
        j->st = pkss_register(ctx, j->src, j->n, j->tgt, j->n, &res);
        memcpy(j->T, res.T_target_source, sizeof j->T);
        snprintf(j->detail, sizeof j->detail, "%s", pkss_context_last_error(ctx));
    }
    pkss_context_destroy(ctx);
    return NULL;
}

/* Four threads, four contexts: successes and errors are reported per
 * context, and results equal the single-threaded ones. */
static void test_threads(void **state)
{
    (void)state;
    size_t n = 700;
    double *a = make_cloud(n, 5), *b = make_cloud(n, 6);
    double *nan_cloud = make_cloud(n, 7);
    nan_cloud[3 * 42] = NAN;
    job jobs[4] = {{a, b, n, 0, {0}, ""}, {b, a, n, 0, {0}, ""},
                   {nan_cloud, a, n, 0, {0}, ""}, {a, b, n, 0, {0}, ""}};
    pthread_t th[4];
    for (int i = 0; i < 4; ++i)
        assert_int_equal(pthread_create(&th[i], NULL, worker, &jobs[i]), 0);
    for (int i = 0; i < 4; ++i)
        pthread_join(th[i], NULL);
    assert_int_equal(jobs[0].st, PKSS_OK);
    assert_int_equal(jobs[1].st, PKSS_OK);
    assert_int_equal(jobs[2].st, PKSS_ERR_NONFINITE);
    assert_non_null(strstr(jobs[2].detail, "point 42"));
    assert_string_equal(jobs[0].detail, "");
    assert_int_equal(jobs[3].st, PKSS_OK);
    job single = {a, b, n, 0, {0}, ""};
    worker(&single);
    for (int k = 0; k < 16; ++k) {
        assert_float_equal(jobs[0].T[k], single.T[k], 0);
        assert_float_equal(jobs[3].T[k], single.T[k], 0);
    }
    free(a);
    free(b);
    free(nan_cloud);
}

/* Determinism: the same input gives the same output. */
static void test_deterministic(void **state)
{
    (void)state;
    pkss_context *ctx = ref_context();
    size_t n = 700;
    double *a = make_cloud(n, 8);
    pkss_result x, y;
    pkss_result_init(&x, sizeof x);
    pkss_result_init(&y, sizeof y);
    assert_int_equal(pkss_register(ctx, a, n, a, n, &x), PKSS_OK);
    assert_int_equal(pkss_register(ctx, a, n, a, n, &y), PKSS_OK);
    assert_memory_equal(x.T_target_source, y.T_target_source, sizeof x.T_target_source);
    assert_string_equal(x.device, "reference (C, CPU)");
    assert_int_equal(x.backend, PKSS_BACKEND_REFERENCE);
    free(a);
    pkss_context_destroy(ctx);
}

/* A cloud above PKSS_CULL_SUBSET m points is culled on a seeded uniform
 * subset of that many: outliers appended at the end keep their share in it
 * (culling removes about that share), the same input gives the same points,
 * and a smaller cloud is culled whole. */
static void test_culling_subset(void **state)
{
    (void)state;
    pkss_context *ctx = ref_context(); /* m = 500: subsets of 4000 */
    const size_t n_surf = 8000, n_out = 1000, n = n_surf + n_out;
    const size_t want = PKSS_CULL_SUBSET * 500;
    double *a = make_cloud(n, 21);
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 22)};
    for (size_t i = n_surf; i < n; ++i) {
        a[3 * i] = 8.0 * pkss_test_uniform(&rng) - 4.0;
        a[3 * i + 1] = 6.0 * pkss_test_uniform(&rng) - 3.0;
        a[3 * i + 2] = 4.0 * pkss_test_uniform(&rng) - 2.0;
    }
    pkss_cloud *c1 = NULL, *c2 = NULL, *c3 = NULL;
    assert_int_equal(pkss_cloud_create(ctx, a, n, &c1), PKSS_OK);
    pkss_counts k;
    assert_int_equal(pkss_cloud_counts(c1, &k), PKSS_OK);
    assert_int_equal(k.thinned, want);
    double expected = (double)want * (double)n_out / (double)n;
    double removed = (double)(k.thinned - k.after_stat);
    printf("subset of %zu: %.0f culled, %.0f outliers expected in it\n", want, removed, expected);
    assert_true(removed > 0.6 * expected && removed < 1.4 * expected);
    assert_int_equal(pkss_cloud_create(ctx, a, n, &c2), PKSS_OK);
    double *p1 = malloc(500 * 3 * sizeof(double)), *p2 = malloc(500 * 3 * sizeof(double));
    assert_int_equal(pkss_cloud_points(c1, p1, 500), PKSS_OK);
    assert_int_equal(pkss_cloud_points(c2, p2, 500), PKSS_OK);
    assert_memory_equal(p1, p2, 500 * 3 * sizeof(double));
    assert_int_equal(pkss_cloud_create(ctx, a, want - 1, &c3), PKSS_OK);
    assert_int_equal(pkss_cloud_counts(c3, &k), PKSS_OK);
    assert_int_equal(k.thinned, want - 1);
    free(p1);
    free(p2);
    free(a);
    pkss_cloud_destroy(c1);
    pkss_cloud_destroy(c2);
    pkss_cloud_destroy(c3);
    pkss_context_destroy(ctx);
}

int main(void)
{
    pkss_test_seed(PROGRAM, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_null_and_status_strings),
        cmocka_unit_test(test_parameters),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_culling_subset),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_out_of_memory),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
