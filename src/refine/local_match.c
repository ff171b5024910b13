/* SPDX-License-Identifier: MIT
 * local_match.c -- starts from local shape (issue #25): where both clouds
 * are parts (a pair cut on both sides), the global search compares what
 * each shows about its own centroid, and a cut changes that everywhere.
 * Local surface shape survives a cut: fast point feature histograms
 * (Rusu et al., ICRA 2009) on the coarse views, matched in feature space,
 * then a RANSAC over similarity transforms (3 matches each, the scale free)
 * ranked by the matches they bring within reach. The best distinct poses
 * become candidates, refined as every other (stages.c).
 */
#include "refine/icp_parts.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define N_HIST (3 * PKSS_LOCAL_BINS)

static int bin_of(double v, double lo, double hi)
{
    int b = (int)((v - lo) / (hi - lo) * PKSS_LOCAL_BINS);
    return b < 0 ? 0 : (b >= PKSS_LOCAL_BINS ? PKSS_LOCAL_BINS - 1 : b);
}

/* The Darboux-frame angles of point p's pair with q (Rusu's alpha, phi,
 * theta) added to hist. The PCA normals have no sign: u is p's normal
 * turned toward q and q's normal is turned toward u, so the angles
 * depend on the surface alone. */
static void add_pair(const double *p, const double *np, const double *q,
                     const double *nq, float *hist)
{
    double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    double len = sqrt(pkss__dot3(d, d));
    if (!(len > 0.0))
        return;
    for (int k = 0; k < 3; ++k)
        d[k] /= len;
    double u[3] = {np[0], np[1], np[2]}, n[3] = {nq[0], nq[1], nq[2]};
    if (pkss__dot3(u, d) < 0.0)
        for (int k = 0; k < 3; ++k)
            u[k] = -u[k];
    if (pkss__dot3(u, n) < 0.0)
        for (int k = 0; k < 3; ++k)
            n[k] = -n[k];
    double v[3], w[3];
    pkss__cross3(d, u, v);
    double lv = sqrt(pkss__dot3(v, v));
    if (!(lv > 1e-12))
        return; /* the normal lies along the pair: no frame */
    for (int k = 0; k < 3; ++k)
        v[k] /= lv;
    pkss__cross3(u, v, w);
    hist[bin_of(pkss__dot3(v, n), -1.0, 1.0)] += 1.0f;
    hist[PKSS_LOCAL_BINS + bin_of(pkss__dot3(u, d), 0.0, 1.0)] += 1.0f;
    double theta = atan2(pkss__dot3(w, n), pkss__dot3(u, n));
    hist[2 * PKSS_LOCAL_BINS + bin_of(theta, -0.5 * PKSS_PI, 0.5 * PKSS_PI)] += 1.0f;
}

static void normalise(float *h)
{
    double sum = 0.0;
    for (int k = 0; k < N_HIST; ++k)
        sum += (double)h[k] * h[k];
    float inv = sum > 0.0 ? (float)(1.0 / sqrt(sum)) : 0.0f;
    for (int k = 0; k < N_HIST; ++k)
        h[k] *= inv;
}

/* FPFH of every point of the coarse view v into f (m x N_HIST): each
 * point's own histogram (SPFH) plus its neighbours', weighted by inverse
 * distance, over the PKSS_LOCAL_K nearest. */
