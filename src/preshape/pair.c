/* SPDX-License-Identifier: MIT
 * pair.c -- pre-processing the two clouds of a registration at once: the
 * source on the calling thread, the target on the call's helper thread;
 * then the target's dense-view planes and tree on both. The source's dense
 * view is only sampled (fine.c), so it gets neither.
 */
#include "pkss_internal.h"

#include <string.h>

/* Each job has its own copy of the context for the error detail, so the
 * two never share a buffer; the copies share the call's run state. */
typedef struct build_job {
    pkss_context ctx;
    const double *xyz;
    size_t n;
    const char *which;
    pkss__prep *prep;
    pkss_status st;
} build_job;

static void build_worker(void *arg)
{
    build_job *j = arg;
    j->st = pkss__prep_open(&j->ctx, j->xyz, j->n, j->which, &j->prep);
}

/* While the helper builds the target, the caller keeps the progress
 * callback alive (cancellation stays prompt), waking every
 * PKSS_WAIT_TICK seconds or as soon as the job is done. */
static void wait_ticking(pkss_context *ctx, pkss__helper *helper, unsigned long ticket)
{
    while (!pkss__helper_wait(helper, ticket, PKSS_WAIT_TICK))
        pkss__tick(ctx->run);
}

pkss_status pkss__cloud_build_pair(pkss_context *ctx, const double *source,
                                   size_t n_source, const double *target,
                                   size_t n_target, pkss_cloud **src,
                                   pkss_cloud **tgt)
{
    build_job *jobs = pkss__calloc(2, sizeof *jobs);
    if (!jobs)
        return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    const double *xyz[2] = {source, target};
    const size_t n[2] = {n_source, n_target};
    const char *which[2] = {"source", "target"};
    for (int i = 0; i < 2; ++i) {
        jobs[i].ctx.params = ctx->params;
        jobs[i].ctx.run = ctx->run;
        jobs[i].xyz = xyz[i];
        jobs[i].n = n[i];
        jobs[i].which = which[i];
    }
    pkss__helper *helper = pkss__run_helper(ctx->run);
    unsigned long ticket = pkss__helper_offer(helper, build_worker, &jobs[1]);
    build_worker(&jobs[0]);
    if (ticket)
        wait_ticking(ctx, helper, ticket);
    else
        build_worker(&jobs[1]);
    if (jobs[0].st == PKSS_OK && jobs[1].st == PKSS_OK)
        jobs[1].st = pkss__prep_planes(jobs[1].prep, helper);
    /* the source's error first, as in a sequential run */
    pkss_status st = PKSS_OK;
    for (int i = 0; i < 2 && st == PKSS_OK; ++i)
        if (jobs[i].st != PKSS_OK) {
            st = jobs[i].st;
            memcpy(ctx->detail, jobs[i].ctx.detail, sizeof ctx->detail);
        }
    pkss__prep_close(jobs[0].prep, st == PKSS_OK ? src : NULL);
    pkss__prep_close(jobs[1].prep, st == PKSS_OK ? tgt : NULL);
    pkss__free(jobs);
    return st;
}
