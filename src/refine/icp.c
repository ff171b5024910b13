/* SPDX-License-Identifier: MIT
 * icp.c -- the overlap-aware similarity ICP of SPEC 6, on the resampled
 * pre-shape clouds:
 *   - h = median NN spacing of the template; a distance gate starts at the
 *     schedule's gate_start h and shrinks by ICP_GATE_DECAY per iteration to
 *     a floor of ICP_GATE_FLOOR h;
 *   - rigid first: pairs gated in both directions update R, t (scale
 *     frozen) -- a free scale collapses on partial overlap;
 *   - scale last: only mutual NN pairs, full Umeyama update with scale; the
 *     gate reopens to ICP_GATE_SCALE_START h and holds while the scale still
 *     moves, or a partial source's wrong initial scale cannot recover (SPEC 6
 *     caveat; docs/tuning.md);
 *   - stop when the pose no longer moves and the gate is at its floor, or
 *     every pair lies inside the floor already;
 *   - then (deviation from SPEC 6) a few point-to-plane steps on the mutual
 *     pairs within the floor (plane_stage): on flat faces point-to-point
 *     pairs leave the scale and the sliding of a part loose.
 * The overlap score (overlap_with) judges the runs against each other while
 * they run; the same score within 1 spacing, the fit, picks the winner
 * (register.c). Where one cloud shows a part of the other, register.c first
 * searches the scale that maximises it (pkss__icp_scale_search): the
 * mutual-pair scale update barely moves there, since a too-large part's
 * overhang has no mutual partners.
 * A view is a prefix of a cloud's FPS-ordered points (a uniform sample):
 * register.c runs a coarse rigid level on every candidate and the full
 * schedule on the few best. */
#include "pkss_internal.h"

#include <math.h>
#include <pthread.h>
#include <string.h>

#define ICP_GATE_SCALE_START 8.0
/* relative scale change per iteration below which the scale has settled */
#define ICP_SCALE_SETTLED 1e-4
#define ICP_GATE_DECAY 0.85
#define ICP_GATE_FLOOR 3.0
#define ICP_MIN_PAIRS 10
#define ICP_OVERLAP_DIST 2.0
/* The fit: the coverage overlap within 1 spacing instead of 2, at a refined
 * pose (register.c picks the winner by it): a box part turned 180 degrees can
 * cover as much within 2 spacings as the truth, but lies on it less closely
 * (docs/tuning.md). */
#define ICP_FIT_DIST 1.0
#define ICP_SAME_BASIN_RAD (3.0 * PKSS_PI / 180.0)
/* Iterations over which a stage's overlap gain is measured, to project
 * where it can end (pkss__icp_run). */
#define ICP_GAIN_WINDOW 5
/* A rigid stage whose overlap gained less than this over the window (3 of
 * 3000 points) has settled: what is left is point-to-point ICP sliding by
 * a small fraction of a spacing per iteration, which the scale stage
 * carries on with anyway. */
#define ICP_STAGNANT 1e-3
/* ... while its pose moves less than this per iteration (pose_change, in
 * pre-shape units: ~1/30 of a spacing). The overlap of a complete object
 * saturates near 1 before the pose has arrived: a chef with noise read as
 * settled while still turning by 2e-2 per iteration, 6 degrees short,
 * and the scale stage's mutual pairs then held it there. */
#define ICP_SETTLED_MOVE 2e-3

void pkss__icp_view_full(const pkss_cloud *c, pkss__icp_view *v)
{
    v->pts = c->pre;
    v->m = c->m;
    v->tree = c->tree;
    v->normal = c->normal;
    v->spacing = c->spacing;
    v->run = NULL;
}

void pkss__icp_view_coarse(const pkss_cloud *c, pkss__icp_view *v)
{
    v->pts = c->pre;
    v->m = c->m_coarse;
    v->tree = c->tree_coarse;
    v->normal = c->normal; /* the coarse view is a prefix of the points */
    v->spacing = c->spacing_coarse;
    v->run = NULL;
}

static void transform_point(const pkss__pose *T, const double *x, double *y)
{
    double r[3];
    pkss__mat3_apply(T->R, x, r);
    for (int d = 0; d < 3; ++d)
        y[d] = T->s * r[d] + T->t[d];
}

