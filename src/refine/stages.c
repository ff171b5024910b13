/* SPDX-License-Identifier: MIT
 * stages.c -- the refinement stages of stages.h: which candidates get which
 * ICP run, against which leader, and which one wins.
 */
#include "refine/stages.h"
#include "pkss_shared.h"

#include <math.h>
#include <string.h>

/* ---- initial poses and coarse levels ---------------------------------- */

/* Eq. 7: the local rotation O_r of a kept candidate, from the matched
 * contour representatives in the candidate's frame (host side, double). */
static void local_rotation(const float *src_pts, int n_src,
                           const float *tgt_pts, int n_tgt,
                           const pkss__rotation_set *rot, uint32_t r,
                           const float *offset, int n_az, const float *edges,
                           double *O_r)
{
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    float src_reps[PKSS_MAX_CELLS * 4], tgt_reps[PKSS_MAX_CELLS * 4];
    int b = rot->binning[r], shift = rot->shift[r];
    pkss_bin_points(src_pts, n_src, rot->bin_R + 9 * b, 0, 0, 0, n_az, edges,
                    src_reps);
    pkss_bin_points(tgt_pts, n_tgt, I, offset[0], offset[1], offset[2], n_az,
                    edges, tgt_reps);
    /* The azimuth shift is a rotation about z by shift * 2pi / n_az. */
    double ang = shift * 2.0 * PKSS_PI / n_az;
    double Rz[9] = {cos(ang), -sin(ang), 0, sin(ang), cos(ang), 0, 0, 0, 1};
    int n_el = n_az / 2, k = 0;
    double xs[PKSS_MAX_CELLS][3], ys[PKSS_MAX_CELLS][3];
    double mx[3] = {0, 0, 0}, my[3] = {0, 0, 0};
    for (int e = 0; e < n_el; ++e)
        for (int a = 0; a < n_az; ++a) {
            int ct = n_az * e + a, as = (a - shift + n_az) % n_az;
            int cs = n_az * e + as;
            if (!(tgt_reps[4 * ct + 3] > 0 && src_reps[4 * cs + 3] > 0))
                continue;
            double x[3] = {src_reps[4 * cs], src_reps[4 * cs + 1], src_reps[4 * cs + 2]};
            pkss__mat3_apply(Rz, x, xs[k]);
            for (int d = 0; d < 3; ++d) {
                ys[k][d] = tgt_reps[4 * ct + d];
                mx[d] += xs[k][d];
                my[d] += ys[k][d];
            }
            ++k;
        }
    pkss__mat3_identity(O_r);
    if (k < PKSS_MIN_MATCHED)
        return;
    double H[9] = {0};
    for (int i = 0; i < k; ++i)
        for (int r0 = 0; r0 < 3; ++r0)
            for (int c0 = 0; c0 < 3; ++c0)
                H[3 * r0 + c0] += (xs[i][r0] - mx[r0] / k) * (ys[i][c0] - my[c0] / k);
    pkss__procrustes_rotation(H, O_r);
}

/* Work on candidates that is independent across them, over the caller and
 * the call's helper thread (each ICP run owns its buffers). */
enum { CAND_START = 0, CAND_OVERLAP = 1, CAND_FROM_POSE = 2 };

typedef struct cand_work {
    pkss__refinement *rs;
    const pkss__search_setup *ss;
    const pkss_cloud *src, *tgt;
    int refine, phase;
    const int *list; /* candidates to process (absolute indices) */
    size_t n_list, first, stride;
} cand_work;

/* CAND_START: the initial pose O_r * O_f * R_pre (Eq. 7-9) and the coarse
 * level (or, unrefined, the overlap at that pose). CAND_OVERLAP: the
 * overlap score of the pose in ir[c] on all points. CAND_FROM_POSE: the
 * coarse level from the pose in ir[c]. */
