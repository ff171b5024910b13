/* SPDX-License-Identifier: MIT
 * test_nn_field.c -- the nearest-neighbour field of src/common/nn_field.c
 * against brute force.
 *
 * The field promises, where it answers: the returned points are the nearest
 * by (squared distance, index) in order, with distances equal to the
 * tree's, each strictly nearer than *lb; every other point lies at least
 * *lb away. Checked on a noisy sphere with outliers (the clouds ICP
 * sees), on an integer grid and on stacks of duplicates (ties everywhere),
 * with queries near the surface and far from it; with two threads sharing
 * one field; and with a table and pool too small for the queries, where it
 * must still answer correctly or decline. A cube's first query is declined
 * (its list is built on the second), so each query is asked twice, unless
 * the field was warmed (its lists built ahead for a cloud's points), also
 * while another thread queries it.
 */
#include "support.h"

#include "pkss_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_nn_field";
static uint64_t g_seed;

enum { KEEP = 3 };

typedef enum cloud_kind { SPHERE, GRID, DUPLICATES, N_KINDS } cloud_kind;
static const char *KIND_NAME[N_KINDS] = {"sphere", "grid", "duplicates"};

/* n points of the kind; *spacing the typical distance between neighbours. */
static double *make_cloud(pkss_test_rng *r, cloud_kind kind, size_t n, double *spacing)
{
    double *x = malloc(3 * n * sizeof(double));
    assert_non_null(x);
    int side = (int)ceil(cbrt((double)n));
    for (size_t i = 0; i < n; ++i) {
        double *p = x + 3 * i;
        if (kind == SPHERE) {
            double v[3] = {pkss_test_normal(r), pkss_test_normal(r), pkss_test_normal(r)};
            double s = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            for (int d = 0; d < 3; ++d)
                p[d] = v[d] / s + 0.003 * pkss_test_normal(r);
            if (i % 20 == 0) /* 5 % outliers in the sphere's box */
                for (int d = 0; d < 3; ++d)
                    p[d] = 2.4 * pkss_test_uniform(r) - 1.2;
        } else if (kind == GRID) {
            uint64_t j = pkss_test_next(r) % (uint64_t)(side * side * side);
            p[0] = (double)(j % (uint64_t)side);
            p[1] = (double)((j / (uint64_t)side) % (uint64_t)side);
            p[2] = (double)(j / (uint64_t)(side * side));
        } else {
            /* ~8 copies of each position, copies at scattered indices */
            uint64_t j = pkss_test_next(r) % (n / 8 + 1);
            pkss_test_rng pr = {j * 0x9E3779B97F4A7C15ull + 1};
            for (int d = 0; d < 3; ++d)
                p[d] = pkss_test_uniform(&pr);
        }
    }
    *spacing = kind == SPHERE ? sqrt(4.0 * 3.14159265358979 / (double)n) : kind == GRID ? 1.0
                                                                            : 1.0 / cbrt((double)n / 8.0);
    return x;
}

/* A query: near a random point (within a spacing), or anywhere in the box
 * grown by a quarter. */
static void make_query(pkss_test_rng *r, const double *x, size_t n, double spacing,
                       int far, double q[3])
{
    if (!far) {
        const double *p = x + 3 * (pkss_test_next(r) % n);
        for (int d = 0; d < 3; ++d)
            q[d] = p[d] + spacing * pkss_test_normal(r);
        return;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            lo[d] = fmin(lo[d], x[3 * i + d]);
            hi[d] = fmax(hi[d], x[3 * i + d]);
        }
    for (int d = 0; d < 3; ++d) {
        double w = hi[d] - lo[d] + spacing;
        q[d] = lo[d] - 0.25 * w + 1.5 * w * pkss_test_uniform(r);
    }
}

static double dist2(const double *p, const double *q)
{
    double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
    return dx * dx + dy * dy + dz * dz;
}

/* (d2, i) comes before (bd, bi): nearer, or as near with a lower index. */
static int before(double d2, uint32_t i, double bd, uint32_t bi)
{
    return d2 < bd || (d2 == bd && i < bi);
}

/* Checks one answer of the field against all points; returns 1 if the
 * field answered (got >= 0). */
