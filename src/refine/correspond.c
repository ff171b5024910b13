/* SPDX-License-Identifier: MIT
 * correspond.c -- correspondences of the ICP engine: nearest partners both
 * ways (kd-tree queries, remembered while provably unchanged), the pair
 * lists each stage uses, and the coverage overlap that judges poses (SPEC 6,
 * with the deviation in docs/design.md).
 */
#include "refine/icp_parts.h"
#include "refine/work_counts.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

#ifdef PKSS_COUNT_WORK
/* The work of the lookups below, counted (CMake option PKSS_COUNT_WORK):
 * time on a shared machine is noisy, these counts are not. */
static atomic_ulong work_counts[PKSS_WORK_COUNTS];
#define COUNT(k) atomic_fetch_add_explicit(&work_counts[k], 1, memory_order_relaxed)

void pkss__work_counts(unsigned long out[PKSS_WORK_COUNTS])
{
    for (int k = 0; k < PKSS_WORK_COUNTS; ++k)
        out[k] = atomic_exchange_explicit(&work_counts[k], 0, memory_order_relaxed);
}
#else
#define COUNT(k) ((void)0)
#endif

/* Stores what a fresh query from q proved for point k of memo m (its got
 * nearest, idx/dd, and the margin lb) and returns its answer within the
 * gate (UINT32_MAX and *d2 = g2 if none). */
static uint32_t remember(pkss__nn_memo *m, size_t k, const double *q, const uint32_t *idx,
                         const double *dd, size_t got, double lb, double g2, double *d2)
{
    enum { KEEP = ICP_MEMO_K - 1 };
    uint32_t *near = m->near + KEEP * k;
    memcpy(m->q0 + 3 * k, q, 3 * sizeof(double));
    for (size_t i = 0; i < KEEP; ++i)
        near[i] = i < got ? idx[i] : UINT32_MAX;
    m->lb[k] = lb;
    int hit = got > 0 && dd[0] < g2;
    *d2 = hit ? dd[0] : g2;
    return hit ? idx[0] : UINT32_MAX;
}

/* The nearest point of view v to q within sqrt(g2), exactly as
 * pkss__kdtree_nearest answers it (UINT32_MAX and *d2 = g2 if none). A
 * query remembers up to ICP_MEMO_K - 1 nearest points of q0 and a distance
 * lb within which no other point lies: after q moves by |q - q0|, every
 * point not remembered is at least lb - |q - q0| away (triangle inequality),
 * so the nearest remembered one (ties to the lowest index) is still the
 * answer when it is closer than that, and none is when that is beyond the
 * gate. A fresh query asks the view's field first (shared by every run),
 * then the tree. */