static void cand_one(const cand_work *w, int c)
{
    pkss__refinement *rs = w->rs;
    pkss__icp_result *r = &rs->ir[c];
    const pkss__views *v = &rs->v;
    if (w->phase == CAND_OVERLAP) {
        rs->st[c] = pkss__icp_overlap(&v->sv, &v->tv, &r->pose, &r->overlap,
                                      &r->rms, &r->fit);
        r->overlap_unpolished = r->overlap;
        return;
    }
    if (w->phase == CAND_FROM_POSE) {
        pkss__pose init = r->pose;
        rs->st[c] = pkss__icp_run(&v->svc, &v->tvc, &pkss__schedule_coarse, NULL,
                                  &init, r);
        rs->stage[c] = PKSS_STAGE_COARSE;
        return;
    }
    const pkss__search_setup *ss = w->ss;
    const pkss__pick *pk = &rs->picks[c];
    const float *offset = ss->offsets + 3 * (size_t)pk->offset;
    double O_r[9], RfRpre[9];
    local_rotation(ss->src_pts, (int)w->src->m, ss->tgt_pts, (int)w->tgt->m,
                   &ss->rot, pk->rotation, offset, ss->n_az, ss->edges, O_r);
    pkss__pose init;
    pkss__mat3_mul(ss->rot.R + 9 * (size_t)pk->rotation, ss->R_pre, RfRpre);
    pkss__mat3_mul(O_r, RfRpre, init.R);
    init.s = 1.0; /* pre-shape units: sigma_t / sigma_s in caller units */
    for (int d = 0; d < 3; ++d)
        init.t[d] = offset[d];
    if (w->refine) {
        rs->st[c] = pkss__icp_run(&v->svc, &v->tvc, &pkss__schedule_coarse, NULL,
                                  &init, r);
        rs->stage[c] = PKSS_STAGE_COARSE;
    } else {
        r->pose = init;
        r->iterations = 0;
        rs->stage[c] = PKSS_STAGE_SEARCH;
        rs->st[c] = pkss__icp_overlap(&v->sv, &v->tv, &init, &r->overlap,
                                      &r->rms, &r->fit);
        r->overlap_unpolished = r->overlap;
    }
}

static void cand_worker(void *arg)
{
    const cand_work *w = arg;
    for (size_t k = w->first; k < w->n_list; k += w->stride)
        cand_one(w, w->list[k]);
}

/* Odd-numbered entries on the helper thread if it is free (else here after
 * the even ones), the even ones here: each candidate owns its results. */
static pkss_status for_each_candidate(const cand_work *w)
{
    cand_work a = *w, b = *w;
    a.first = 0;
    b.first = 1;
    a.stride = b.stride = 2;
    pkss__helper *helper = w->n_list > 1 ? pkss__run_helper(w->rs->v.sv.run) : NULL;
    pkss__helper_both(helper, cand_worker, &a, &b);
    for (size_t k = 0; k < w->n_list; ++k)
        if (w->rs->st[w->list[k]] != PKSS_OK)
            return w->rs->st[w->list[k]];
    return PKSS_OK;
}

pkss_status pkss__stage_coarse_levels(pkss__refinement *rs,
                                      const pkss__search_setup *ss,
                                      const pkss_cloud *src,
                                      const pkss_cloud *tgt, size_t base,
                                      size_t kept, int refine, int *scored)
{
    int list[PKSS_MAX_CANDIDATES];
    for (size_t c = 0; c < kept; ++c) {
        list[c] = (int)(base + c);
        rs->refined[base + c] = 0;
        scored[c] = 0;
    }
    /* The first wave: the best by search score. If one of them covers both
     * clouds, no other can beat its overlap by more than 0.02, so the rest
     * are only scored at the search's pose. */
    size_t wave = kept < PKSS_FIRST_WAVE ? kept : PKSS_FIRST_WAVE;
    cand_work cw = {rs, ss, src, tgt, refine, CAND_START, list, wave, 0, 1};
    pkss_status first = for_each_candidate(&cw);
    double wave_best = 0.0;
    for (size_t k = 0; k < wave; ++k)
        if (rs->st[list[k]] == PKSS_OK && rs->ir[list[k]].overlap > wave_best)
            wave_best = rs->ir[list[k]].overlap;
    pkss_status rest = PKSS_OK;
    if (kept > wave) {
        cand_work more = cw;
        more.list = list + wave;
        more.n_list = kept - wave;
        if (wave_best >= PKSS_COARSE_COMPLETE) {
            more.refine = 0;
            for (size_t k = wave; k < kept; ++k)
                scored[k] = 1;
        }
        rest = for_each_candidate(&more);
    }
    return first != PKSS_OK ? first : rest;
}

/* ---- which candidates get a full run ---------------------------------- */

