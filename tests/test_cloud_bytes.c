/* SPDX-License-Identifier: MIT
 * test_cloud_bytes.c -- serialised prepared clouds (pkss_cloud_serialize /
 * pkss_cloud_deserialize) and the retrieval call pkss_register_templates:
 * a restored cloud registers bit for bit like the original on both
 * backends, every kind of bad bytes gets its own status and message, and
 * the template batch equals one pkss_register_clouds per template.
 */
#include "support.h"

#include "pkss_internal.h" /* pkss__test_set_alloc_budget */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <dirent.h>
#include <string.h>

static const char *PROGRAM = "test_cloud_bytes";

/* A context on `backend` with small clouds (fast); NULL when the backend
 * has no device (the caller skips). */
static pkss_context *make_context(int backend)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 1000), PKSS_OK);
    pkss_status st = pkss_context_prepare(ctx);
    if (st == PKSS_ERR_NO_DEVICE) {
        print_message("SKIP: no OpenCL device: %s\n", pkss_context_last_error(ctx));
        pkss_context_destroy(ctx);
        return NULL;
    }
    assert_int_equal(st, PKSS_OK);
    return ctx;
}

static pkss_cloud *prepare(pkss_context *ctx, const double *xyz, size_t n)
{
    pkss_cloud *c = NULL;
    pkss_status st = pkss_cloud_create(ctx, xyz, n, &c);
    if (st != PKSS_OK)
        fail_msg("pkss_cloud_create: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));
    return c;
}

static unsigned char *to_bytes(const pkss_cloud *c, size_t *size)
{
    assert_int_equal(pkss_cloud_serialize(c, NULL, 0, size), PKSS_OK);
    unsigned char *b = malloc(*size);
    assert_non_null(b);
    size_t again = 0;
    assert_int_equal(pkss_cloud_serialize(c, b, *size, &again), PKSS_OK);
    assert_int_equal(again, *size);
    return b;
}

static pkss_cloud *restore(pkss_context *ctx, const pkss_cloud *c)
{
    size_t size;
    unsigned char *b = to_bytes(c, &size);
    pkss_cloud *r = NULL;
    pkss_status st = pkss_cloud_deserialize(ctx, b, size, &r);
    if (st != PKSS_OK)
        fail_msg("pkss_cloud_deserialize: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));
    /* restored bytes are the same bytes */
    size_t size2;
    unsigned char *b2 = to_bytes(r, &size2);
    assert_int_equal(size, size2);
    assert_memory_equal(b, b2, size);
    free(b);
    free(b2);
    return r;
}

static void register_ok(pkss_context *ctx, const pkss_cloud *s, const pkss_cloud *t,
                        pkss_result *res)
{
    pkss_result_init(res, sizeof *res);
    pkss_status st = pkss_register_clouds(ctx, s, t, res);
    if (st != PKSS_OK)
        fail_msg("pkss_register_clouds: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));
}

/* The test pairs: the bundled airplane pair and two generated similar
 * pairs of it (random similarity, independent resamplings). */
typedef struct pairs {
    double *src[3], *tgt[3];
    size_t ns[3], nt[3];
} pairs;

static void load_pairs(pairs *p)
{
    p->src[0] = pkss_test_load_bundled("airplane_0001_s.ply", &p->ns[0]);
    p->tgt[0] = pkss_test_load_bundled("airplane_0001_t.ply", &p->nt[0]);
    assert_non_null(p->src[0]);
    assert_non_null(p->tgt[0]);
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 24)};
    for (int i = 1; i < 3; ++i) {
        double T[16];
        pkss_test_similar_pair(&rng, p->src[0], p->ns[0], 0.7, &p->src[i], &p->ns[i],
                               &p->tgt[i], &p->nt[i], T);
        assert_non_null(p->src[i]);
    }
}

static void free_pairs(pairs *p)
{
    for (int i = 0; i < 3; ++i) {
        free(p->src[i]);
        free(p->tgt[i]);
    }
}

static void roundtrip_on(int backend)
{
    pkss_context *ctx = make_context(backend);
    if (!ctx)
        skip();
    pairs p;
    load_pairs(&p);
    for (int i = 0; i < 3; ++i) {
        pkss_cloud *s = prepare(ctx, p.src[i], p.ns[i]);
        pkss_cloud *t = prepare(ctx, p.tgt[i], p.nt[i]);
        pkss_cloud *rs = restore(ctx, s), *rt = restore(ctx, t);
        pkss_result a, b, c;
        register_ok(ctx, s, t, &a);
        register_ok(ctx, rs, rt, &b);
        register_ok(ctx, s, rt, &c);
        if (memcmp(a.T_target_source, b.T_target_source, sizeof a.T_target_source) ||
            memcmp(a.T_target_source, c.T_target_source, sizeof a.T_target_source))
            fail_msg("pair %d: restored clouds register differently", i);
        assert_true(a.fit == b.fit && a.overlap == b.overlap && a.score == b.score);
        assert_int_equal(a.n_candidates, b.n_candidates);
        assert_memory_equal(&a.source_counts, &b.source_counts, sizeof a.source_counts);
        /* a restored cloud outlives the context it was restored in */
        pkss_cloud_destroy(s);
        pkss_cloud_destroy(t);
        pkss_cloud_destroy(rs);
        pkss_cloud_destroy(rt);
    }
    free_pairs(&p);
    pkss_context_destroy(ctx);
}

static void test_roundtrip_reference(void **state)
{
    (void)state;
    roundtrip_on(PKSS_BACKEND_REFERENCE);
}

static void test_roundtrip_opencl(void **state)
{
    (void)state;
    roundtrip_on(PKSS_BACKEND_OPENCL);
}

/* Writes a little-endian u32/u64 at off and re-seals the checksum, so the
 * field under test is the only thing wrong. */
static uint64_t fnv(uint64_t h, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

static void put_le(unsigned char *b, size_t off, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; ++i)
        b[off + (size_t)i] = (unsigned char)(v >> (8 * i));
}

static void reseal(unsigned char *b, size_t size)
{
    put_le(b, 32, fnv(fnv(0xcbf29ce484222325ull, b, 32), b + 40, size - 40), 8);
}

static void expect(pkss_context *ctx, const unsigned char *b, size_t size,
                   pkss_status want, const char *needle)
{
    pkss_cloud *out = (pkss_cloud *)&out; /* must be reset (NULL on failure) */
    pkss_status st = pkss_cloud_deserialize(ctx, b, size, &out);
    const char *detail = pkss_context_last_error(ctx);
    int out_ok = want == PKSS_OK ? out != NULL : out == NULL;
    if (st == PKSS_OK)
        pkss_cloud_destroy(out);
    if (st != want || !out_ok || !strstr(detail, needle))
        fail_msg("size %zu: got %s \"%s\", want %s with \"%s\"", size,
                 pkss_status_name(st), detail, pkss_status_name(want), needle);
}

static void test_bad_bytes(void **state)
{
    (void)state;
    pkss_context *ctx = make_context(PKSS_BACKEND_REFERENCE);
    assert_non_null(ctx);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256), PKSS_OK);
    size_t n;
    double *xyz = pkss_test_load_bundled("airplane_0001_t.ply", &n);
    assert_non_null(xyz);
    pkss_cloud *c = prepare(ctx, xyz, n);
    size_t size;
    unsigned char *good = to_bytes(c, &size);
    unsigned char *b = malloc(size + 1);
    assert_non_null(b);

    /* arguments */
    pkss_cloud *out = NULL;
    size_t need = 0;
    assert_int_equal(pkss_cloud_serialize(NULL, b, size, &need), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_cloud_serialize(c, b, size, NULL), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_cloud_serialize(c, b, size - 1, &need), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(need, size);
    assert_int_equal(pkss_cloud_deserialize(NULL, good, size, &out), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_cloud_deserialize(ctx, NULL, size, &out), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_cloud_deserialize(ctx, good, size, NULL), PKSS_ERR_NULL_ARGUMENT);

    /* wrong magic, truncated at every length of the header and a few of the payload */
    memcpy(b, good, size);
    b[0] = 'X';
    expect(ctx, b, size, PKSS_ERR_CORRUPT_DATA, "magic");
    expect(ctx, (const unsigned char *)"ply\nformat ascii 1.0\n", 21, PKSS_ERR_CORRUPT_DATA,
           "not a serialised pkss cloud");
    for (size_t k = 0; k < 8; ++k)
        expect(ctx, good, k, PKSS_ERR_CORRUPT_DATA, "magic");
    for (size_t k = 8; k < 200; ++k)
        expect(ctx, good, k, PKSS_ERR_CORRUPT_DATA, "truncated");
    expect(ctx, good, size - 1, PKSS_ERR_CORRUPT_DATA, "truncated");
    expect(ctx, good, size / 2, PKSS_ERR_CORRUPT_DATA, "truncated");
    memcpy(b, good, size);
    b[size] = 0;
    expect(ctx, b, size + 1, PKSS_ERR_CORRUPT_DATA, "trailing");

    /* one flipped bit anywhere after the magic: never accepted */
    for (size_t k = 8; k < size; k += 7) {
        memcpy(b, good, size);
        b[k] ^= (unsigned char)(1u << (k % 8));
        pkss_status st = pkss_cloud_deserialize(ctx, b, size, &out);
        if (st != PKSS_ERR_CORRUPT_DATA && st != PKSS_ERR_STALE_DATA)
            fail_msg("bit flip at byte %zu: %s", k, pkss_status_name(st));
        assert_null(out);
    }
    memcpy(b, good, size);
    b[size - 3] ^= 0x10;
    expect(ctx, b, size, PKSS_ERR_CORRUPT_DATA, "checksum");

    /* stale: format, library version, each kind of parameter */
    memcpy(b, good, size);
    put_le(b, 8, 1, 4);
    expect(ctx, b, size, PKSS_ERR_STALE_DATA, "format version 1");
    memcpy(b, good, size);
    put_le(b, 16, PKSS_VERSION_NUMBER + 1, 4);
    reseal(b, size);
    expect(ctx, b, size, PKSS_ERR_STALE_DATA, "prepare it again");
    expect(ctx, good, size, PKSS_OK, "");
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 300), PKSS_OK);
    expect(ctx, good, size, PKSS_ERR_STALE_DATA, "points = 256");
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_SEED, 7), PKSS_OK);
    expect(ctx, good, size, PKSS_ERR_STALE_DATA, "seed");
    assert_int_equal(pkss_context_reset(ctx, PKSS_RESET_PARAMS), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256), PKSS_OK);
    assert_int_equal(pkss_context_set_double(ctx, PKSS_PARAM_FEATURE_FRAC, 0.3), PKSS_OK);
    expect(ctx, good, size, PKSS_ERR_STALE_DATA, "feature_frac");
    assert_int_equal(pkss_context_reset(ctx, PKSS_RESET_PARAMS), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_CULL_STAT, PKSS_SWITCH_OFF), PKSS_OK);
    expect(ctx, good, size, PKSS_ERR_STALE_DATA, "cull_stat");
    /* a search parameter does not make a cloud stale */
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_CULL_STAT, 0), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_TOP_K, 4), PKSS_OK);
    expect(ctx, good, size, PKSS_OK, "");

    /* inconsistent sizes behind a valid checksum: m beyond the bytes, a
     * feature index out of range */
    memcpy(b, good, size);
    put_le(b, 96 + 64, 1000000, 8);
    reseal(b, size);
    expect(ctx, b, size, PKSS_ERR_CORRUPT_DATA, "inconsistent sizes");
    memcpy(b, good, size);
    put_le(b, size - 4, 0xffffffffu, 4);
    reseal(b, size);
    expect(ctx, b, size, PKSS_ERR_CORRUPT_DATA, "feature");

    /* out of memory while restoring: a clean status, nothing leaked */
    for (long long budget = 0; budget < 8; ++budget) {
        pkss__test_set_alloc_budget(budget);
        pkss_status st = pkss_cloud_deserialize(ctx, good, size, &out);
        pkss__test_set_alloc_budget(-1);
        if (st == PKSS_OK) {
            pkss_cloud_destroy(out);
            break;
        }
        assert_int_equal(st, PKSS_ERR_OUT_OF_MEMORY);
        assert_null(out);
    }
    free(b);
    free(good);
    free(xyz);
    pkss_cloud_destroy(c);
    pkss_context_destroy(ctx);
}

