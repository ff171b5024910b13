/* SPDX-License-Identifier: MIT
 * icp.h -- the ICP engine of the refinement (SPEC 6): poses, views of a
 * cloud, schedules, the stop rules a caller puts on a run, and the local
 * searches (scale, slide). The engine knows nothing of candidates: which
 * runs compete, and against what, is the stages' business (stages.h).
 */
#ifndef PKSS_REFINE_ICP_H
#define PKSS_REFINE_ICP_H

#include "pkss_internal.h"

typedef struct pkss__pose {
    double s;        /* scale */
    double R[9];
    double t[3];
} pkss__pose;

/* Points an ICP level works on: a prefix of a cloud's pre-shape points. */
typedef struct pkss__icp_view {
    const double *pts;
    size_t m;
    const pkss__kdtree *tree;
    const double *normal; /* unit normal at each point (cloud.c) */
    double spacing;  /* median NN spacing h of this view */
    pkss__run *run;  /* the call's cancellation state and helper, or NULL */
    pkss__nn_field *field; /* the tree's answers by cubes of space, or NULL */
} pkss__icp_view;

void pkss__icp_view_full(const pkss_cloud *c, pkss__icp_view *v);
void pkss__icp_view_coarse(const pkss_cloud *c, pkss__icp_view *v);
/* The first m (at most all) of the points culling kept, a uniform sample
 * in their seeded order (fine.c: the winner's last steps). Its tree spans
 * all of them: a sample (m < m_dense) may only ask, never be asked. */
void pkss__icp_view_dense(const pkss_cloud *c, size_t m, pkss__icp_view *v);

/* Pairs that drive the free scale. Mutual pairs by default; where one cloud
 * shows a part of the other, every point of the part has its partner on
 * the whole, so the part's one-way pairs are all genuine and pull an
 * overhanging part back (the stages decide by coverage). */
enum pkss__scale_pairs {
    PKSS__SCALE_MUTUAL = 1,
    PKSS__SCALE_SOURCE_PART = 2,   /* source -> template pairs */
    PKSS__SCALE_TEMPLATE_PART = 3  /* template -> source pairs */
};

/* A run's iterations: a rigid stage, a free-scale stage, a point-to-plane
 * polish. The values are in src/tuning.h (PKSS_SCHEDULE_*). */
typedef struct pkss__icp_schedule {
    double gate_start;   /* in units of the template view's h */
    int rigid_iters;     /* iterations with the scale frozen */
    int max_iters;       /* all iterations (rigid + scale) */
    int free_scale;      /* 0: rigid only; else a pkss__scale_pairs */
    int plane_iters;     /* most point-to-plane iterations (0: none) */
} pkss__icp_schedule;

extern const pkss__icp_schedule pkss__schedule_coarse, pkss__schedule_full,
    pkss__schedule_settle, pkss__schedule_settle_fine, pkss__schedule_polish;

/* Minima reached by runs (the end of each rigid stage and each final
 * pose), with the id of the run that found each, the scale bar that run
 * faced, and whether a bar then stopped it (abandoned). */
typedef struct pkss__basins {
    pkss__pose pose[2 * PKSS_MAX_CANDIDATES];
    int owner[2 * PKSS_MAX_CANDIDATES];
    double bar[2 * PKSS_MAX_CANDIDATES];
    int abandoned[2 * PKSS_MAX_CANDIDATES];
    int n;
} pkss__basins;

/* Tolerances within which two poses lie in one basin (basin.c). */
typedef struct pkss__basin_tol {
    double degrees, scale, spacings; /* rotation, relative scale, h */
} pkss__basin_tol;
/* Before a full run (PKSS_START_BASIN_*) and during one (PKSS_RUN_BASIN_*). */
extern const pkss__basin_tol pkss__start_basin, pkss__run_basin;

/* The one same-minimum test: rotation, scale ratio and translation (in
 * units of h) within tol. */
int pkss__same_basin(const pkss__pose *a, const pkss__pose *b, double h,
                     const pkss__basin_tol *tol);
/* The owner of a basin of b (not owned by `not_owner`) that T lies in
 * (pkss__run_basin) and that stands for a run judged by `bar` (a scale
 * bar; -1: none may stop it), or -1. A basin whose run was abandoned only
 * stands for runs judged at least as strictly: a later search's bar is its
 * own leader's, and from there a run may reach what the first could not. */
int pkss__basins_find(const pkss__basins *b, const pkss__pose *T, double h,
                      int not_owner, double bar);
/* Records T as a minimum of run id, judged by scale bar `bar` (b may be
 * NULL; a full table drops it). */
void pkss__basins_add(pkss__basins *b, const pkss__pose *T, int id, double bar);
/* Marks the minima of run id as those of an abandoned run. */
void pkss__basins_abandon(pkss__basins *b, int id);

/* Stop rules a caller puts on a run (all optional: NULL stops = none).
 * A bar is an overlap a stage must be able to reach: a rigid stage that
 * ends below rigid_bar, or either stage projected to end below its bar,
 * stops the run (abandoned). With basins and a free scale, a run that
 * reaches another run's minimum stops there (duplicate_of), and records
 * its own under id. A run whose merit (pkss__icp_merit) already beats
 * merit_bar (0: none) is not stopped by a bar: the winner is chosen by
 * merit, and a loose overlap can hide the closer fit. */