void pkss__order_by_overlap(const pkss__icp_result *ir, size_t kept, int *order)
{
    for (size_t c = 0; c < kept; ++c)
        order[c] = (int)c;
    for (size_t i = 1; i < kept; ++i) {
        int c = order[i];
        size_t j = i;
        while (j > 0 && ir[order[j - 1]].overlap < ir[c].overlap) {
            order[j] = order[j - 1];
            --j;
        }
        order[j] = c;
    }
}

size_t pkss__initial_full_count(const pkss__icp_result *ir, const int *order,
                                size_t kept)
{
    size_t n_full = kept < PKSS_FULL_REFINE ? kept : PKSS_FULL_REFINE;
    while (n_full > 1 &&
           ir[order[n_full - 1]].overlap < PKSS_FULL_REFINE_RATIO * ir[order[0]].overlap)
        --n_full;
    return n_full;
}

int pkss__wants_full_run(const pkss__refinement *rs, const pkss__icp_result *ir,
                         const int *order, size_t i, size_t *n_full, double h)
{
    int c = order[i];
    /* with a partial source the truth can rank 4th-6th by coarse overlap */
    if (i == *n_full && ir[c].overlap >= rs->lead_overlap)
        ++*n_full;
    int same_basin = 0;
    for (size_t j = 0; j < i && j < *n_full && !same_basin; ++j)
        same_basin = pkss__same_basin(&ir[c].pose, &ir[order[j]].pose, h,
                                      &pkss__start_basin);
    /* a refined candidate covering both clouds ends the full runs: another
     * pose could raise the overlap by 0.02 at most; so does one on which a
     * cloud lies wholly within the fit distance: at its scale, another pose
     * could explain no more of either; and one in contact: it has placed
     * the part (pkss__in_contact) */
    return i < *n_full && !same_basin && rs->lead_here < PKSS_COARSE_COMPLETE &&
           rs->explained_here < PKSS_EXPLAINED && !rs->contact_here;
}

pkss_status pkss__stage_full_runs(pkss__refinement *rs, size_t base, size_t kept,
                                  double lead_in, const int *scored)
{
    int order[PKSS_MAX_CANDIDATES], rest[PKSS_MAX_CANDIDATES];
    const pkss__icp_result *ir = rs->ir + base;
    pkss__order_by_overlap(ir, kept, order);
    size_t n_full = pkss__initial_full_count(ir, order, kept), n_rest = 0;
    rs->lead_overlap = lead_in;
    rs->lead_here = 0.0;
    rs->explained_here = 0.0;
    rs->contact_here = 0;
    for (size_t i = 0; i < kept; ++i) {
        size_t c = base + (size_t)order[i];
        PKSS_FORWARD(pkss__checkpoint(rs->v.sv.run, PKSS_PROGRESS_REFINE, (uint32_t)i,
                                      (uint32_t)kept));
        rs->refined[c] = pkss__wants_full_run(rs, ir, order, i, &n_full,
                                              rs->v.tvc.spacing);
        if (rs->refined[c])
            PKSS_FORWARD(pkss__stage_full_run(rs, c, 0));
        else if (!scored[order[i]])
            rest[n_rest++] = (int)c;
    }
    return pkss__stage_score_rest(rs, rest, n_rest);
}

/* ---- local-feature starts --------------------------------------------- */

/* Appends poses[0..n) as candidates, each scored by the search's measure
 * at its pose (no grid indices), with their coarse levels. */
static pkss_status append_starts(pkss__refinement *rs, const pkss__search_setup *ss,
                                 const pkss__pose *poses, size_t n)
{
    int list[PKSS_MAX_CANDIDATES];
    double pre_t[9];
    pkss__mat3_transpose(ss->R_pre, pre_t); /* the search's source is pre-aligned */
    for (size_t k = 0; k < n; ++k) {
        size_t c = rs->n + k;
        double R[9];
        pkss__mat3_mul(poses[k].R, pre_t, R);
        PKSS_FORWARD(pkss__score_pose(&ss->in, R, poses[k].t, &rs->picks[c]));
        rs->picks[c].rotation = rs->picks[c].offset = UINT32_MAX;
        memset(&rs->ir[c], 0, sizeof rs->ir[c]);
        rs->ir[c].pose = poses[k];
        rs->refined[c] = 0;
        list[k] = (int)c;
    }
    rs->n += n;
    cand_work cw = {rs, NULL, NULL, NULL, 1, CAND_FROM_POSE, list, n, 0, 1};
    return for_each_candidate(&cw);
}