static pkss_status features(const pkss__icp_view *v, float *f)
{
    const size_t m = v->m, k = PKSS_LOCAL_K;
    uint32_t *nb = pkss__malloc(m * k * sizeof *nb);
    double *d2 = pkss__malloc(m * k * sizeof *d2);
    float *spfh = pkss__calloc(m * N_HIST, sizeof *spfh);
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    if (!nb || !d2 || !spfh)
        goto done;
    if ((st = pkss__knn_all(v->tree, v->pts, m, k, nb, d2)) != PKSS_OK)
        goto done;
    for (size_t i = 0; i < m; ++i) {
        for (size_t j = 0; j < k; ++j) {
            size_t q = nb[k * i + j];
            add_pair(v->pts + 3 * i, v->normal + 3 * i, v->pts + 3 * q,
                     v->normal + 3 * q, spfh + N_HIST * i);
        }
        for (int b = 0; b < N_HIST; ++b)
            spfh[N_HIST * i + b] /= (float)k;
    }
    for (size_t i = 0; i < m; ++i) {
        float *out = f + N_HIST * i;
        memcpy(out, spfh + N_HIST * i, N_HIST * sizeof *out);
        double wsum = 0.0;
        for (size_t j = 0; j < k; ++j)
            wsum += d2[k * i + j] > 0.0 ? 1.0 / sqrt(d2[k * i + j]) : 0.0;
        for (size_t j = 0; j < k && wsum > 0.0; ++j) {
            double w = d2[k * i + j] > 0.0 ? 1.0 / sqrt(d2[k * i + j]) / wsum : 0.0;
            const float *s = spfh + N_HIST * (size_t)nb[k * i + j];
            for (int b = 0; b < N_HIST; ++b)
                out[b] += (float)w * s[b];
        }
        normalise(out);
    }
    st = PKSS_OK;
done:
    pkss__free(nb);
    pkss__free(d2);
    pkss__free(spfh);
    return st;
}

/* Index of the row of b (nb rows) nearest to row a in feature space. */
static uint32_t nearest_feature(const float *a, const float *b, size_t nb)
{
    uint32_t best = 0;
    float bd = INFINITY;
    for (size_t j = 0; j < nb; ++j) {
        const float *r = b + N_HIST * j;
        float d = 0.0f;
        for (int k = 0; k < N_HIST; ++k) {
            float e = a[k] - r[k];
            d += e * e;
        }
        if (d < bd) {
            bd = d;
            best = (uint32_t)j;
        }
    }
    return best;
}

/* Mutual nearest neighbours in feature space: (ps[k], pt[k]), k < *n. */
static pkss_status match(const float *fs, size_t ms, const float *ft, size_t mt,
                         uint32_t *ps, uint32_t *pt, size_t *n)
{
    uint32_t *back = pkss__malloc(mt * sizeof *back);
    if (!back)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (size_t j = 0; j < mt; ++j)
        back[j] = nearest_feature(ft + N_HIST * j, fs, ms);
    *n = 0;
    for (size_t i = 0; i < ms; ++i) {
        uint32_t j = nearest_feature(fs + N_HIST * i, ft, mt);
        if (back[j] == i) {
            ps[*n] = (uint32_t)i;
            pt[*n] = j;
            ++*n;
        }
    }
    pkss__free(back);
    return PKSS_OK;
}

/* Whether three matches can come from one similarity: the target's edge
 * lengths are the source's times one factor, within PKSS_LOCAL_EDGE_TOL,
 * no edge is shorter than PKSS_LOCAL_MIN_EDGE spacings (a degenerate
 * triangle fixes no rotation), and the factor is a plausible scale. */
static int consistent(const double *x, const double *y, double h)
{
    double lo = INFINITY, hi = 0.0;
    for (int a = 0; a < 3; ++a) {
        int b = (a + 1) % 3;
        double ex[3], ey[3];
        for (int d = 0; d < 3; ++d) {
            ex[d] = x[3 * b + d] - x[3 * a + d];
            ey[d] = y[3 * b + d] - y[3 * a + d];
        }
        double lx = sqrt(pkss__dot3(ex, ex)), ly = sqrt(pkss__dot3(ey, ey));
        if (lx < PKSS_LOCAL_MIN_EDGE * h || ly < PKSS_LOCAL_MIN_EDGE * h)
            return 0;
        double r = ly / lx;
        lo = fmin(lo, r);
        hi = fmax(hi, r);
    }
    return hi <= lo * (1.0 + PKSS_LOCAL_EDGE_TOL) && lo >= 1.0 / PKSS_LOCAL_SCALE_MAX &&
           hi <= PKSS_LOCAL_SCALE_MAX;
}

/* Matches k whose source point T brings within reach of its target point
 * (their indices into in, if not NULL); returns how many. */
