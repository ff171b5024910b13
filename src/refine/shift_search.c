/* SPDX-License-Identifier: MIT
 * shift_search.c -- the translation search at a winner's rotation and
 * scale (issue #25): where a part lies on a scene of planes, the ICP terms
 * hold the pose on whichever walls it first met, and the translation that
 * puts it on its own walls is a wall's width away. At the held rotation
 * and scale, each of the source's coarse points votes once for every
 * translation cell in which some template point meets it (binned from the
 * exact differences, so no grid alignment decides): a cell's votes are
 * the share of the source that translation would cover. Distinct peaks
 * with clearly more votes than the held translation become candidates,
 * refined as every other (stages.c: pkss__stage_shift).
 */
#include "refine/icp_parts.h"

#include <math.h>
#include <stdlib.h>

typedef struct peak {
    int k[3];
    double votes;
} peak;

static int within_a_cell(const int *a, const int *b)
{
    return abs(a[0] - b[0]) <= 1 && abs(a[1] - b[1]) <= 1 && abs(a[2] - b[2]) <= 1;
}

/* Keeps the PKSS_SHIFT_TRIALS best peaks (most votes first), each more
 * than a cell from the others and from the held translation (k = 0). */
static void keep_best(peak *best, int *n_best, const peak *s)
{
    static const int zero[3] = {0, 0, 0};
    if (within_a_cell(s->k, zero))
        return;
    int at = -1;
    for (int b = 0; b < *n_best && at < 0; ++b)
        if (within_a_cell(s->k, best[b].k)) {
            if (s->votes <= best[b].votes)
                return;
            at = b;
        }
    if (at < 0) {
        if (*n_best < PKSS_SHIFT_TRIALS)
            at = (*n_best)++;
        else if (s->votes > best[PKSS_SHIFT_TRIALS - 1].votes)
            at = PKSS_SHIFT_TRIALS - 1;
        else
            return;
    }
    best[at] = *s;
    for (int b = at; b > 0 && best[b].votes > best[b - 1].votes; --b) {
        peak t = best[b];
        best[b] = best[b - 1];
        best[b - 1] = t;
    }
}

/* The half-range r in cells and the cell side: PKSS_SHIFT_CELL template
 * spacings, coarsened so that r <= PKSS_SHIFT_MAX_R; the range is
 * PKSS_SHIFT_RANGE of the template's bounding-box diagonal. */
static int grid_of(const pkss__icp_view *tgt, double *cell)
{
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (size_t j = 0; j < tgt->m; ++j)
        for (int d = 0; d < 3; ++d) {
            lo[d] = fmin(lo[d], tgt->pts[3 * j + d]);
            hi[d] = fmax(hi[d], tgt->pts[3 * j + d]);
        }
    double d2 = 0.0;
    for (int d = 0; d < 3; ++d)
        d2 += (hi[d] - lo[d]) * (hi[d] - lo[d]);
    const double range = PKSS_SHIFT_RANGE * sqrt(d2);
    *cell = fmax(PKSS_SHIFT_CELL * tgt->spacing, range / PKSS_SHIFT_MAX_R);
    return *cell > 0.0 ? (int)ceil(range / *cell) : 0;
}

/* Votes of the pairs (source point y_i, template point p_j) whose
 * difference p_j - y_i lies within r cells of 0, binned by cell; a source
 * point votes once per cell (stamp: the last point that voted there), so
 * a cell counts the source points that some template point meets there,
 * as an overlap does, not how dense the template is. */
static pkss_status cast_votes(const double *y, size_t m, const pkss__icp_view *tgt,
                              double cell, int r, float *acc, uint32_t *stamp)
{
    const int side = 2 * r + 1;
    const double reach = (r + 0.5) * cell;
    for (size_t i = 0; i < m; ++i) {
        if (i % 64 == 0 && pkss__tick(tgt->run) != PKSS_OK)
            return PKSS_ERR_CANCELLED;
        const double *q = y + 3 * i;
        for (size_t j = 0; j < tgt->m; ++j) {
            const double *p = tgt->pts + 3 * j;
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            if (fabs(dx) >= reach || fabs(dy) >= reach || fabs(dz) >= reach)
                continue;
            int a = (int)floor(dx / cell + 0.5) + r, b = (int)floor(dy / cell + 0.5) + r,
                c = (int)floor(dz / cell + 0.5) + r;
            if (a < 0 || b < 0 || c < 0 || a >= side || b >= side || c >= side)
                continue;
            size_t at = ((size_t)c * (size_t)side + (size_t)b) * (size_t)side + (size_t)a;
            if (stamp[at] != (uint32_t)i + 1) {
                stamp[at] = (uint32_t)i + 1;
                acc[at] += 1.0f;
            }
        }
    }
    return PKSS_OK;
}

/* The votes of cell k. */
static double votes_at(const float *acc, int r, const int *k)
{
    const int side = 2 * r + 1;
    return acc[((size_t)(k[2] + r) * (size_t)side + (size_t)(k[1] + r)) * (size_t)side +
               (size_t)(k[0] + r)];
}

pkss_status pkss__shift_starts(const pkss__icp_view *src_coarse,
                              const pkss__icp_view *tgt, const pkss__pose *held,
                              size_t max, pkss__pose *starts, size_t *n_starts)
{
    *n_starts = 0;
    if (!(tgt->spacing > 0.0) || src_coarse->m == 0 || tgt->m == 0 || max == 0)
        return PKSS_OK;
    double cell = 0.0;
    const int r = grid_of(tgt, &cell);
    if (r < 2)
        return PKSS_OK;
    const int side = 2 * r + 1;
    const size_t m = src_coarse->m;
    double *y = pkss__malloc(3 * m * sizeof(double));
    float *acc = pkss__calloc((size_t)side * side * side, sizeof(float));
    uint32_t *stamp = pkss__calloc((size_t)side * side * side, sizeof(uint32_t));
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    if (!y || !acc || !stamp)
        goto done;
    for (size_t i = 0; i < m; ++i)
        pkss__pose_apply(held, src_coarse->pts + 3 * i, y + 3 * i);
    if ((st = cast_votes(y, m, tgt, cell, r, acc, stamp)) != PKSS_OK)
        goto done;
    peak best[PKSS_SHIFT_TRIALS];
    int n_best = 0;
    for (int c = -r; c <= r; ++c)
        for (int b = -r; b <= r; ++b)
            for (int a = -r; a <= r; ++a) {
                peak s = {{a, b, c}, 0.0};
                s.votes = votes_at(acc, r, s.k);
                keep_best(best, &n_best, &s);
            }
    /* a start gathers PKSS_SHIFT_GAIN more votes than the held translation:
     * the part on other walls, not the held pose's own spread */
    const double bar = (1.0 + PKSS_SHIFT_GAIN) * votes_at(acc, r, (const int[3]){0, 0, 0});
    for (int b = 0; b < n_best && *n_starts < max && best[b].votes > bar; ++b) {
        pkss__pose *p = starts + (*n_starts)++;
        *p = *held;
        for (int d = 0; d < 3; ++d)
            p->t[d] += best[b].k[d] * cell;
    }
done:
    pkss__free(y);
    pkss__free(acc);
    pkss__free(stamp);
    return st;
}
