/* SPDX-License-Identifier: MIT
 * ahead.h -- work done ahead on the call's helper thread while a search runs
 * on the device, which leaves the helper idle (ahead.c): the coarse views'
 * field lists during the first search, the starts from local shape during
 * the wide one.
 * Each job ends (or is waited for) before what it touches is freed; which
 * thread does the work never changes a result.
 */
#ifndef PKSS_REFINE_AHEAD_H
#define PKSS_REFINE_AHEAD_H

#include "refine/stages.h"

/* The coarse views' fields built ahead (pkss__nn_field_warm), each over its
 * own points: every candidate's coarse level reads them. The full views'
 * lists are built as the few full runs ask: built here too, they slowed a
 * CPU device's scoring by about their own cost (docs/tuning.md). */
typedef struct pkss__warmup {
    const pkss__views *v;
    pkss__helper *helper;
    unsigned long ticket; /* 0: not running */
    atomic_int stop;
} pkss__warmup;

/* Offers the warm-up to helper (NULL: none; a busy helper refuses it). */
void pkss__warm_begin(pkss__helper *helper, const pkss__views *v, pkss__warmup *w);
/* Stops it within one cube's list and waits for it (idempotent; w may be
 * NULL). */
void pkss__warm_end(pkss__warmup *w);

/* The starts from local shape (pkss__local_starts): they depend on the
 * coarse views and the seed alone. */
typedef struct pkss__local_job {
    const pkss__views *v;
    uint64_t seed;
    pkss__helper *helper;
    unsigned long ticket; /* 0: not on the helper */
    int ready;            /* starts computed */
    pkss_status st;
    size_t n;
    pkss__pose starts[PKSS_LOCAL_STARTS];
} pkss__local_job;

/* Offers their computation to helper (NULL: none). */
void pkss__local_begin(pkss__helper *helper, const pkss__views *v, uint64_t seed,
                       pkss__local_job *j);
/* Waits for the helper's computation, if it took it (idempotent). */
void pkss__local_wait(pkss__local_job *j);
/* The starts in j->starts[0..j->n): the helper's, or computed here. */
pkss_status pkss__local_take(const pkss__views *v, uint64_t seed, pkss__local_job *j);

#endif
