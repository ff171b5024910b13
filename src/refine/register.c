/* SPDX-License-Identifier: MIT
 * register.c -- PKSS-Align end to end (Algorithm 1): both clouds onto the
 * pre-shape space, PCA pre-alignment, the global search over rotations x
 * centre offsets, top-k selection, overlap-aware refinement, and the
 * composition of the winner back into the caller's coordinates.
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include "pkss_internal.h"
#include "pkss_shared.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

/* Candidates refined at full resolution (by coarse overlap). */
#define PKSS_FULL_REFINE 3
#define PKSS_FULL_REFINE_RATIO 0.6
/* Fits (pick_winner) closer than this (~10 of 3000 points) do not tell two
 * refined poses apart; the lower RMS breaks the tie (docs/tuning.md). */
#define PKSS_OVERLAP_TIE 0.003
/* Coarse overlap at which a candidate covers both clouds: matching complete
 * objects reach 0.98-1.0, partial scans stay far below (docs/tuning.md). */
#define PKSS_COARSE_COMPLETE 0.98
/* Coverage asymmetry |f_s - f_t| above which one cloud is taken to show a
 * part of the other's surface, so that the pre-shape scale ratio is off
 * (SPEC 6 caveat) and the scale is searched first (docs/tuning.md). */
#define PKSS_PART_OF_WHOLE 0.05
/* ... and the part's own coverage at or above which it lies wholly on the
 * other cloud, so that its one-way pairs drive the scale; where neither cloud
 * reaches it the scale is searched too, as an overhanging part leaves f_s and
 * f_t alike (docs/tuning.md). */
#define PKSS_PART_COVERED 0.9

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

/* Pre-shape pose -> caller coordinates: x_t = s R x_s + t with
 * s = sigma_t s' / sigma_s and t = sigma_t t' + c_t - s R c_s. */
static void compose(const pkss_cloud *src, const pkss_cloud *tgt,
                    const pkss__pose *P, double *T16, double *s_out,
                    double *R_out, double *t_out)
{
    double s = tgt->sigma * P->s / src->sigma;
    double Rc[3];
    pkss__mat3_apply(P->R, src->centroid, Rc);
    double t[3];
    for (int d = 0; d < 3; ++d)
        t[d] = tgt->sigma * P->t[d] + tgt->centroid[d] - s * Rc[d];
    memset(T16, 0, 16 * sizeof(double));
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            T16[4 * r + c] = s * P->R[3 * r + c];
        T16[4 * r + 3] = t[r];
    }
    T16[15] = 1.0;
    if (s_out) *s_out = s;
    if (R_out) memcpy(R_out, P->R, 9 * sizeof(double));
    if (t_out) memcpy(t_out, t, 3 * sizeof(double));
}

/* Two poses close enough that full refinement would take the second to
 * where it took the first (within 5 degrees, 5 % scale and 5 coarse
 * spacings at the origin): refining it again would only repeat work. */
static int same_pose(const pkss__pose *a, const pkss__pose *b, double h)
{
    double dt = 0.0;
    for (int d = 0; d < 3; ++d)
        dt += (a->t[d] - b->t[d]) * (a->t[d] - b->t[d]);
    return pkss__rotation_angle(a->R, b->R) < 5.0 * PKSS_PI / 180.0 &&
           fabs(a->s / b->s - 1.0) < 0.05 && sqrt(dt) < 5.0 * h;
}

static pkss_status check_result_arg(pkss_context *ctx, pkss_result *result)
{
    PKSS_RETURN_IF(!result, ctx, PKSS_ERR_NULL_ARGUMENT, "result is NULL");
    PKSS_RETURN_IF(result->struct_size == 0, ctx, PKSS_ERR_INVALID_ARGUMENT,
                   "result->struct_size is 0: call pkss_result_init(&result, sizeof result) first");
    PKSS_RETURN_IF(result->struct_size < PKSS_RESULT_MIN_SIZE, ctx,
                   PKSS_ERR_INVALID_ARGUMENT,
                   "result->struct_size %zu is smaller than pkss_result 1.0 (%zu): "
                   "call pkss_result_init(&result, sizeof result)",
                   result->struct_size, (size_t)PKSS_RESULT_MIN_SIZE);
    return PKSS_OK;
}

/* A registration's whole outcome, library-sized: the caller receives the
 * fields its struct_size covers, the context keeps the candidates. */
