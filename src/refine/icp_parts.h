/* SPDX-License-Identifier: MIT
 * icp_parts.h -- the pieces the ICP engine (icp.c) and the local searches
 * (local_search.c) share: pose arithmetic and the least-squares updates
 * (solve.c), correspondences, pairs and coverage (correspond.c).
 */
#ifndef PKSS_REFINE_ICP_PARTS_H
#define PKSS_REFINE_ICP_PARTS_H

#include "refine/icp.h"

/* ---- pose arithmetic and updates (solve.c) ---- */
/* (inline: the correspondences call these once per point and iteration) */
static inline void pkss__pose_apply(const pkss__pose *T, const double *x, double *y)
{
    double r[3];
    pkss__mat3_apply(T->R, x, r);
    for (int d = 0; d < 3; ++d)
        y[d] = T->s * r[d] + T->t[d];
}
/* x = R^T (y - t) / s: a template point in source pre-shape coordinates */
static inline void pkss__pose_inverse_apply(const pkss__pose *T, const double *y, double *x)
{
    double v[3] = {y[0] - T->t[0], y[1] - T->t[1], y[2] - T->t[2]};
    for (int d = 0; d < 3; ++d)
        x[d] = (T->R[d] * v[0] + T->R[3 + d] * v[1] + T->R[6 + d] * v[2]) / T->s;
}
/* sum of absolute differences of s, R and t */
double pkss__pose_change(const pkss__pose *a, const pkss__pose *b);
/* The least-squares similarity (Umeyama) or rigid motion (Kabsch, T->s
 * kept) y ~ T x of pairs (xs row pi[k], ys row pj[k]), k < n, into T.
 * Returns 0 where the scale was asked and the pairs fix none (T->s kept). */
int pkss__similarity_fit(const double *xs, const uint32_t *pi, const double *ys,
                         const uint32_t *pj, size_t n, int with_scale, pkss__pose *T);
/* Least-squares similarity (Umeyama) or rigid (Kabsch, fixed s) update
 * from pairs (src pi[k], tgt pj[k]). Returns 0 if too few pairs. */
int pkss__solve_point(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      const uint32_t *pi, const uint32_t *pj, size_t n,
                      int with_scale, pkss__pose *T);
/* One Gauss-Newton step of the point-to-plane similarity fit; returns the
 * step's largest component, or -1 if the pairs fix no pose. */
double pkss__solve_plane(const pkss__icp_view *src, const pkss__icp_view *tgt,
                         const uint32_t *pi, const uint32_t *pj, size_t n,
                         pkss__pose *T);

/* ---- correspondences (correspond.c) ---- */
/* What one direction's last kd-tree query proved, per query point: where
 * it stood (q0), its ICP_MEMO_K - 1 nearest points (near, UINT32_MAX where
 * the tree has fewer) and the distance of the next one, a lower bound for
 * every other point (lb; infinite if none, < 0 before the first query). */
typedef struct pkss__nn_memo {
    double *q0, *lb;
    uint32_t *near;
} pkss__nn_memo;

/* One lookup chunk's pairs beneath their points (forward, backward), left
 * in its stretch of the pair lists, and the farthest answer's squared
 * distance (template units). */
typedef struct pkss__chunk_pairs {
    size_t n[2];
    double d2max;
} pkss__chunk_pairs;

/* Nearest partners both ways and the pair lists built from them. fwd/bwd
 * hold the answers within the last gate or UINT32_MAX. */
typedef struct pkss__icp_work {
    uint32_t *fwd, *bwd, *pi, *pj;
    double *fwd_d2, *bwd_d2;
    pkss__chunk_pairs *chunks; /* of correspond_beneath(), per lookup chunk */
    /* the last two-way pass's coverage distance at its pose
     * (pkss__coverage_gate) and the answers within it each way */
    double cover_gate;
    size_t covered[2];
    pkss__nn_memo fwd_memo, bwd_memo;
} pkss__icp_work;

