/* SPDX-License-Identifier: MIT
 * stages.h -- the refinement (SPEC 6 and docs/design.md §4) as named stages
 * over one state. Per search: every candidate's coarse level
 * (stage_coarse_levels), full runs for the chosen few (stage_full_runs:
 * wants_full_run, stage_full_run), the rest scored (stage_score_rest).
 * After the searches: the winner (pick_winner), starts from local shape
 * (stage_local) and the winner again, the shift search (stage_shift) and
 * the winner again, the shift search from other rotations (stage_reshift)
 * and the winner again, then the slide search (stage_slide).
 */
#ifndef PKSS_REFINE_STAGES_H
#define PKSS_REFINE_STAGES_H

#include "refine/icp.h"

/* The full and coarse views of both clouds. */
typedef struct pkss__views {
    pkss__icp_view sv, tv, svc, tvc;
} pkss__views;

/* The refinement state. Candidates of one search or two: the second
 * search's follow the first's, so one index names a candidate in every
 * array and in pkss_result.candidates. */
typedef struct pkss__refinement {
    pkss__pick picks[PKSS_MAX_CANDIDATES];
    pkss__icp_result ir[PKSS_MAX_CANDIDATES];
    pkss_status st[PKSS_MAX_CANDIDATES];
    int refined[PKSS_MAX_CANDIDATES];    /* fully refined: may win */
    uint32_t stage[PKSS_MAX_CANDIDATES]; /* pkss_candidate_stage */
    size_t n;
    /* the leader: the best overlap fully refined (before its polish), in
     * any search and in the current one */
    double lead_overlap, lead_here;
    double lead_merit; /* the best merit fully refined, in any search */
    /* the largest share of one cloud that a candidate fully refined in the
     * current search lies on within the fit distance */
    double explained_here;
    /* whether a candidate fully refined in the current search is in
     * contact (pkss__in_contact) */
    int contact_here;
    pkss__basins basins; /* minima reached by the full runs */
    pkss__views v;
    double search_seconds, refine_seconds;
} pkss__refinement;

/* Initial poses (Eq. 7-9) and coarse levels of candidates [base, base+kept):
 * reads picks, writes ir/st/stage; scored[c] set for those only scored at
 * the search's pose (a first wave covered both clouds). */
pkss_status pkss__stage_coarse_levels(pkss__refinement *rs,
                                      const pkss__search_setup *ss,
                                      const pkss_cloud *src,
                                      const pkss_cloud *tgt, size_t base,
                                      size_t kept, int refine, int *scored);
/* The candidates of one search by coarse overlap, best first (stable). */
void pkss__order_by_overlap(const pkss__icp_result *ir, size_t kept, int *order);
/* How many of them get a full run to begin with: PKSS_FULL_REFINE, less
 * those below PKSS_FULL_REFINE_RATIO of the best. */
size_t pkss__initial_full_count(const pkss__icp_result *ir, const int *order,
                                size_t kept);
/* Whether order[i] gets a full run: among the first *n_full (which grows by
 * one when the candidate at n_full reaches the leader's overlap), not in
 * the basin of one ranked before it (pkss__start_basin, coarse h), and
 * while no refined candidate of this search covers both clouds, has one
 * cloud lying on it wholly (PKSS_EXPLAINED), or is in contact
 * (pkss__in_contact). */
int pkss__wants_full_run(const pkss__refinement *rs, const pkss__icp_result *ir,
                         const int *order, size_t i, size_t *n_full, double h);
/* The full runs of candidates [base, base+kept) after their coarse levels:
 * by coarse overlap, those pkss__wants_full_run chooses, judged in the
 * rigid stage against lead_in (an earlier search's winner before its
 * polish, 0 for the first) and in the scale stage against these alone;
 * the rest scored on all points unless scored[i] (relative index). */
pkss_status pkss__stage_full_runs(pkss__refinement *rs, size_t base, size_t kept,
                                  double lead_in, const int *scored);