typedef struct outcome {
    pkss_result res;
    pkss_candidate cand[PKSS_MAX_CANDIDATES];
    pkss__assessment assess;
} outcome;

static void deliver(pkss_context *ctx, pkss_result *dst, const outcome *o)
{
    pkss__deliver_result(dst, &o->res);
    memcpy(ctx->candidates, o->cand, sizeof o->cand);
    ctx->n_candidates = o->res.n_candidates;
    ctx->assess = o->assess;
}

/* A failed call: no pose in the result, no candidates in the context. */
static void clear_result(pkss_context *ctx, pkss_result *result)
{
    if (ctx)
        ctx->n_candidates = 0;
    if (result && result->struct_size >= PKSS_RESULT_MIN_SIZE)
        pkss__clear_result(result);
}

/* Per-candidate work of the refinement that is independent across
 * candidates, spread over two threads (each ICP run owns its buffers). */
enum { CAND_START = 0, CAND_OVERLAP = 1 };

typedef struct cand_work {
    const pkss__search_setup *ss;
    const pkss_cloud *src, *tgt;
    const pkss__pick *picks;
    const pkss__icp_view *sv, *tv, *svc, *tvc;
    const pkss__icp_schedule *coarse;
    int refine;
    pkss__icp_result *ir;   /* per candidate */
    pkss_status *st;        /* per candidate */
    uint32_t *stage;        /* per candidate: pkss_candidate_stage */
    const int *list;        /* candidates to process */
    size_t n_list;
    int phase;
    size_t first, stride;
} cand_work;

/* CAND_START: the initial pose O_r * O_f * R_pre (Eq. 7-9) and the coarse
 * level (or, unrefined, the overlap at that pose). CAND_OVERLAP: the
 * overlap score of the pose in ir[c] on all points. */
static void cand_one(const cand_work *w, int c)
{
    pkss__icp_result *r = &w->ir[c];
    if (w->phase == CAND_OVERLAP) {
        w->st[c] = pkss__icp_overlap(w->sv, w->tv, &r->pose, &r->overlap, &r->rms,
                                     &r->fit);
        r->overlap_unpolished = r->overlap;
        return;
    }
    const pkss__search_setup *ss = w->ss;
    const pkss__pick *pk = &w->picks[c];
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
        w->st[c] = pkss__icp_run(w->svc, w->tvc, w->coarse, &init, NULL, 0, r);
        w->stage[c] = PKSS_STAGE_COARSE;
    } else {
        r->pose = init;
        r->iterations = 0;
        w->stage[c] = PKSS_STAGE_SEARCH;
        w->st[c] = pkss__icp_overlap(w->sv, w->tv, &init, &r->overlap, &r->rms,
                                     &r->fit);
        r->overlap_unpolished = r->overlap;
    }
}

static void *cand_worker(void *arg)
{
    const cand_work *w = arg;
    for (size_t k = w->first; k < w->n_list; k += w->stride)
        cand_one(w, w->list[k]);
    return NULL;
}

static void for_each_candidate(const cand_work *w)
{
    cand_work a = *w, b = *w;
    a.first = 0;
    b.first = 1;
    a.stride = b.stride = 2;
    pthread_t th;
    if (w->n_list > 1 && pthread_create(&th, NULL, cand_worker, &b) == 0) {
        cand_worker(&a);
        pthread_join(th, NULL);
    } else {
        a.stride = 1;
        cand_worker(&a);
    }
}

static pkss_status fail_oom(pkss_context *ctx)
{
    return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                      "out of memory during the search/refinement");
}

/* A step of the search or refinement failed with st: cancelled, or out of
 * memory (their only failures). */
static pkss_status fail_step(pkss_context *ctx, pkss_status st)
{
    return st == PKSS_ERR_CANCELLED ? pkss__cancel_fail(ctx) : fail_oom(ctx);
}

/* The candidates of a registration, of one search or two (run): the second
 * search's follow the first's, so one index names a candidate in every
 * array and in pkss_result.candidates. */
typedef struct cand_set {
    pkss__pick picks[PKSS_MAX_CANDIDATES];
    pkss__icp_result ir[PKSS_MAX_CANDIDATES];
    pkss_status st[PKSS_MAX_CANDIDATES];
    int refined[PKSS_MAX_CANDIDATES]; /* fully refined: may win */
    uint32_t stage[PKSS_MAX_CANDIDATES]; /* pkss_candidate_stage */
    size_t n;
    pkss__icp_basins basins; /* minima reached by the full runs of both */
    double search_seconds, refine_seconds;
} cand_set;