/* x = R^T (y - t) / s : a template point in source pre-shape coordinates */
static void inverse_point(const pkss__pose *T, const double *y, double *x)
{
    double v[3] = {y[0] - T->t[0], y[1] - T->t[1], y[2] - T->t[2]};
    for (int d = 0; d < 3; ++d)
        x[d] = (T->R[d] * v[0] + T->R[3 + d] * v[1] + T->R[6 + d] * v[2]) / T->s;
}

/* Squared distance between two points. */
static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* Search radius^2 for a warm-started query: the previous iteration's partner
 * (prev, UINT32_MAX if none) at its current distance bounds the search, so
 * the tree prunes almost everything; the result is exactly that of a cold
 * search within the gate (the true nearest is at most that far). */
static double warm_bound(const double *q, const double *pts, uint32_t prev,
                         double g2)
{
    if (prev == UINT32_MAX)
        return g2;
    /* a relative slack far above rounding keeps the old partner inside */
    double d2 = dist2(q, pts + 3 * (size_t)prev) * (1.0 + 1e-9) + 1e-300;
    return d2 < g2 ? d2 : g2;
}

typedef struct bwd_job {
    const pkss__icp_view *src, *tgt;
    const pkss__pose *T;
    double g2s;
    uint32_t *bwd;
    double *bwd_d2;
} bwd_job;

static void *backward(void *arg)
{
    const bwd_job *j = arg;
    for (size_t k = 0; k < j->tgt->m; ++k) {
        double x[3];
        inverse_point(j->T, j->tgt->pts + 3 * k, x);
        double b = warm_bound(x, j->src->pts, j->bwd[k], j->g2s);
        j->bwd[k] = pkss__kdtree_nearest(j->src->tree, x, b, &j->bwd_d2[k]);
    }
    return NULL;
}

/* Below this many queries a second thread costs more than it saves. */
#define ICP_THREAD_MIN 1000

/* Nearest template point of every source point (fwd) and nearest source
 * point of every template point (bwd), both within gate (template units);
 * UINT32_MAX where none; fwd_d2 / bwd_d2 the squared distances (bwd_d2 in
 * source units, where the backward search runs). fwd/bwd hold the previous
 * call's answers on entry (or UINT32_MAX) and serve as warm starts. The two
 * directions are independent: large views run the backward one on a second
 * thread. */
static void correspond(const pkss__icp_view *src, const pkss__icp_view *tgt,
                       const pkss__pose *T, double gate, uint32_t *fwd,
                       double *fwd_d2, uint32_t *bwd, double *bwd_d2)
{
    double g2 = gate * gate;
    bwd_job job = {src, tgt, T, g2 / (T->s * T->s), bwd, bwd_d2};
    pthread_t th;
    int threaded = src->m + tgt->m >= 2 * ICP_THREAD_MIN &&
                   pthread_create(&th, NULL, backward, &job) == 0;
    for (size_t i = 0; i < src->m; ++i) {
        double y[3];
        transform_point(T, src->pts + 3 * i, y);
        double b = warm_bound(y, tgt->pts, fwd[i], g2);
        fwd[i] = pkss__kdtree_nearest(tgt->tree, y, b, &fwd_d2[i]);
    }
    if (threaded)
        pthread_join(th, NULL);
    else
        backward(&job);
}

/* Least-squares similarity (Umeyama) or rigid (Kabsch, fixed s) update
 * from pairs (src i, tgt j). Returns 0 if too few pairs. */
static int solve(const pkss__icp_view *src, const pkss__icp_view *tgt,
                 const uint32_t *pi, const uint32_t *pj, size_t n,
                 int with_scale, pkss__pose *T)
{
    if (n < ICP_MIN_PAIRS)
        return 0;
    double mx[3] = {0, 0, 0}, my[3] = {0, 0, 0};
    for (size_t k = 0; k < n; ++k)
        for (int d = 0; d < 3; ++d) {
            mx[d] += src->pts[3 * (size_t)pi[k] + d];
            my[d] += tgt->pts[3 * (size_t)pj[k] + d];
        }
    for (int d = 0; d < 3; ++d) {
        mx[d] /= (double)n;
        my[d] /= (double)n;
    }
    double H[9] = {0}, sxx = 0.0;
    for (size_t k = 0; k < n; ++k) {
        const double *x = src->pts + 3 * (size_t)pi[k];
        const double *y = tgt->pts + 3 * (size_t)pj[k];
        double a[3] = {x[0] - mx[0], x[1] - mx[1], x[2] - mx[2]};
        double b[3] = {y[0] - my[0], y[1] - my[1], y[2] - my[2]};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                H[3 * r + c] += a[r] * b[c];
        sxx += a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    }
    double R[9];
    pkss__procrustes_rotation(H, R);
    double s = T->s;
    if (with_scale) {
        /* s = tr(R H) / sum |x - mx|^2 (Umeyama) */
        double tr = 0.0;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                tr += R[3 * r + c] * H[3 * c + r];
        if (sxx > 0.0 && tr > 0.0)
            s = tr / sxx;
    }
    double Rm[3];
    pkss__mat3_apply(R, mx, Rm);
    memcpy(T->R, R, sizeof R);
    T->s = s;
    for (int d = 0; d < 3; ++d)
        T->t[d] = my[d] - s * Rm[d];
    return 1;
}