static size_t count_inliers(const pkss__icp_view *s, const pkss__icp_view *t,
                            const uint32_t *ps, const uint32_t *pt, size_t n,
                            const pkss__pose *T, double reach2, uint32_t *in)
{
    size_t c = 0;
    for (size_t k = 0; k < n; ++k) {
        double y[3];
        pkss__pose_apply(T, s->pts + 3 * (size_t)ps[k], y);
        if (pkss__dist2(y, t->pts + 3 * (size_t)pt[k]) <= reach2) {
            if (in)
                in[c] = (uint32_t)k;
            ++c;
        }
    }
    return c;
}

typedef struct hypothesis {
    pkss__pose pose;
    size_t inliers;
} hypothesis;

/* Most inliers first (stable). */
static void sort_hypotheses(hypothesis *best, size_t n)
{
    for (size_t i = 1; i < n; ++i)
        for (size_t j = i; j > 0 && best[j].inliers > best[j - 1].inliers; --j) {
            hypothesis tmp = best[j];
            best[j] = best[j - 1];
            best[j - 1] = tmp;
        }
}

/* Keeps the best `cap` hypotheses, most inliers first, one per basin. */
static void keep_hypothesis(hypothesis *best, size_t *n_best, size_t cap,
                            const hypothesis *hy, double h)
{
    size_t at = *n_best;
    for (size_t b = 0; b < *n_best && at == *n_best; ++b)
        if (pkss__same_basin(&hy->pose, &best[b].pose, h, &pkss__start_basin))
            at = b;
    if (at < *n_best) {
        if (hy->inliers <= best[at].inliers)
            return;
    } else if (*n_best < cap) {
        at = (*n_best)++;
    } else if (hy->inliers > best[cap - 1].inliers) {
        at = cap - 1;
    } else {
        return;
    }
    best[at] = *hy;
    sort_hypotheses(best, *n_best);
}

/* Samples that draw, with PKSS_LOCAL_ODDS, one triple of inliers where only
 * the least accepted evidence (PKSS_LOCAL_MIN_INLIERS of the n >= that many
 * matches) is right: 1 - (1 - q)^N >= odds, q the odds of one draw (Fischler
 * and Bolles 1981); within [PKSS_LOCAL_SAMPLES, PKSS_LOCAL_SAMPLES_MAX]. */
static long sample_count(size_t n)
{
    double q = 1.0;
    for (int a = 0; a < 3; ++a)
        q *= (double)(PKSS_LOCAL_MIN_INLIERS - a) / (double)(n - (size_t)a);
    double need = q < 1.0 ? ceil(log1p(-PKSS_LOCAL_ODDS) / log1p(-q)) : 0.0;
    return (long)fmin(fmax(need, PKSS_LOCAL_SAMPLES), PKSS_LOCAL_SAMPLES_MAX);
}

/* The RANSAC over the matches: the best distinct poses, each refitted on
 * its inliers. */
static size_t ransac(const pkss__icp_view *s, const pkss__icp_view *t,
                     const uint32_t *ps, const uint32_t *pt, size_t n,
                     uint64_t seed, hypothesis *best, size_t cap)
{
    const double h = t->spacing, reach2 = pow(PKSS_LOCAL_REACH * h, 2);
    size_t n_best = 0;
    uint64_t rng = seed ^ 0x6C6F63616C6D6174ull;
    const long samples = sample_count(n);
    for (long it = 0; it < samples; ++it) {
        size_t k[3];
        for (int a = 0; a < 3; ++a)
            k[a] = (size_t)(pkss__splitmix64(&rng) % n);
        if (k[0] == k[1] || k[1] == k[2] || k[0] == k[2])
            continue;
        double x[9], y[9];
        for (int a = 0; a < 3; ++a)
            for (int d = 0; d < 3; ++d) {
                x[3 * a + d] = s->pts[3 * (size_t)ps[k[a]] + d];
                y[3 * a + d] = t->pts[3 * (size_t)pt[k[a]] + d];
            }
        const uint32_t i3[3] = {ps[k[0]], ps[k[1]], ps[k[2]]};
        const uint32_t j3[3] = {pt[k[0]], pt[k[1]], pt[k[2]]};
        hypothesis hy = {.pose = {.s = 1.0}};
        if (!consistent(x, y, h) ||
            !pkss__similarity_fit(s->pts, i3, t->pts, j3, 3, 1, &hy.pose))
            continue;
        hy.inliers = count_inliers(s, t, ps, pt, n, &hy.pose, reach2, NULL);
        if (hy.inliers >= PKSS_LOCAL_MIN_INLIERS)
            keep_hypothesis(best, &n_best, cap, &hy, h);
    }
    return n_best;
}

