/* SPDX-License-Identifier: MIT
 * icp.c -- the overlap-aware similarity ICP of SPEC 6 on the resampled
 * pre-shape clouds, as three explicit stages:
 *   - rigid: pairs gated in both directions, each partner beneath its
 *     point (not beside it, on a rim), update R, t with the scale
 *     frozen (a free scale collapses on partial overlap); the gate starts
 *     at the schedule's gate_start h and decays by ICP_GATE_DECAY to
 *     ICP_GATE_FLOOR h;
 *   - scale: the gate reopens to ICP_GATE_SCALE_START h and holds while the
 *     scale moves; mutual pairs (or a part's one-way pairs) drive a full
 *     Umeyama update (SPEC 6 caveat);
 *   - plane: a few point-to-plane steps within the floor (a deviation from
 *     SPEC 6: on flat faces point-to-point pairs leave the scale and the
 *     sliding loose).
 * A stage ends when the pose stops moving at the floor. The caller's stop
 * rules (pkss__icp_stops) can end a run early; the engine applies them
 * without knowing why they were set.
 */
#include "refine/icp_parts.h"

#include <math.h>
#include <string.h>

void pkss__icp_view_full(const pkss_cloud *c, pkss__icp_view *v)
{
    v->pts = c->pre;
    v->m = c->m;
    v->tree = c->tree;
    v->normal = c->normal;
    v->spacing = c->spacing;
    v->run = NULL;
    v->field = NULL;
}

void pkss__icp_view_coarse(const pkss_cloud *c, pkss__icp_view *v)
{
    v->pts = c->pre;
    v->m = c->m_coarse;
    v->tree = c->tree_coarse;
    v->normal = c->normal; /* the coarse view is a prefix of the points */
    v->spacing = c->spacing_coarse;
    v->run = NULL;
    v->field = NULL;
}

/* The point-to-plane stage after the scale stage: mutual pairs within the
 * gate's floor, each step a Gauss-Newton step of the similarity against the
 * template's local planes, until it settles or after iters steps. Returns
 * the steps taken. *overlap_start receives the overlap at the pose it
 * starts from, read from its first correspondences where the floor gate
 * covers the coverage distance, else scored apart. */
int pkss__plane_stage(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      int iters, pkss__icp_work *w, pkss__pose *T,
                      double *overlap_start)
{
    const double gate = ICP_GATE_FLOOR * tgt->spacing;
    const int runs = tgt->normal && iters > 0;
    const int from_pairs = runs && gate >= pkss__coverage_gate(src, tgt, T);
    if (!from_pairs) {
        double rms;
        pkss__overlap_with(src, tgt, T, w, overlap_start, &rms, NULL, NULL, NULL);
    }
    int it = 0;
    while (runs && it < iters) {
        pkss__correspond(src, tgt, T, gate, w);
        if (it == 0 && from_pairs)
            *overlap_start = pkss__overlap_from_pairs(src, tgt, gate, w);
        double d2max = 0.0;
        size_t n = pkss__mutual_pairs(w, src->m, &d2max);
        double step = pkss__solve_plane(src, tgt, w->pi, w->pj, n, T);
        ++it;
        if (step < ICP_PLANE_SETTLED)
            break;
    }
    return it;
}

/* One run's state: the pose, the gate, the window of overlaps that
 * projects where a stage can end, and the iteration count. */
typedef struct icp_state {
    const pkss__icp_view *src, *tgt;
    const pkss__icp_schedule *sched;
    pkss__icp_stops stops;
    pkss__icp_work w;
    pkss__icp_result *out;
    pkss__pose T;
    double h, gate, floor_gate;
    double ring[ICP_GAIN_WINDOW + 1];
    int n_ring, it;
    int beats_merit; /* its merit passed merit_bar: no bar stops it any more */
} icp_state;

enum { RIGID = 0, SCALE = 1 };
/* what an iteration decides */
enum { ITER_GO, ITER_STAGE_DONE, ITER_RUN_DONE };

/* Pairs of one iteration: both directions in the rigid stage, each partner
 * beneath its point (ICP_BENEATH); mutual, or the part's one-way pairs, in
 * the scale stage. */
static size_t stage_pairs(icp_state *r, int stage, double *d2max)
{
    pkss__icp_work *w = &r->w;
    if (stage == RIGID)
        return pkss__beneath_pairs(w, r->src->m, r->tgt->m, NULL, d2max);
    switch (r->sched->free_scale) {
    case PKSS__SCALE_SOURCE_PART:
        return pkss__forward_pairs(w, r->src->m, 0, d2max);
    case PKSS__SCALE_TEMPLATE_PART:
        return pkss__backward_pairs(w, r->tgt->m, 0, r->T.s, d2max);
    default:
        return pkss__mutual_pairs(w, r->src->m, d2max);
    }
}