/* Candidates from local shape where the winner covers neither cloud
 * wholly: starts[0..n), the poses of pkss__local_starts, as many as there
 * is room for (*added of them, appended; scored by ss's measure at their
 * poses), each with a coarse level, then full runs as a search's
 * candidates get them (pkss__stage_full_runs, against lead_in). */
pkss_status pkss__stage_local(pkss__refinement *rs, const pkss__search_setup *ss,
                              const pkss__pose *starts, size_t n, double lead_in,
                              size_t *added);
/* The scale pairs of a full run from coverages f_s, f_t (otherwise when
 * neither is a part wholly on the other). */
int pkss__part_mode(double fs, double ft, int otherwise);
/* Candidate c's full run (scale search where the coverages show a part,
 * unless scale_known: a shift of a refined pose keeps its searched scale;
 * then rigid, scale and plane stages), judged against the leader; updates
 * ir[c], stage[c], refined[c] and the leader. */
pkss_status pkss__stage_full_run(pkss__refinement *rs, size_t c, int scale_known);
/* Overlap scores on all points, at their poses, of candidates list[0..n). */
pkss_status pkss__stage_score_rest(pkss__refinement *rs, const int *list,
                                   size_t n);
/* The winner: the fully refined candidate with the highest merit
 * (pkss__icp_merit), merits within PKSS_OVERLAP_TIE broken by the lower RMS;
 * candidate 0 when none is. */
int pkss__pick_winner(const pkss__refinement *rs);
/* Whether candidate w is fully refined and lies on the template in
 * contact: of its points within the overlap distance, PKSS_CONTACT or more
 * lie within the fit distance (fit >= PKSS_CONTACT x overlap). Surfaces
 * that coincide there: the part is placed, and wrong poses lie near the
 * surface, not on it. */
int pkss__in_contact(const pkss__refinement *rs, int w);
/* Whether winner w leaves a part's place to be searched for (the wide
 * search, the local starts): it covers neither cloud wholly and does not
 * lie on the template as a placed winner does (fit >= PKSS_PLACED x
 * overlap; the winner of every refined candidate, so a lower ratio than
 * one candidate's contact needs). */
int pkss__part_unplaced(const pkss__refinement *rs, int w);
/* Whether the shift search runs on winner w: it is refined, does not cover
 * both clouds, and has not placed the part (fit < PKSS_PLACED x overlap). */
int pkss__shift_wanted(const pkss__refinement *rs, int w);
/* The shift search on winner w where it is wanted: up to PKSS_SHIFT_TRIALS
 * translations of it that land more points (shift_search.c) become
 * candidates (*added of them, appended) and get full runs. */
pkss_status pkss__stage_shift(pkss__refinement *rs, int w, size_t *added);
/* Whether winner w, where the shift search runs on it, lies astray: less
 * than PKSS_ASTRAY of its overlap lies within the fit distance. */
int pkss__astray(const pkss__refinement *rs, int w);
/* The shift search from other rotations where winner w lies astray: the
 * candidates scored on all points at up to PKSS_RESHIFT_SOURCES other
 * rotations (best merit first) each vote (shift_search.c); each one's
 * PKSS_RESHIFT_SETTLED best peaks by merit are settled on all points, and
 * the best settled, if its merit there beats the winner's settled the same
 * way, gets a full run (*added of them). */
pkss_status pkss__stage_reshift(pkss__refinement *rs, int w, size_t *added);
/* Steps of PKSS_RESCALE_STEP between winner w's scale and the pre-shape
 * ratio, at most PKSS_RESCALE_STEPS; 0 unless both clouds are parts. */
int pkss__rescale_steps(const pkss__refinement *rs, int w);
/* The scale sweep at winner w's rotation: at each step toward the
 * pre-shape ratio, the best of the held pose and its shift search's peaks
 * by merit is settled on all points; the best settled, if it beats the
 * winner's settled the same way, gets a full run (*added: 0 or 1). */
pkss_status pkss__stage_rescale(pkss__refinement *rs, int w, size_t *added);
/* The slide search on winner w when it does not cover both clouds. */
pkss_status pkss__stage_slide(pkss__refinement *rs, int w);

#endif