/* A pre-shape-distinct second object: a box with a bump (no airplane). */
static double *make_object(int kind, size_t *n)
{
    size_t m = 4000;
    double *xyz = malloc(3 * m * sizeof(double));
    assert_non_null(xyz);
    pkss_test_rng rng = {77 + (uint64_t)kind};
    for (size_t i = 0; i < m; ++i) {
        double u = pkss_test_uniform(&rng), v = pkss_test_uniform(&rng);
        double *q = xyz + 3 * i;
        if (kind == 0) { /* a torus */
            double a = 2 * 3.14159265358979 * u, b = 2 * 3.14159265358979 * v;
            q[0] = (2 + 0.6 * cos(b)) * cos(a);
            q[1] = (2 + 0.6 * cos(b)) * sin(a);
            q[2] = 0.6 * sin(b);
        } else { /* a box 3 x 2 x 1 surface */
            int f = (int)(6 * pkss_test_uniform(&rng));
            double s[3] = {3, 2, 1};
            int ax = f % 3;
            q[ax] = (f < 3 ? -0.5 : 0.5) * s[ax];
            q[(ax + 1) % 3] = (u - 0.5) * s[(ax + 1) % 3];
            q[(ax + 2) % 3] = (v - 0.5) * s[(ax + 2) % 3];
        }
    }
    *n = m;
    return xyz;
}

