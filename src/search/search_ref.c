/* SPDX-License-Identifier: MIT
 * search_ref.c -- the reference (plain C) backend of the factorised global
 * search (SPEC 5, Eq. 8-12, Algorithm 1), and the top-k selection shared by
 * all backends. The binning and scoring are the functions of
 * kernels/pkss_shared.h, the same code the OpenCL kernels run.
 */
#include "pkss_internal.h"
#include "pkss_shared.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

pkss_status pkss__search_ref(pkss_context *ctx, const pkss__search_input *in,
                             float *scores, float *g_contour,
                             float *g_feature)
{
    const int n_az = in->n_az;
    const int n_cells = n_az * (n_az / 2);
    const size_t table = (size_t)n_cells * 4;
    const pkss__rotation_set *rot = in->rot;
    const size_t n_bin = rot->n_binnings, n_off = (size_t)in->n_offsets;
    const int feat = in->use_features;

    float *src = pkss__malloc(n_bin * table * sizeof(float) * (feat ? 2 : 1));
    float *tgt = pkss__malloc(n_off * table * sizeof(float) * (feat ? 2 : 1));
    int *occ = pkss__malloc(n_off * 2 * sizeof(int));
    int *src_occ = pkss__malloc(n_bin * 2 * sizeof(int));
    if (!src || !tgt || !occ || !src_occ) {
        pkss__free(src);
        pkss__free(tgt);
        pkss__free(occ);
        pkss__free(src_occ);
        return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                          "out of memory for %zu x %zu search tables", n_bin,
                          n_off);
    }
    float *src_feat = feat ? src + n_bin * table : NULL;
    float *tgt_feat = feat ? tgt + n_off * table : NULL;
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

    /* The source is binned once per binning rotation about its centroid
     * (the origin of pre-shape space) ... */
    for (size_t b = 0; b < n_bin; ++b) {
        pkss_bin_points(in->src_pts, in->n_src, rot->bin_R + 9 * b, 0.0f, 0.0f,
                        0.0f, n_az, in->edges, src + b * table);
        src_occ[2 * b] = pkss_count_occupied(src + b * table, n_cells);
        if (feat) {
            pkss_bin_points(in->src_feat, in->n_src_feat, rot->bin_R + 9 * b,
                            0.0f, 0.0f, 0.0f, n_az, in->edges,
                            src_feat + b * table);
            src_occ[2 * b + 1] = pkss_count_occupied(src_feat + b * table, n_cells);
        }
    }
    /* ... the template once per centre offset (Eq. 11-12). */
    for (size_t o = 0; o < n_off; ++o) {
        const float *c = in->offsets + 3 * o;
        pkss_bin_points(in->tgt_pts, in->n_tgt, I, c[0], c[1], c[2], n_az,
                        in->edges, tgt + o * table);
        occ[2 * o] = pkss_count_occupied(tgt + o * table, n_cells);
        if (feat) {
            pkss_bin_points(in->tgt_feat, in->n_tgt_feat, I, c[0], c[1], c[2],
                            n_az, in->edges, tgt_feat + o * table);
            occ[2 * o + 1] = pkss_count_occupied(tgt_feat + o * table, n_cells);
        }
    }
    /* Every (rotation, offset) pair: G_K = max(G_contour, G_feature),
     * Eq. 7_3. */
    pkss_status st = PKSS_OK;
    for (size_t r = 0; r < rot->n_rotations && st == PKSS_OK; ++r) {
        st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_SEARCH, (uint32_t)r,
                              (uint32_t)rot->n_rotations);
        const size_t b = (size_t)rot->binning[r];
        const float *s = src + b * table;
        const float *sf = feat ? src_feat + b * table : NULL;
        int shift = rot->shift[r];
        for (size_t o = 0; o < n_off; ++o) {
            size_t k = r * n_off + o;
            float gc = pkss_score_pair(s, shift, tgt + o * table, occ[2 * o],
                                       n_az, in->keep, in->src_cover,
                                       src_occ[2 * b]);
            float gf = feat ? pkss_score_pair(sf, shift, tgt_feat + o * table,
                                              occ[2 * o + 1], n_az, in->keep,
                                              in->src_cover,
                                              src_occ[2 * b + 1])
                            : 0.0f;
            scores[k] = gc > gf ? gc : gf;
            if (g_contour)
                g_contour[k] = gc;
            if (g_feature)
                g_feature[k] = gf;
        }
    }
    pkss__free(src);
    pkss__free(tgt);
    pkss__free(occ);
    pkss__free(src_occ);
    return st == PKSS_OK ? PKSS_OK : pkss__cancel_fail(ctx);
}

/* G_contour and G_feature (the paper's, untrimmed) of one pose: the source
 * binned turned by R about its centroid, the template about t (Eq. 11-12
 * at one rotation and offset). */