/* Drops the candidates from base on whose coarse pose lies in the basin of
 * a refined candidate before base (they would arrive at its minimum). */
static void drop_known_basins(pkss__refinement *rs, size_t base)
{
    size_t kept = base;
    for (size_t c = base; c < rs->n; ++c) {
        int known = 0;
        for (size_t j = 0; j < base && !known; ++j)
            known = rs->refined[j] && pkss__same_basin(&rs->ir[c].pose, &rs->ir[j].pose,
                                                       rs->v.tvc.spacing,
                                                       &pkss__start_basin);
        if (known)
            continue;
        rs->picks[kept] = rs->picks[c];
        rs->ir[kept] = rs->ir[c];
        rs->stage[kept] = rs->stage[c];
        rs->st[kept] = rs->st[c];
        ++kept;
    }
    rs->n = kept;
}

pkss_status pkss__stage_local(pkss__refinement *rs, const pkss__search_setup *ss,
                              const pkss__pose *starts, size_t n, double lead_in,
                              size_t *added)
{
    const size_t base = rs->n, room = PKSS_MAX_CANDIDATES - base;
    *added = 0;
    PKSS_FORWARD(append_starts(rs, ss, starts, n < room ? n : room));
    drop_known_basins(rs, base);
    static const int none_scored[PKSS_LOCAL_STARTS];
    *added = rs->n - base;
    if (*added == 0)
        return PKSS_OK;
    return pkss__stage_full_runs(rs, base, *added, lead_in, none_scored);
}

/* ---- a full run ------------------------------------------------------- */

int pkss__part_mode(double fs, double ft, int otherwise)
{
    if (fs >= PKSS_PART_COVERED && fs - ft > PKSS_PART_OF_WHOLE)
        return PKSS__SCALE_SOURCE_PART;
    if (ft >= PKSS_PART_COVERED && ft - fs > PKSS_PART_OF_WHOLE)
        return PKSS__SCALE_TEMPLATE_PART;
    return otherwise;
}

/* The scale pairs of a full run from io's coverages, after a scale search
 * (SPEC 6 caveat) where they show a part or cover neither cloud wholly:
 * coarse moves, then fine moves on all points where a part shows. The
 * coverages at the searched scale supersede those at the pre-shape ratio,
 * which an overhanging part can invert. */
static pkss_status plan_scale(const pkss__views *v, pkss__icp_result *io,
                              int *mode)
{
    double fs = io->cover[0], ft = io->cover[1];
    *mode = pkss__part_mode(fs, ft, pkss__schedule_full.free_scale);
    if (!(fabs(fs - ft) > PKSS_PART_OF_WHOLE || fmax(fs, ft) < PKSS_PART_COVERED))
        return PKSS_OK;
    PKSS_FORWARD(pkss__icp_scale_search(&v->svc, &v->tvc, PKSS_SCALE_STEP_COARSE,
                                        &pkss__schedule_settle, io));
    if (pkss__part_mode(io->cover[0], io->cover[1], 0) != 0)
        PKSS_FORWARD(pkss__icp_scale_search(&v->sv, &v->tv, PKSS_SCALE_STEP_FINE,
                                            &pkss__schedule_settle_fine, io));
    *mode = pkss__part_mode(io->cover[0], io->cover[1], *mode);
    return PKSS_OK;
}

