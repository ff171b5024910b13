/* SPDX-License-Identifier: MIT
 * correspond.c -- correspondences of the ICP engine: nearest partners both
 * ways (warm-started kd-tree queries), the pair lists each stage uses, and
 * the coverage overlap that judges poses (SPEC 6, with the deviation in
 * docs/design.md).
 */
#include "refine/icp_parts.h"

#include <math.h>
#include <string.h>

/* Search radius^2 for a warm-started query: the previous iteration's partner
 * (prev, UINT32_MAX if none) at its current distance bounds the search, so
 * the tree prunes almost everything; the result is exactly that of a cold
 * search within the gate (the true nearest is at most that far). */
static double warm_bound(const double *q, const double *pts, uint32_t prev,
                         double g2)
{
    if (prev == UINT32_MAX)
        return g2;
    /* a relative slack far above rounding keeps the old partner inside */
    double d2 = pkss__dist2(q, pts + 3 * (size_t)prev) * (1.0 + ICP_WARM_SLACK) + 1e-300;
    return d2 < g2 ? d2 : g2;
}

typedef struct bwd_job {
    const pkss__icp_view *src, *tgt;
    const pkss__pose *T;
    double g2s;
    uint32_t *bwd;
    double *bwd_d2;
} bwd_job;

static void backward(void *arg)
{
    const bwd_job *j = arg;
    for (size_t k = 0; k < j->tgt->m; ++k) {
        double x[3];
        pkss__pose_inverse_apply(j->T, j->tgt->pts + 3 * k, x);
        double b = warm_bound(x, j->src->pts, j->bwd[k], j->g2s);
        j->bwd[k] = pkss__kdtree_nearest(j->src->tree, x, b, &j->bwd_d2[k]);
    }
}

/* Nearest template point of every source point (fwd) and nearest source
 * point of every template point (bwd), both within gate (template units);
 * UINT32_MAX where none; fwd_d2 / bwd_d2 the squared distances (bwd_d2 in
 * source units, where the backward search runs). The two directions are
 * independent: large views offer the backward one to the call's helper
 * thread (ICP_THREAD_MIN). */
void pkss__correspond(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      const pkss__pose *T, double gate, pkss__icp_work *w)
{
    double g2 = gate * gate;
    bwd_job job = {src, tgt, T, g2 / (T->s * T->s), w->bwd, w->bwd_d2};
    pkss__helper *helper = src->run ? &src->run->helper : NULL;
    unsigned long ticket = 0;
    if (src->m + tgt->m >= 2 * ICP_THREAD_MIN)
        ticket = pkss__helper_offer(helper, backward, &job);
    for (size_t i = 0; i < src->m; ++i) {
        double y[3];
        pkss__pose_apply(T, src->pts + 3 * i, y);
        double b = warm_bound(y, tgt->pts, w->fwd[i], g2);
        w->fwd[i] = pkss__kdtree_nearest(tgt->tree, y, b, &w->fwd_d2[i]);
    }
    if (ticket)
        pkss__helper_wait(helper, ticket, 0.0);
    else
        backward(&job);
}

void pkss__work_free(pkss__icp_work *w)
{
    pkss__free(w->fwd);
    pkss__free(w->bwd);
    pkss__free(w->pi);
    pkss__free(w->pj);
    pkss__free(w->fwd_d2);
    pkss__free(w->bwd_d2);
}

int pkss__work_alloc(pkss__icp_work *w, size_t ns, size_t nt)
{
    memset(w, 0, sizeof *w);
    w->fwd = pkss__malloc(ns * sizeof(uint32_t));
    w->fwd_d2 = pkss__malloc(ns * sizeof(double));
    w->bwd = pkss__malloc(nt * sizeof(uint32_t));
    w->bwd_d2 = pkss__malloc(nt * sizeof(double));
    w->pi = pkss__malloc((ns + nt) * sizeof(uint32_t));
    w->pj = pkss__malloc((ns + nt) * sizeof(uint32_t));
    if (!w->fwd || !w->fwd_d2 || !w->bwd || !w->bwd_d2 || !w->pi || !w->pj) {
        pkss__work_free(w);
        return 0;
    }
    memset(w->fwd, 0xff, ns * sizeof(uint32_t)); /* no warm start yet */
    memset(w->bwd, 0xff, nt * sizeof(uint32_t));
    return 1;
}

/* Appends the gated source -> template pairs to w->pi / w->pj from n on;
 * returns the new count and raises *d2max to the farthest pair's squared
 * distance (template units). */
size_t pkss__forward_pairs(pkss__icp_work *w, size_t ns, size_t n, double *d2max)
{
    for (size_t i = 0; i < ns; ++i)
        if (w->fwd[i] != UINT32_MAX) {
            w->pi[n] = (uint32_t)i;
            w->pj[n++] = w->fwd[i];
            if (w->fwd_d2[i] > *d2max)
                *d2max = w->fwd_d2[i];
        }
    return n;
}

/* The same for the gated template -> source pairs (s = the pose's scale:
 * the backward distances are in source units). */
