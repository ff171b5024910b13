/* SPDX-License-Identifier: MIT
 * test_abi.c -- the ABI 1.0 contract (docs/compatibility.md): the growth
 * rule of struct_size-versioned structs (an older caller is never written
 * past and gets whole fields), the frozen stable layout of pkss_result,
 * candidates through their accessor, the parameter table, the progress
 * callback and cancellation, and what a failed call leaves behind.
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "pkss_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_abi";

/* The stable fields of pkss_result 1.0, as a caller built against the 1.0
 * header sees them. A change to any of them breaks this copy's layout. */
typedef struct result_1_0 {
    size_t struct_size;
    double T_target_source[16];
    double scale;
    double rotation[9];
    double translation[3];
    double score, rms, overlap, fit;
    uint32_t winner, n_candidates, n_rotations, n_offsets;
    uint64_t n_evaluations;
    pkss_counts source_counts, target_counts;
    pkss_timings timings;
    int32_t backend;
    uint32_t flags;
    char device[128];
    char note[256];
} result_1_0;

_Static_assert(sizeof(result_1_0) == PKSS_RESULT_MIN_SIZE,
               "the stable part of pkss_result 1.0 is frozen");
_Static_assert(offsetof(result_1_0, note) == offsetof(pkss_result, note),
               "stable fields keep their offsets");
_Static_assert(offsetof(result_1_0, n_evaluations) == offsetof(pkss_result, n_evaluations),
               "stable fields keep their offsets");

static double *load_sample(size_t *ns, double **tgt, size_t *nt)
{
    double *src = pkss_test_load_bundled("airplane_0001_s.ply", ns);
    *tgt = pkss_test_load_bundled("airplane_0001_t.ply", nt);
    assert_non_null(src);
    assert_non_null(*tgt);
    return src;
}

static pkss_context *ref_context(int points)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE),
                     PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, points), PKSS_OK);
    return ctx;
}

/* A 1.0 caller's struct, allocated to its exact size (ASan reports any
 * write past it), receives the same values as the full struct. */
static void test_old_caller(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    pkss_context *ctx = ref_context(600);
    pkss_result full;
    pkss_result_init(&full, sizeof full);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &full), PKSS_OK);
    result_1_0 *old = malloc(sizeof *old);
    pkss_result_init((pkss_result *)old, sizeof *old);
    assert_int_equal(old->struct_size, sizeof *old);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, (pkss_result *)old), PKSS_OK);
    assert_int_equal(old->struct_size, sizeof *old);
    assert_memory_equal(old->T_target_source, full.T_target_source, sizeof full.T_target_source);
    assert_memory_equal(old->rotation, full.rotation, sizeof full.rotation);
    assert_true(old->scale == full.scale && old->fit == full.fit);
    assert_int_equal(old->n_candidates, full.n_candidates);
    assert_int_equal(old->winner, full.winner);
    assert_int_equal(old->n_evaluations, full.n_evaluations);
    assert_memory_equal(&old->source_counts, &full.source_counts, sizeof full.source_counts);
    assert_string_equal(old->device, full.device);
    printf("  1.0 caller (%zu bytes, library struct %zu): same pose, scale %.6f\n",
           sizeof *old, sizeof full, old->scale);
    free(old);
    free(src);
    free(tgt);
    pkss_context_destroy(ctx);
}

/* Sizes below the 1.0 struct are refused without a write; a size that cuts
 * a field in two gets the fields before it and not that one. */
