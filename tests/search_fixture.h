/* SPDX-License-Identifier: MIT
 * search_fixture.h -- builds the pkss__search_input of two clouds exactly as
 * src/register.c does (pre-shape points from pkss__cloud_build, PCA
 * pre-alignment of the source, feature copies, template offsets along the
 * PCA axes), so that a test or a benchmark can run one search backend in
 * isolation. Header-only (static functions); used by tests/test_cl_search.c
 * and tools/bench_search.c.
 */
#ifndef PKSS_SEARCH_FIXTURE_H
#define PKSS_SEARCH_FIXTURE_H

#include "pkss_internal.h"
#include "pkss_shared.h"

#include <stdlib.h>
#include <string.h>

typedef struct search_fixture {
    pkss_cloud *src, *tgt;
    pkss__rotation_set rot;
    float edges[PKSS_EDGES_SIZE];
    float *src_pts, *tgt_pts, *src_feat, *tgt_feat, *offsets;
    int n_off;
    pkss__search_input in;
    double prep_seconds; /* both clouds' pre-processing */
} search_fixture;

static void search_fixture_free(search_fixture *f)
{
    pkss_cloud_destroy(f->src);
    pkss_cloud_destroy(f->tgt);
    pkss__rotations_free(&f->rot);
    free(f->src_pts);
    free(f->tgt_pts);
    free(f->src_feat);
    free(f->tgt_feat);
    free(f->offsets);
    memset(f, 0, sizeof *f);
}

static void search_fixture_to_float(const double *in, size_t n, const double *R,
                                    float *out)
{
    for (size_t i = 0; i < n; ++i) {
        double y[3];
        if (R)
            pkss__mat3_apply(R, in + 3 * i, y);
        else
            memcpy(y, in + 3 * i, sizeof y);
        out[3 * i] = (float)y[0];
        out[3 * i + 1] = (float)y[1];
        out[3 * i + 2] = (float)y[2];
    }
}

/* Pre-processes both inputs with ctx's parameters and builds the search
 * input for ctx's search parameters. Returns PKSS_OK or the failure. */
static pkss_status search_fixture_build(pkss_context *ctx, const double *src,
                                        size_t ns, const double *tgt, size_t nt,
                                        search_fixture *f)
{
    memset(f, 0, sizeof *f);
    const pkss__params *p = &ctx->params;
    double t0 = pkss__now();
    pkss_status st = pkss__cloud_build(ctx, src, ns, "source", &f->src);
    if (st == PKSS_OK)
        st = pkss__cloud_build(ctx, tgt, nt, "target", &f->tgt);
    if (st == PKSS_OK)
        st = pkss__rotations_build(p, &f->rot);
    if (st != PKSS_OK) {
        search_fixture_free(f);
        return st;
    }
    f->prep_seconds = pkss__now() - t0;
    int n_az = p->cell_steps ? p->cell_steps : p->rotation_steps;
    pkss__cell_edges(n_az, f->edges);
    double R_pre[9];
    if (p->pca_prealign) {
        double St[9];
        pkss__mat3_transpose(f->src->axes, St);
        pkss__mat3_mul(f->tgt->axes, St, R_pre);
    } else {
        pkss__mat3_identity(R_pre);
    }
    const pkss_cloud *s = f->src, *t = f->tgt;
    int N = p->offset_steps, h = N / 2;
    f->n_off = N * N * N;
    f->offsets = malloc((size_t)f->n_off * 3 * sizeof(float));
    f->src_pts = malloc(s->m * 3 * sizeof(float));
    f->tgt_pts = malloc(t->m * 3 * sizeof(float));
    f->src_feat = malloc((s->n_feat + 1) * 3 * sizeof(float));
    f->tgt_feat = malloc((t->n_feat + 1) * 3 * sizeof(float));
    if (!f->offsets || !f->src_pts || !f->tgt_pts || !f->src_feat || !f->tgt_feat) {
        search_fixture_free(f);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    int k = 0;
    for (int a = -h; a <= h; ++a)
        for (int b = -h; b <= h; ++b)
            for (int c = -h; c <= h; ++c) {
                double q[3] = {a * t->half_extent[0] / 8.0,
                               b * t->half_extent[1] / 8.0,
                               c * t->half_extent[2] / 8.0};
                for (int d = 0; d < 3; ++d)
                    f->offsets[3 * k + d] = (float)(t->axes[3 * d] * q[0] +
                                                    t->axes[3 * d + 1] * q[1] +
                                                    t->axes[3 * d + 2] * q[2]);
                ++k;
            }
    search_fixture_to_float(s->pre, s->m, R_pre, f->src_pts);
    search_fixture_to_float(t->pre, t->m, NULL, f->tgt_pts);
    for (size_t i = 0; i < s->n_feat; ++i)
        memcpy(f->src_feat + 3 * i, f->src_pts + 3 * (size_t)s->feat[i], 3 * sizeof(float));
    for (size_t i = 0; i < t->n_feat; ++i)
        memcpy(f->tgt_feat + 3 * i, f->tgt_pts + 3 * (size_t)t->feat[i], 3 * sizeof(float));
    pkss__search_input in = {
        .n_az = n_az, .edges = f->edges,
        .src_pts = f->src_pts, .n_src = (int)s->m,
        .src_feat = f->src_feat, .n_src_feat = (int)s->n_feat,
        .tgt_pts = f->tgt_pts, .n_tgt = (int)t->m,
        .tgt_feat = f->tgt_feat, .n_tgt_feat = (int)t->n_feat,
        .rot = &f->rot, .n_offsets = f->n_off, .offsets = f->offsets,
        .use_features = p->use_features,
    };
    f->in = in;
    return PKSS_OK;
}

#endif /* PKSS_SEARCH_FIXTURE_H */
