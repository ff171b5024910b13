/* SPDX-License-Identifier: MIT
 * =========================================================================
 * search.cl -- the factorised global search of SPEC 5 on an OpenCL device:
 * bin the source once per binning rotation, the template once per centre
 * offset, then measure G (the batched 3x3-SVD shape measurement of SPEC 4)
 * for every (rotation, offset) pair. All arithmetic is the one definition
 * in kernels/pkss_shared.h (prepended to this file by the build), so the
 * results are those of the C reference, src/search/search_ref.c.
 *
 * Launched by src/search/evaluate_cl.c (pkss__search_cl), in this order:
 *   bin_source    one work-item per (binning rotation b, cloud kind):
 *                 kind 0 = contour points, 1 = feature points. Writes one
 *                 rep table float[n_cells][4] per work-item and its
 *                 occupied count.
 *   bin_template  one work-item per (offset o, cloud kind), o < n_off_pad
 *                 (columns o >= n_off are written empty). Writes column o of
 *                 the kind's structure-of-arrays table
 *                 tgt[kind][4*cell + k][n_off_pad] and its occupied count.
 *   score_pairs   one work-item per (rotation r, chunk of PKSS_VW
 *                 consecutive offsets): G_contour, G_feature and
 *                 G_K = max(G_c, G_f) (Eq. 7_3) of PKSS_VW pairs, one per
 *                 SIMD lane. Work-items are chunk-major, so a work-group
 *                 shares its template columns.
 *
 * Points arrive as structure-of-arrays blocks, x[pad] y[pad] z[pad], with
 * pad a multiple of PKSS_VW (contour block, then feature block).
 * Host-set defines (each has a default so the file compiles on its own,
 * e.g. clang -x cl -cl-std=CL1.2 -I kernels -fsyntax-only search.cl):
 *   PKSS_VW        lanes per work-item: 16 on CPUs (AVX-512 width; two
 *                  AVX2 registers), 1 on GPUs, whose SIMT hardware already
 *                  runs work-items in lock step.
 *   PKSS_WG_BIN    work-group size of the binning kernels
 *   PKSS_WG_SCORE  work-group size of score_pairs
 * =========================================================================
 */
#ifndef PKSS_SHARED_H
#include "pkss_shared.h"
#endif

#ifndef PKSS_WG_BIN
#define PKSS_WG_BIN 8
#endif
#ifndef PKSS_WG_SCORE
#define PKSS_WG_SCORE 8
#endif

__kernel __attribute__((reqd_work_group_size(PKSS_WG_BIN, 1, 1)))
void bin_source(__global const float *pts, int n_pts, int pad_pts,
                int n_feat, int pad_feat, __global const float *bin_R,
                int n_bin, __global const float *edges, int n_az, int kinds,
                __global float *tables, __global int *occ)
{
    int g = (int)get_global_id(0);
    if (g >= n_bin * kinds)
        return;
    int b = g % n_bin, kind = g / n_bin;
    float R[9];
    for (int i = 0; i < 9; ++i)
        R[i] = bin_R[9 * b + i];
    int n_cells = n_az * (n_az / 2);
    __global const float *p = kind ? pts + 3 * pad_pts : pts;
    __global float *t = tables + (size_t)g * 4 * n_cells;
    pkss_bin_points_strided(p, kind ? pad_feat : pad_pts, 1,
                            kind ? n_feat : n_pts, R, 0.0f, 0.0f, 0.0f, n_az,
                            edges, t, 1);
    occ[g] = pkss_count_occupied_strided(t, n_cells, 1);
}

__kernel __attribute__((reqd_work_group_size(PKSS_WG_BIN, 1, 1)))
void bin_template(__global const float *pts, int n_pts, int pad_pts,
                  int n_feat, int pad_feat, __global const float *offsets,
                  int n_off, int n_off_pad, __global const float *edges,
                  int n_az, int kinds, __global float *tables,
                  __global int *occ)
{
    int g = (int)get_global_id(0);
    if (g >= n_off_pad * kinds)
        return;
    int o = g % n_off_pad, kind = g / n_off_pad;
    int n_cells = n_az * (n_az / 2);
    __global float *t = tables + (size_t)kind * 4 * n_cells * n_off_pad + o;
    if (o >= n_off) {
        /* padding lane: an empty template, never matched */
        for (int c = 0; c < n_cells; ++c) {
            t[(4 * c + 0) * n_off_pad] = 0.0f;
            t[(4 * c + 1) * n_off_pad] = 0.0f;
            t[(4 * c + 2) * n_off_pad] = 0.0f;
            t[(4 * c + 3) * n_off_pad] = -1.0f;
        }
        occ[g] = 0;
        return;
    }
    const float I[9] = {1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f};
    __global const float *p = kind ? pts + 3 * pad_pts : pts;
    pkss_bin_points_strided(p, kind ? pad_feat : pad_pts, 1,
                            kind ? n_feat : n_pts, I, offsets[3 * o],
                            offsets[3 * o + 1], offsets[3 * o + 2], n_az,
                            edges, t, n_off_pad);
    occ[g] = pkss_count_occupied_strided(t, n_cells, n_off_pad);
}

/* out: G_K[n_rot][n_off], then G_c, then G_f (0 without features). */
__kernel __attribute__((reqd_work_group_size(PKSS_WG_SCORE, 1, 1)))
void score_pairs(__global const float *src_tab, __global const int *src_occ,
                 __global const float *tgt_tab,
                 __global const int *occ, __global const int *rot_info,
                 int n_bin, int n_rot, int n_off, int n_off_pad, int n_az,
                 int kinds, float keep, float src_cover,
                 __global float *out)
{
    int g = (int)get_global_id(0);
    int n_chunks = n_off_pad / PKSS_VW;
    if (g >= n_rot * n_chunks)
        return;
    int r = g % n_rot, o0 = (g / n_rot) * PKSS_VW;
    size_t table = 4 * (size_t)(n_az * (n_az / 2));
    int b = rot_info[2 * r], shift = rot_info[2 * r + 1];
    pkss_vf gc = pkss_score_lanes(src_tab + b * table, shift, tgt_tab + o0,
                                  n_off_pad, PKSS_LOADV(occ, o0), n_az, keep,
                                  src_cover, src_occ[b]);
    pkss_vf gf = PKSS_VF(0.0f);
    if (kinds > 1)
        gf = pkss_score_lanes(src_tab + (n_bin + b) * table, shift,
                              tgt_tab + table * n_off_pad + o0, n_off_pad,
                              PKSS_LOADV(occ, n_off_pad + o0), n_az, keep,
                              src_cover, src_occ[n_bin + b]);
    pkss_vf gk = PKSS_SEL(gc > gf, gc, gf);
    float ka[PKSS_VW], ca[PKSS_VW], fa[PKSS_VW];
    PKSS_STOREV(gk, ka);
    PKSS_STOREV(gc, ca);
    PKSS_STOREV(gf, fa);
    size_t total = (size_t)n_rot * n_off;
    for (int l = 0; l < PKSS_VW && o0 + l < n_off; ++l) {
        size_t k = (size_t)r * n_off + o0 + l;
        out[k] = ka[l];
        out[total + k] = ca[l];
        out[2 * total + k] = fa[l];
    }
}