/* Largest step of the point-to-plane stage (in rotation radians, relative
 * scale and pre-shape units): its pairs lie within 3h, so a larger step
 * would only jump past the linearisation. */
#define ICP_PLANE_MAX_STEP 0.05
/* ... and the step below which it has settled (~1/40 of a spacing) */
#define ICP_PLANE_SETTLED 1e-4

/* One Gauss-Newton step of the point-to-plane similarity fit on pairs
 * (src i, tgt j): minimises sum (n_j . (p' - y_j))^2 over
 * p' = c + (1 + sg)(I + [w]x)(p - c) + tau, p = T x_i, c = mean p, to first
 * order in (sg, w, tau), and applies it to T. Returns the step's largest
 * component, or -1 if there are too few pairs or they fix no pose.
 * The scale's lever is taken at the template point, n . (y - c): at p, the
 * source's noise along the normals would shrink it (regression dilution;
 * docs/tuning.md). The rotation's levers see only the tangential part. */
static double solve_plane(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const uint32_t *pi, const uint32_t *pj, size_t n,
                          pkss__pose *T)
{
    if (n < ICP_MIN_PAIRS)
        return -1.0;
    double c[3] = {0, 0, 0};
    for (size_t k = 0; k < n; ++k) {
        double p[3];
        transform_point(T, src->pts + 3 * (size_t)pi[k], p);
        for (int d = 0; d < 3; ++d)
            c[d] += p[d];
    }
    for (int d = 0; d < 3; ++d)
        c[d] /= (double)n;
    double A[49] = {0}, g[7] = {0};
    for (size_t k = 0; k < n; ++k) {
        double p[3], a[3];
        transform_point(T, src->pts + 3 * (size_t)pi[k], p);
        const double *y = tgt->pts + 3 * (size_t)pj[k];
        const double *nv = tgt->normal + 3 * (size_t)pj[k];
        for (int d = 0; d < 3; ++d)
            a[d] = p[d] - c[d];
        double r = nv[0] * (p[0] - y[0]) + nv[1] * (p[1] - y[1]) + nv[2] * (p[2] - y[2]);
        double J[7] = {nv[0] * (y[0] - c[0]) + nv[1] * (y[1] - c[1]) + nv[2] * (y[2] - c[2]),
                       a[1] * nv[2] - a[2] * nv[1], a[2] * nv[0] - a[0] * nv[2],
                       a[0] * nv[1] - a[1] * nv[0], nv[0], nv[1], nv[2]};
        for (int i = 0; i < 7; ++i) {
            g[i] -= J[i] * r;
            for (int j = 0; j <= i; ++j)
                A[7 * i + j] += J[i] * J[j];
        }
    }
    /* A direction the pairs leave free (a plane's sliding, the scale of a
     * flat patch) makes A singular: a relative damping of 1e-6 keeps it
     * solvable and leaves that direction where it is (no pair's row, and so
     * not the gradient, has a component along it). */
    double tr = 0.0;
    for (int i = 0; i < 7; ++i) {
        for (int j = 0; j < i; ++j)
            A[7 * j + i] = A[7 * i + j];
        tr += A[8 * i];
    }
    for (int i = 0; i < 7; ++i)
        A[8 * i] += 1e-6 * tr / 7.0 + 1e-300;
    if (!pkss__solve_spd(A, g, 7))
        return -1.0;
    double step = 0.0;
    for (int i = 0; i < 7; ++i)
        step = fmax(step, fabs(g[i]));
    if (!(step < HUGE_VAL))
        return -1.0;
    if (step > ICP_PLANE_MAX_STEP)
        for (int i = 0; i < 7; ++i)
            g[i] *= ICP_PLANE_MAX_STEP / step;
    double dR[9], R[9], v[3], Rv[3];
    double f = 1.0 + g[0];
    pkss__rotation_exp(g + 1, dR);
    pkss__mat3_mul(dR, T->R, R);
    for (int d = 0; d < 3; ++d)
        v[d] = T->t[d] - c[d];
    pkss__mat3_apply(dR, v, Rv);
    memcpy(T->R, R, sizeof R);
    T->s *= f;
    for (int d = 0; d < 3; ++d)
        T->t[d] = f * Rv[d] + c[d] + g[4 + d];
    return step;
}