pkss_status pkss__stage_full_run(pkss__refinement *rs, size_t c, int scale_known)
{
    pkss__icp_result *r = &rs->ir[c];
    pkss__icp_result scaled = *r;
    pkss__icp_schedule sched = pkss__schedule_full;
    if (scale_known)
        sched.free_scale = pkss__part_mode(r->cover[0], r->cover[1], sched.free_scale);
    else
        PKSS_FORWARD(plan_scale(&rs->v, &scaled, &sched.free_scale));
    /* judged against the leader on all points in the rigid stage (the coarse
     * level may stop mid-way), and in the scale stage against this search's;
     * neither stops it once its merit beats the best refined one */
    pkss__icp_stops stops = {PKSS_FULL_REFINE_RATIO * rs->lead_overlap, rs->lead_here,
                             &rs->basins, (int)c, rs->lead_merit};
    pkss__pose start = scaled.pose;
    PKSS_FORWARD(pkss__icp_run(&rs->v.sv, &rs->v.tv, &sched, &stops, &start, r));
    if (r->duplicate_of >= 0 || r->abandoned) {
        /* the basin's first run stands for it; reported at this pose */
        rs->stage[c] = PKSS_STAGE_STOPPED;
        rs->refined[c] = 0;
        return PKSS_OK;
    }
    rs->stage[c] = PKSS_STAGE_REFINED;
    /* bars are held before the polish, which raises a box part's overlap by
     * ~0.01-0.03 and made the others' scale stages stop short of it */
    rs->lead_overlap = fmax(rs->lead_overlap, r->overlap_unpolished);
    rs->lead_here = fmax(rs->lead_here, r->overlap_unpolished);
    rs->lead_merit = fmax(rs->lead_merit, pkss__icp_merit(r));
    rs->explained_here = fmax(rs->explained_here, fmax(r->fit_cover[0], r->fit_cover[1]));
    rs->contact_here |= pkss__in_contact(rs, (int)c);
    return PKSS_OK;
}

pkss_status pkss__stage_score_rest(pkss__refinement *rs, const int *list,
                                   size_t n)
{
    cand_work cw = {rs, NULL, NULL, NULL, 0, CAND_OVERLAP, list, n, 0, 1};
    return for_each_candidate(&cw);
}

/* ---- the winner and the slide search ---------------------------------- */

int pkss__pick_winner(const pkss__refinement *rs)
{
    int best = -1;
    double top = 0.0; /* the best merit */
    for (size_t c = 0; c < rs->n; ++c) {
        double m = pkss__icp_merit(&rs->ir[c]);
        if (rs->refined[c] && (best < 0 || m > top)) {
            best = (int)c;
            top = m;
        }
    }
    if (best < 0)
        return 0;
    for (size_t c = 0; c < rs->n; ++c)
        if (rs->refined[c] && pkss__icp_merit(&rs->ir[c]) >= top - PKSS_OVERLAP_TIE &&
            rs->ir[c].rms < rs->ir[best].rms)
            best = (int)c;
    return best;
}

/* Whether candidate w is fully refined and at least `ratio` of its points
 * within the overlap distance lie within the fit distance. */
static int lies_on(const pkss__refinement *rs, int w, double ratio)
{
    const pkss__icp_result *r = &rs->ir[w];
    return rs->refined[w] && r->overlap > 0.0 && r->fit >= ratio * r->overlap;
}

int pkss__in_contact(const pkss__refinement *rs, int w)
{
    return lies_on(rs, w, PKSS_CONTACT);
}

int pkss__part_unplaced(const pkss__refinement *rs, int w)
{
    const pkss__icp_result *r = &rs->ir[w];
    return fmax(r->cover[0], r->cover[1]) < PKSS_PART_COVERED &&
           !lies_on(rs, w, PKSS_PLACED);
}

/* Whether the refined winner w shows a part: the translation searches'
 * condition (one cloud covers the other wholly, or neither: a part can
 * then be held on the wrong walls, or slide). */
static int shows_part(const pkss__refinement *rs, int w)
{
    const pkss__icp_result *r = &rs->ir[w];
    return rs->refined[w] && fmin(r->cover[0], r->cover[1]) < PKSS_PART_COVERED;
}

/* A part held on the wrong walls lies near them, not on them: a placed
 * winner has no other place to search for (PKSS_PLACED). */
int pkss__shift_wanted(const pkss__refinement *rs, int w)
{
    return shows_part(rs, w) && !lies_on(rs, w, PKSS_PLACED);
}

/* A full run of candidate w moved to start, appended as a new candidate
 * (scale known: a shift keeps its searched scale). */
static pkss_status run_shifted(pkss__refinement *rs, int w, const pkss__pose *start)
{
    size_t c = rs->n++;
    rs->picks[c] = rs->picks[w];
    rs->ir[c] = rs->ir[w]; /* its coverages choose the scale pairs */
    rs->ir[c].pose = *start;
    rs->st[c] = PKSS_OK;
    rs->refined[c] = 1; /* cleared by the run if it stops short */
    rs->stage[c] = PKSS_STAGE_SEARCH;
    return pkss__stage_full_run(rs, c, 1);
}