typedef struct refine_views {
    pkss__icp_view sv, tv, svc, tvc; /* full and coarse, source and template */
} refine_views;

/* The pairs that drive the scale stage (icp.c) of a candidate whose
 * coverages are f_s, f_t: one cloud's one-way pairs where that cloud lies
 * wholly on the other and covers clearly more of it than it is covered;
 * otherwise `otherwise`. */
static int part_mode(double fs, double ft, int otherwise)
{
    if (fs >= PKSS_PART_COVERED && fs - ft > PKSS_PART_OF_WHOLE)
        return PKSS__SCALE_SOURCE_PART;
    if (ft >= PKSS_PART_COVERED && ft - fs > PKSS_PART_OF_WHOLE)
        return PKSS__SCALE_TEMPLATE_PART;
    return otherwise;
}

/* The scale search before a candidate's full refinement (SPEC 6 caveat):
 * 10 % moves on the coarse views, then 3 % moves on all points where the
 * coverages show a part, since the coarse tolerance cannot place the scale
 * to 3 % (docs/tuning.md). */
static pkss_status search_scale(const refine_views *v, pkss__icp_result *io)
{
    pkss_status st = pkss__icp_scale_search(&v->svc, &v->tvc, 0.10, io);
    if (st != PKSS_OK)
        return st;
    if (part_mode(io->cover[0], io->cover[1], 0) == 0)
        return PKSS_OK;
    return pkss__icp_scale_search(&v->sv, &v->tv, 0.03, io);
}

/* One global search (SPEC 5) over ss's rotations x offsets, its best top_k
 * candidates appended to cs, each refined (SPEC 6) unless refine is off.
 * lead_in is the best overlap an earlier search refined, before its polish
 * (0 for the first): the rigid stage is judged against it, the scale stage
 * only against this search's own leader, as a part the wide grid places
 * starts its scale stage far off (docs/tuning.md). */