static double pose_change(const pkss__pose *a, const pkss__pose *b)
{
    double c = fabs(a->s - b->s);
    for (int i = 0; i < 9; ++i)
        c += fabs(a->R[i] - b->R[i]);
    for (int i = 0; i < 3; ++i)
        c += fabs(a->t[i] - b->t[i]);
    return c;
}

typedef struct icp_work {
    uint32_t *fwd, *bwd, *pi, *pj;
    double *fwd_d2, *bwd_d2;
} icp_work;

static void work_free(icp_work *w)
{
    pkss__free(w->fwd);
    pkss__free(w->bwd);
    pkss__free(w->pi);
    pkss__free(w->pj);
    pkss__free(w->fwd_d2);
    pkss__free(w->bwd_d2);
}

static int work_alloc(icp_work *w, size_t ns, size_t nt)
{
    memset(w, 0, sizeof *w);
    w->fwd = pkss__malloc(ns * sizeof(uint32_t));
    w->fwd_d2 = pkss__malloc(ns * sizeof(double));
    w->bwd = pkss__malloc(nt * sizeof(uint32_t));
    w->bwd_d2 = pkss__malloc(nt * sizeof(double));
    w->pi = pkss__malloc((ns + nt) * sizeof(uint32_t));
    w->pj = pkss__malloc((ns + nt) * sizeof(uint32_t));
    if (!w->fwd || !w->fwd_d2 || !w->bwd || !w->bwd_d2 || !w->pi || !w->pj) {
        work_free(w);
        return 0;
    }
    memset(w->fwd, 0xff, ns * sizeof(uint32_t)); /* no warm start yet */
    memset(w->bwd, 0xff, nt * sizeof(uint32_t));
    return 1;
}

/* Appends the gated source -> template pairs to w->pi / w->pj from n on;
 * returns the new count and raises *d2max to the farthest pair's squared
 * distance (template units). */