size_t pkss__backward_pairs(pkss__icp_work *w, size_t nt, size_t n, double s,
                            double *d2max)
{
    for (size_t j = 0; j < nt; ++j)
        if (w->bwd[j] != UINT32_MAX) {
            w->pi[n] = w->bwd[j];
            w->pj[n++] = (uint32_t)j;
            if (s * s * w->bwd_d2[j] > *d2max)
                *d2max = s * s * w->bwd_d2[j];
        }
    return n;
}

/* The same for the mutual pairs. */
size_t pkss__mutual_pairs(pkss__icp_work *w, size_t ns, double *d2max)
{
    size_t n = 0;
    for (size_t i = 0; i < ns; ++i) {
        uint32_t j = w->fwd[i];
        if (j != UINT32_MAX && w->bwd[j] == i) {
            w->pi[n] = (uint32_t)i;
            w->pj[n++] = j;
            if (w->fwd_d2[i] > *d2max)
                *d2max = w->fwd_d2[i];
        }
    }
    return n;
}

/* Distance within which a point counts as covered by the other cloud: 2 x
 * the coarser of the two spacings, in template units. */
double pkss__coverage_gate(const pkss__icp_view *src, const pkss__icp_view *tgt,
                           const pkss__pose *T)
{
    double h = tgt->spacing, hs = T->s * src->spacing;
    return ICP_OVERLAP_DIST * (h > hs ? h : hs);
}

/* The shares of each cloud covered by the other (f_s, f_t) from the
 * answers of the last correspond() at pose T, whose gate was at least the
 * coverage distance cg: the nearest partner within that gate is the nearest
 * within cg whenever it lies inside cg. */
void pkss__coverage_from_pairs(const pkss__icp_view *src,
                               const pkss__icp_view *tgt, const pkss__pose *T,
                               double cg, const pkss__icp_work *w,
                               double cover[2])
{
    double cg2 = cg * cg, cg2s = cg2 / (T->s * T->s);
    size_t fwd_hits = 0, bwd_hits = 0;
    for (size_t i = 0; i < src->m; ++i)
        fwd_hits += w->fwd[i] != UINT32_MAX && w->fwd_d2[i] <= cg2;
    for (size_t j = 0; j < tgt->m; ++j)
        bwd_hits += w->bwd[j] != UINT32_MAX && w->bwd_d2[j] <= cg2s;
    cover[0] = src->m ? (double)fwd_hits / (double)src->m : 0.0;
    cover[1] = tgt->m ? (double)bwd_hits / (double)tgt->m : 0.0;
}

/* Coverage overlap: f_s = share of source points with a template point
 * within d, f_t = share of template points with a source point within d,
 * overlap = sqrt(f_s f_t), d = 2 x the coarser of the two spacings (template
 * units). For uniform samples it is |A_o| / sqrt(|A_s| |A_t|): it falls when
 * the source shrinks and when it overhangs the template. Deviation from
 * SPEC 6 (mutual pairs / min(n_s, n_t)), which keeps rising while a partial
 * source is blown up (docs/tuning.md). RMS is that of the mutual pairs; fit
 * (if not NULL) is the same score within ICP_FIT_DIST spacings. */
void pkss__overlap_with(const pkss__icp_view *src, const pkss__icp_view *tgt,
                        const pkss__pose *T, pkss__icp_work *w,
                        double *overlap, double *rms, double *cover,
                        double *fit)
{
    double cg = pkss__coverage_gate(src, tgt, T), f[2];
    pkss__correspond(src, tgt, T, cg, w);
    if (fit) {
        pkss__coverage_from_pairs(src, tgt, T, ICP_FIT_DIST / ICP_OVERLAP_DIST * cg, w, f);
        *fit = sqrt(f[0] * f[1]);
    }
    pkss__coverage_from_pairs(src, tgt, T, cg, w, f);
    double d2max = 0.0, ss = 0.0;
    size_t mutual = pkss__mutual_pairs(w, src->m, &d2max);
    for (size_t k = 0; k < mutual; ++k)
        ss += w->fwd_d2[w->pi[k]];
    *overlap = sqrt(f[0] * f[1]);
    if (cover) {
        cover[0] = f[0];
        cover[1] = f[1];
    }
    *rms = mutual ? sqrt(ss / (double)mutual) : 0.0;
}

/* The overlap score at the pose the last correspond() ran at (gate), from
 * its answers; -1 if the gate was narrower than the coverage distance (the
 * answers cannot tell). */
double pkss__overlap_from_pairs(const pkss__icp_view *src,
                                const pkss__icp_view *tgt, const pkss__pose *T,
                                double gate, const pkss__icp_work *w)
{
    double cg = pkss__coverage_gate(src, tgt, T), f[2];
    if (gate < cg)
        return -1.0;
    pkss__coverage_from_pairs(src, tgt, T, cg, w, f);
    return sqrt(f[0] * f[1]);
}

pkss_status pkss__icp_overlap(const pkss__icp_view *src,
                              const pkss__icp_view *tgt,
                              const pkss__pose *pose, double *overlap,
                              double *rms, double *fit)
{
    pkss__icp_work w;
    *overlap = 0.0;
    *rms = 0.0;
    if (fit)
        *fit = 0.0;
    if (!pkss__work_alloc(&w, src->m, tgt->m))
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss__overlap_with(src, tgt, pose, &w, overlap, rms, NULL, fit);
    pkss__work_free(&w);
    return PKSS_OK;
}