static void test_struct_sizes(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    pkss_context *ctx = ref_context(400);
    size_t big = sizeof(pkss_result) + 64;
    unsigned char *buf = malloc(big);
    pkss_result *r = (pkss_result *)buf;
    memset(buf, 0xAB, big);
    r->struct_size = PKSS_RESULT_MIN_SIZE - 1;
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, r), PKSS_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(pkss_context_last_error(ctx), "pkss_result_init"));
    for (size_t i = sizeof(size_t); i < big; ++i)
        assert_int_equal(buf[i], 0xAB);
    /* half of prepare_seconds: the stable fields, not the cut one */
    memset(buf, 0xAB, big);
    r->struct_size = PKSS_RESULT_MIN_SIZE + 4;
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, r), PKSS_OK);
    assert_true(r->T_target_source[15] == 1.0);
    for (size_t i = PKSS_RESULT_MIN_SIZE; i < big; ++i)
        assert_int_equal(buf[i], 0xAB);
    /* a candidate struct cut before `fit` */
    size_t cut = offsetof(pkss_candidate, fit);
    unsigned char *cbuf = malloc(sizeof(pkss_candidate) + 16);
    memset(cbuf, 0xCD, sizeof(pkss_candidate) + 16);
    pkss_candidate *c = (pkss_candidate *)cbuf;
    c->struct_size = cut;
    assert_int_equal(pkss_context_candidate(ctx, 0, c), PKSS_OK);
    assert_true(c->scale > 0);
    for (size_t i = cut; i < sizeof(pkss_candidate) + 16; ++i)
        assert_int_equal(cbuf[i], 0xCD);
    pkss_candidate whole = pkss_test_candidate(ctx, 0);
    assert_memory_equal(c->T_target_source, whole.T_target_source, sizeof whole.T_target_source);
    c->struct_size = 0;
    assert_int_equal(pkss_context_candidate(ctx, 0, c), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_context_candidate(ctx, PKSS_MAX_CANDIDATES, &whole),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_context_candidate(NULL, 0, &whole), PKSS_ERR_NULL_ARGUMENT);
    assert_true(pkss__abi_tables_complete());
    free(cbuf);
    free(buf);
    free(src);
    free(tgt);
    pkss_context_destroy(ctx);
}

/* A failed call leaves no pose and no candidates, a NULL context too. */
static void test_failed_call_clears(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    pkss_context *ctx = ref_context(400);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
    assert_true(res.n_candidates > 0);
    assert_int_equal(pkss_register(NULL, src, ns, tgt, nt, &res), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(res.n_candidates, 0);
    assert_true(res.T_target_source[15] == 0.0);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
    assert_int_equal(pkss_register(ctx, NULL, ns, tgt, nt, &res), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(res.n_candidates, 0);
    pkss_candidate c;
    pkss_candidate_init(&c, sizeof c);
    assert_int_equal(pkss_context_candidate(ctx, 0, &c), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_register_clouds(NULL, NULL, NULL, &res), PKSS_ERR_NULL_ARGUMENT);
    free(src);
    free(tgt);
    pkss_context_destroy(ctx);
}

/* The fields added after 1.0 (confidence, ambiguity, symmetry) and the
 * alternatives follow the growth rule: a 1.0-sized result is not written
 * past, an alternative cut short gets only its whole fields, and a failed
 * call leaves no alternatives. A generated box has some (its half turns). */
static void test_alternatives_growth(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_abi", 3)};
    enum { N = 8000 };
    double *box = malloc(3 * N * sizeof *box);
    assert_non_null(box);
    const double dims[3] = {1.0, 0.7, 0.45};
    for (size_t i = 0; i < N; ++i) {
        int face = (int)(pkss_test_uniform(&rng) * 3);
        for (int d = 0; d < 3; ++d)
            box[3 * i + d] = (pkss_test_uniform(&rng) - 0.5) * dims[d];
        box[3 * i + face] = (pkss_test_uniform(&rng) < 0.5 ? -0.5 : 0.5) * dims[face];
    }
    pkss_context *ctx = ref_context(0);
    unsigned char *buf = malloc(sizeof(pkss_result) + 16);
    assert_non_null(buf);
    memset(buf, 0xCD, sizeof(pkss_result) + 16);
    pkss_result *old = (pkss_result *)buf;
    old->struct_size = offsetof(pkss_result, confidence); /* a 1.0 caller's size */
    assert_int_equal(pkss_register(ctx, box, N, box, N, old), PKSS_OK);
    for (size_t i = offsetof(pkss_result, confidence); i < sizeof(pkss_result) + 16; ++i)
        assert_int_equal(buf[i], 0xCD);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, box, N, box, N, &res), PKSS_OK);
    assert_true(res.confidence >= 0.0 && res.confidence <= 1.0);
    assert_true(res.ambiguous);
    assert_true(res.n_alternatives > 0);
    assert_int_equal(res.symmetry, PKSS_SYMMETRY_DISCRETE);
    size_t cut = offsetof(pkss_alternative, candidate);
    unsigned char abuf[sizeof(pkss_alternative) + 16];
    memset(abuf, 0xCD, sizeof abuf);
    pkss_alternative *a = (pkss_alternative *)abuf;
    a->struct_size = cut;
    assert_int_equal(pkss_context_alternative(ctx, 0, a), PKSS_OK);
    assert_true(a->angle_degrees > 0.0 && a->angle_degrees <= 180.0);
    for (size_t i = cut; i < sizeof abuf; ++i)
        assert_int_equal(abuf[i], 0xCD);
    pkss_alternative whole;
    pkss_alternative_init(&whole, sizeof whole);
    assert_int_equal(pkss_context_alternative(ctx, res.n_alternatives, &whole),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_context_alternative(NULL, 0, &whole), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_context_alternative(ctx, 0, NULL), PKSS_ERR_NULL_ARGUMENT);
    whole.struct_size = 0;
    assert_int_equal(pkss_context_alternative(ctx, 0, &whole), PKSS_ERR_INVALID_ARGUMENT);
    pkss_alternative_init(&whole, sizeof whole);
    assert_int_equal(pkss_register(ctx, NULL, N, box, N, &res), PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_context_alternative(ctx, 0, &whole), PKSS_ERR_INVALID_ARGUMENT);
    assert_true(res.confidence == 0.0 && res.n_alternatives == 0);
    free(buf);
    free(box);
    pkss_context_destroy(ctx);
}

