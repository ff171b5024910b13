/* SPDX-License-Identifier: MIT
 * solve.c -- pose arithmetic and the least-squares updates of the ICP
 * engine: point-to-point (Umeyama / Kabsch) and point-to-plane
 * (Gauss-Newton on the similarity).
 */
#include "refine/icp_parts.h"

#include <math.h>
#include <string.h>

int pkss__similarity_fit(const double *xs, const uint32_t *pi, const double *ys,
                         const uint32_t *pj, size_t n, int with_scale, pkss__pose *T)
{
    double mx[3] = {0, 0, 0}, my[3] = {0, 0, 0};
    for (size_t k = 0; k < n; ++k)
        for (int d = 0; d < 3; ++d) {
            mx[d] += xs[3 * (size_t)pi[k] + d];
            my[d] += ys[3 * (size_t)pj[k] + d];
        }
    for (int d = 0; d < 3; ++d) {
        mx[d] /= (double)n;
        my[d] /= (double)n;
    }
    double H[9] = {0}, sxx = 0.0;
    for (size_t k = 0; k < n; ++k) {
        const double *x = xs + 3 * (size_t)pi[k];
        const double *y = ys + 3 * (size_t)pj[k];
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
    int fitted = !with_scale;
    if (with_scale) {
        /* s = tr(R H) / sum |x - mx|^2 (Umeyama) */
        double tr = 0.0;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                tr += R[3 * r + c] * H[3 * c + r];
        fitted = sxx > 0.0 && tr > 0.0;
        if (fitted)
            s = tr / sxx;
    }
    double Rm[3];
    pkss__mat3_apply(R, mx, Rm);
    memcpy(T->R, R, sizeof R);
    T->s = s;
    for (int d = 0; d < 3; ++d)
        T->t[d] = my[d] - s * Rm[d];
    return fitted;
}

int pkss__solve_point(const pkss__icp_view *src, const pkss__icp_view *tgt,
                 const uint32_t *pi, const uint32_t *pj, size_t n,
                 int with_scale, pkss__pose *T)
{
    if (n < ICP_MIN_PAIRS)
        return 0;
    pkss__similarity_fit(src->pts, pi, tgt->pts, pj, n, with_scale, T);
    return 1;
}

/* One Gauss-Newton step of the point-to-plane similarity fit on pairs
 * (src i, tgt j): minimises sum (n_j . (p' - y_j))^2 over
 * p' = c + (1 + sg)(I + [w]x)(p - c) + tau, p = T x_i, c = mean p, to first
 * order in (sg, w, tau), and applies it to T. Returns the step's largest
 * component, or -1 if there are too few pairs or they fix no pose.
 * The scale's lever is taken at the template point, n . (y - c): at p, the
 * source's noise along the normals would shrink it (regression dilution;
 * docs/tuning.md). The rotation's levers see only the tangential part. */
double pkss__solve_plane(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const uint32_t *pi, const uint32_t *pj, size_t n,
                          pkss__pose *T)
{
    if (n < ICP_MIN_PAIRS)
        return -1.0;
    double c[3] = {0, 0, 0};
    for (size_t k = 0; k < n; ++k) {
        double p[3];
        pkss__pose_apply(T, src->pts + 3 * (size_t)pi[k], p);
        for (int d = 0; d < 3; ++d)
            c[d] += p[d];
    }
    for (int d = 0; d < 3; ++d)
        c[d] /= (double)n;
    double A[49] = {0}, g[7] = {0};
    for (size_t k = 0; k < n; ++k) {
        double p[3], a[3];
        pkss__pose_apply(T, src->pts + 3 * (size_t)pi[k], p);
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
     * flat patch) makes A singular: a small relative damping keeps it
     * solvable and leaves that direction where it is (no pair's row, and so
     * not the gradient, has a component along it): ICP_PLANE_DAMPING. */
    double tr = 0.0;
    for (int i = 0; i < 7; ++i) {
        for (int j = 0; j < i; ++j)
            A[7 * j + i] = A[7 * i + j];
        tr += A[8 * i];
    }
    for (int i = 0; i < 7; ++i)
        A[8 * i] += ICP_PLANE_DAMPING * tr / 7.0 + 1e-300;
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

double pkss__pose_change(const pkss__pose *a, const pkss__pose *b)
{
    double c = fabs(a->s - b->s);
    for (int i = 0; i < 9; ++i)
        c += fabs(a->R[i] - b->R[i]);
    for (int i = 0; i < 3; ++i)
        c += fabs(a->t[i] - b->t[i]);
    return c;
}