static void test_register_templates(void **state)
{
    (void)state;
    pkss_context *ctx = make_context(PKSS_BACKEND_REFERENCE);
    assert_non_null(ctx);
    pairs p;
    load_pairs(&p);
    size_t n1, n2;
    double *o1 = make_object(0, &n1), *o2 = make_object(1, &n2);
    pkss_cloud *src = prepare(ctx, p.src[1], p.ns[1]);
    pkss_cloud *tpl[3] = {prepare(ctx, o1, n1), prepare(ctx, p.tgt[1], p.nt[1]),
                          prepare(ctx, o2, n2)};
    pkss_result res[3], one;
    pkss_status status[3];
    size_t order[3];
    for (int i = 0; i < 3; ++i)
        pkss_result_init(&res[i], sizeof res[i]);
    const pkss_cloud *const *t = (const pkss_cloud *const *)tpl;
    pkss_status st = pkss_register_templates(ctx, src, t, 3, res, status, order);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    for (int i = 0; i < 3; ++i) {
        if (status[i] != PKSS_OK)
            continue;
        register_ok(ctx, src, tpl[i], &one);
        if (memcmp(one.T_target_source, res[i].T_target_source, sizeof one.T_target_source))
            fail_msg("template %d: batch and single registration differ", i);
        assert_true(one.fit == res[i].fit && one.overlap == res[i].overlap);
    }
    print_message("ranking %zu %zu %zu, fits %.3f %.3f %.3f\n", order[0], order[1],
                  order[2], res[0].fit, res[1].fit, res[2].fit);
    assert_int_equal(status[1], PKSS_OK);
    assert_int_equal(order[0], 1); /* the airplane is the airplane */
    for (int k = 0; k + 1 < 3; ++k) {
        size_t a = order[k], b = order[k + 1];
        if (status[a] == PKSS_OK && status[b] == PKSS_OK)
            assert_true(res[a].fit > res[b].fit ||
                        (res[a].fit == res[b].fit && res[a].overlap >= res[b].overlap));
        else
            assert_true(status[a] == PKSS_OK || status[b] != PKSS_OK);
    }
    /* order and status may be NULL */
    assert_int_equal(pkss_register_templates(ctx, src, t, 1, res, NULL, NULL), PKSS_OK);

    /* contract */
    assert_int_equal(pkss_register_templates(NULL, src, t, 3, res, status, order),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_register_templates(ctx, NULL, t, 3, res, status, order),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_register_templates(ctx, src, NULL, 3, res, status, order),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_register_templates(ctx, src, t, 0, res, status, order),
                     PKSS_ERR_INVALID_ARGUMENT);
    const pkss_cloud *holey[2] = {tpl[0], NULL};
    assert_int_equal(pkss_register_templates(ctx, src, holey, 2, res, status, order),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(pkss_context_last_error(ctx), "templates[1]"));
    res[2].struct_size = 8;
    assert_int_equal(pkss_register_templates(ctx, src, t, 3, res, status, order),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(pkss_context_last_error(ctx), "results[2]"));

    for (int i = 0; i < 3; ++i)
        pkss_cloud_destroy(tpl[i]);
    pkss_cloud_destroy(src);
    free(o1);
    free(o2);
    free_pairs(&p);
    pkss_context_destroy(ctx);
}