static int check_answer(const double *x, size_t n, const double q[3], int got,
                        const uint32_t *idx, const double *d2, double lb, const char *what)
{
    if (got < 0)
        return 0;
    if (got > KEEP || !(lb >= 0.0))
        fail_msg("%s: got %d, lb %g", what, got, lb);
    /* brute force: the got nearest by (d2, index) */
    uint32_t bi[KEEP];
    double bd[KEEP];
    int have = 0;
    for (size_t i = 0; i < n && got > 0; ++i) {
        double dd = dist2(x + 3 * i, q);
        int at;
        if (have < got)
            at = have++;
        else if (before(dd, (uint32_t)i, bd[got - 1], bi[got - 1]))
            at = got - 1;
        else
            continue;
        while (at > 0 && before(dd, (uint32_t)i, bd[at - 1], bi[at - 1])) {
            bd[at] = bd[at - 1];
            bi[at] = bi[at - 1];
            --at;
        }
        bd[at] = dd;
        bi[at] = (uint32_t)i;
    }
    for (int k = 0; k < got; ++k)
        if (idx[k] != bi[k] || d2[k] != bd[k])
            fail_msg("%s: answer %d is %u (d2 %.17g), brute force %u (d2 %.17g)", what, k,
                     idx[k], d2[k], bi[k], bd[k]);
    for (int k = 0; k < got; ++k)
        if (!(d2[k] < lb * lb))
            fail_msg("%s: answer %d (d2 %.17g) is not inside lb %.17g", what, k, d2[k], lb);
    /* every point not returned lies at least lb away */
    for (size_t i = 0; i < n; ++i) {
        int returned = 0;
        for (int k = 0; k < got; ++k)
            returned |= idx[k] == i;
        if (!returned && sqrt(dist2(x + 3 * i, q)) < lb)
            fail_msg("%s: point %zu lies at %.17g, inside lb %.17g", what, i,
                     sqrt(dist2(x + 3 * i, q)), lb);
    }
    return 1;
}

/* The field declines a cube's first query (it builds a list only for a
 * cube asked again): the second answer is the one to check. */
static int ask_twice(pkss__nn_field *f, const double q[3], uint32_t *idx, double *d2,
                     double *lb)
{
    int got = pkss__nn_field_near(f, q, KEEP, idx, d2, lb);
    return got >= 0 ? got : pkss__nn_field_near(f, q, KEEP, idx, d2, lb);
}

static void test_answers_equal_brute_force(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed};
    for (int kind = 0; kind < N_KINDS; ++kind) {
        const size_t n = 3000;
        double spacing;
        double *x = make_cloud(&rng, (cloud_kind)kind, n, &spacing);
        pkss__kdtree *t = NULL;
        assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
        pkss__nn_field *f = pkss__nn_field_new(t, spacing);
        assert_non_null(f);
        size_t answered[2] = {0, 0}, total = 400;
        for (int far = 0; far < 2; ++far)
            for (size_t j = 0; j < total; ++j) {
                double q[3], d2[KEEP], lb = -1.0;
                uint32_t idx[KEEP];
                make_query(&rng, x, n, spacing, far, q);
                int got = ask_twice(f, q, idx, d2, &lb);
                char what[64];
                snprintf(what, sizeof what, "%s, %s query %zu", KIND_NAME[kind],
                         far ? "far" : "near", j);
                answered[far] += (size_t)check_answer(x, n, q, got, idx, d2, lb, what);
            }
        printf("%s: the field answered %zu of %zu near and %zu of %zu far queries\n",
               KIND_NAME[kind], answered[0], total, answered[1], total);
        /* declining is always correct, so the field must also be of use */
        assert_true(answered[0] >= total * 9 / 10);
        assert_true(answered[1] >= total / 2);
        pkss__nn_field_free(f);
        pkss__kdtree_free(t);
        free(x);
    }
}

/* A noisy sphere of n points with its tree, a field on it and n_queries
 * queries (a quarter of them far): the set-up of the warm-up and two-thread
 * tests. */
typedef struct sphere_case {
    double *x, *queries, spacing;
    size_t n, n_queries;
    pkss__kdtree *t;
    pkss__nn_field *f;
} sphere_case;

