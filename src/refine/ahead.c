/* SPDX-License-Identifier: MIT
 * ahead.c -- work done ahead on the call's helper thread while a search
 * runs on the device (ahead.h).
 */
#include "refine/ahead.h"

static void warm_fields(void *arg)
{
    pkss__warmup *w = arg;
    const pkss__icp_view *coarse[2] = {&w->v->tvc, &w->v->svc};
    for (int i = 0; i < 2; ++i)
        pkss__nn_field_warm(coarse[i]->field, coarse[i]->pts, coarse[i]->m, &w->stop);
}

void pkss__warm_begin(pkss__helper *helper, const pkss__views *v, pkss__warmup *w)
{
    w->v = v;
    atomic_init(&w->stop, 0);
    w->helper = helper;
    w->ticket = pkss__helper_offer(helper, warm_fields, w);
}

void pkss__warm_end(pkss__warmup *w)
{
    if (!w || !w->ticket)
        return;
    atomic_store_explicit(&w->stop, 1, memory_order_relaxed);
    pkss__helper_wait(w->helper, w->ticket, 0.0);
    w->ticket = 0;
}

static void compute_local_starts(void *arg)
{
    pkss__local_job *j = arg;
    j->st = pkss__local_starts(&j->v->svc, &j->v->tvc, j->seed, PKSS_LOCAL_STARTS,
                               j->starts, &j->n);
}

void pkss__local_begin(pkss__helper *helper, const pkss__views *v, uint64_t seed,
                       pkss__local_job *j)
{
    j->v = v;
    j->seed = seed;
    j->helper = helper;
    j->ticket = pkss__helper_offer(helper, compute_local_starts, j);
}

void pkss__local_wait(pkss__local_job *j)
{
    if (!j->ticket)
        return;
    pkss__helper_wait(j->helper, j->ticket, 0.0);
    j->ticket = 0;
    j->ready = 1;
}

pkss_status pkss__local_take(const pkss__views *v, uint64_t seed, pkss__local_job *j)
{
    pkss__local_wait(j);
    if (!j->ready) {
        pkss__local_begin(NULL, v, seed, j); /* no helper: records the inputs */
        compute_local_starts(j);
        j->ready = 1;
    }
    return j->st;
}