static pkss_status search_pass(pkss_context *ctx, const pkss_cloud *src,
                               const pkss_cloud *tgt,
                               const pkss__search_setup *ss,
                               const refine_views *v, size_t top_k,
                               double lead_in, cand_set *cs)
{
    const pkss__params *p = &ctx->params;
    const pkss__search_input *in = &ss->in;
    const pkss__rotation_set *rot = &ss->rot;
    const int n_off = ss->n_offsets;
    const size_t base = cs->n;
    size_t total = rot->n_rotations * (size_t)n_off;
    double t0 = pkss__now();
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    float *scores = pkss__malloc(total * sizeof(float));
    float *gc = pkss__malloc(total * sizeof(float));
    float *gf = pkss__malloc(total * sizeof(float));
    if (!scores || !gc || !gf)
        goto fail;
    if ((st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_SEARCH, 0, 1)) != PKSS_OK)
        goto fail;
    if (ctx->backend_in_use == PKSS_BACKEND_OPENCL)
        st = pkss__search_cl(ctx, in, scores, gc, gf);
    else
        st = pkss__search_ref(ctx, in, scores, gc, gf);
    if (st != PKSS_OK)
        goto done;
    if ((st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_SEARCH, 1, 1)) != PKSS_OK)
        goto fail;
    pkss__pick *picks = cs->picks + base;
    size_t kept = pkss__select_top_k(scores, gc, p->use_features ? gf : NULL,
                                     rot, (size_t)n_off, top_k, picks);
    if (kept == SIZE_MAX) {
        st = PKSS_ERR_OUT_OF_MEMORY;
        goto fail;
    }
    cs->n = base + kept;
    double t1 = pkss__now();
    cs->search_seconds += t1 - t0;
    if (kept == 0)
        goto done;

    /* Every candidate gets a coarse rigid level on a quarter of the points; the
     * best few by coarse overlap, and any other reaching the refined leader's,
     * get the full run (rigid, free scale, point-to-plane) on all points; the
     * winner is picked by fit (pick_winner). */
    /* The search is ~10-20 degrees accurate: a 12h gate covers the rim's
     * displacement at the coarse spacing (docs/tuning.md). */
    static const pkss__icp_schedule coarse = {12.0, 14, 14, 0, 0.0, 0.0, 0};
    /* Beyond SPEC 6's 60 iterations: a part's scale converges slowly from ~20 %
     * off (200 in all), the rigid stage ends once settled (at most 60), and the
     * point-to-plane polish is bounded as it can creep on box parts (30)
     * (docs/tuning.md). */
    static const pkss__icp_schedule full = {6.0, 60, 200, PKSS__SCALE_MUTUAL, 0.0, 0.0, 30};
    pkss__icp_result *ir = cs->ir + base;
    pkss_status *cst = cs->st + base;
    int *refined = cs->refined + base;
    uint32_t *stage = cs->stage + base;
    int order[PKSS_MAX_CANDIDATES], list[PKSS_MAX_CANDIDATES];
    /* scored on all points at its final pose already (CAND_START unrefined) */
    int scored[PKSS_MAX_CANDIDATES] = {0};
    cand_work cw = {ss, src, tgt, picks, &v->sv, &v->tv, &v->svc, &v->tvc,
                    &coarse, p->refine, ir, cst, stage, list, kept,
                    CAND_START, 0, 1};
    for (size_t c = 0; c < kept; ++c) {
        order[c] = (int)c;
        list[c] = (int)c;
        refined[c] = 0;
    }
    /* Every candidate's local rotation and coarse level, two at a time:
     * first the two best by search score. If one of them already covers
     * both clouds (PKSS_COARSE_COMPLETE), no other can beat its overlap by
     * more than 0.02, so the rest are only scored at the search's pose. */
    size_t wave = kept < 2 ? kept : 2;
    if ((st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_REFINE, 0, (uint32_t)kept)) != PKSS_OK)
        goto fail;
    cw.n_list = wave;
    for_each_candidate(&cw);
    double wave_best = 0.0;
    for (size_t c = 0; c < wave; ++c)
        if (cst[c] == PKSS_OK && ir[c].overlap > wave_best)
            wave_best = ir[c].overlap;
    if (kept > wave) {
        cand_work rest = cw;
        rest.list = list + wave;
        rest.n_list = kept - wave;
        if (wave_best >= PKSS_COARSE_COMPLETE) {
            rest.refine = 0;
            for (size_t k = wave; k < kept; ++k)
                scored[list[k]] = 1;
        }
        for_each_candidate(&rest);
    }
    for (size_t c = 0; c < kept; ++c)
        if ((st = cst[c]) != PKSS_OK)
            goto fail;
    if (p->refine) {
        /* candidates by coarse overlap, best first (stable) */
        for (size_t i = 1; i < kept; ++i) {
            int c = order[i];
            size_t j = i;
            while (j > 0 && ir[order[j - 1]].overlap < ir[c].overlap) {
                order[j] = order[j - 1];
                --j;
            }
            order[j] = c;
        }
        /* Full refinement for the best few by coarse overlap, skipping those below
         * PKSS_FULL_REFINE_RATIO of the best (converged elsewhere); n_full may grow
         * below. */
        size_t n_full = kept < PKSS_FULL_REFINE ? kept : PKSS_FULL_REFINE;
        while (n_full > 1 &&
               ir[order[n_full - 1]].overlap < PKSS_FULL_REFINE_RATIO * ir[order[0]].overlap)
            --n_full;
        size_t n_rest = 0;
        /* best overlap fully refined so far: in any search, and in this */
        double lead_overlap = lead_in, lead_here = 0.0;
        for (size_t i = 0; i < kept; ++i) {
            int c = order[i];
            st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_REFINE, (uint32_t)i,
                                  (uint32_t)kept);
            if (st != PKSS_OK)
                goto fail;
            /* Past the top few, a candidate is refined too while its coarse overlap is
             * at least the refined leader's: with a partial source the truth can rank
             * 4th-6th by coarse overlap (docs/tuning.md). */
            if (i == n_full && ir[c].overlap >= lead_overlap)
                ++n_full;
            int same_basin = 0;
            for (size_t j = 0; j < i && j < n_full && !same_basin; ++j)
                same_basin = same_pose(&ir[c].pose, &ir[order[j]].pose, v->tvc.spacing);
            /* A refined candidate of this search that covers both clouds ends the full
             * refinements, as a complete coarse level ends the coarse ones: another pose
             * could raise the overlap by 0.02 at most (docs/tuning.md). */
            refined[c] = i < n_full && !same_basin &&
                         lead_here < PKSS_COARSE_COMPLETE;
            if (refined[c]) {
                pkss__icp_result scaled = ir[c];
                pkss__icp_schedule sched = full;
                /* The coarse level may stop mid-way, so a candidate is judged against the
                 * refined leader on all points during its full rigid stage, and stops in
                 * its scale stage once projected to end below the leader (icp.c). */
                sched.rigid_min_overlap = PKSS_FULL_REFINE_RATIO * lead_overlap;
                sched.scale_min_overlap = lead_here;
                double fs = ir[c].cover[0], ft = ir[c].cover[1];
                sched.free_scale = part_mode(fs, ft, sched.free_scale);
                if (fabs(fs - ft) > PKSS_PART_OF_WHOLE ||
                    fmax(fs, ft) < PKSS_PART_COVERED) {
                    st = search_scale(v, &scaled);
                    if (st != PKSS_OK)
                        goto fail;
                    /* The coverages at the searched scale tell a part from a whole better than
                     * those at the pre-shape ratio, which an overhanging part can invert; a
                     * search that found no part leaves the first reading. */
                    sched.free_scale = part_mode(scaled.cover[0], scaled.cover[1],
                                                 sched.free_scale);
                }
                pkss__pose start = scaled.pose;
                st = pkss__icp_run(&v->sv, &v->tv, &sched, &start, &cs->basins,
                                   (int)(base + (size_t)c), &ir[c]);
                if (st != PKSS_OK)
                    goto fail;
                if (ir[c].duplicate_of >= 0 || ir[c].abandoned) {
                    stage[c] = PKSS_STAGE_STOPPED;
                    /* reached a refined candidate's rigid minimum or final
                     * pose (that one stands for the basin), or fell behind
                     * the leader:
                     * reported at this pose (already scored on all points),
                     * not in the selection */
                    refined[c] = 0;
                } else {
                    stage[c] = PKSS_STAGE_REFINED;
                    /* the bars are held at the stage they judge: before
                     * the point-to-plane polish, which raises a box
                     * part's overlap by ~0.01-0.03 and made the others'
                     * scale stages stop short of it */
                    lead_overlap = fmax(lead_overlap, ir[c].overlap_unpolished);
                    lead_here = fmax(lead_here, ir[c].overlap_unpolished);
                }
            } else if (!scored[c]) {
                list[n_rest++] = c;
            }
        }
        /* the others' overlap scores on all points (reported evidence) */
        cw.phase = CAND_OVERLAP;
        cw.n_list = n_rest;
        for_each_candidate(&cw);
        for (size_t i = 0; i < n_rest; ++i)
            if ((st = cst[list[i]]) != PKSS_OK)
                goto fail;
    }
    cs->refine_seconds += pkss__now() - t1;
    goto done;