pkss_status pkss__stage_shift(pkss__refinement *rs, int w, size_t *added)
{
    *added = 0;
    if (!pkss__shift_wanted(rs, w))
        return PKSS_OK;
    pkss__pose starts[PKSS_SHIFT_TRIALS];
    size_t room = PKSS_MAX_CANDIDATES - rs->n, n = 0;
    const pkss__shift_ask ask = {PKSS_SHIFT_TRIALS, PKSS_SHIFT_SHARE,
                                 room < PKSS_SHIFT_TRIALS ? room : PKSS_SHIFT_TRIALS};
    PKSS_FORWARD(pkss__shift_starts(&rs->v.svc, &rs->v.tv, &rs->ir[w].pose, &ask, starts, &n));
    for (size_t k = 0; k < n; ++k)
        PKSS_FORWARD(run_shifted(rs, w, &starts[k]));
    *added = n;
    return PKSS_OK;
}

/* ---- the shift search from other rotations ------------------------------ */

int pkss__astray(const pkss__refinement *rs, int w)
{
    const pkss__icp_result *r = &rs->ir[w];
    return pkss__shift_wanted(rs, w) && r->fit < PKSS_ASTRAY * r->overlap;
}

/* The next source: the candidate scored on all points (refined or stopped)
 * with the best merit, at a rotation PKSS_RUN_BASIN_DEG or more from every
 * one in done[0..n_done), or -1. */
static int next_source(const pkss__refinement *rs, size_t n, const int *done, int n_done)
{
    const double apart = PKSS_RUN_BASIN_DEG * PKSS_PI / 180.0;
    int best = -1;
    for (size_t c = 0; c < n; ++c) {
        const int scored = rs->stage[c] == PKSS_STAGE_STOPPED ||
                           rs->stage[c] == PKSS_STAGE_REFINED;
        if (!scored || !(rs->ir[c].overlap > 0.0))
            continue;
        int far = 1;
        for (int k = 0; k < n_done && far; ++k)
            far = pkss__rotation_angle(rs->ir[c].pose.R, rs->ir[done[k]].pose.R) >= apart;
        if (far && (best < 0 || pkss__icp_merit(&rs->ir[c]) > pkss__icp_merit(&rs->ir[best])))
            best = (int)c;
    }
    return best;
}

/* order[0..m): the starts by their merit on all points as they stand, best
 * first (ties by index): a settle costs about ten of these. */
static pkss_status rank_unsettled(const pkss__refinement *rs, const pkss__pose *starts,
                                  size_t m, size_t *order)
{
    double merit[PKSS_RESHIFT_PEAKS + 1];
    for (size_t j = 0; j < m; ++j) {
        pkss__icp_result q;
        PKSS_FORWARD(pkss__icp_overlap(&rs->v.sv, &rs->v.tv, &starts[j], &q.overlap, &q.rms,
                                       &q.fit));
        merit[j] = pkss__icp_merit(&q);
        size_t i = j;
        for (; i > 0 && merit[order[i - 1]] < merit[j]; --i)
            order[i] = order[i - 1];
        order[i] = j;
    }
    return PKSS_OK;
}

/* The merit of a short rigid settle from pose on all points (the coarse
 * views' fit distance is twice as wide and cannot tell a slid part from
 * its truth); the settled pose in *settled unless it is NULL. */
static pkss_status settled_merit(const pkss__refinement *rs, const pkss__pose *pose,
                                 pkss__pose *settled, double *merit)
{
    pkss__icp_result r;
    PKSS_FORWARD(pkss__icp_run(&rs->v.sv, &rs->v.tv, &pkss__schedule_settle, NULL, pose, &r));
    if (settled)
        *settled = r.pose;
    *merit = pkss__icp_merit(&r);
    return PKSS_OK;
}