typedef struct pkss__icp_stops {
    double rigid_bar, scale_bar; /* 0: none */
    pkss__basins *basins;
    int id;
    double merit_bar;
} pkss__icp_stops;

typedef struct pkss__icp_result {
    pkss__pose pose;
    double rms;      /* of the final mutual pairs, pre-shape template units */
    double overlap;  /* overlap score on the views used (correspond.c) */
    double cover[2]; /* its parts: shares of source, template covered */
    double fit;      /* the overlap within ICP_FIT_DIST spacings */
    double fit_cover[2]; /* its parts: shares of source, template that close */
    double overlap_unpolished; /* the overlap before the point-to-plane
                                  polish (= overlap without one): the value
                                  that other runs' bars are set from */
    int iterations;
    int abandoned;   /* stopped short of a bar */
    int duplicate_of; /* owner of the known minimum it stopped at, or -1 */
} pkss__icp_result;

/* What picks the winner: fit^2 / overlap, the fit weighted by the share of
 * the overlap within the fit distance. A part held near the surface but not
 * on it (turned end for end, or shrunk into the other's outline) can cover
 * more within 2 spacings than the truth, less of it within 1 (design.md §4). */
double pkss__icp_merit(const pkss__icp_result *r);

/* SPEC 6: overlap-aware similarity ICP of the source view onto the template
 * view from init (pre-shape coordinates of both), under the stop rules. */
pkss_status pkss__icp_run(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__icp_schedule *sched,
                          const pkss__icp_stops *stops,
                          const pkss__pose *init, pkss__icp_result *out);
/* The winner's last steps (fine.c): point-to-plane steps of io's pose,
 * each point of the source's dense sample paired with its nearest point of
 * the template's dense view within PKSS_FINE_GATE dense spacings (or
 * PKSS_FINE_NOISE_SIGMAS sigmas of the contact's noise, if wider), until
 * settled or PKSS_FINE_ITERS; then io's scores at the pose it ends at, on
 * the views src and tgt. */
pkss_status pkss__icp_fine(const pkss__icp_view *src, const pkss__icp_view *tgt,
                           const pkss__icp_view *src_dense,
                           const pkss__icp_view *tgt_dense, pkss__icp_result *io);
/* The scale that maximises the overlap score, by a pattern search in log
 * scale (steps of log_step, at most PKSS_SCALE_MOVES moves), each trial
 * settled by the rigid schedule settle; io holds the start pose on entry
 * and the best pose found (with its overlap, RMS and coverages) on exit. */
pkss_status pkss__icp_scale_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double log_step,
                                   const pkss__icp_schedule *settle,
                                   pkss__icp_result *io);
/* A search along the direction in which the template's surface under the
 * source constrains the translation least (a part of a box or a cylinder
 * slides along it): trial shifts of io's pose scored by their fit, the best
 * polished (point-to-plane steps); io receives the polished pose if its fit
 * beats io's by more than min_gain. */
pkss_status pkss__icp_slide_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double min_gain,
                                   pkss__icp_result *io);
/* Similarity poses of the source's coarse view onto the template's from
 * local shape alone: FPFH matches and a RANSAC over them (local_match.c),
 * at most max (<= PKSS_LOCAL_KEPT), most matches within reach first, one
 * per basin (pkss__start_basin). seed: the call's. */
pkss_status pkss__local_starts(const pkss__icp_view *src_coarse,
                               const pkss__icp_view *tgt_coarse, uint64_t seed,
                               size_t max, pkss__pose *starts, size_t *n_starts);
/* What a translation search asks for: the `peaks` best distinct vote peaks
 * (at most PKSS_SHIFT_PEAKS_MAX), of which those with more than `share` of
 * the held translation's votes become starts, at most max of them. */
#define PKSS_SHIFT_PEAKS_MAX \
    (PKSS_RESHIFT_PEAKS > PKSS_SHIFT_TRIALS ? PKSS_RESHIFT_PEAKS : PKSS_SHIFT_TRIALS)
typedef struct pkss__shift_ask {
    int peaks;
    double share;
    size_t max;
} pkss__shift_ask;
/* Translations of held (its rotation and scale kept) at which more of the
 * source's coarse points meet a template point than ask->share of those at
 * held's (a vote per point and translation cell), most votes first, each
 * more than a cell from the others and from held (shift_search.c). */
pkss_status pkss__shift_starts(const pkss__icp_view *src_coarse,
                              const pkss__icp_view *tgt, const pkss__pose *held,
                              const pkss__shift_ask *ask, pkss__pose *starts,
                              size_t *n_starts);
/* Overlap score (coverage), RMS of the mutual pairs and the fit (fit may be
 * NULL) at pose. */
pkss_status pkss__icp_overlap(const pkss__icp_view *src,
                              const pkss__icp_view *tgt,
                              const pkss__pose *pose, double *overlap,
                              double *rms, double *fit);

#endif