fail:
    st = fail_step(ctx, st);
done:
    pkss__free(scores);
    pkss__free(gc);
    pkss__free(gf);
    return st;
}

/* The winner among the fully refined candidates (the first by search score
 * when none is: refine off): the highest fit, the overlap within 1 spacing
 * at the polished pose, which tells a box part turned 180 degrees from the
 * truth where 2 spacings do not; fits within PKSS_OVERLAP_TIE are a tie that
 * the lower RMS breaks (docs/tuning.md). */
static int pick_winner(const cand_set *cs)
{
    int best = -1;
    for (size_t c = 0; c < cs->n; ++c)
        if (cs->refined[c] && (best < 0 || cs->ir[c].fit > cs->ir[best].fit))
            best = (int)c;
    if (best < 0)
        return 0;
    double top = cs->ir[best].fit;
    for (size_t c = 0; c < cs->n; ++c)
        if (cs->refined[c] && cs->ir[c].fit >= top - PKSS_OVERLAP_TIE &&
            cs->ir[c].rms < cs->ir[best].rms)
            best = (int)c;
    return best;
}

/* The device, if not prepared yet (PKSS_PROGRESS_DEVICE), timed. */
static pkss_status prepare_device(pkss_context *ctx, outcome *out)
{
    if (ctx->prepared)
        return PKSS_OK;
    PKSS_FORWARD(pkss__checkpoint(ctx->run, PKSS_PROGRESS_DEVICE, 0, 1) == PKSS_OK
                     ? PKSS_OK : pkss__cancel_fail(ctx));
    double t0 = pkss__now();
    pkss_status st = pkss_context_prepare(ctx);
    out->res.prepare_seconds += pkss__now() - t0;
    return st;
}