static float score_one(const float *src, int n_src, const float *tgt, int n_tgt,
                       const float *R, const float *t, const pkss__search_input *in,
                       float *a, float *b)
{
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int n_cells = in->n_az * (in->n_az / 2);
    pkss_bin_points(src, n_src, R, 0.0f, 0.0f, 0.0f, in->n_az, in->edges, a);
    pkss_bin_points(tgt, n_tgt, I, t[0], t[1], t[2], in->n_az, in->edges, b);
    return pkss_score_pair(a, 0, b, pkss_count_occupied(b, n_cells), in->n_az, 1.0f,
                           0.0f, 0);
}

pkss_status pkss__score_pose(const pkss__search_input *in, const double *R,
                             const double *t, pkss__pick *out)
{
    const size_t table = (size_t)in->n_az * (size_t)(in->n_az / 2) * 4;
    float *a = pkss__malloc(2 * table * sizeof(float));
    if (!a)
        return PKSS_ERR_OUT_OF_MEMORY;
    float Rf[9], tf[3];
    for (int k = 0; k < 9; ++k)
        Rf[k] = (float)R[k];
    for (int d = 0; d < 3; ++d)
        tf[d] = (float)t[d];
    out->g_contour = score_one(in->src_pts, in->n_src, in->tgt_pts, in->n_tgt, Rf, tf,
                               in, a, a + table);
    out->g_feature = in->use_features
                         ? score_one(in->src_feat, in->n_src_feat, in->tgt_feat,
                                     in->n_tgt_feat, Rf, tf, in, a, a + table)
                         : 0.0f;
    out->score = out->g_contour > out->g_feature ? out->g_contour : out->g_feature;
    pkss__free(a);
    return PKSS_OK;
}

/* ---------------------------------------------------------- selection */
typedef struct scored {
    float score;
    uint32_t index;
} scored;

static int cmp_scored(const void *a, const void *b)
{
    const scored *x = a, *y = b;
    if (x->score < y->score) return -1;
    if (x->score > y->score) return 1;
    return (x->index > y->index) - (x->index < y->index);
}

/* Best top_k by G_K, suppressing a candidate whose rotation lies within
 * 45 degrees (geodesic) of an already kept one: argmin alone is fragile on
 * near-symmetric objects, whose near-equal minima lie ~180 deg apart.
 * Only each rotation's best pair (lowest score, then lowest index) can be
 * kept: once it is kept or suppressed, every later pair of that rotation is
 * suppressed (angle 0). So the greedy pass runs over the rotations' bests,
 * sorted by (score, index) -- the order in which they come first in the
 * sorted list of all pairs -- with the same result as sorting all pairs,
 * at n_rotations log n_rotations instead of n_pairs log n_pairs. */
size_t pkss__select_top_k(const float *scores, const float *gc,
                          const float *gf, const pkss__rotation_set *rot,
                          size_t n_offsets, size_t top_k, pkss__pick *out)
{
    size_t n_rot = rot->n_rotations;
    scored *best = pkss__malloc((n_rot ? n_rot : 1) * sizeof *best);
    if (!best)
        return SIZE_MAX;
    size_t valid = 0;
    for (size_t r = 0; r < n_rot; ++r) {
        const float *s = scores + r * n_offsets;
        size_t bo = SIZE_MAX;
        for (size_t o = 0; o < n_offsets; ++o)
            /* G = pi/2 marks the coverage guard: never a candidate. */
            if (s[o] < PKSS_HALF_PI_F && (bo == SIZE_MAX || s[o] < s[bo]))
                bo = o;
        if (bo == SIZE_MAX)
            continue;
        best[valid].score = s[bo];
        best[valid].index = (uint32_t)(r * n_offsets + bo);
        ++valid;
    }
    qsort(best, valid, sizeof *best, cmp_scored);
    const double min_angle = PKSS_TOPK_SUPPRESS_DEG * PKSS_PI / 180.0;
    size_t kept = 0;
    for (size_t i = 0; i < valid && kept < top_k; ++i) {
        uint32_t r = best[i].index / (uint32_t)n_offsets;
        int close = 0;
        for (size_t j = 0; j < kept && !close; ++j)
            close = pkss__rotation_angle(rot->R + 9 * (size_t)r,
                                         rot->R + 9 * (size_t)out[j].rotation) <
                    min_angle;
        if (close)
            continue;
        out[kept].rotation = r;
        out[kept].offset = best[i].index % (uint32_t)n_offsets;
        out[kept].score = best[i].score;
        out[kept].g_contour = gc ? gc[best[i].index] : best[i].score;
        out[kept].g_feature = gf ? gf[best[i].index] : 0.0f;
        ++kept;
    }
    pkss__free(best);
    return kept;
}