static sphere_case sphere_case_new(uint64_t seed, size_t n, size_t n_queries)
{
    pkss_test_rng rng = {seed};
    sphere_case c = {.n = n, .n_queries = n_queries};
    c.x = make_cloud(&rng, SPHERE, n, &c.spacing);
    c.queries = malloc(3 * (n_queries ? n_queries : 1) * sizeof(double));
    assert_non_null(c.queries);
    for (size_t j = 0; j < n_queries; ++j)
        make_query(&rng, c.x, n, c.spacing, j % 4 == 0, c.queries + 3 * j);
    assert_int_equal(pkss__kdtree_build(c.x, n, &c.t), PKSS_OK);
    c.f = pkss__nn_field_new(c.t, c.spacing);
    assert_non_null(c.f);
    return c;
}

static void sphere_case_free(sphere_case *c)
{
    pkss__nn_field_free(c->f);
    pkss__kdtree_free(c->t);
    free(c->queries);
    free(c->x);
}

/* Two threads query one field at once, each in its own order: cubes are
 * claimed and built by whichever comes first (tools/run-tests.sh runs this
 * program under ThreadSanitizer too). */
typedef struct share_job {
    pkss__nn_field *f;
    const double *x, *queries;
    size_t n, n_queries, first;
    size_t answered;
} share_job;

static void *share_worker(void *arg)
{
    share_job *j = arg;
    for (size_t s = 0; s < j->n_queries; ++s) {
        const double *q = j->queries + 3 * ((j->first + 7 * s) % j->n_queries);
        double d2[KEEP], lb;
        uint32_t idx[KEEP];
        int got = ask_twice(j->f, q, idx, d2, &lb);
        j->answered += (size_t)check_answer(j->x, j->n, q, got, idx, d2, lb, "shared");
    }
    return NULL;
}

static void test_threads_share_a_field(void **state)
{
    (void)state;
    sphere_case c = sphere_case_new(g_seed ^ 0x5eedu, 2000, 600);
    share_job a = {c.f, c.x, c.queries, c.n, c.n_queries, 0, 0};
    share_job b = {c.f, c.x, c.queries, c.n, c.n_queries, c.n_queries / 2, 0};
    pthread_t th;
    assert_int_equal(pthread_create(&th, NULL, share_worker, &b), 0);
    share_worker(&a);
    assert_int_equal(pthread_join(th, NULL), 0);
    printf("shared: %zu and %zu of %zu answered\n", a.answered, b.answered, c.n_queries);
    assert_true(a.answered + b.answered >= c.n_queries);
    sphere_case_free(&c);
}

/* A field warmed with the cloud's own points answers a near query on its
 * first sight (the list is built ahead), correctly; a stop already set
 * builds nothing. */
static void test_warm_builds_ahead(void **state)
{
    (void)state;
    sphere_case c = sphere_case_new(g_seed ^ 0x3a3au, 2000, 0);
    pkss__nn_field *f = c.f;
    const double *x = c.x;
    const size_t n = c.n;
    atomic_int stop;
    atomic_init(&stop, 1);
    assert_int_equal(pkss__nn_field_warm(f, x, n, &stop), 0);
    atomic_store(&stop, 0);
    size_t built = pkss__nn_field_warm(f, x, n, &stop);
    assert_true(built > 0);
    assert_int_equal(pkss__nn_field_warm(f, x, n, &stop), 0); /* all built already */
    assert_int_equal(pkss__nn_field_warm(NULL, x, n, &stop), 0);
    size_t first = 0;
    for (size_t i = 0; i < n; i += 7) {
        double d2[KEEP], lb;
        uint32_t idx[KEEP];
        int got = pkss__nn_field_near(f, x + 3 * i, KEEP, idx, d2, &lb);
        first += (size_t)check_answer(x, n, x + 3 * i, got, idx, d2, lb, "warm");
    }
    printf("warm: %zu cubes built, %zu of %zu first queries answered\n", built, first,
           (n + 6) / 7);
    assert_true(first >= (n + 6) / 7 * 9 / 10);
    sphere_case_free(&c);
}

/* One thread warms a field while another queries it (as the helper warms
 * while a search runs, and the refinement may start before it stops):
 * every answer stays exact. */
typedef struct warm_job {
    pkss__nn_field *f;
    const double *x;
    size_t n;
    atomic_int stop;
} warm_job;

static void *warm_worker(void *arg)
{
    warm_job *j = arg;
    pkss__nn_field_warm(j->f, j->x, j->n, &j->stop);
    return NULL;
}

