/* SPDX-License-Identifier: MIT
 * fine.c -- the winner's last steps: point-to-plane steps of the similarity
 * (as the polish of icp.c) against the template's dense view, the points
 * culling kept rather than the m resampled ones. Each point of a uniform
 * sample of the source's dense view pairs with its nearest dense template
 * point within PKSS_FINE_GATE dense spacings, or PKSS_FINE_NOISE_SIGMAS
 * sigmas of the contact's noise if wider: at the resampled spacing the gate
 * reaches past the edge of a partial overlap, where pairs lie beside the
 * surface and pull the scale (docs/design.md §5).
 */
#include "refine/icp_parts.h"

#include <math.h>

/* a Gaussian's sigma per median absolute value (the MAD's consistency) */
#define MEDIAN_ABS_TO_SIGMA 1.4826

void pkss__icp_view_dense(const pkss_cloud *c, size_t m, pkss__icp_view *v)
{
    v->pts = c->dense;
    v->m = m < c->m_dense ? m : c->m_dense;
    v->tree = c->tree_dense;
    v->normal = c->normal_dense;
    v->spacing = c->spacing_dense;
    v->run = NULL;
    v->field = NULL;
}

/* A robust sigma of the contact's noise at T: MEDIAN_ABS_TO_SIGMA x the median distance
 * of the sample's points to their partners' planes, paired within the ICP's
 * floor gate (that of the polish the winner ended with); 0 without pairs. */
static double contact_noise(const pkss__icp_view *tgt, const pkss__icp_view *src_dense,
                            const pkss__icp_view *tgt_dense, const pkss__pose *T,
                            pkss__icp_work *w)
{
    pkss__correspond_forward(src_dense, tgt_dense, T, ICP_GATE_FLOOR * tgt->spacing, w);
    double d2max = 0.0;
    size_t n = pkss__forward_pairs(w, src_dense->m, 0, &d2max);
    if (n == 0)
        return 0.0;
    double *r = pkss__malloc(n * sizeof(double));
    if (!r)
        return 0.0; /* the spacing's gate alone */
    for (size_t k = 0; k < n; ++k) {
        double x[3];
        pkss__pose_apply(T, src_dense->pts + 3 * (size_t)w->pi[k], x);
        const double *y = tgt_dense->pts + 3 * (size_t)w->pj[k];
        const double *nv = tgt_dense->normal + 3 * (size_t)w->pj[k];
        r[k] = fabs(nv[0] * (x[0] - y[0]) + nv[1] * (x[1] - y[1]) + nv[2] * (x[2] - y[2]));
    }
    double sigma = MEDIAN_ABS_TO_SIGMA * pkss__select_value(r, n, n / 2);
    pkss__free(r);
    return sigma;
}

pkss_status pkss__icp_fine(const pkss__icp_view *src, const pkss__icp_view *tgt,
                           const pkss__icp_view *src_dense,
                           const pkss__icp_view *tgt_dense, pkss__icp_result *io)
{
    pkss__icp_work w; /* forward passes only: no template-side buffers */
    if (!pkss__work_alloc(&w, src_dense->m, 0, 1))
        return PKSS_ERR_OUT_OF_MEMORY;
    const double gate = fmax(PKSS_FINE_GATE * tgt_dense->spacing,
                             PKSS_FINE_NOISE_SIGMAS *
                                 contact_noise(tgt, src_dense, tgt_dense, &io->pose, &w));
    pkss_status st = PKSS_OK;
    for (int it = 0; it < PKSS_FINE_ITERS; ++it) {
        if (pkss__tick(src_dense->run) != PKSS_OK) {
            st = PKSS_ERR_CANCELLED;
            break;
        }
        pkss__correspond_forward(src_dense, tgt_dense, &io->pose, gate, &w);
        double d2max = 0.0;
        size_t n = pkss__forward_pairs(&w, src_dense->m, 0, &d2max);
        double step = pkss__solve_plane(src_dense, tgt_dense, w.pi, w.pj, n, &io->pose);
        ++io->iterations;
        if (step < ICP_PLANE_SETTLED) /* settled, or no pose (-1) */
            break;
    }
    pkss__work_free(&w);
    if (st != PKSS_OK)
        return st;
    /* the scores of the pose it ends at, on the views every candidate has */
    if (!pkss__work_alloc(&w, src->m, tgt->m, 0))
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss__overlap_with(src, tgt, &io->pose, &w, &io->overlap, &io->rms, io->cover,
                       &io->fit, io->fit_cover);
    pkss__work_free(&w);
    return PKSS_OK;
}
