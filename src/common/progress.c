/* SPDX-License-Identifier: MIT
 * progress.c -- the progress callback and cancellation (pkss.h, Progress).
 * A call that pre-processes or registers opens a run on its context; every
 * stage reaches pkss__checkpoint() often. Only the calling thread invokes
 * the user's callback (bindings such as Python need that, to raise a
 * KeyboardInterrupt); worker threads read the shared cancelled flag. */
#define _POSIX_C_SOURCE 200809L /* pthread_equal */
#include "pkss_internal.h"

#include <pthread.h>
#include <string.h>

void pkss__run_begin(pkss_context *ctx, pkss__run *run)
{
    memset(run, 0, sizeof *run);
    run->fn = ctx->progress_fn;
    run->user = ctx->progress_user;
    run->caller = pthread_self();
    run->t0 = pkss__now();
    run->last_call = -1.0;
    atomic_init(&run->cancelled, 0);
    pkss__helper_init(&run->helper);
    ctx->run = run;
}

void pkss__run_end(pkss_context *ctx)
{
    if (ctx->run)
        pkss__helper_close(&ctx->run->helper);
    ctx->run = NULL;
}

int pkss__cancelled(const pkss__run *run)
{
    return run && atomic_load_explicit(&run->cancelled, memory_order_relaxed);
}

pkss_status pkss__checkpoint(pkss__run *run, int stage, uint32_t step,
                             uint32_t steps)
{
    if (!run || !pthread_equal(run->caller, pthread_self()))
        return pkss__cancelled(run) ? PKSS_ERR_CANCELLED : PKSS_OK;
    int changed = stage != run->stage;
    run->stage = stage;
    run->step = step;
    run->steps = steps;
    if (run->fn && !pkss__cancelled(run)) {
        double now = pkss__now();
        if (changed || now - run->last_call >= PKSS_PROGRESS_INTERVAL) {
            pkss_progress p = {sizeof p, stage, step, steps, now - run->t0};
            run->last_call = now;
            if (run->fn(run->user, &p) != 0)
                atomic_store(&run->cancelled, 1);
        }
    }
    return pkss__cancelled(run) ? PKSS_ERR_CANCELLED : PKSS_OK;
}

pkss_status pkss__cancel_fail(pkss_context *ctx)
{
    return pkss__fail(ctx, PKSS_ERR_CANCELLED,
                      "cancelled by the progress callback");
}

pkss_status pkss__tick(pkss__run *run)
{
    if (!run || !pthread_equal(run->caller, pthread_self()))
        return pkss__cancelled(run) ? PKSS_ERR_CANCELLED : PKSS_OK;
    return pkss__checkpoint(run, run->stage, run->step, run->steps);
}