static size_t add_forward_pairs(icp_work *w, size_t ns, size_t n,
                                double *d2max)
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
static size_t add_backward_pairs(icp_work *w, size_t nt, size_t n, double s,
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
static size_t add_mutual_pairs(icp_work *w, size_t ns, double *d2max)
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

/* Distance within which a point counts as covered by the other cloud: 2 x
 * the coarser of the two spacings, in template units. */
static double coverage_gate(const pkss__icp_view *src,
                            const pkss__icp_view *tgt, const pkss__pose *T)
{
    double h = tgt->spacing, hs = T->s * src->spacing;
    return ICP_OVERLAP_DIST * (h > hs ? h : hs);
}

/* The shares of each cloud covered by the other (f_s, f_t) from the
 * answers of the last correspond() at pose T, whose gate was at least the
 * coverage distance cg: the nearest partner within that gate is the nearest
 * within cg whenever it lies inside cg. */
static void coverage_from_pairs(const pkss__icp_view *src,
                                const pkss__icp_view *tgt,
                                const pkss__pose *T, double cg,
                                const icp_work *w, double cover[2])
{
    double cg2 = cg * cg, cg2s = cg2 / (T->s * T->s);
    size_t fwd_hits = 0, bwd_hits = 0;
    for (size_t i = 0; i < src->m; ++i)
        fwd_hits += w->fwd[i] != UINT32_MAX && w->fwd_d2[i] <= cg2;
    for (size_t j = 0; j < tgt->m; ++j)
        bwd_hits += w->bwd[j] != UINT32_MAX && w->bwd_d2[j] <= cg2s;
    cover[0] = src->m ? (double)fwd_hits / (double)src->m : 0.0;
    cover[1] = tgt->m ? (double)bwd_hits / (double)tgt->m : 0.0;
}

/* Coverage overlap: f_s = share of source points with a template point
 * within d, f_t = share of template points with a source point within d,
 * overlap = sqrt(f_s f_t), d = 2 x the coarser of the two spacings (template
 * units). For uniform samples it is |A_o| / sqrt(|A_s| |A_t|): it falls when
 * the source shrinks and when it overhangs the template. Deviation from
 * SPEC 6 (mutual pairs / min(n_s, n_t)), which keeps rising while a partial
 * source is blown up (docs/tuning.md). RMS is that of the mutual pairs; fit
 * (if not NULL) is the same score within ICP_FIT_DIST spacings. */
static void overlap_with(const pkss__icp_view *src, const pkss__icp_view *tgt,
                         const pkss__pose *T, icp_work *w, double *overlap,
                         double *rms, double *cover, double *fit)
{
    double cg = coverage_gate(src, tgt, T), f[2];
    correspond(src, tgt, T, cg, w->fwd, w->fwd_d2, w->bwd, w->bwd_d2);
    if (fit) {
        coverage_from_pairs(src, tgt, T, ICP_FIT_DIST / ICP_OVERLAP_DIST * cg, w, f);
        *fit = sqrt(f[0] * f[1]);
    }
    coverage_from_pairs(src, tgt, T, cg, w, f);
    double d2max = 0.0, ss = 0.0;
    size_t mutual = add_mutual_pairs(w, src->m, &d2max);
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
static double overlap_from_pairs(const pkss__icp_view *src,
                                 const pkss__icp_view *tgt,
                                 const pkss__pose *T, double gate,
                                 const icp_work *w)
{
    double cg = coverage_gate(src, tgt, T), f[2];
    if (gate < cg)
        return -1.0;
    coverage_from_pairs(src, tgt, T, cg, w, f);
    return sqrt(f[0] * f[1]);
}

/* The point-to-plane stage after the scale stage: mutual pairs within the
 * gate's floor, each step a Gauss-Newton step of the similarity against the
 * template's local planes (solve_plane), until it settles or after iters
 * steps. Returns the steps taken. *overlap_start receives the overlap score
 * at the pose it starts from, read from its first correspondences where the
 * floor gate covers the coverage distance, else scored apart.
 * Point-to-point pairs on flat faces fix the pose only through the faces'
 * rims, in a valley where the overlap is flat; against the planes every pair
 * on them constrains the scale and the sliding (docs/tuning.md). */
static int plane_stage(const pkss__icp_view *src, const pkss__icp_view *tgt,
                       int iters, icp_work *w, pkss__pose *T,
                       double *overlap_start)
{
    const double gate = ICP_GATE_FLOOR * tgt->spacing;
    const int runs = tgt->normal && iters > 0;
    const int from_pairs = runs && gate >= coverage_gate(src, tgt, T);
    if (!from_pairs) {
        double rms;
        overlap_with(src, tgt, T, w, overlap_start, &rms, NULL, NULL);
    }
    int it = 0;
    while (runs && it < iters) {
        correspond(src, tgt, T, gate, w->fwd, w->fwd_d2, w->bwd, w->bwd_d2);
        if (it == 0 && from_pairs)
            *overlap_start = overlap_from_pairs(src, tgt, T, gate, w);
        double d2max = 0.0;
        size_t n = add_mutual_pairs(w, src->m, &d2max);
        double step = solve_plane(src, tgt, w->pi, w->pj, n, T);
        ++it;
        if (step < ICP_PLANE_SETTLED)
            break;
    }
    return it;
}

pkss_status pkss__icp_overlap(const pkss__icp_view *src,
                              const pkss__icp_view *tgt,
                              const pkss__pose *pose, double *overlap,
                              double *rms, double *fit)
{
    icp_work w;
    *overlap = 0.0;
    *rms = 0.0;
    if (fit)
        *fit = 0.0;
    if (!work_alloc(&w, src->m, tgt->m))
        return PKSS_ERR_OUT_OF_MEMORY;
    overlap_with(src, tgt, pose, &w, overlap, rms, NULL, fit);
    work_free(&w);
    return PKSS_OK;
}

/* Another run's minimum (not run id's own): within 3 degrees, 1 template
 * spacing and 1 % scale. Distinct minima lie >= 15 degrees apart, while two
 * runs into the same minimum can creep toward it 1-1.5 degrees apart when
 * the samplings differ (docs/tuning.md). */
static int known_basin(const pkss__icp_basins *b, const pkss__pose *T,
                       double h, int id)
{
    for (int k = 0; k < b->n; ++k) {
        if (b->owner[k] == id)
            continue;
        const pkss__pose *q = &b->pose[k];
        double dt2 = dist2(T->t, q->t);
        if (pkss__rotation_angle(T->R, q->R) < ICP_SAME_BASIN_RAD &&
            dt2 < h * h && fabs(T->s / q->s - 1.0) < 0.01)
            return b->owner[k];
    }
    return -1;
}

static void add_basin(pkss__icp_basins *b, const pkss__pose *T, int id)
{
    if (!b || b->n >= (int)(sizeof b->owner / sizeof *b->owner))
        return;
    b->pose[b->n] = *T;
    b->owner[b->n++] = id;
}

pkss_status pkss__icp_run(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__icp_schedule *sched,
                          const pkss__pose *init, pkss__icp_basins *basins,
                          int id, pkss__icp_result *out)
{
    if (!sched->free_scale)
        basins = NULL;
    out->duplicate_of = -1;
    out->abandoned = 0;
    icp_work w;
    if (!work_alloc(&w, src->m, tgt->m))
        return PKSS_ERR_OUT_OF_MEMORY;
    const double h = tgt->spacing;
    pkss__pose T = *init;
    double gate = sched->gate_start * h;
    /* the current stage's overlap at its last ICP_GAIN_WINDOW + 1
     * iterations (ring; the rigid stage's from the floor on), when a bar
     * is set (rigid_min_overlap, scale_min_overlap) */
    double ov_ring[ICP_GAIN_WINDOW + 1];
    int n_ring = 0, ring_stage = 0;
    int it;
    for (it = 0; it < sched->max_iters; ++it) {
        if (pkss__tick(src->run) != PKSS_OK) {
            work_free(&w);
            return PKSS_ERR_CANCELLED;
        }
        int scale_stage = sched->free_scale && it >= sched->rigid_iters;
        if (sched->free_scale && it == sched->rigid_iters && gate < ICP_GATE_SCALE_START * h)
            gate = ICP_GATE_SCALE_START * h; /* reopen for the free scale */
        correspond(src, tgt, &T, gate, w.fwd, w.fwd_d2, w.bwd, w.bwd_d2);
        size_t n = 0;
        double d2max = 0.0;
        if (!scale_stage) {
            /* pairs from both directions, each within the gate */
            n = add_forward_pairs(&w, src->m, n, &d2max);
            n = add_backward_pairs(&w, tgt->m, n, T.s, &d2max);
        } else if (sched->free_scale == PKSS__SCALE_SOURCE_PART) {
            n = add_forward_pairs(&w, src->m, n, &d2max);
        } else if (sched->free_scale == PKSS__SCALE_TEMPLATE_PART) {
            n = add_backward_pairs(&w, tgt->m, n, T.s, &d2max);
        } else {
            n = add_mutual_pairs(&w, src->m, &d2max);
        }
        pkss__pose prev = T;
        if (!solve(src, tgt, w.pi, w.pj, n, scale_stage, &T))
            break; /* too few pairs: keep the pose */
        double change = pose_change(&prev, &T);
        /* At the floor, or with every pair already inside it: a gate at the
         * floor would pick the same pairs (the nearest partner within any
         * gate past its distance is the same), so the pose has converged
         * as far as the floor allows once it stops moving. This saves the
         * 5-6 iterations the decaying gate would take to reach the floor
         * while nothing changes. */
        const double floor_gate = ICP_GATE_FLOOR * h * 1.000001;
        int at_floor = gate <= floor_gate || d2max <= floor_gate * floor_gate;
        /* While the free scale is still moving, hold the reopened gate: a
         * scale error e displaces rim points by ~e * radius, many spacings,
         * and a tightening gate would keep only the pairs near the centre,
         * which barely constrain the scale. */
        int scale_moving = scale_stage && fabs(T.s - prev.s) > ICP_SCALE_SETTLED * T.s;
        const double gate_used = gate;
        if (!scale_moving)
            gate *= ICP_GATE_DECAY;
        if (gate < ICP_GATE_FLOOR * h)
            gate = ICP_GATE_FLOOR * h;
        /* the bar this stage must reach, and the iteration it ends at */
        double bar = scale_stage ? sched->scale_min_overlap : sched->rigid_min_overlap;
        int stage_end = scale_stage ? sched->max_iters : sched->rigid_iters;
        if (scale_stage != ring_stage) {
            n_ring = 0;
            ring_stage = scale_stage;
        }
        /* the overlap is tracked against a bar, and in a rigid stage
         * before a scale stage, to see it settle (ICP_STAGNANT) */
        int track = bar > 0.0 || (sched->free_scale && !scale_stage);
        int stagnant = 0;
        if (track && (scale_stage || gate_used <= floor_gate)) {
            /* A run heading for the bar gains overlap steadily; one caught in a wrong
             * minimum creeps. The linear projection of the last ICP_GAIN_WINDOW
             * iterations' gain over-estimates a decelerating run, so one that cannot
             * reach the bar even so stops now. Not while the free scale still moves: a
             * part's scale stage can stall in overlap, then climb (docs/tuning.md). */
            double ov = overlap_from_pairs(src, tgt, &prev, gate_used, &w);
            if (ov < 0.0) {
                n_ring = 0;
            } else {
                ov_ring[n_ring % (ICP_GAIN_WINDOW + 1)] = ov;
                ++n_ring;
            }
            if (n_ring > ICP_GAIN_WINDOW) {
                double old = ov_ring[(n_ring - 1 - ICP_GAIN_WINDOW) % (ICP_GAIN_WINDOW + 1)];
                double gain = (ov - old) / ICP_GAIN_WINDOW;
                stagnant = ov - old < ICP_STAGNANT && change < ICP_SETTLED_MOVE;
                double reach = ov + (gain > 0.0 ? gain : 0.0) *
                                        (double)(stage_end - it);
                if (bar > 0.0 && reach < bar && !scale_moving) {
                    overlap_with(src, tgt, &T, &w, &out->overlap, &out->rms, out->cover, &out->fit);
                    out->abandoned = 1;
                    ++it;
                    break;
                }
            }
        }
        if (basins && at_floor) {
            out->duplicate_of = known_basin(basins, &T, h, id);
            if (out->duplicate_of >= 0) {
                ++it;
                break;
            }
        }
        /* A rigid stage ends once its overlap has settled, without waiting for the
         * pose to stop: with unequal samplings point-to-point ICP slides on slowly
         * while no pair changes side of the coverage distance, and the scale stage
         * moves the pose anyway (docs/tuning.md). */
        int rigid_settled = stagnant && !scale_stage && sched->free_scale;
        if (at_floor && (change < 1e-6 || rigid_settled)) {
            if (scale_stage || !sched->free_scale) {
                ++it;
                break;
            }
            if (it < sched->rigid_iters - 1)
                it = sched->rigid_iters - 1; /* rigid converged: free the scale */
        }
        if (sched->free_scale && it + 1 == sched->rigid_iters) {
            /* the rigid stage ends here (converged or out of iterations) */
            if (sched->rigid_min_overlap > 0.0) {
                overlap_with(src, tgt, &T, &w, &out->overlap, &out->rms, out->cover, &out->fit);
                if (out->overlap < sched->rigid_min_overlap) {
                    out->abandoned = 1; /* scored at this pose already */
                    ++it;
                    break;
                }
            }
            add_basin(basins, &T, id);
        }
    }
    if (!out->abandoned && out->duplicate_of < 0) {
        /* the basin is where the scale stage ended: a run that reaches it
         * would take the same plane steps */
        add_basin(basins, &T, id);
        if (sched->plane_iters > 0)
            it += plane_stage(src, tgt, sched->plane_iters, &w, &T,
                              &out->overlap_unpolished);
    }
    out->pose = T;
    out->iterations = it;
    if (!out->abandoned)
        overlap_with(src, tgt, &T, &w, &out->overlap, &out->rms, out->cover, &out->fit);
    if (out->abandoned || out->duplicate_of >= 0 || sched->plane_iters <= 0)
        out->overlap_unpolished = out->overlap;
    work_free(&w);
    return PKSS_OK;
}

/* Rescales pose T by factor f about the image of the source point c, so
 * the overlap stays in place while the source grows or shrinks around it. */
static void rescale_about(pkss__pose *T, const double *c, double f)
{
    double y[3];
    transform_point(T, c, y);
    T->s *= f;
    double Rc[3];
    pkss__mat3_apply(T->R, c, Rc);
    for (int d = 0; d < 3; ++d)
        T->t[d] = y[d] - T->s * Rc[d];
}

/* Centroid of the source points that have a template partner, from the
 * answers of a correspond() at the coverage distance (overlap_with). */
static void covered_centroid(const pkss__icp_view *src, const icp_work *w,
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

/* The most moves of a scale search. */
#define SCALE_MOVES 4

pkss_status pkss__icp_scale_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double log_step,
                                   pkss__icp_result *io)
{
    /* a short rigid settle after each trial scale: from 5h to the floor */
    static const pkss__icp_schedule settle = {5.0, 10, 10, 0, 0.0, 0.0, 0};
    icp_work w;
    if (!work_alloc(&w, src->m, tgt->m))
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss_status st = PKSS_OK;
    pkss__icp_result best = *io;
    overlap_with(src, tgt, &best.pose, &w, &best.overlap, &best.rms, best.cover, NULL);
    int w_at_best = 1; /* w holds the coverage answers at best.pose */
    double f = exp(log_step);
    int dir = 0; /* direction that last improved; 0 = try both */
    for (int move = 0; move < SCALE_MOVES; ++move) {
        pkss__icp_result next = best;
        int next_dir = 0;
        double c[3];
        if (!w_at_best)
            correspond(src, tgt, &best.pose,
                       coverage_gate(src, tgt, &best.pose), w.fwd,
                       w.fwd_d2, w.bwd, w.bwd_d2);
        w_at_best = 1;
        covered_centroid(src, &w, c);
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            if (dir != 0 && sgn != dir)
                continue;
            pkss__pose trial = best.pose;
            rescale_about(&trial, c, sgn > 0 ? f : 1.0 / f);
            pkss__icp_result r;
            st = pkss__icp_run(src, tgt, &settle, &trial, NULL, 0, &r);
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
    work_free(&w);
    return st;
}

/* Trial shifts of a slide search reach this share of the template's
 * extent along the slide direction, either way (the slides measured on
 * box parts: 8-14 % of the diameter, ~13 % of the carton's length). */
#define SLIDE_RANGE 0.2

/* The slide search (register.c runs it on a winner that does not cover both
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
    /* the polish: point-to-plane steps only (plane_stage), from the shift */
    static const pkss__icp_schedule polish = {ICP_GATE_FLOOR, 0, 0, 0, 0.0, 0.0, 30};
    if (!tgt->normal || !(tgt->spacing > 0.0))
        return PKSS_OK;
    icp_work w;
    if (!work_alloc(&w, src->m, tgt->m))
        return PKSS_ERR_OUT_OF_MEMORY;
    const double h = tgt->spacing;
    const pkss__pose at = io->pose;
    /* the slide direction: least constrained by the normals of the
     * template points the source lies on */
    correspond(src, tgt, &at, ICP_GATE_FLOOR * h, w.fwd, w.fwd_d2, w.bwd, w.bwd_d2);
    double d2max = 0.0;
    size_t n = add_mutual_pairs(&w, src->m, &d2max);
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
    const int steps = (int)(SLIDE_RANGE * (hi - lo) / h);
    const double fg = ICP_FIT_DIST / ICP_OVERLAP_DIST * coverage_gate(src, tgt, &at);
    double best_fit = -1.0;
    int best_k = 0;
    for (int k = -steps; k <= steps; ++k) {
        pkss__pose trial = at;
        for (int d = 0; d < 3; ++d)
            trial.t[d] += k * h * u[d];
        double f[2];
        correspond(src, tgt, &trial, fg, w.fwd, w.fwd_d2, w.bwd, w.bwd_d2);
        coverage_from_pairs(src, tgt, &trial, fg, &w, f);
        double fit = sqrt(f[0] * f[1]);
        if (fit > best_fit) {
            best_fit = fit;
            best_k = k;
        }
    }
    if (best_k != 0) {
        pkss__pose start = at;
        for (int d = 0; d < 3; ++d)
            start.t[d] += best_k * h * u[d];
        pkss__icp_result r;
        pkss_status st = pkss__icp_run(src, tgt, &polish, &start, NULL, 0, &r);
        if (st != PKSS_OK) {
            work_free(&w);
            return st;
        }
        if (r.fit > io->fit + min_gain)
            *io = r;
    }
out:
    work_free(&w);
    return PKSS_OK;
}
