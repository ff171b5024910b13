/* SPDX-License-Identifier: MIT
 * shift_search.c -- the translation search at a winner's rotation and
 * scale (issue #25): where a part lies on a scene of planes, the ICP terms
 * hold the pose on whichever walls it first met, and the translation that
 * puts it on its own walls is a wall's width away. At the held rotation
 * and scale, each of the source's coarse points votes once for every
 * translation cell in which some template point meets it (binned from the
 * exact differences, so no grid alignment decides): a cell's votes are
 * the share of the source that translation would cover. Distinct peaks
 * with the caller's share of the held translation's votes become starts
 * (stages.c: pkss__stage_shift refines them as every other candidate,
 * pkss__stage_reshift ranks them first).
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

/* Keeps the `cap` best peaks (most votes first), each more than a cell
 * from the others and from the held translation (k = 0). */
static void keep_best(peak *best, int *n_best, int cap, const peak *s)
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
        if (*n_best < cap)
            at = (*n_best)++;
        else if (s->votes > best[cap - 1].votes)
            at = cap - 1;
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

/* The template's points grouped by block (PKSS_SHIFT_BLOCK cells a side),
 * so that a source point visits only the blocks its reach meets, each in
 * memory order: the votes do not depend on the order of the pairs. */
typedef struct blocks {
    double *pts;  /* the points, block after block */
    size_t *start; /* block b holds pts[start[b] .. start[b + 1]) */
    double *box;   /* block b's bounds: box[6b .. 6b+3) low, [6b+3 .. 6b+6) high */
    int n[3];
    double lo[3], side;
} blocks;

static int block_axis(const blocks *g, double x, int d)
{
    double k = floor((x - g->lo[d]) / g->side);
    return k < 0.0 ? 0 : k >= g->n[d] ? g->n[d] - 1 : (int)k;
}

static size_t block_of(const blocks *g, const double *p)
{
    return ((size_t)block_axis(g, p[2], 2) * (size_t)g->n[1] +
            (size_t)block_axis(g, p[1], 1)) * (size_t)g->n[0] +
           (size_t)block_axis(g, p[0], 0);
}

static void blocks_free(blocks *g)
{
    pkss__free(g->pts);
    pkss__free(g->start);
    pkss__free(g->box);
}

static int blocks_build(const pkss__icp_view *tgt, double cell, blocks *g)
{
    double hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    g->lo[0] = g->lo[1] = g->lo[2] = HUGE_VAL;
    for (size_t j = 0; j < tgt->m; ++j)
        for (int d = 0; d < 3; ++d) {
            g->lo[d] = fmin(g->lo[d], tgt->pts[3 * j + d]);
            hi[d] = fmax(hi[d], tgt->pts[3 * j + d]);
        }
    g->side = PKSS_SHIFT_BLOCK * cell;
    size_t nb = 1;
    for (int d = 0; d < 3; ++d) {
        g->n[d] = (int)fmin(floor((hi[d] - g->lo[d]) / g->side) + 1.0, PKSS_SHIFT_MAX_BLOCKS);
        nb *= (size_t)g->n[d];
    }
    g->pts = pkss__malloc(3 * tgt->m * sizeof(double));
    g->start = pkss__calloc(nb + 1, sizeof(size_t));
    g->box = pkss__malloc(6 * nb * sizeof(double));
    size_t *fill = pkss__calloc(nb, sizeof(size_t));
    if (!g->pts || !g->start || !g->box || !fill) {
        pkss__free(fill);
        return 0;
    }
    for (size_t j = 0; j < tgt->m; ++j)
        ++g->start[block_of(g, tgt->pts + 3 * j) + 1];
    for (size_t b = 0; b < nb; ++b)
        g->start[b + 1] += g->start[b];
    for (size_t b = 0; b < nb; ++b)
        for (int d = 0; d < 3; ++d) {
            g->box[6 * b + d] = HUGE_VAL;
            g->box[6 * b + 3 + d] = -HUGE_VAL;
        }
    for (size_t j = 0; j < tgt->m; ++j) {
        size_t b = block_of(g, tgt->pts + 3 * j), at = g->start[b] + fill[b]++;
        for (int d = 0; d < 3; ++d) {
            double x = tgt->pts[3 * j + d];
            g->pts[3 * at + d] = x;
            g->box[6 * b + d] = fmin(g->box[6 * b + d], x);
            g->box[6 * b + 3 + d] = fmax(g->box[6 * b + 3 + d], x);
        }
    }
    pkss__free(fill);
    return 1;
}

/* One share of the vote: source points [first, end) into acc, with its own
 * stamps; cancellation is checked every 64 points. */
typedef struct vote_job {
    const double *y;
    size_t first, end;
    const blocks *g;
    double cell;
    int r;
    pkss__run *run;
    float *acc;
    uint32_t *stamp;
    pkss_status st;
} vote_job;

/* Whether every point of block b fails the reach test of q (the bounds
 * bound every difference, as rounding is monotone), or the block is empty. */
static int beyond_reach(const blocks *g, size_t b, const double *q, double reach)
{
    const double *box = g->box + 6 * b;
    for (int d = 0; d < 3; ++d)
        if (box[d] - q[d] >= reach || q[d] - box[3 + d] >= reach)
            return 1;
    return g->start[b] == g->start[b + 1];
}

