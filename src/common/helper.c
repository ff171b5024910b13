/* SPDX-License-Identifier: MIT
 * helper.c -- the one extra thread of a call (pkss.h: "at most one extra
 * thread"). A job is offered to it; if it is busy (or cannot start) the
 * offer is refused and the caller runs the job itself, so nested offers
 * never wait on each other. Which thread runs a job never changes its
 * result: every job owns its outputs.
 * Both sides spin briefly (PKSS_HELPER_SPIN) before they sleep: an ICP
 * iteration hands over a job every few hundred microseconds, and waking a
 * sleeping thread took 20-60 us of each hand-over. The mutex still orders
 * every job; the spins only read the counters' atomic copies. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include "pkss_internal.h"

#include <string.h>
#include <time.h>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CPU_RELAX() _mm_pause()
#else
#define CPU_RELAX() ((void)0)
#endif

static double monotonic(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Spins until *count reaches target or PKSS_HELPER_SPIN seconds pass (the
 * clock is read every 64 turns). */
static void spin_until(const atomic_ulong *count, unsigned long target)
{
    double t0 = -1.0;
    for (unsigned turn = 1;; ++turn) {
        if (atomic_load_explicit(count, memory_order_acquire) >= target)
            return;
        if (turn % 64 == 0) {
            double t = monotonic();
            if (t0 < 0.0)
                t0 = t;
            else if (t - t0 > PKSS_HELPER_SPIN)
                return;
        }
        CPU_RELAX();
    }
}

static void *helper_main(void *arg)
{
    pkss__helper *h = arg;
    pthread_mutex_lock(&h->lock);
    for (;;) {
        if (!h->busy && !h->quit) {
            unsigned long next = h->submitted + 1;
            pthread_mutex_unlock(&h->lock);
            spin_until(&h->posted, next);
            pthread_mutex_lock(&h->lock);
        }
        while (!h->busy && !h->quit)
            pthread_cond_wait(&h->wake, &h->lock);
        if (!h->busy)
            break;
        void (*fn)(void *) = h->fn;
        void *job = h->arg;
        pthread_mutex_unlock(&h->lock);
        fn(job);
        pthread_mutex_lock(&h->lock);
        h->busy = 0;
        ++h->completed;
        atomic_store_explicit(&h->finished, h->completed, memory_order_release);
        pthread_cond_broadcast(&h->done);
    }
    pthread_mutex_unlock(&h->lock);
    return NULL;
}

void pkss__helper_init(pkss__helper *h)
{
    memset(h, 0, sizeof *h);
    atomic_init(&h->posted, 0);
    atomic_init(&h->finished, 0);
    pthread_mutex_init(&h->lock, NULL);
    pthread_cond_init(&h->wake, NULL);
    pthread_cond_init(&h->done, NULL);
}

void pkss__helper_close(pkss__helper *h)
{
    pthread_mutex_lock(&h->lock);
    h->quit = 1;
    pthread_cond_signal(&h->wake);
    int started = h->started;
    pthread_mutex_unlock(&h->lock);
    if (started)
        pthread_join(h->thread, NULL);
    pthread_mutex_destroy(&h->lock);
    pthread_cond_destroy(&h->wake);
    pthread_cond_destroy(&h->done);
}

unsigned long pkss__helper_offer(pkss__helper *h, void (*fn)(void *), void *arg)
{
    if (!h)
        return 0;
    unsigned long ticket = 0;
    pthread_mutex_lock(&h->lock);
    if (!h->started && !h->failed) {
        h->started = pthread_create(&h->thread, NULL, helper_main, h) == 0;
        h->failed = !h->started;
    }
    if (h->started && !h->busy && !h->quit) {
        h->fn = fn;
        h->arg = arg;
        h->busy = 1;
        ticket = ++h->submitted;
        atomic_store_explicit(&h->posted, h->submitted, memory_order_release);
        pthread_cond_signal(&h->wake);
    }
    pthread_mutex_unlock(&h->lock);
    return ticket;
}

int pkss__helper_wait(pkss__helper *h, unsigned long ticket, double seconds)
{
    if (seconds <= 0.0)
        spin_until(&h->finished, ticket);
    pthread_mutex_lock(&h->lock);
    if (seconds > 0.0 && h->completed < ticket) {
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        long ns = until.tv_nsec + (long)(seconds * 1e9);
        until.tv_sec += ns / 1000000000L;
        until.tv_nsec = ns % 1000000000L;
        pthread_cond_timedwait(&h->done, &h->lock, &until);
    }
    while (seconds <= 0.0 && h->completed < ticket)
        pthread_cond_wait(&h->done, &h->lock);
    int done = h->completed >= ticket;
    pthread_mutex_unlock(&h->lock);
    return done;
}

void pkss__helper_both(pkss__helper *h, void (*fn)(void *), void *a, void *b)
{
    unsigned long ticket = pkss__helper_offer(h, fn, b);
    fn(a);
    if (ticket)
        pkss__helper_wait(h, ticket, 0.0);
    else
        fn(b);
}