static pkss_status run(pkss_context *ctx, const pkss_cloud *src,
                       const pkss_cloud *tgt, outcome *out)
{
    pkss_result *res = &out->res;
    const pkss__params *p = &ctx->params;
    pkss_status st = PKSS_OK;
    double t0 = pkss__now();
    pkss__search_setup *ss = pkss__calloc(1, sizeof *ss);
    cand_set *cs = pkss__calloc(1, sizeof *cs);
    if (!ss || !cs) {
        st = pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
        goto done;
    }
    st = pkss__search_setup_build(p, src, tgt, ss);
    if (st != PKSS_OK) {
        st = fail_oom(ctx);
        goto done;
    }
    cs->search_seconds = pkss__now() - t0;
    refine_views v;
    pkss__icp_view_full(src, &v.sv);
    pkss__icp_view_full(tgt, &v.tv);
    pkss__icp_view_coarse(src, &v.svc);
    pkss__icp_view_coarse(tgt, &v.tvc);
    v.sv.run = v.tv.run = v.svc.run = v.tvc.run = ctx->run;
    const int n_off = ss->n_offsets;
    const size_t n_eval = ss->rot.n_rotations * (size_t)n_off;
    st = search_pass(ctx, src, tgt, ss, &v, (size_t)p->top_k, 0.0, cs);
    if (st != PKSS_OK)
        goto done;
    if (cs->n == 0) {
        st = pkss__fail(ctx, PKSS_ERR_NO_CONSENSUS,
                        "no (rotation, offset) candidate matched enough cells "
                        "(>= %d and >= %.0f%% of the template's): the clouds "
                        "share too little shape",
                        PKSS_MIN_MATCHED, 100.0 * PKSS_MIN_COVERAGE);
        goto done;
    }
    const size_t n_first = cs->n;
    int best = pick_winner(cs);
    res->n_evaluations = (uint64_t)n_eval;
    /* Second search on the wide offset grid (twice the step, SPEC 5 deviation)
     * when the winner covers neither cloud: a part's centroid lies beyond the
     * paper's grid. It only adds candidates, which must beat the first search's
     * winner, and scores with the trimmed G (PKSS_WIDE_KEEP), as the cells that
     * look into the missing part mislead the paper's G (docs/tuning.md). */
    const pkss__icp_result *w = &cs->ir[best];
    size_t room = PKSS_MAX_CANDIDATES - cs->n;
    size_t k2 = (size_t)p->top_k < room ? (size_t)p->top_k : room;
    if (p->refine && n_off > 1 && k2 > 0 &&
        fmax(w->cover[0], w->cover[1]) < PKSS_PART_COVERED) {
        double t2 = pkss__now();
        st = pkss__search_setup_widen(p, tgt, ss);
        if (st != PKSS_OK) {
            st = fail_oom(ctx);
            goto done;
        }
        cs->search_seconds += pkss__now() - t2;
        st = search_pass(ctx, src, tgt, ss, &v, k2, w->overlap_unpolished, cs);
        if (st != PKSS_OK)
            goto done;
        res->n_evaluations += (uint64_t)n_eval;
        best = pick_winner(cs);
    }
    /* A winner that does not cover both clouds gets a slide search (icp.c):
     * a translation search along the direction its surface constrains least,
     * kept if it raises the fit by more than a tie (docs/tuning.md). */
    if (p->refine && cs->refined[best] &&
        fmin(cs->ir[best].cover[0], cs->ir[best].cover[1]) < PKSS_PART_COVERED) {
        double t3 = pkss__now();
        st = pkss__icp_slide_search(&v.sv, &v.tv, PKSS_OVERLAP_TIE, &cs->ir[best]);
        if (st != PKSS_OK) {
            st = fail_step(ctx, st);
            goto done;
        }
        cs->refine_seconds += pkss__now() - t3;
    }
    res->n_rotations = (uint32_t)ss->rot.n_rotations;
    res->n_offsets = (uint32_t)n_off;

    for (size_t c = 0; c < cs->n; ++c) {
        const pkss__pick *pk = &cs->picks[c];
        pkss_candidate *cand = &out->cand[c];
        cand->struct_size = sizeof *cand;
        compose(src, tgt, &cs->ir[c].pose, cand->T_target_source,
                &cand->scale, NULL, NULL);
        cand->score = pk->score;
        cand->score_contour = pk->g_contour;
        cand->score_feature = pk->g_feature;
        cand->rms = cs->ir[c].rms * tgt->sigma;
        cand->overlap = cs->ir[c].overlap;
        cand->fit = cs->ir[c].fit;
        cand->stage = cs->stage[c];
        cand->rotation_index = pk->rotation;
        cand->offset_index = pk->offset;
        cand->search = c < n_first ? 0u : 1u;
    }
    compose(src, tgt, &cs->ir[best].pose, res->T_target_source, &res->scale,
            res->rotation, res->translation);
    res->n_candidates = (uint32_t)cs->n;
    res->winner = (uint32_t)best;
    res->score = out->cand[best].score;
    res->rms = out->cand[best].rms;
    res->overlap = out->cand[best].overlap;
    res->fit = out->cand[best].fit;
    res->timings.search = cs->search_seconds;
    res->timings.refine = cs->refine_seconds;
    /* How far to trust it: alternatives, symmetry, confidence (assess.c). */
    pkss__assess_input ai = {&v.sv, &v.tv, &v.svc, &v.tvc, tgt->sigma, tgt->centroid,
                             cs->ir, out->cand, cs->n, best, p->refine};
    if ((st = pkss__assess(&ai, &out->assess)) != PKSS_OK) {
        st = fail_step(ctx, st);
        goto done;
    }
    pkss__assess_store(&out->assess, res);

done:
    pkss__search_setup_free(ss);
    pkss__free(ss);
    pkss__free(cs);
    return st;
}

