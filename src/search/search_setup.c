/* SPDX-License-Identifier: MIT
 * search_setup.c -- assembles the input of the global search (SPEC 5) from
 * two pre-processed clouds: the bin edges, the PCA pre-alignment of the
 * source (SPEC 2.7), the rotation candidates, the template's centre offsets
 * along its PCA axes (Eq. 11-12) and the float32 point and feature copies
 * the backends read. Used by register.c and by the tests and benchmarks
 * that run one backend in isolation, so they all search the same thing.
 */
#include "pkss_internal.h"

#include <string.h>

/* Offsets of the template's binning centre along its PCA axes (Eq. 11-12,
 * SPEC 5): q = (a E_u u + b E_v v + c E_w w) / div, a, b, c in -h..h;
 * div = 8 is the paper's grid (+-E/4 at N = 5), div = 4 the wide one
 * (pkss__search_setup_widen). */
static float *build_offsets(const pkss_cloud *tgt, int N, double div,
                            int *count)
{
    int h = N / 2, n = N * N * N;
    float *q = pkss__malloc((size_t)n * 3 * sizeof(float));
    if (!q)
        return NULL;
    int k = 0;
    for (int a = -h; a <= h; ++a)
        for (int b = -h; b <= h; ++b)
            for (int c = -h; c <= h; ++c) {
                double f[3] = {a * tgt->half_extent[0] / div,
                               b * tgt->half_extent[1] / div,
                               c * tgt->half_extent[2] / div};
                for (int d = 0; d < 3; ++d)
                    q[3 * k + d] = (float)(tgt->axes[3 * d] * f[0] +
                                           tgt->axes[3 * d + 1] * f[1] +
                                           tgt->axes[3 * d + 2] * f[2]);
                ++k;
            }
    *count = n;
    return q;
}

static void to_float(const double *in, size_t n, const double *R, float *out)
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

void pkss__search_setup_free(pkss__search_setup *s)
{
    if (!s)
        return;
    pkss__rotations_free(&s->rot);
    pkss__free(s->offsets);
    pkss__free(s->src_pts);
    pkss__free(s->tgt_pts);
    pkss__free(s->src_feat);
    pkss__free(s->tgt_feat);
    memset(s, 0, sizeof *s);
}

pkss_status pkss__search_setup_build(const pkss__params *p,
                                     const pkss_cloud *src,
                                     const pkss_cloud *tgt,
                                     pkss__search_setup *s)
{
    memset(s, 0, sizeof *s);
    s->n_az = p->cell_steps ? p->cell_steps : p->rotation_steps;
    pkss__cell_edges(s->n_az, s->edges);
    /* SPEC 2.7: rotate the source into the template's principal frame. */
    if (p->pca_prealign) {
        double St[9];
        pkss__mat3_transpose(src->axes, St);
        pkss__mat3_mul(tgt->axes, St, s->R_pre);
    } else {
        pkss__mat3_identity(s->R_pre);
    }
    pkss_status st = pkss__rotations_build(p, &s->rot);
    if (st != PKSS_OK) {
        pkss__search_setup_free(s);
        return st;
    }
    s->offsets = build_offsets(tgt, p->offset_steps, PKSS_OFFSET_DIV, &s->n_offsets);
    s->src_pts = pkss__malloc(src->m * 3 * sizeof(float));
    s->tgt_pts = pkss__malloc(tgt->m * 3 * sizeof(float));
    s->src_feat = pkss__malloc((src->n_feat + 1) * 3 * sizeof(float));
    s->tgt_feat = pkss__malloc((tgt->n_feat + 1) * 3 * sizeof(float));
    if (!s->offsets || !s->src_pts || !s->tgt_pts || !s->src_feat || !s->tgt_feat) {
        pkss__search_setup_free(s);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    to_float(src->pre, src->m, s->R_pre, s->src_pts);
    to_float(tgt->pre, tgt->m, NULL, s->tgt_pts);
    for (size_t i = 0; i < src->n_feat; ++i)
        memcpy(s->src_feat + 3 * i, s->src_pts + 3 * (size_t)src->feat[i], 3 * sizeof(float));
    for (size_t i = 0; i < tgt->n_feat; ++i)
        memcpy(s->tgt_feat + 3 * i, s->tgt_pts + 3 * (size_t)tgt->feat[i], 3 * sizeof(float));
    pkss__search_input in = {
        .n_az = s->n_az, .edges = s->edges,
        .src_pts = s->src_pts, .n_src = (int)src->m,
        .src_feat = s->src_feat, .n_src_feat = (int)src->n_feat,
        .tgt_pts = s->tgt_pts, .n_tgt = (int)tgt->m,
        .tgt_feat = s->tgt_feat, .n_tgt_feat = (int)tgt->n_feat,
        .rot = &s->rot, .n_offsets = s->n_offsets, .offsets = s->offsets,
        .use_features = p->use_features,
        .keep = 1.0f,
        .src_cover = 0.0f,
    };
    s->in = in;
    return PKSS_OK;
}

pkss_status pkss__search_setup_widen(const pkss__params *p,
                                     const pkss_cloud *tgt,
                                     pkss__search_setup *s)
{
    int n;
    float *q = build_offsets(tgt, p->offset_steps, PKSS_WIDE_OFFSET_DIV, &n);
    if (!q)
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss__free(s->offsets);
    s->offsets = q;
    s->n_offsets = n;
    s->in.offsets = q;
    s->in.n_offsets = n;
    s->in.keep = PKSS_WIDE_KEEP;
    s->in.src_cover = PKSS_WIDE_SRC_COVER;
    return PKSS_OK;
}