/* The table agrees with every other parameter call. */
static void test_param_table(void **state)
{
    (void)state;
    pkss_context *ctx;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    size_t n = pkss_param_count();
    assert_true(n >= 19);
    int last_id = 0;
    for (size_t i = 0; i < n; ++i) {
        pkss_param_info info;
        pkss_param_info_init(&info, sizeof info);
        assert_int_equal(pkss_param_at(i, &info), PKSS_OK);
        assert_true(info.id > last_id);
        last_id = info.id;
        assert_string_equal(info.name, pkss_param_name((pkss_param)info.id));
        pkss_param found;
        assert_int_equal(pkss_param_find(info.name, &found), PKSS_OK);
        assert_int_equal(found, info.id);
        assert_non_null(info.doc);
        size_t len = strlen(info.doc);
        assert_true(len > 10 && info.doc[len - 1] != '.');
        assert_non_null(info.unit);
        assert_non_null(info.constraint);
        assert_non_null(info.choices);
        if (info.type == PKSS_TYPE_STRING)
            continue;
        double lo, hi, def, now;
        assert_int_equal(pkss_param_bounds((pkss_param)info.id, &lo, &hi, &def), PKSS_OK);
        assert_true(lo == info.lower && hi == info.upper && def == info.default_value);
        assert_int_equal(pkss_context_get_double(ctx, (pkss_param)info.id, &now), PKSS_OK);
        assert_true(now == def);
        if (info.type == PKSS_TYPE_SWITCH || info.type == PKSS_TYPE_CHOICE) {
            int names = 1;
            for (const char *p = info.choices; *p; ++p)
                names += *p == '|';
            assert_int_equal(names, (int)info.upper + 1);
        } else {
            assert_string_equal(info.choices, "");
        }
    }
    pkss_param_info info;
    pkss_param_info_init(&info, sizeof info);
    assert_int_equal(pkss_param_at(n, &info), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_param_at(0, NULL), PKSS_ERR_NULL_ARGUMENT);
    pkss_param id;
    assert_int_equal(pkss_param_find("no_such_parameter", &id), PKSS_ERR_UNKNOWN_PARAMETER);
    /* a caller that knows only id and type */
    struct { size_t struct_size; int32_t id, type; const char *name; } small;
    memset(&small, 0xEE, sizeof small);
    small.struct_size = offsetof(pkss_param_info, name);
    assert_int_equal(pkss_param_at(0, (pkss_param_info *)&small), PKSS_OK);
    assert_int_equal(small.id, PKSS_PARAM_POINTS);
    assert_true(small.name == (const char *)(uintptr_t)0xEEEEEEEEEEEEEEEEull);
    pkss_context_destroy(ctx);
}

/* ------------------------------------------------------------ progress */
typedef struct watch {
    pthread_t caller;
    int calls, wrong_thread, out_of_order;
    int last_stage, cancel_at_stage;
    double cancelled_at;
    int seen[8];
} watch;

static int on_progress(void *user, const pkss_progress *p)
{
    watch *w = user;
    w->calls++;
    if (!pthread_equal(w->caller, pthread_self()))
        w->wrong_thread++;
    if (p->stage < w->last_stage)
        w->out_of_order++;
    w->last_stage = p->stage;
    if (p->stage >= 0 && p->stage < 8)
        w->seen[p->stage]++;
    if (w->cancel_at_stage && p->stage == w->cancel_at_stage && w->cancelled_at == 0) {
        w->cancelled_at = pkss__now();
        return 1;
    }
    return 0;
}