/* Runs the search and refinement into a library-sized result; the caller
 * delivers it. */
static pkss_status register_into(pkss_context *ctx, const pkss_cloud *source,
                                 const pkss_cloud *target, outcome *out)
{
    double t0 = pkss__now();
    pkss_status st = prepare_device(ctx, out);
    if (st != PKSS_OK)
        return st;
    pkss_result *res = &out->res;
    res->struct_size = sizeof *res;
    res->source_counts = source->counts;
    res->target_counts = target->counts;
    res->backend = ctx->backend_in_use;
    snprintf(res->device, sizeof res->device, "%s", ctx->device_name);
    if (ctx->backend_in_use == PKSS_BACKEND_REFERENCE && ctx->fallback_note[0]) {
        res->flags |= PKSS_FLAG_FELL_BACK;
        snprintf(res->note, sizeof res->note, "%s", ctx->fallback_note);
    }
    st = run(ctx, source, target, out);
    res->timings.total = pkss__now() - t0;
    return st;
}

pkss_status pkss_register_clouds(pkss_context *ctx, const pkss_cloud *source,
                                 const pkss_cloud *target, pkss_result *result)
{
    if (!ctx) {
        clear_result(NULL, result);
        return PKSS_ERR_NULL_ARGUMENT;
    }
    pkss__clear_error(ctx);
    clear_result(ctx, result);
    PKSS_FORWARD(check_result_arg(ctx, result));
    PKSS_RETURN_IF(!source, ctx, PKSS_ERR_NULL_ARGUMENT, "source cloud is NULL");
    PKSS_RETURN_IF(!target, ctx, PKSS_ERR_NULL_ARGUMENT, "target cloud is NULL");
    outcome *out = pkss__calloc(1, sizeof *out);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    pkss__run run_state;
    pkss__run_begin(ctx, &run_state);
    pkss_status st = register_into(ctx, source, target, out);
    if (st == PKSS_OK)
        deliver(ctx, result, out);
    pkss__checkpoint(ctx->run, PKSS_PROGRESS_DONE, 1, 1);
    pkss__run_end(ctx);
    pkss__free(out);
    return st;
}

/* Pre-processing one cloud on a worker thread. Each job has its own copy
 * of the context for the error detail, so the two never share a buffer;
 * the copies share the call's cancellation state. */
typedef struct build_job {
    pkss_context ctx;
    const double *xyz;
    size_t n;
    const char *which;
    pkss_cloud *cloud;
    pkss_status st;
    pthread_mutex_t lock; /* guards done, signalled through finished */
    pthread_cond_t finished;
    int done;
} build_job;

static void *build_worker(void *arg)
{
    build_job *j = arg;
    j->st = pkss__cloud_build(&j->ctx, j->xyz, j->n, j->which, &j->cloud);
    pthread_mutex_lock(&j->lock);
    j->done = 1;
    pthread_cond_signal(&j->finished);
    pthread_mutex_unlock(&j->lock);
    return NULL;
}

/* Seconds between the calling thread's progress ticks while it waits. */
#define PKSS_WAIT_TICK 0.01

/* While the target's job runs on the helper thread, the calling thread
 * keeps the progress callback alive (cancellation stays prompt); it wakes
 * as soon as the job is done. */