/* Cancelling stops the batch with CANCELLED and clears what was not tried. */
static int cancel_second(void *user, const pkss_progress *pr)
{
    int *dones = user;
    if (pr->stage == PKSS_PROGRESS_DONE)
        ++*dones;
    return *dones >= 1 && pr->stage == PKSS_PROGRESS_SEARCH;
}

static void test_templates_cancel(void **state)
{
    (void)state;
    pkss_context *ctx = make_context(PKSS_BACKEND_REFERENCE);
    assert_non_null(ctx);
    pairs p;
    load_pairs(&p);
    pkss_cloud *src = prepare(ctx, p.src[0], p.ns[0]);
    pkss_cloud *tpl[3] = {prepare(ctx, p.tgt[0], p.nt[0]), prepare(ctx, p.tgt[1], p.nt[1]),
                          prepare(ctx, p.tgt[2], p.nt[2])};
    int dones = 0;
    assert_int_equal(pkss_context_set_progress(ctx, cancel_second, &dones), PKSS_OK);
    pkss_result res[3];
    pkss_status status[3];
    size_t order[3];
    for (int i = 0; i < 3; ++i)
        pkss_result_init(&res[i], sizeof res[i]);
    assert_int_equal(pkss_register_templates(ctx, src, (const pkss_cloud *const *)tpl, 3,
                                             res, status, order),
                     PKSS_ERR_CANCELLED);
    assert_int_equal(status[0], PKSS_OK);
    assert_int_equal(status[1], PKSS_ERR_CANCELLED);
    assert_int_equal(status[2], PKSS_ERR_CANCELLED);
    assert_int_equal(res[2].n_candidates, 0);
    assert_true(order[0] == SIZE_MAX && order[2] == SIZE_MAX);
    assert_non_null(strstr(pkss_context_last_error(ctx), "template 1"));
    for (int i = 0; i < 3; ++i)
        pkss_cloud_destroy(tpl[i]);
    pkss_cloud_destroy(src);
    free_pairs(&p);
    pkss_context_destroy(ctx);
}