pkss_status pkss__stage_reshift(pkss__refinement *rs, int w, size_t *added)
{
    *added = 0;
    if (!pkss__astray(rs, w))
        return PKSS_OK;
    double bar; /* the winner's merit, settled as the peaks are */
    PKSS_FORWARD(settled_merit(rs, &rs->ir[w].pose, NULL, &bar));
    const size_t n = rs->n;
    int done[PKSS_RESHIFT_SOURCES + 1] = {w};
    for (int k = 1; k <= PKSS_RESHIFT_SOURCES && rs->n < PKSS_MAX_CANDIDATES; ++k) {
        const int c = next_source(rs, n, done, k);
        if (c < 0)
            break;
        done[k] = c;
        pkss__pose starts[PKSS_RESHIFT_PEAKS], best = {0}, settled;
        size_t m = 0, order[PKSS_RESHIFT_PEAKS];
        const pkss__shift_ask ask = {PKSS_RESHIFT_PEAKS, PKSS_RESHIFT_SHARE, PKSS_RESHIFT_PEAKS};
        PKSS_FORWARD(pkss__shift_starts(&rs->v.svc, &rs->v.tv, &rs->ir[c].pose, &ask, starts, &m));
        PKSS_FORWARD(rank_unsettled(rs, starts, m, order));
        /* only a start that, settled, already lies on the template more
         * closely than the winner gets a full run: the best of them */
        double top = bar, merit;
        for (size_t j = 0; j < m && j < PKSS_RESHIFT_SETTLED; ++j) {
            PKSS_FORWARD(settled_merit(rs, &starts[order[j]], &settled, &merit));
            if (merit > top) {
                top = merit;
                best = settled;
            }
        }
        if (top > bar) {
            PKSS_FORWARD(run_shifted(rs, c, &best));
            ++*added;
        }
    }
    return PKSS_OK;
}

/* ---- the scale sweep at the winner's rotation ---------------------------- */

int pkss__rescale_steps(const pkss__refinement *rs, int w)
{
    const pkss__icp_result *r = &rs->ir[w];
    if (!rs->refined[w] || fmax(r->cover[0], r->cover[1]) >= PKSS_PART_COVERED)
        return 0;
    const int n = (int)floor(fabs(log(r->pose.s)) / log(PKSS_RESCALE_STEP) + 0.5);
    return n < PKSS_RESCALE_STEPS ? n : PKSS_RESCALE_STEPS;
}

/* Of held and the peaks of its shift search, the pose with the best merit
 * on all points as it stands (one settle per scale, not one per peak). */
static pkss_status best_unsettled(const pkss__refinement *rs, const pkss__pose *held,
                                  pkss__pose *best)
{
    pkss__pose starts[PKSS_RESHIFT_PEAKS + 1];
    size_t m = 0, order[PKSS_RESHIFT_PEAKS + 1];
    const pkss__shift_ask ask = {PKSS_RESHIFT_PEAKS, PKSS_RESHIFT_SHARE, PKSS_RESHIFT_PEAKS};
    PKSS_FORWARD(pkss__shift_starts(&rs->v.svc, &rs->v.tv, held, &ask, starts, &m));
    starts[m++] = *held;
    PKSS_FORWARD(rank_unsettled(rs, starts, m, order));
    *best = starts[order[0]];
    return PKSS_OK;
}

pkss_status pkss__stage_rescale(pkss__refinement *rs, int w, size_t *added)
{
    *added = 0;
    const int n = pkss__rescale_steps(rs, w);
    if (n == 0 || rs->n >= PKSS_MAX_CANDIDATES)
        return PKSS_OK;
    double bar, top, merit; /* the winner's merit, settled as the sweep's are */
    PKSS_FORWARD(settled_merit(rs, &rs->ir[w].pose, NULL, &bar));
    top = bar;
    /* toward the pre-shape ratio, where both clouds have unit RMS radius */
    const double f = rs->ir[w].pose.s < 1.0 ? PKSS_RESCALE_STEP : 1.0 / PKSS_RESCALE_STEP;
    pkss__pose held = rs->ir[w].pose, start, settled, best = held;
    for (int k = 1; k <= n; ++k) {
        held.s *= f; /* about the source's centroid, the pre-shape origin */
        PKSS_FORWARD(best_unsettled(rs, &held, &start));
        PKSS_FORWARD(settled_merit(rs, &start, &settled, &merit));
        if (merit > top) {
            top = merit;
            best = settled;
        }
    }
    if (top > bar) {
        PKSS_FORWARD(run_shifted(rs, w, &best));
        *added = 1;
    }
    return PKSS_OK;
}

pkss_status pkss__stage_slide(pkss__refinement *rs, int w)
{
    if (!shows_part(rs, w))
        return PKSS_OK;
    return pkss__icp_slide_search(&rs->v.sv, &rs->v.tv, PKSS_OVERLAP_TIE, &rs->ir[w]);
}
