/* SPDX-License-Identifier: MIT
 * identify.c -- one prepared source against many prepared templates
 * (retrieval): each template is registered exactly as by
 * pkss_register_clouds, then the templates are ranked by fit, overlap.
 */
#include "pkss_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct rank_entry {
    size_t index;
    int ok;
    double fit, overlap;
} rank_entry;

/* Best first: registered before failed, then fit and overlap descending
 * (the fit picks the winner among a registration's own candidates too),
 * then the template's index: a total order, so the ranking is stable. */
static int cmp_rank(const void *a, const void *b)
{
    const rank_entry *x = a, *y = b;
    if (x->ok != y->ok)
        return x->ok ? -1 : 1;
    if (x->ok) {
        if (x->fit != y->fit)
            return x->fit > y->fit ? -1 : 1;
        if (x->overlap != y->overlap)
            return x->overlap > y->overlap ? -1 : 1;
    }
    return (x->index > y->index) - (x->index < y->index);
}

/* Statuses that say something about one template, not about the batch. */
static int per_template(pkss_status st)
{
    return st == PKSS_ERR_NO_CONSENSUS || st == PKSS_ERR_DEGENERATE;
}

pkss_status pkss_register_templates(pkss_context *ctx, const pkss_cloud *source,
                                    const pkss_cloud *const *templates,
                                    size_t n, pkss_result *results,
                                    pkss_status *status, size_t *order)
{
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    PKSS_RETURN_IF(!source, ctx, PKSS_ERR_NULL_ARGUMENT, "source cloud is NULL");
    PKSS_RETURN_IF(!templates || !results, ctx, PKSS_ERR_NULL_ARGUMENT,
                   "%s is NULL", templates ? "results" : "templates");
    PKSS_RETURN_IF(n == 0, ctx, PKSS_ERR_INVALID_ARGUMENT, "n = 0 templates");
    PKSS_RETURN_IF(n > SIZE_MAX / sizeof(rank_entry), ctx,
                   PKSS_ERR_INVALID_ARGUMENT, "n = %zu templates is too many", n);
    for (size_t i = 0; i < n; ++i) {
        PKSS_RETURN_IF(!templates[i], ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "templates[%zu] is NULL", i);
        PKSS_RETURN_IF(results[i].struct_size < PKSS_RESULT_MIN_SIZE, ctx,
                       PKSS_ERR_INVALID_ARGUMENT,
                       "results[%zu].struct_size %zu is smaller than pkss_result "
                       "1.0 (%zu): call pkss_result_init on each result",
                       i, results[i].struct_size, (size_t)PKSS_RESULT_MIN_SIZE);
    }
    rank_entry *rank = pkss__malloc(n * sizeof *rank);
    PKSS_RETURN_IF(!rank, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    /* the first per-template failure's detail, reported at the end */
    char *first_detail = pkss__calloc(1, PKSS_DETAIL_SIZE);
    if (!first_detail) {
        pkss__free(rank);
        return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    }
    pkss_status st = PKSS_OK;
    size_t i = 0;
    for (; i < n; ++i) {
        /* the same call a caller would make: bit-identical by construction */
        pkss_status s = pkss_register_clouds(ctx, source, templates[i], &results[i]);
        if (status)
            status[i] = s;
        rank[i].index = i;
        rank[i].ok = s == PKSS_OK;
        rank[i].fit = results[i].fit;
        rank[i].overlap = results[i].overlap;
        if (s != PKSS_OK && !per_template(s)) {
            st = s; /* the detail of this failure stays in ctx */
            break;
        }
        if (s != PKSS_OK && !first_detail[0])
            snprintf(first_detail, PKSS_DETAIL_SIZE, "template %zu: %.4000s", i,
                     ctx->detail);
    }
    if (st != PKSS_OK) {
        char detail[PKSS_DETAIL_SIZE];
        snprintf(detail, sizeof detail, "%s", ctx->detail);
        for (size_t j = i + 1; j < n; ++j) {
            pkss__clear_result(&results[j]);
            if (status)
                status[j] = st;
        }
        if (order)
            for (size_t j = 0; j < n; ++j)
                order[j] = SIZE_MAX;
        pkss__fail(ctx, st, "template %zu: %.4000s", i, detail);
    } else {
        qsort(rank, n, sizeof *rank, cmp_rank);
        if (order)
            for (size_t j = 0; j < n; ++j)
                order[j] = rank[j].index;
        snprintf(ctx->detail, sizeof ctx->detail, "%s", first_detail);
    }
    pkss__free(first_detail);
    pkss__free(rank);
    return st;
}