static uint32_t nearest_memo(const pkss__icp_view *v, const double *q, double g2,
                             pkss__nn_memo *m, size_t k, double *d2)
{
    const pkss__kdtree *tree = v->tree;
    const double *pts = v->pts;
    enum { KEEP = ICP_MEMO_K - 1 };
    COUNT(PKSS_WORK_LOOKUPS);
    if (!m->lb) { /* a single query: nothing to remember */
        COUNT(PKSS_WORK_SINGLE);
        return pkss__kdtree_nearest(tree, q, g2, d2);
    }
    double *q0 = m->q0 + 3 * k;
    uint32_t *near = m->near + KEEP * k;
    if (m->lb[k] >= 0.0) {
        double moved = sqrt(pkss__dist2(q, q0));
        double others = m->lb[k] - moved;
        uint32_t best = UINT32_MAX;
        double bd = INFINITY;
        for (int i = 0; i < KEEP && near[i] != UINT32_MAX; ++i) {
            double dj = pkss__dist2(q, pts + 3 * (size_t)near[i]);
            if (dj < bd || (dj == bd && near[i] < best)) {
                bd = dj;
                best = near[i];
            }
        }
        /* lb is infinite when the memo holds every point of the tree; the
         * slack (far above the rounding of the squares) keeps the proof
         * sound, compared squared */
        double o = others - ICP_MEMO_SLACK * (moved + m->lb[k]);
        int proved = isinf(m->lb[k]) ? bd < INFINITY
                                     : o > 0.0 && (bd < o * o || (!(bd < g2) && o * o >= g2));
        if (proved) {
            *d2 = bd < g2 ? bd : g2;
            return bd < g2 ? best : UINT32_MAX;
        }
    }
    COUNT(m->lb[k] < 0.0 ? PKSS_WORK_FIRST : PKSS_WORK_MOVED);
    /* the field's answer where it has one: the nearest few with the margin,
     * or only the margin where no point lies within the gate */
    uint32_t idx[ICP_MEMO_K];
    double dd[ICP_MEMO_K], lb;
    int near_got = pkss__nn_field_near(v->field, q, KEEP, idx, dd, &lb);
    if (near_got > 0 || (near_got == 0 && lb * lb >= g2))
        return remember(m, k, q, idx, dd, (size_t)near_got, lb, g2, d2);
    /* only as far as ICP_MEMO_REACH gates: a point with no partner near
     * stops at the boxes beyond, and the reach is then its margin */
    const double reach2 = ICP_MEMO_REACH * ICP_MEMO_REACH * g2;
    size_t got = pkss__kdtree_knn_within(tree, q, ICP_MEMO_K, SIZE_MAX, reach2, idx, dd);
    lb = got == ICP_MEMO_K                ? sqrt(dd[KEEP])
         : got == pkss__kdtree_size(tree) ? INFINITY
                                          : sqrt(reach2);
    return remember(m, k, q, idx, dd, got < KEEP ? got : KEEP, lb, g2, d2);
}

/* One pass's lookups, forward [0, src->m) then backward, claimed in chunks
 * of PKSS_LOOKUP_CHUNK by whichever thread is free: the two directions'
 * costs differ (a part's points find no partner), so a fixed split leaves
 * one thread waiting. Each lookup owns its memo entry, so which thread
 * answers it never changes the answer. */
typedef struct lookup_job {
    const pkss__icp_view *src, *tgt;
    const pkss__pose *T;
    double g2, g2s;
    double tol2, tol2s; /* squared beneath tolerances (< 0: no pairs) */
    double cg2, cg2s;   /* squared coverage distance, template and source units */
    pkss__icp_work *w;
    size_t total; /* src->m: forward only; src->m + tgt->m: both ways */
    atomic_size_t covered[2]; /* answers within the coverage distance */
    /* claimed by both threads: a cache line of its own (the alignment pads
     * the job to whole lines), away from the fields every lookup reads */
    _Alignas(64) atomic_size_t next;
} lookup_job;

