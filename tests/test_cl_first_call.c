/* SPDX-License-Identifier: MIT
 * test_cl_first_call.c -- the first registration of a process: it starts
 * the OpenCL driver on a thread of its own while the clouds are built
 * (device.c:pkss__cl_warmup_begin). Nothing in this program may list
 * devices before those calls, or the driver would be started already:
 * the tests run in this order, and the device check comes last.
 *
 * What the overlap must not change: stages are reported in pipeline order
 * on the calling thread, a cancel at the device stage stops the call
 * before any work, a device failure is reported before an input failure,
 * and the pose is the one of a context prepared beforehand.
 */
#include "support.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct stages {
    pthread_t caller;
    int order_ok, thread_ok, calls, cancel_device;
    int last, seen[8];
} stages;

static int on_progress(void *user, const pkss_progress *p)
{
    stages *s = user;
    s->calls++;
    s->thread_ok &= pthread_equal(s->caller, pthread_self()) != 0;
    s->order_ok &= p->stage >= s->last;
    s->last = p->stage;
    if (p->stage >= 0 && p->stage < 8)
        s->seen[p->stage]++;
    return s->cancel_device && p->stage == PKSS_PROGRESS_DEVICE;
}

static double *g_src, *g_tgt;
static size_t g_ns, g_nt;

static void load_pair(void)
{
    if (g_src)
        return;
    g_src = pkss_test_load_bundled("airplane_0001_s.ply", &g_ns);
    g_tgt = pkss_test_load_bundled("airplane_0001_t.ply", &g_nt);
    assert_non_null(g_src);
    assert_non_null(g_tgt);
}

static pkss_context *small_context(void)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 1000), PKSS_OK);
    return ctx;
}

/* First: a cancel at the device stage, before the driver is started. */
static void test_cancel_at_device_stage(void **state)
{
    (void)state;
    load_pair();
    pkss_context *ctx = small_context();
    stages s = {.caller = pthread_self(), .order_ok = 1, .thread_ok = 1,
                .cancel_device = 1};
    assert_int_equal(pkss_context_set_progress(ctx, on_progress, &s), PKSS_OK);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, g_src, g_ns, g_tgt, g_nt, &res),
                     PKSS_ERR_CANCELLED);
    assert_int_equal(s.seen[PKSS_PROGRESS_DEVICE], 1);
    assert_int_equal(s.seen[PKSS_PROGRESS_PREPROCESS], 0); /* no work done */
    assert_int_equal(s.seen[PKSS_PROGRESS_SEARCH], 0);
    assert_true(s.order_ok && s.thread_ok);
    pkss_context_destroy(ctx);
}

/* Then the first full call, with the driver starting alongside. */
static void test_first_call_matches_prepared(void **state)
{
    (void)state;
    load_pair();
    pkss_context *ctx = small_context();
    stages s = {.caller = pthread_self(), .order_ok = 1, .thread_ok = 1};
    assert_int_equal(pkss_context_set_progress(ctx, on_progress, &s), PKSS_OK);
    pkss_result first;
    pkss_result_init(&first, sizeof first);
    assert_int_equal(pkss_register(ctx, g_src, g_ns, g_tgt, g_nt, &first), PKSS_OK);
    printf("  first call on %s: prepare %.4f s (waited), preprocess %.4f s\n",
           first.device, first.prepare_seconds, first.timings.preprocess);
    assert_true(s.order_ok && s.thread_ok);
    for (int st = PKSS_PROGRESS_DEVICE; st <= PKSS_PROGRESS_DONE; ++st)
        assert_true(s.seen[st] > 0);
    assert_true(s.seen[PKSS_PROGRESS_DEVICE] == 1);

    /* the same pose from a context whose device was opened beforehand */
    pkss_context *ready = small_context();
    assert_int_equal(pkss_context_prepare(ready), PKSS_OK);
    pkss_result again;
    pkss_result_init(&again, sizeof again);
    assert_int_equal(pkss_register(ready, g_src, g_ns, g_tgt, g_nt, &again), PKSS_OK);
    assert_string_equal(first.device, again.device);
    assert_memory_equal(first.T_target_source, again.T_target_source,
                        sizeof first.T_target_source);
    assert_true(again.prepare_seconds == 0.0); /* prepared: nothing to wait for */
    pkss_context_destroy(ready);
    pkss_context_destroy(ctx);
}

/* A device that cannot be opened is reported before bad input, as when the
 * device was opened before the clouds were built. */
static void test_device_failure_before_input_failure(void **state)
{
    (void)state;
    pkss_context *ctx = small_context();
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND,
                                          PKSS_BACKEND_OPENCL), PKSS_OK);
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE,
                                             "no-such-device-first-call"), PKSS_OK);
    double pts[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}; /* too few */
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_register(ctx, pts, 4, pts, 4, &res);
    const char *detail = pkss_context_last_error(ctx);
    printf("  %s: %s\n", pkss_status_name(st), detail);
    /* no matching device, or no OpenCL at all: a device status either way */
    assert_true(st == PKSS_ERR_NO_DEVICE || st == PKSS_ERR_UNSUPPORTED);
    /* with a device that opens, the input's own failure and its detail */
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND,
                                          PKSS_BACKEND_REFERENCE), PKSS_OK);
    assert_int_equal(pkss_register(ctx, pts, 4, pts, 4, &res), PKSS_ERR_TOO_FEW_POINTS);
    assert_non_null(strstr(pkss_context_last_error(ctx), "source"));
    pkss_context_destroy(ctx);
}

int main(void)
{
    pkss_test_seed("test_cl_first_call", 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cancel_at_device_stage),
        cmocka_unit_test(test_first_call_matches_prepared),
        cmocka_unit_test(test_device_failure_before_input_failure),
    };
    int rc = cmocka_run_group_tests_name("test_cl_first_call", tests, NULL, NULL);
    free(g_src);
    free(g_tgt);
    return rc;
}
