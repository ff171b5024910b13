/* SPDX-License-Identifier: MIT
 * local_search.c -- two searches around a refined pose that ICP alone
 * cannot make: the scale that maximises the overlap (a part's mutual pairs
 * barely move it, SPEC 6 caveat), and the slide along a direction the
 * template's surface leaves free (box faces, cylinders).
 */
#include "refine/icp_parts.h"

#include <math.h>

/* Rescales pose T by factor f about the image of the source point c, so
 * the overlap stays in place while the source grows or shrinks around it. */
static void rescale_about(pkss__pose *T, const double *c, double f)
{
    double y[3];
    pkss__pose_apply(T, c, y);
    T->s *= f;
    double Rc[3];
    pkss__mat3_apply(T->R, c, Rc);
    for (int d = 0; d < 3; ++d)
        T->t[d] = y[d] - T->s * Rc[d];
}

/* Centroid of the source points that have a template partner, from the
 * answers of a correspond() at the coverage distance (overlap_with). */
static void covered_centroid(const pkss__icp_view *src, const pkss__icp_work *w,
                             double *c)
{
    size_t n = 0;
    c[0] = c[1] = c[2] = 0.0;
    for (size_t i = 0; i < src->m; ++i)
        if (w->fwd[i] != UINT32_MAX) {
            for (int d = 0; d < 3; ++d)
                c[d] += src->pts[3 * i + d];
            ++n;
        }
    if (n == 0)
        for (size_t i = 0; i < src->m; ++i)
            for (int d = 0; d < 3; ++d)
                c[d] += src->pts[3 * i + d];
    double k = (double)(n ? n : (src->m ? src->m : 1));
    for (int d = 0; d < 3; ++d)
        c[d] /= k;
}

pkss_status pkss__icp_scale_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double log_step,
                                   const pkss__icp_schedule *settle,
                                   pkss__icp_result *io)
{
    pkss__icp_work w;
    if (!pkss__work_alloc(&w, src->m, tgt->m, 1))
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss_status st = PKSS_OK;
    pkss__icp_result best = *io;
    pkss__overlap_with(src, tgt, &best.pose, &w, &best.overlap, &best.rms, best.cover, NULL,
                       NULL);
    int w_at_best = 1; /* w holds the coverage answers at best.pose */
    double f = exp(log_step);
    int dir = 0; /* direction that last improved; 0 = try both */
    for (int move = 0; move < PKSS_SCALE_MOVES; ++move) {
        pkss__icp_result next = best;
        int next_dir = 0;
        double c[3];
        if (!w_at_best)
            pkss__correspond(src, tgt, &best.pose,
                             pkss__coverage_gate(src, tgt, &best.pose), &w);
        w_at_best = 1;
        covered_centroid(src, &w, c);
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            if (dir != 0 && sgn != dir)
                continue;
            pkss__pose trial = best.pose;
            rescale_about(&trial, c, sgn > 0 ? f : 1.0 / f);
            pkss__icp_result r;
            st = pkss__icp_run(src, tgt, settle, NULL, &trial, &r);
            if (st != PKSS_OK)
                goto out;
            if (r.overlap > next.overlap) {
                next = r;
                next_dir = sgn;
            }
        }
        if (next_dir == 0)
            break;
        best = next;
        dir = next_dir;
        w_at_best = 0;
    }
    *io = best;
out:
    pkss__work_free(&w);
    return st;
}

/* One share of the slide search's trials (every other shift, k != 0):
 * the best fit and its shift, starting from the held pose's. A trial is
 * counted only until it cannot reach the share's best (most fall far
 * short): the best is the same as counting every one. */
typedef struct slide_job {
    const pkss__icp_view *src, *tgt;
    const pkss__pose *at;
    double u[3], h, fg;
    int steps, parity;
    double best_fit;
    int best_k;
} slide_job;

/* Whether (fit, k) beats (best_fit, best_k): a higher fit, or as high at a
 * lower shift (the order of a scan from -steps up). */
static int beats(double fit, int k, double best_fit, int best_k)
{
    return fit > best_fit || (fit == best_fit && k < best_k);
}