/* The votes of source point i against the template points of block b. */
static void vote_block(const vote_job *v, size_t i, size_t b, double reach, int side)
{
    const double *q = v->y + 3 * i;
    if (beyond_reach(v->g, b, q, reach))
        return;
    const double cell = v->cell;
    const int r = v->r;
    for (size_t j = v->g->start[b]; j < v->g->start[b + 1]; ++j) {
        const double *p = v->g->pts + 3 * j;
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        if (fabs(dx) >= reach || fabs(dy) >= reach || fabs(dz) >= reach)
            continue;
        int a = (int)floor(dx / cell + 0.5) + r, bb = (int)floor(dy / cell + 0.5) + r,
            c = (int)floor(dz / cell + 0.5) + r;
        if (a < 0 || bb < 0 || c < 0 || a >= side || bb >= side || c >= side)
            continue;
        size_t at = ((size_t)c * (size_t)side + (size_t)bb) * (size_t)side + (size_t)a;
        if (v->stamp[at] != (uint32_t)i + 1) {
            v->stamp[at] = (uint32_t)i + 1;
            v->acc[at] += 1.0f;
        }
    }
}

/* Votes of the pairs (source point y_i, template point p_j) whose
 * difference p_j - y_i lies within r cells of 0, binned by cell; a source
 * point votes once per cell (stamp: the last point that voted there), so
 * a cell counts the source points that some template point meets there,
 * as an overlap does, not how dense the template is. Blocks beyond the
 * reach are skipped with a block's margin against rounding. */
static void vote_worker(void *arg)
{
    vote_job *v = arg;
    const blocks *g = v->g;
    const int side = 2 * v->r + 1;
    const double reach = (v->r + 0.5) * v->cell;
    v->st = PKSS_OK;
    for (size_t i = v->first; i < v->end; ++i) {
        if ((i - v->first) % 64 == 0 && pkss__tick(v->run) != PKSS_OK) {
            v->st = PKSS_ERR_CANCELLED;
            return;
        }
        const double *q = v->y + 3 * i;
        int k0[3], k1[3];
        for (int d = 0; d < 3; ++d) {
            k0[d] = block_axis(g, q[d] - reach, d) - 1;
            k1[d] = block_axis(g, q[d] + reach, d) + 1;
            k0[d] = k0[d] < 0 ? 0 : k0[d];
            k1[d] = k1[d] >= g->n[d] ? g->n[d] - 1 : k1[d];
        }
        for (int z = k0[2]; z <= k1[2]; ++z)
            for (int yy = k0[1]; yy <= k1[1]; ++yy) {
                size_t row = ((size_t)z * (size_t)g->n[1] + (size_t)yy) * (size_t)g->n[0];
                for (int x = k0[0]; x <= k1[0]; ++x)
                    vote_block(v, i, row + (size_t)x, reach, side);
            }
    }
}

/* The vote over the caller and the call's helper thread (half the source
 * points each, each into its own accumulator, then summed: the counts are
 * whole numbers, so the sum is exact and the order does not matter). */
static pkss_status cast_votes(const double *y, size_t m, const pkss__icp_view *tgt,
                              double cell, int r, float *acc, uint32_t *stamp)
{
    const size_t cells = (size_t)(2 * r + 1) * (size_t)(2 * r + 1) * (size_t)(2 * r + 1);
    blocks g = {0};
    float *acc2 = pkss__calloc(cells, sizeof(float));
    uint32_t *stamp2 = pkss__calloc(cells, sizeof(uint32_t));
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    if (!acc2 || !stamp2 || !blocks_build(tgt, cell, &g))
        goto done;
    vote_job a = {y, 0, m / 2, &g, cell, r, tgt->run, acc, stamp, PKSS_OK};
    vote_job b = {y, m / 2, m, &g, cell, r, tgt->run, acc2, stamp2, PKSS_OK};
    pkss__helper *helper = pkss__run_helper(tgt->run);
    pkss__helper_both(helper, vote_worker, &a, &b);
    for (size_t k = 0; k < cells; ++k)
        acc[k] += acc2[k];
    st = a.st != PKSS_OK ? a.st : b.st;
done:
    blocks_free(&g);
    pkss__free(acc2);
    pkss__free(stamp2);
    return st;
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
                              const pkss__shift_ask *ask, pkss__pose *starts,
                              size_t *n_starts)
{
    *n_starts = 0;
    const size_t max = ask->max;
    if (!(tgt->spacing > 0.0) || src_coarse->m == 0 || tgt->m == 0 || max == 0 ||
        ask->peaks < 1 || ask->peaks > PKSS_SHIFT_PEAKS_MAX)
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
    peak best[PKSS_SHIFT_PEAKS_MAX];
    int n_best = 0;
    for (int c = -r; c <= r; ++c)
        for (int b = -r; b <= r; ++b)
            for (int a = -r; a <= r; ++a) {
                peak s = {{a, b, c}, 0.0};
                s.votes = votes_at(acc, r, s.k);
                keep_best(best, &n_best, ask->peaks, &s);
            }
    /* a start gathers the asked share of the held translation's votes: the
     * part on other walls covers more, a partial view slid back onto its
     * truth may cover less (its merit, not its cover, wins it) */
    const double bar = ask->share * votes_at(acc, r, (const int[3]){0, 0, 0});
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