/* Hypothesis hy refitted on its inliers (twice: the refit gathers more). */
static pkss_status refit(const pkss__icp_view *s, const pkss__icp_view *t,
                         const uint32_t *ps, const uint32_t *pt, size_t n,
                         hypothesis *hy)
{
    const double reach2 = pow(PKSS_LOCAL_REACH * t->spacing, 2);
    uint32_t *in = pkss__malloc(3 * n * sizeof *in);
    if (!in)
        return PKSS_ERR_OUT_OF_MEMORY;
    uint32_t *is = in + n, *it = in + 2 * n; /* the inliers' points */
    for (int round = 0; round < 2; ++round) {
        size_t c = count_inliers(s, t, ps, pt, n, &hy->pose, reach2, in);
        if (c < PKSS_LOCAL_MIN_INLIERS)
            break;
        for (size_t k = 0; k < c; ++k) {
            is[k] = ps[in[k]];
            it[k] = pt[in[k]];
        }
        pkss__pose T = hy->pose;
        if (!pkss__similarity_fit(s->pts, is, t->pts, it, c, 1, &T))
            break;
        hy->pose = T;
        hy->inliers = c;
    }
    pkss__free(in);
    return PKSS_OK;
}

/* The first `max` poses of best[0..n) that lie in no earlier one's basin. */
static size_t distinct_poses(const hypothesis *best, size_t n, double h, size_t max,
                             pkss__pose *out)
{
    size_t k = 0;
    for (size_t b = 0; b < n && k < max; ++b) {
        int dup = 0;
        for (size_t j = 0; j < k && !dup; ++j)
            dup = pkss__same_basin(&best[b].pose, &out[j], h, &pkss__start_basin);
        if (!dup)
            out[k++] = best[b].pose;
    }
    return k;
}

pkss_status pkss__local_starts(const pkss__icp_view *src_coarse,
                               const pkss__icp_view *tgt_coarse, uint64_t seed,
                               size_t max, pkss__pose *starts, size_t *n_starts)
{
    const size_t ms = src_coarse->m, mt = tgt_coarse->m;
    *n_starts = 0;
    if (max == 0 || !src_coarse->normal || !tgt_coarse->normal ||
        ms <= PKSS_LOCAL_K || mt <= PKSS_LOCAL_K)
        return PKSS_OK;
    float *fs = pkss__malloc(ms * N_HIST * sizeof *fs);
    float *ft = pkss__malloc(mt * N_HIST * sizeof *ft);
    uint32_t *ps = pkss__malloc(ms * sizeof *ps), *pt = pkss__malloc(ms * sizeof *pt);
    hypothesis best[PKSS_LOCAL_KEPT];
    size_t n = 0, n_best = 0;
    pkss_status st = fs && ft && ps && pt ? PKSS_OK : PKSS_ERR_OUT_OF_MEMORY;
    if (st == PKSS_OK)
        st = features(src_coarse, fs);
    if (st == PKSS_OK)
        st = features(tgt_coarse, ft);
    if (st == PKSS_OK)
        st = match(fs, ms, ft, mt, ps, pt, &n);
    if (st == PKSS_OK && n >= PKSS_LOCAL_MIN_INLIERS)
        n_best = ransac(src_coarse, tgt_coarse, ps, pt, n, seed, best, PKSS_LOCAL_KEPT);
    for (size_t b = 0; b < n_best && st == PKSS_OK; ++b)
        st = refit(src_coarse, tgt_coarse, ps, pt, n, &best[b]);
    /* the refit may reorder the hypotheses or merge their basins */
    sort_hypotheses(best, n_best);
    if (st == PKSS_OK)
        *n_starts = distinct_poses(best, n_best, tgt_coarse->spacing, max, starts);
    pkss__free(fs);
    pkss__free(ft);
    pkss__free(ps);
    pkss__free(pt);
    return st;
}