static int better(const slide_job *a, const slide_job *b)
{
    return beats(a->best_fit, a->best_k, b->best_fit, b->best_k);
}

static void slide_trials(void *arg)
{
    slide_job *j = arg;
    for (int k = -j->steps; k <= j->steps; ++k) {
        if (k == 0 || (k + j->steps) % 2 != j->parity)
            continue;
        pkss__pose trial = *j->at;
        for (int d = 0; d < 3; ++d)
            trial.t[d] += k * j->h * j->u[d];
        double fit = pkss__fit_reaching(j->src, j->tgt, &trial, j->fg, j->best_fit);
        if (beats(fit, k, j->best_fit, j->best_k)) {
            j->best_fit = fit;
            j->best_k = k;
        }
    }
}

/* The slide search (the stages run it on a winner that does not cover both
 * clouds): on a prism-like template surface (box faces, a cylinder) the
 * translation along it is held only by the part's rims and end features,
 * and the runs end in local minima along it, while the fit along that
 * direction peaks narrowly at the truth. The search scores every shift of
 * one spacing (unpolished) and polishes the best. The direction is the
 * eigenvector of sum(n n^T) over the mutual pairs' template normals with the
 * smallest eigenvalue (docs/tuning.md). */
pkss_status pkss__icp_slide_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double min_gain,
                                   pkss__icp_result *io)
{
    if (!tgt->normal || !(tgt->spacing > 0.0))
        return PKSS_OK;
    pkss__icp_work w;
    if (!pkss__work_alloc(&w, src->m, tgt->m, 1))
        return PKSS_ERR_OUT_OF_MEMORY;
    const double h = tgt->spacing;
    const pkss__pose at = io->pose;
    /* the slide direction: least constrained by the normals of the
     * template points the source lies on */
    pkss__correspond(src, tgt, &at, ICP_GATE_FLOOR * h, &w);
    double d2max = 0.0;
    size_t n = pkss__mutual_pairs(&w, src->m, &d2max);
    if (n < ICP_MIN_PAIRS)
        goto out;
    double A[9] = {0}, ev[3], V[9];
    for (size_t k = 0; k < n; ++k) {
        const double *nv = tgt->normal + 3 * (size_t)w.pj[k];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                A[3 * r + c] += nv[r] * nv[c];
    }
    pkss__eig_sym3(A, ev, V);
    const double u[3] = {V[2], V[5], V[8]};
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (size_t j = 0; j < tgt->m; ++j) {
        const double *y = tgt->pts + 3 * j;
        double x = u[0] * y[0] + u[1] * y[1] + u[2] * y[2];
        lo = fmin(lo, x);
        hi = fmax(hi, x);
    }
    /* every trial shift's fit, unpolished, in steps of one spacing (the
     * fit's own tolerance: a narrower peak could fall between steps) */
    const double fg = ICP_FIT_DIST / ICP_OVERLAP_DIST * pkss__coverage_gate(src, tgt, &at);
    double f0[2];
    pkss__cover_within(src, tgt, &at, fg, f0);
    slide_job jobs[2];
    for (int k = 0; k < 2; ++k)
        jobs[k] = (slide_job){src, tgt, &at, {u[0], u[1], u[2]}, h, fg,
                              (int)(PKSS_SLIDE_RANGE * (hi - lo) / h), k,
                              sqrt(f0[0] * f0[1]), 0};
    pkss__helper *helper = pkss__run_helper(src->run);
    pkss__helper_both(helper, slide_trials, &jobs[0], &jobs[1]);
    const slide_job *b = better(&jobs[1], &jobs[0]) ? &jobs[1] : &jobs[0];
    const int best_k = b->best_k;
    if (best_k != 0) {
        pkss__pose start = at;
        for (int d = 0; d < 3; ++d)
            start.t[d] += best_k * h * u[d];
        pkss__icp_result r;
        pkss_status st = pkss__icp_run(src, tgt, &pkss__schedule_polish, NULL, &start, &r);
        if (st != PKSS_OK) {
            pkss__work_free(&w);
            return st;
        }
        if (r.fit > io->fit + min_gain)
            *io = r;
    }
out:
    pkss__work_free(&w);
    return PKSS_OK;
}