/* The fuzzer's seeds load and its regression inputs keep the contract
 * (tests/fuzz/{corpus,regressions}/cloud, prepared with points = 256). */
static void replay_dir(pkss_context *ctx, const char *dir, int must_load)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int files = 0;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        FILE *f = fopen(path, "rb");
        assert_non_null(f);
        unsigned char *b = malloc(1 << 20);
        assert_non_null(b);
        size_t size = fread(b, 1, 1 << 20, f);
        fclose(f);
        pkss_cloud *c = NULL;
        pkss_status st = pkss_cloud_deserialize(ctx, b, size, &c);
        if (must_load ? st != PKSS_OK
                      : (st != PKSS_ERR_CORRUPT_DATA && st != PKSS_ERR_STALE_DATA))
            fail_msg("%s: %s %s", path, pkss_status_name(st), pkss_context_last_error(ctx));
        pkss_cloud_destroy(c);
        free(b);
        ++files;
    }
    closedir(d);
    assert_true(files > 0);
}

static void test_fuzz_inputs(void **state)
{
    (void)state;
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256), PKSS_OK);
    replay_dir(ctx, PKSS_TEST_DATA_DIR "/../fuzz/corpus/cloud", 1);
    replay_dir(ctx, PKSS_TEST_DATA_DIR "/../fuzz/regressions/cloud", 0);
    pkss_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_bytes),
        cmocka_unit_test(test_fuzz_inputs),
        cmocka_unit_test(test_roundtrip_reference),
        cmocka_unit_test(test_roundtrip_opencl),
        cmocka_unit_test(test_register_templates),
        cmocka_unit_test(test_templates_cancel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