/* remember: the queries will be repeated from nearby poses (the memos);
 * nt = 0 for a work that only ever runs forward passes */
int pkss__work_alloc(pkss__icp_work *w, size_t ns, size_t nt, int remember);
void pkss__work_free(pkss__icp_work *w);
/* Nearest template point of every source point and nearest source point of
 * every template point, both within gate (template units). */
void pkss__correspond(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      const pkss__pose *T, double gate, pkss__icp_work *w);
/* correspond(), and the pairs whose partner lies beneath its point: the
 * point's offset along the partner's surface (orthogonal to the partner's
 * normal) within tol (template units; tol / s for the backward answers).
 * Views without normals keep every pair. Read by pkss__beneath_pairs. */
void pkss__correspond_beneath(const pkss__icp_view *src, const pkss__icp_view *tgt,
                              const pkss__pose *T, double gate, double tol,
                              pkss__icp_work *w);
/* The forward half of correspond(): fwd only (bwd keeps its last answers). */
void pkss__correspond_forward(const pkss__icp_view *src, const pkss__icp_view *tgt,
                              const pkss__pose *T, double gate, pkss__icp_work *w);
/* Pair lists from the last correspond() into w->pi / w->pj: forward and
 * backward ones appended from n on, mutual ones from 0; each returns the
 * new count and raises *d2max to the farthest pair (template units). */
size_t pkss__forward_pairs(pkss__icp_work *w, size_t ns, size_t n, double *d2max);
size_t pkss__backward_pairs(pkss__icp_work *w, size_t nt, size_t n, double s,
                            double *d2max);
size_t pkss__mutual_pairs(pkss__icp_work *w, size_t ns, double *d2max);
/* The pairs beneath of the last correspond_beneath() into w->pi / w->pj
 * from 0, forward (their count in *n_forward, if not NULL) then backward,
 * each in index order as forward_pairs and backward_pairs list them;
 * returns the count and raises *d2max to the farthest of all answers. */
size_t pkss__beneath_pairs(pkss__icp_work *w, size_t ns, size_t nt, size_t *n_forward,
                           double *d2max);
/* The coverage distance: ICP_OVERLAP_DIST x the coarser spacing. */
double pkss__coverage_gate(const pkss__icp_view *src, const pkss__icp_view *tgt,
                           const pkss__pose *T);
/* Shares of each cloud within cg of the other, from the last correspond()
 * whose gate was at least cg. */
void pkss__coverage_from_pairs(const pkss__icp_view *src,
                               const pkss__icp_view *tgt, const pkss__pose *T,
                               double cg, const pkss__icp_work *w,
                               double cover[2]);
/* Shares of each cloud within dist (template units) of the other at T, by
 * existence queries: the shares correspond() and coverage_from_pairs()
 * give at gate dist, without finding the nearest points. */
void pkss__cover_within(const pkss__icp_view *src, const pkss__icp_view *tgt,
                        const pkss__pose *T, double dist, double cover[2]);
/* The fit sqrt(f_s f_t) within dist at T, equal to pkss__cover_within's,
 * or -1 as soon as the counts show it stays below bar. One thread. */
double pkss__fit_reaching(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__pose *T, double dist, double bar);
/* Overlap score, RMS, coverages (may be NULL), fit and its coverages (both
 * NULL or neither) at T. */
void pkss__overlap_with(const pkss__icp_view *src, const pkss__icp_view *tgt,
                        const pkss__pose *T, pkss__icp_work *w,
                        double *overlap, double *rms, double *cover,
                        double *fit, double *fit_cover);
/* The overlap at the pose of the last correspond() (gate), or -1 when the
 * gate was narrower than the coverage distance. */
double pkss__overlap_from_pairs(const pkss__icp_view *src,
                                const pkss__icp_view *tgt, double gate,
                                const pkss__icp_work *w);
/* The point-to-plane polish (icp.c): returns the steps taken. */
int pkss__plane_stage(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      int iters, pkss__icp_work *w, pkss__pose *T,
                      double *overlap_start);

#endif