/* The squared offset of p from q along the surface whose normal at q is nq. */
static double offset_along_surface2(const double *p, const double *q, const double *nq)
{
    const double d[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
    const double across = pkss__dot3(d, nq);
    return pkss__dot3(d, d) - across * across;
}

/* Whether the partner u of view `under` found for point p at squared
 * distance d2 lies beneath p: p's offset along the partner's surface within
 * sqrt(tol2). No offset exceeds the pair's distance; a view without normals
 * keeps every pair. */
static int beneath(const double *p, uint32_t u, double d2, double tol2,
                   const pkss__icp_view *under)
{
    if (!under->normal || d2 <= tol2)
        return 1;
    return offset_along_surface2(p, under->pts + 3 * (size_t)u,
                                 under->normal + 3 * (size_t)u) <= tol2;
}

/* Whether an answer (nearest nn at squared distance d2) lies within the
 * squared distance c2: the coverage counts' test. */
static int covered(uint32_t nn, double d2, double c2)
{
    return nn != UINT32_MAX && d2 <= c2;
}

/* Lookups [a, b) of a pass (forward below src->m, backward above), and
 * their answers within the coverage distance counted. With beneath
 * tolerances, the chunk's pairs beneath their points are compacted in its
 * own stretch of pi / pj, in the lists' order, for pkss__beneath_pairs to
 * join: the caller would otherwise build them while the helper waits. */
static void lookup_range(const lookup_job *j, size_t a, size_t b, size_t hits[2])
{
    pkss__icp_work *w = j->w;
    const size_t nf = j->src->m, b0 = a > nf ? a : nf;
    const double s2 = j->T->s * j->T->s;
    size_t at = a, bt = b0;
    double d2max = 0.0;
    for (size_t i = a; i < b && i < nf; ++i) {
        double y[3];
        pkss__pose_apply(j->T, j->src->pts + 3 * i, y);
        uint32_t u = nearest_memo(j->tgt, y, j->g2, &w->fwd_memo, i, &w->fwd_d2[i]);
        w->fwd[i] = u;
        hits[0] += (size_t)covered(u, w->fwd_d2[i], j->cg2);
        if (j->tol2 >= 0.0 && u != UINT32_MAX) {
            d2max = w->fwd_d2[i] > d2max ? w->fwd_d2[i] : d2max;
            if (beneath(y, u, w->fwd_d2[i], j->tol2, j->tgt)) {
                w->pi[at] = (uint32_t)i;
                w->pj[at++] = u;
            }
        }
    }
    for (size_t k = b0 - nf; k + nf < b; ++k) {
        double x[3];
        pkss__pose_inverse_apply(j->T, j->tgt->pts + 3 * k, x);
        uint32_t u = nearest_memo(j->src, x, j->g2s, &w->bwd_memo, k, &w->bwd_d2[k]);
        w->bwd[k] = u;
        hits[1] += (size_t)covered(u, w->bwd_d2[k], j->cg2s);
        if (j->tol2s >= 0.0 && u != UINT32_MAX) {
            d2max = s2 * w->bwd_d2[k] > d2max ? s2 * w->bwd_d2[k] : d2max;
            if (beneath(x, u, w->bwd_d2[k], j->tol2s, j->src)) {
                w->pi[bt] = u;
                w->pj[bt++] = (uint32_t)k;
            }
        }
    }
    if (j->tol2 >= 0.0) {
        pkss__chunk_pairs *c = &w->chunks[a / PKSS_LOOKUP_CHUNK];
        c->n[0] = at - a;
        c->n[1] = bt - b0;
        c->d2max = d2max;
    }
}

static void lookups(void *arg)
{
    lookup_job *j = arg;
    const size_t total = j->total;
    size_t hits[2] = {0, 0};
    for (;;) {
        size_t a = atomic_fetch_add_explicit(&j->next, PKSS_LOOKUP_CHUNK,
                                             memory_order_relaxed);
        if (a >= total)
            break;
        lookup_range(j, a, a + PKSS_LOOKUP_CHUNK < total ? a + PKSS_LOOKUP_CHUNK : total,
                     hits);
    }
    atomic_fetch_add_explicit(&j->covered[0], hits[0], memory_order_relaxed);
    atomic_fetch_add_explicit(&j->covered[1], hits[1], memory_order_relaxed);
}

/* The call's helper thread for a two-way pass over src and tgt, or NULL
 * where the views are too small to gain from it (ICP_THREAD_MIN). */
static pkss__helper *pass_helper(const pkss__icp_view *src, const pkss__icp_view *tgt)
{
    return src->m + tgt->m >= 2 * ICP_THREAD_MIN ? pkss__run_helper(src->run) : NULL;
}

/* One pass's lookups, the first `total` of forward then backward (lookups),
 * by both threads, each claiming chunks until none is left; with tol >= 0
 * each chunk's pairs beneath their points as well. */
static void run_pass(const pkss__icp_view *src, const pkss__icp_view *tgt,
                     const pkss__pose *T, double gate, double tol, pkss__icp_work *w,
                     size_t total)
{
    double g2 = gate * gate, tol_s = tol / T->s;
    double cg = pkss__coverage_gate(src, tgt, T), cg2 = cg * cg;
    lookup_job job = {.src = src, .tgt = tgt, .T = T, .g2 = g2, .g2s = g2 / (T->s * T->s),
                      .tol2 = tol >= 0.0 ? tol * tol : -1.0,
                      .tol2s = tol >= 0.0 ? tol_s * tol_s : -1.0, .cg2 = cg2,
                      .cg2s = cg2 / (T->s * T->s), .w = w, .total = total};
    atomic_init(&job.next, 0);
    atomic_init(&job.covered[0], 0);
    atomic_init(&job.covered[1], 0);
    pkss__helper_both(pass_helper(src, tgt), lookups, &job, &job);
    if (total > src->m) { /* both ways: the coverages at this pose */
        w->cover_gate = cg;
        w->covered[0] = atomic_load(&job.covered[0]);
        w->covered[1] = atomic_load(&job.covered[1]);
    }
}

/* Nearest template point of every source point (fwd) and nearest source
 * point of every template point (bwd), both within gate (template units);
 * UINT32_MAX where none; fwd_d2 / bwd_d2 the squared distances (bwd_d2 in
 * source units, where the backward search runs). */
void pkss__correspond(const pkss__icp_view *src, const pkss__icp_view *tgt,
                      const pkss__pose *T, double gate, pkss__icp_work *w)
{
    run_pass(src, tgt, T, gate, -1.0, w, src->m + tgt->m);
}

void pkss__correspond_beneath(const pkss__icp_view *src, const pkss__icp_view *tgt,
                              const pkss__pose *T, double gate, double tol,
                              pkss__icp_work *w)
{
    run_pass(src, tgt, T, gate, tol, w, src->m + tgt->m);
}

void pkss__correspond_forward(const pkss__icp_view *src, const pkss__icp_view *tgt,
                              const pkss__pose *T, double gate, pkss__icp_work *w)
{
    run_pass(src, tgt, T, gate, -1.0, w, src->m);
}

static void memo_free(pkss__nn_memo *m)
{
    pkss__free(m->q0);
    pkss__free(m->lb);
    pkss__free(m->near);
}

static int memo_alloc(pkss__nn_memo *m, size_t n)
{
    m->q0 = pkss__malloc(3 * n * sizeof(double));
    m->lb = pkss__malloc(n * sizeof(double));
    m->near = pkss__malloc((ICP_MEMO_K - 1) * n * sizeof(uint32_t));
    if (!m->q0 || !m->lb || !m->near)
        return 0;
    for (size_t k = 0; k < n; ++k)
        m->lb[k] = -1.0; /* nothing proved yet */
    return 1;
}

void pkss__work_free(pkss__icp_work *w)
{
    pkss__free(w->fwd);
    pkss__free(w->bwd);
    pkss__free(w->pi);
    pkss__free(w->pj);
    pkss__free(w->fwd_d2);
    pkss__free(w->bwd_d2);
    pkss__free(w->chunks);
    memo_free(&w->fwd_memo);
    memo_free(&w->bwd_memo);
}

int pkss__work_alloc(pkss__icp_work *w, size_t ns, size_t nt, int remember)
{
    memset(w, 0, sizeof *w);
    w->fwd = pkss__malloc(ns * sizeof(uint32_t));
    w->fwd_d2 = pkss__malloc(ns * sizeof(double));
    w->bwd = pkss__malloc(nt * sizeof(uint32_t));
    w->bwd_d2 = pkss__malloc(nt * sizeof(double));
    w->pi = pkss__malloc((ns + nt) * sizeof(uint32_t));
    w->pj = pkss__malloc((ns + nt) * sizeof(uint32_t));
    w->chunks = pkss__malloc(((ns + nt) / PKSS_LOOKUP_CHUNK + 1) * sizeof *w->chunks);
    int memos = !remember || (memo_alloc(&w->fwd_memo, ns) & memo_alloc(&w->bwd_memo, nt));
    if (!w->fwd || !w->fwd_d2 || !w->bwd || !w->bwd_d2 || !w->pi || !w->pj || !w->chunks ||
        !memos) {
        pkss__work_free(w);
        return 0;
    }
    memset(w->fwd, 0xff, ns * sizeof(uint32_t)); /* no answers yet */
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

/* Moves the n pairs at pi / pj [from, from + n) to [*at, *at + n). */
static void join(pkss__icp_work *w, size_t from, size_t n, size_t *at)
{
    memmove(w->pi + *at, w->pi + from, n * sizeof *w->pi);
    memmove(w->pj + *at, w->pj + from, n * sizeof *w->pj);
    *at += n;
}

size_t pkss__beneath_pairs(pkss__icp_work *w, size_t ns, size_t nt, size_t *n_forward,
                           double *d2max)
{
    const size_t chunks = (ns + nt + PKSS_LOOKUP_CHUNK - 1) / PKSS_LOOKUP_CHUNK;
    size_t n = 0;
    for (size_t c = 0; c * PKSS_LOOKUP_CHUNK < ns; ++c)
        join(w, c * PKSS_LOOKUP_CHUNK, w->chunks[c].n[0], &n);
    if (n_forward)
        *n_forward = n;
    for (size_t c = 0; c < chunks; ++c) {
        size_t first = c * PKSS_LOOKUP_CHUNK;
        if (first + PKSS_LOOKUP_CHUNK > ns)
            join(w, first > ns ? first : ns, w->chunks[c].n[1], &n);
        *d2max = w->chunks[c].d2max > *d2max ? w->chunks[c].d2max : *d2max;
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
        fwd_hits += (size_t)covered(w->fwd[i], w->fwd_d2[i], cg2);
    for (size_t j = 0; j < tgt->m; ++j)
        bwd_hits += (size_t)covered(w->bwd[j], w->bwd_d2[j], cg2s);
    cover[0] = src->m ? (double)fwd_hits / (double)src->m : 0.0;
    cover[1] = tgt->m ? (double)bwd_hits / (double)tgt->m : 0.0;
}

/* Points [i0, i1) of view q with a point of `tree` strictly within
 * sqrt(d2), q's points taken through T (forward: source points into the
 * template, d2 in template units) or through its inverse (template points
 * into the source, d2 in source units). */
static size_t hits_within(const pkss__icp_view *q, const pkss__kdtree *tree,
                          const pkss__pose *T, int inverse, double d2, size_t i0,
                          size_t i1)
{
    size_t hits = 0;
    for (size_t i = i0; i < i1; ++i) {
        double y[3];
        if (inverse)
            pkss__pose_inverse_apply(T, q->pts + 3 * i, y);
        else
            pkss__pose_apply(T, q->pts + 3 * i, y);
        hits += (size_t)pkss__kdtree_any_within(tree, y, d2);
    }
    return hits;
}

/* One direction's existence queries over all of view q's points. */
typedef struct cover_job {
    const pkss__icp_view *q;
    const pkss__kdtree *tree;
    const pkss__pose *T;
    int inverse;
    double d2;
    size_t hits;
} cover_job;

static void cover_count(void *arg)
{
    cover_job *j = arg;
    j->hits = hits_within(j->q, j->tree, j->T, j->inverse, j->d2, 0, j->q->m);
}

void pkss__cover_within(const pkss__icp_view *src, const pkss__icp_view *tgt,
                        const pkss__pose *T, double dist, double cover[2])
{
    /* the squared bounds as correspond() forms its gates */
    double d2 = dist * dist;
    cover_job fwd = {src, tgt->tree, T, 0, d2, 0};
    cover_job bwd = {tgt, src->tree, T, 1, d2 / (T->s * T->s), 0};
    pkss__helper_both(pass_helper(src, tgt), cover_count, &fwd, &bwd);
    cover[0] = src->m ? (double)fwd.hits / (double)src->m : 0.0;
    cover[1] = tgt->m ? (double)bwd.hits / (double)tgt->m : 0.0;
}

/* A share whose count may still gain the rest of its points. */
static double share_at_most(size_t hits, size_t done, size_t m)
{
    return (double)(hits + (m - done)) / (double)m;
}

double pkss__fit_reaching(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__pose *T, double dist, double bar)
{
    if (src->m == 0 || tgt->m == 0)
        return 0.0;
    double d2 = dist * dist, d2s = d2 / (T->s * T->s);
    size_t fwd = 0, bwd = 0;
    /* the counts in blocks, each block ending in the test that even every
     * point left covered keeps sqrt(f_s f_t) below bar (both are rounded
     * monotonically, so the bound holds for the exact fit too) */
    for (size_t i = 0; i < src->m; i += PKSS_FIT_BLOCK) {
        if (sqrt(share_at_most(fwd, i, src->m)) < bar)
            return -1.0;
        size_t end = i + PKSS_FIT_BLOCK < src->m ? i + PKSS_FIT_BLOCK : src->m;
        fwd += hits_within(src, tgt->tree, T, 0, d2, i, end);
    }
    const double fs = (double)fwd / (double)src->m;
    for (size_t j = 0; j < tgt->m; j += PKSS_FIT_BLOCK) {
        if (sqrt(fs * share_at_most(bwd, j, tgt->m)) < bar)
            return -1.0;
        size_t end = j + PKSS_FIT_BLOCK < tgt->m ? j + PKSS_FIT_BLOCK : tgt->m;
        bwd += hits_within(tgt, src->tree, T, 1, d2s, j, end);
    }
    return sqrt(fs * ((double)bwd / (double)tgt->m));
}

double pkss__icp_merit(const pkss__icp_result *r)
{
    return r->overlap > 0.0 ? r->fit * r->fit / r->overlap : 0.0;
}

/* The coverages the last two-way pass counted at its coverage distance. */
static void counted_cover(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__icp_work *w, double cover[2])
{
    cover[0] = src->m ? (double)w->covered[0] / (double)src->m : 0.0;
    cover[1] = tgt->m ? (double)w->covered[1] / (double)tgt->m : 0.0;
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
                        double *fit, double *fit_cover)
{
    double cg = pkss__coverage_gate(src, tgt, T), f[2];
    pkss__correspond(src, tgt, T, cg, w);
    if (fit) {
        pkss__coverage_from_pairs(src, tgt, T, ICP_FIT_DIST / ICP_OVERLAP_DIST * cg, w,
                                  fit_cover);
        *fit = sqrt(fit_cover[0] * fit_cover[1]);
    }
    counted_cover(src, tgt, w, f);
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
                                const pkss__icp_view *tgt, double gate,
                                const pkss__icp_work *w)
{
    if (gate < w->cover_gate)
        return -1.0;
    double f[2];
    counted_cover(src, tgt, w, f);
    return sqrt(f[0] * f[1]);
}

pkss_status pkss__icp_overlap(const pkss__icp_view *src,
                              const pkss__icp_view *tgt,
                              const pkss__pose *pose, double *overlap,
                              double *rms, double *fit)
{
    pkss__icp_work w;
    double fit_cover[2];
    *overlap = 0.0;
    *rms = 0.0;
    if (fit)
        *fit = 0.0;
    if (!pkss__work_alloc(&w, src->m, tgt->m, 0))
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss__overlap_with(src, tgt, pose, &w, overlap, rms, NULL, fit, fit ? fit_cover : NULL);
    pkss__work_free(&w);
    return PKSS_OK;
}