/* Scores the pose on all points into out. */
static void score_pose(icp_state *r)
{
    pkss__overlap_with(r->src, r->tgt, &r->T, &r->w, &r->out->overlap,
                       &r->out->rms, r->out->cover, &r->out->fit, r->out->fit_cover);
}

/* Marks the run, scored, abandoned unless its merit beats the merit bar
 * (then it goes on, and no bar stops it any more); returns whether it was. */
static int abandon_scored(icp_state *r)
{
    r->beats_merit = r->stops.merit_bar > 0.0 && pkss__icp_merit(r->out) > r->stops.merit_bar;
    r->out->abandoned = !r->beats_merit;
    if (r->out->abandoned)
        pkss__basins_abandon(r->stops.basins, r->stops.id);
    return r->out->abandoned;
}

static int abandon(icp_state *r)
{
    score_pose(r);
    return abandon_scored(r);
}

/* The overlap window at the floor (or in the scale stage): sets *stagnant,
 * and returns 1 (run abandoned) when the stage's bar is out of reach even
 * by the linear projection of the window's gain, which over-estimates a
 * decelerating run. Not while the scale still moves: a part's scale stage
 * can stall in overlap, then climb (docs/tuning.md). */
static int track_overlap(icp_state *r, int stage, double gate_used, double change,
                         int scale_moving, int *stagnant)
{
    const pkss__icp_schedule *s = r->sched;
    double bar = stage == SCALE ? r->stops.scale_bar : r->stops.rigid_bar;
    int stage_end = stage == SCALE ? s->max_iters : s->rigid_iters;
    int track = bar > 0.0 || (s->free_scale && stage == RIGID);
    if (!track || !(stage == SCALE || gate_used <= r->floor_gate))
        return 0;
    double ov = pkss__overlap_from_pairs(r->src, r->tgt, gate_used, &r->w);
    if (ov < 0.0) {
        r->n_ring = 0;
    } else {
        r->ring[r->n_ring % (ICP_GAIN_WINDOW + 1)] = ov;
        ++r->n_ring;
    }
    if (r->n_ring <= ICP_GAIN_WINDOW)
        return 0;
    double old = r->ring[(r->n_ring - 1 - ICP_GAIN_WINDOW) % (ICP_GAIN_WINDOW + 1)];
    double gain = (ov - old) / ICP_GAIN_WINDOW;
    *stagnant = ov - old < ICP_STAGNANT && change < ICP_SETTLED_MOVE;
    double reach = ov + (gain > 0.0 ? gain : 0.0) * (double)(stage_end - r->it);
    if (bar > 0.0 && reach < bar && !scale_moving && !r->beats_merit)
        return abandon(r);
    return 0;
}

/* One iteration of a stage: correspondences, the update, the gate, then the
 * stop rules in order: a bar out of reach, a known basin, convergence. */
static int iterate(icp_state *r, int stage)
{
    const pkss__icp_schedule *s = r->sched;
    if (stage == RIGID) /* the partners beneath their points (ICP_BENEATH) */
        pkss__correspond_beneath(r->src, r->tgt, &r->T, r->gate, ICP_BENEATH * r->gate, &r->w);
    else
        pkss__correspond(r->src, r->tgt, &r->T, r->gate, &r->w);
    double d2max = 0.0;
    size_t n = stage_pairs(r, stage, &d2max);
    pkss__pose prev = r->T;
    if (!pkss__solve_point(r->src, r->tgt, r->w.pi, r->w.pj, n, stage == SCALE, &r->T))
        return ITER_RUN_DONE; /* too few pairs: keep the pose */
    double change = pkss__pose_change(&prev, &r->T);
    /* With every pair inside the floor already, a gate at the floor picks the
     * same pairs, so the pose has converged as far as the floor allows once
     * it stops moving, without waiting for the gate to decay there. */
    int at_floor = r->gate <= r->floor_gate || d2max <= r->floor_gate * r->floor_gate;
    /* While the free scale moves, the reopened gate holds: a scale error
     * displaces rim points by many spacings. */
    int scale_moving = stage == SCALE && fabs(r->T.s - prev.s) > ICP_SCALE_SETTLED * r->T.s;
    const double gate_used = r->gate;
    if (!scale_moving)
        r->gate *= ICP_GATE_DECAY;
    if (r->gate < ICP_GATE_FLOOR * r->h)
        r->gate = ICP_GATE_FLOOR * r->h;
    int stagnant = 0;
    if (track_overlap(r, stage, gate_used, change, scale_moving, &stagnant))
        return ++r->it, ITER_RUN_DONE;
    if (r->stops.basins && at_floor) {
        r->out->duplicate_of = pkss__basins_find(r->stops.basins, &r->T, r->h, r->stops.id,
                                                 r->beats_merit ? -1.0 : r->stops.scale_bar);
        if (r->out->duplicate_of >= 0)
            return ++r->it, ITER_RUN_DONE;
    }
    /* A rigid stage before a scale stage ends once its overlap has settled:
     * point-to-point ICP slides on slowly with unequal samplings, and the
     * scale stage moves the pose anyway. */
    int rigid_settled = stagnant && stage == RIGID && s->free_scale;
    if (at_floor && (change < ICP_CONVERGED || rigid_settled)) {
        if (stage == SCALE || !s->free_scale)
            return ++r->it, ITER_RUN_DONE;
        return ITER_STAGE_DONE;
    }
    return ITER_GO;
}

