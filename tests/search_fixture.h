/* SPDX-License-Identifier: MIT
 * search_fixture.h -- pre-processes two clouds and builds their search
 * input with pkss__search_setup_build, exactly as src/refine/register.c does, so
 * that a test or a benchmark can run one search backend in isolation.
 * Header-only (static functions); used by tests/test_cl_search.c and
 * tools/bench_search.c.
 */
#ifndef PKSS_SEARCH_FIXTURE_H
#define PKSS_SEARCH_FIXTURE_H

#include "pkss_internal.h"
#include "pkss_shared.h"

#include <stdlib.h>
#include <string.h>

typedef struct search_fixture {
    pkss_cloud *src, *tgt;
    pkss__search_setup setup; /* setup.in is the search input */
    double prep_seconds;      /* both clouds' pre-processing */
} search_fixture;

static void search_fixture_free(search_fixture *f)
{
    pkss_cloud_destroy(f->src);
    pkss_cloud_destroy(f->tgt);
    pkss__search_setup_free(&f->setup);
    memset(f, 0, sizeof *f);
}

/* Pre-processes both inputs with ctx's parameters and builds the search
 * input for ctx's search parameters (pkss__search_setup_build, as
 * src/refine/register.c does). Returns PKSS_OK or the failure. */
static pkss_status search_fixture_build(pkss_context *ctx, const double *src,
                                        size_t ns, const double *tgt, size_t nt,
                                        search_fixture *f)
{
    memset(f, 0, sizeof *f);
    double t0 = pkss__now();
    pkss_status st = pkss__cloud_build(ctx, src, ns, "source", &f->src);
    if (st == PKSS_OK)
        st = pkss__cloud_build(ctx, tgt, nt, "target", &f->tgt);
    f->prep_seconds = pkss__now() - t0;
    if (st == PKSS_OK)
        st = pkss__search_setup_build(&ctx->params, f->src, f->tgt, &f->setup);
    if (st != PKSS_OK)
        search_fixture_free(f);
    return st;
}

#endif /* PKSS_SEARCH_FIXTURE_H */