static void test_progress_stages(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    pkss_context *ctx = ref_context(1000);
    watch w = {.caller = pthread_self()};
    assert_int_equal(pkss_context_set_progress(ctx, on_progress, &w), PKSS_OK);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
    printf("  %d callbacks: device %d, preprocess %d, search %d, refine %d, done %d\n", w.calls,
           w.seen[PKSS_PROGRESS_DEVICE], w.seen[PKSS_PROGRESS_PREPROCESS],
           w.seen[PKSS_PROGRESS_SEARCH], w.seen[PKSS_PROGRESS_REFINE], w.seen[PKSS_PROGRESS_DONE]);
    assert_int_equal(w.wrong_thread, 0);
    assert_int_equal(w.out_of_order, 0);
    for (int s = PKSS_PROGRESS_DEVICE; s <= PKSS_PROGRESS_DONE; ++s)
        assert_true(w.seen[s] > 0);
    assert_int_equal(w.seen[PKSS_PROGRESS_DONE], 1);
    /* the same pose with and without a callback */
    pkss_result plain;
    pkss_result_init(&plain, sizeof plain);
    assert_int_equal(pkss_context_set_progress(ctx, NULL, NULL), PKSS_OK);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &plain), PKSS_OK);
    assert_memory_equal(plain.T_target_source, res.T_target_source, sizeof res.T_target_source);
    assert_int_equal(pkss_context_set_progress(NULL, NULL, NULL), PKSS_ERR_NULL_ARGUMENT);
    free(src);
    free(tgt);
    pkss_context_destroy(ctx);
}

/* Cancelling in each stage returns PKSS_ERR_CANCELLED within 100 ms. */
static void test_cancel(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    const int stages[] = {PKSS_PROGRESS_PREPROCESS, PKSS_PROGRESS_SEARCH, PKSS_PROGRESS_REFINE};
    for (size_t i = 0; i < sizeof stages / sizeof stages[0]; ++i) {
        pkss_context *ctx = ref_context(3000);
        watch w = {.caller = pthread_self(), .cancel_at_stage = stages[i]};
        pkss_context_set_progress(ctx, on_progress, &w);
        pkss_result res;
        pkss_result_init(&res, sizeof res);
        pkss_status st = pkss_register(ctx, src, ns, tgt, nt, &res);
        double latency = pkss__now() - w.cancelled_at;
        printf("  cancelled in stage %d: %s after %.1f ms (\"%s\")\n", stages[i],
               pkss_status_name(st), 1e3 * latency, pkss_context_last_error(ctx));
        assert_int_equal(st, PKSS_ERR_CANCELLED);
        assert_true(latency < 0.100);
        assert_int_equal(res.n_candidates, 0);
        assert_true(res.T_target_source[15] == 0.0);
        /* the context works again afterwards */
        pkss_context_set_progress(ctx, NULL, NULL);
        assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
        pkss_context_destroy(ctx);
    }
    /* a cloud's pre-processing can be cancelled too */
    pkss_context *ctx = ref_context(3000);
    watch w = {.caller = pthread_self(), .cancel_at_stage = PKSS_PROGRESS_PREPROCESS};
    pkss_context_set_progress(ctx, on_progress, &w);
    pkss_cloud *cloud = (pkss_cloud *)1;
    assert_int_equal(pkss_cloud_create(ctx, src, ns, &cloud), PKSS_ERR_CANCELLED);
    assert_null(cloud);
    pkss_context_destroy(ctx);
    free(src);
    free(tgt);
}

/* AUTO says when it did not use the device asked for. */
static void test_auto_reports_fallback(void **state)
{
    (void)state;
    size_t ns, nt;
    double *tgt, *src = load_sample(&ns, &tgt, &nt);
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 400);
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, "no-such-device-xyz"),
                     PKSS_OK);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
    printf("  flags %u, note \"%s\"\n", res.flags, res.note);
    assert_int_equal(res.backend, PKSS_BACKEND_REFERENCE);
    assert_true(res.flags & PKSS_FLAG_FELL_BACK);
    assert_true(strlen(res.note) > 10);
    /* the reference backend asked for: nothing to report */
    pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE);
    assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
    assert_int_equal(res.flags, 0);
    assert_string_equal(res.note, "");
    free(src);
    free(tgt);
    pkss_context_destroy(ctx);
}

int main(void)
{
    pkss_test_seed(PROGRAM, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_old_caller),
        cmocka_unit_test(test_struct_sizes),
        cmocka_unit_test(test_failed_call_clears),
        cmocka_unit_test(test_alternatives_growth),
        cmocka_unit_test(test_param_table),
        cmocka_unit_test(test_progress_stages),
        cmocka_unit_test(test_cancel),
        cmocka_unit_test(test_auto_reports_fallback),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