static void test_warm_while_queried(void **state)
{
    (void)state;
    sphere_case c = sphere_case_new(g_seed ^ 0x7e7eu, 2000, 600);
    warm_job w = {c.f, c.x, c.n, 0};
    atomic_init(&w.stop, 0);
    pthread_t th;
    assert_int_equal(pthread_create(&th, NULL, warm_worker, &w), 0);
    share_job a = {c.f, c.x, c.queries, c.n, c.n_queries, 0, 0};
    share_worker(&a);
    atomic_store(&w.stop, 1);
    assert_int_equal(pthread_join(th, NULL), 0);
    printf("warm while queried: %zu of %zu answered\n", a.answered, c.n_queries);
    assert_true(a.answered >= c.n_queries / 2);
    sphere_case_free(&c);
}

/* A table of 16 slots and a pool of 2000 entries: the field fills soon and
 * must then decline (-1) or answer correctly, never overrun. */
static void test_full_field_declines(void **state)
{
    (void)state;
    pkss_test_rng rng = {g_seed ^ 0xf111u};
    const size_t n = 1500;
    double spacing;
    double *x = make_cloud(&rng, SPHERE, n, &spacing);
    pkss__kdtree *t = NULL;
    assert_int_equal(pkss__kdtree_build(x, n, &t), PKSS_OK);
    pkss__nn_field *f = pkss__nn_field_sized(t, spacing, 4, 2000);
    assert_non_null(f);
    size_t answered = 0, declined = 0;
    for (size_t j = 0; j < 300; ++j) {
        double q[3], d2[KEEP], lb;
        uint32_t idx[KEEP];
        make_query(&rng, x, n, spacing, j % 3 == 0, q);
        int got = ask_twice(f, q, idx, d2, &lb);
        if (check_answer(x, n, q, got, idx, d2, lb, "full"))
            ++answered;
        else
            ++declined;
    }
    printf("full: %zu answered, %zu declined\n", answered, declined);
    assert_true(answered > 0 && declined > 0);
    pkss__nn_field_free(f);
    pkss__kdtree_free(t);
    free(x);
}

static void test_contract(void **state)
{
    (void)state;
    double x[6] = {0, 0, 0, 1, 0, 0}, q[3] = {0.2, 0, 0}, d2[KEEP], lb;
    uint32_t idx[KEEP];
    pkss__kdtree *t = NULL;
    assert_int_equal(pkss__kdtree_build(x, 2, &t), PKSS_OK);
    assert_null(pkss__nn_field_new(NULL, 1.0));
    assert_null(pkss__nn_field_new(t, 0.0));
    assert_null(pkss__nn_field_new(t, NAN));
    assert_null(pkss__nn_field_sized(t, 1.0, 0, 64));
    assert_int_equal(pkss__nn_field_near(NULL, q, KEEP, idx, d2, &lb), -1);
    pkss__nn_field *f = pkss__nn_field_new(t, 1.0);
    assert_non_null(f);
    assert_int_equal(pkss__nn_field_near(f, q, 0, idx, d2, &lb), -1);
    assert_int_equal(pkss__nn_field_near(f, q, PKSS_FIELD_MAX_KEEP, idx, d2, &lb), -1);
    const double bad[3] = {NAN, 0.0, 0.0}, huge[3] = {1e300, 0.0, 0.0};
    assert_int_equal(pkss__nn_field_near(f, bad, KEEP, idx, d2, &lb), -1);
    assert_int_equal(pkss__nn_field_near(f, huge, KEEP, idx, d2, &lb), -1);
    /* declined on first sight, answered on the second */
    assert_int_equal(pkss__nn_field_near(f, q, 1, idx, d2, &lb), -1);
    int got = pkss__nn_field_near(f, q, 1, idx, d2, &lb);
    assert_int_equal(got, 1);
    assert_int_equal(idx[0], 0);
    assert_true(lb > 0.2 && lb <= 0.8);
    pkss__nn_field_free(f);
    pkss__nn_field_free(NULL);
    pkss__kdtree_free(t);
}

int main(void)
{
    g_seed = pkss_test_seed(PROGRAM, 20261206);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_answers_equal_brute_force),
        cmocka_unit_test(test_threads_share_a_field),
        cmocka_unit_test(test_warm_builds_ahead),
        cmocka_unit_test(test_warm_while_queried),
        cmocka_unit_test(test_full_field_declines),
        cmocka_unit_test(test_contract),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