static void wait_for(pkss_context *ctx, build_job *j)
{
    pthread_mutex_lock(&j->lock);
    while (!j->done) {
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_nsec += (long)(PKSS_WAIT_TICK * 1e9);
        if (until.tv_nsec >= 1000000000L) {
            until.tv_sec += 1;
            until.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&j->finished, &j->lock, &until);
        if (!j->done) {
            pthread_mutex_unlock(&j->lock);
            pkss__tick(ctx->run);
            pthread_mutex_lock(&j->lock);
        }
    }
    pthread_mutex_unlock(&j->lock);
}

/* The two clouds are independent: pre-process them concurrently (the
 * target on a second thread); fall back to one thread if none can start.
 * The source's error is reported first, as in a sequential run. */
static pkss_status build_both(pkss_context *ctx, const double *source,
                              size_t n_source, const double *target,
                              size_t n_target, pkss_cloud **src,
                              pkss_cloud **tgt)
{
    build_job *jobs = pkss__calloc(2, sizeof *jobs);
    if (!jobs)
        return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    const double *xyz[2] = {source, target};
    const size_t n[2] = {n_source, n_target};
    const char *which[2] = {"source", "target"};
    for (int i = 0; i < 2; ++i) {
        jobs[i].ctx.params = ctx->params;
        jobs[i].ctx.run = ctx->run;
        jobs[i].xyz = xyz[i];
        jobs[i].n = n[i];
        jobs[i].which = which[i];
        pthread_mutex_init(&jobs[i].lock, NULL);
        pthread_cond_init(&jobs[i].finished, NULL);
    }
    pthread_t th;
    int threaded = pthread_create(&th, NULL, build_worker, &jobs[1]) == 0;
    build_worker(&jobs[0]);
    if (threaded) {
        wait_for(ctx, &jobs[1]);
        pthread_join(th, NULL);
    } else {
        build_worker(&jobs[1]);
    }
    pkss_status st = PKSS_OK;
    for (int i = 0; i < 2 && st == PKSS_OK; ++i)
        if (jobs[i].st != PKSS_OK) {
            st = jobs[i].st;
            memcpy(ctx->detail, jobs[i].ctx.detail, sizeof ctx->detail);
        }
    if (st == PKSS_OK) {
        *src = jobs[0].cloud;
        *tgt = jobs[1].cloud;
    } else {
        pkss_cloud_destroy(jobs[0].cloud);
        pkss_cloud_destroy(jobs[1].cloud);
    }
    for (int i = 0; i < 2; ++i) {
        pthread_mutex_destroy(&jobs[i].lock);
        pthread_cond_destroy(&jobs[i].finished);
    }
    pkss__free(jobs);
    return st;
}

pkss_status pkss_register(pkss_context *ctx, const double *source,
                          size_t n_source, const double *target,
                          size_t n_target, pkss_result *result)
{
    if (!ctx) {
        clear_result(NULL, result);
        return PKSS_ERR_NULL_ARGUMENT;
    }
    pkss__clear_error(ctx);
    clear_result(ctx, result);
    PKSS_FORWARD(check_result_arg(ctx, result));
    double t0 = pkss__now();
    pkss_cloud *src = NULL, *tgt = NULL;
    outcome *out = pkss__calloc(1, sizeof *out);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    pkss__run run_state;
    pkss__run_begin(ctx, &run_state);
    pkss_status st = prepare_device(ctx, out);
    double tb = pkss__now();
    if (st == PKSS_OK)
        st = build_both(ctx, source, n_source, target, n_target, &src, &tgt);
    double build_wall = pkss__now() - tb;
    if (st == PKSS_OK)
        st = register_into(ctx, src, tgt, out);
    if (st == PKSS_OK) {
        /* the two clouds ran concurrently: report wall-clock shares */
        pkss_result *res = &out->res;
        double v = src->validate_seconds > tgt->validate_seconds
                       ? src->validate_seconds : tgt->validate_seconds;
        res->timings.validate = v;
        res->timings.preprocess = build_wall - v;
        res->timings.total = pkss__now() - t0;
        deliver(ctx, result, out);
    }
    pkss__checkpoint(ctx->run, PKSS_PROGRESS_DONE, 1, 1);
    pkss__run_end(ctx);
    pkss__free(out);
    pkss_cloud_destroy(src);
    pkss_cloud_destroy(tgt);
    return st;
}
