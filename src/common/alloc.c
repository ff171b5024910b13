/* SPDX-License-Identifier: MIT
 * alloc.c -- the allocation wrappers every module uses (so tests can inject
 * failures, libuv style) and a monotonic clock. */
#define _POSIX_C_SOURCE 200809L
#include "pkss_internal.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>

/* -1: never fail; otherwise the number of allocations still allowed. Only
 * for tests; atomic so concurrent contexts stay well-defined. */
static atomic_llong alloc_budget = -1;

void pkss__test_set_alloc_budget(long long budget)
{
    atomic_store(&alloc_budget, budget);
}

static int alloc_allowed(void)
{
    long long b = atomic_load(&alloc_budget);
    if (b < 0)
        return 1;
    while (b > 0) {
        if (atomic_compare_exchange_weak(&alloc_budget, &b, b - 1))
            return 1;
    }
    return 0;
}

void *pkss__malloc(size_t size)
{
    if (!alloc_allowed())
        return NULL;
    return malloc(size ? size : 1);
}

void *pkss__calloc(size_t count, size_t size)
{
    if (!alloc_allowed())
        return NULL;
    if (count == 0 || size == 0)
        count = size = 1;
    return calloc(count, size);
}

void *pkss__realloc(void *ptr, size_t size)
{
    if (!alloc_allowed())
        return NULL;
    return realloc(ptr, size ? size : 1);
}

void pkss__free(void *ptr) { free(ptr); }

double pkss__now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