/* The rigid stage; returns ITER_RUN_DONE if the run ended in it. */
static int rigid_stage(icp_state *r, pkss_status *st)
{
    const pkss__icp_schedule *s = r->sched;
    const int end = s->free_scale ? s->rigid_iters : s->max_iters;
    for (; r->it < end; ++r->it) {
        if (pkss__tick(r->src->run) != PKSS_OK)
            return *st = PKSS_ERR_CANCELLED, ITER_RUN_DONE;
        int v = iterate(r, RIGID);
        if (v == ITER_RUN_DONE)
            return v;
        if (v == ITER_STAGE_DONE) {
            r->it = end;
            break;
        }
    }
    if (!s->free_scale || s->rigid_iters <= 0)
        return ITER_GO;
    /* the rigid stage ended (settled or out of iterations) below its bar */
    if (r->stops.rigid_bar > 0.0 && !r->beats_merit) {
        score_pose(r);
        if (r->out->overlap < r->stops.rigid_bar && abandon_scored(r))
            return ITER_RUN_DONE;
    }
    pkss__basins_add(r->stops.basins, &r->T, r->stops.id, r->stops.scale_bar);
    return ITER_GO;
}

/* The free-scale stage, after the rigid one. */
static void scale_stage(icp_state *r, pkss_status *st)
{
    const pkss__icp_schedule *s = r->sched;
    r->n_ring = 0;
    for (; r->it < s->max_iters; ++r->it) {
        if (pkss__tick(r->src->run) != PKSS_OK) {
            *st = PKSS_ERR_CANCELLED;
            return;
        }
        if (r->it == s->rigid_iters && r->gate < ICP_GATE_SCALE_START * r->h)
            r->gate = ICP_GATE_SCALE_START * r->h; /* reopen for the free scale */
        if (iterate(r, SCALE) != ITER_GO)
            return;
    }
}

/* After the stages: the basin of a run that ended on its own, the polish,
 * and the final scores. */
static void finish(icp_state *r)
{
    pkss__icp_result *out = r->out;
    if (!out->abandoned && out->duplicate_of < 0) {
        /* a run that reaches this pose would take the same plane steps */
        pkss__basins_add(r->stops.basins, &r->T, r->stops.id, r->stops.scale_bar);
        if (r->sched->plane_iters > 0)
            r->it += pkss__plane_stage(r->src, r->tgt, r->sched->plane_iters,
                                       &r->w, &r->T, &out->overlap_unpolished);
    }
    out->pose = r->T;
    out->iterations = r->it;
    if (!out->abandoned)
        pkss__overlap_with(r->src, r->tgt, &r->T, &r->w, &out->overlap, &out->rms,
                           out->cover, &out->fit, out->fit_cover);
    if (out->abandoned || out->duplicate_of >= 0 || r->sched->plane_iters <= 0)
        out->overlap_unpolished = out->overlap;
}

pkss_status pkss__icp_run(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__icp_schedule *sched,
                          const pkss__icp_stops *stops,
                          const pkss__pose *init, pkss__icp_result *out)
{
    static const pkss__icp_stops none = {0.0, 0.0, NULL, 0, 0.0};
    icp_state r = {.src = src, .tgt = tgt, .sched = sched, .out = out, .T = *init};
    r.stops = stops ? *stops : none;
    if (!sched->free_scale)
        r.stops.basins = NULL; /* basins are the minima of full runs */
    out->duplicate_of = -1;
    out->abandoned = 0;
    if (!pkss__work_alloc(&r.w, src->m, tgt->m, 1))
        return PKSS_ERR_OUT_OF_MEMORY;
    r.h = tgt->spacing;
    r.gate = sched->gate_start * r.h;
    r.floor_gate = ICP_GATE_FLOOR * r.h * ICP_FLOOR_SLACK;
    pkss_status st = PKSS_OK;
    if (rigid_stage(&r, &st) == ITER_GO && sched->free_scale)
        scale_stage(&r, &st);
    if (st == PKSS_OK)
        finish(&r);
    pkss__work_free(&r.w);
    return st;
}
