/* SPDX-License-Identifier: MIT
 * assess.c -- how far to trust a registration (docs/design.md, "Confidence
 * and ambiguity"): the other poses that fit as well as the winner (refined
 * candidates in other basins, and turns of the aligned source about the
 * target's principal axes), the symmetry that the data shows, and the
 * calibrated confidence of a small logistic model over evidence the
 * pipeline already has (coefficients: confidence_model.h).
 */
#include "refine/assess.h"
#include "refine/confidence_model.h"

#include <math.h>
#include <string.h>

/* Constants: src/tuning.h ("Trust"); the model: confidence_model.h. */

static const double CONTINUOUS_TEST_DEG[] = ASSESS_CONTINUOUS_TEST_DEG;

#define DEG (PKSS_PI / 180.0)

/* Alternatives are told apart with the basin test of the stages
 * (pkss__start_basin: 5 degrees, 5 % scale, 5 spacings). */
static int same_basin(const pkss__pose *a, const pkss__pose *b, double h)
{
    return pkss__same_basin(a, b, h, &pkss__start_basin);
}

/* Angle (radians, [0, pi]) and unit axis of a rotation. */
static void rotation_log(const double *R, double *angle, double *axis)
{
    double c = 0.5 * (R[0] + R[4] + R[8] - 1.0);
    c = c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
    *angle = acos(c);
    double w[3] = {R[7] - R[5], R[2] - R[6], R[3] - R[1]};
    double n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    if (*angle > 0.5 * PKSS_PI) {
        /* near a half turn the skew part vanishes: the axis is the column
         * of (R + I) / 2 = a a^T + ... of largest norm, signed by w */
        int k = 0;
        for (int i = 1; i < 3; ++i)
            if (R[4 * i] > R[4 * k])
                k = i;
        double v[3];
        for (int i = 0; i < 3; ++i)
            v[i] = 0.5 * (R[3 * i + k] + R[3 * k + i]) + (i == k ? 1.0 - c : 0.0);
        n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        double sgn = v[0] * w[0] + v[1] * w[1] + v[2] * w[2] < 0 ? -1.0 : 1.0;
        for (int i = 0; i < 3; ++i)
            axis[i] = n > 0 ? sgn * v[i] / n : (i == 2);
        return;
    }
    for (int i = 0; i < 3; ++i)
        axis[i] = n > 0 ? w[i] / n : (i == 2);
}

/* The pose P turned by Q about the target's centre (the pre-shape origin):
 * out = Q * P. */
static void turn_pose(const double *Q, const pkss__pose *P, pkss__pose *out)
{
    out->s = P->s;
    pkss__mat3_mul(Q, P->R, out->R);
    pkss__mat3_apply(Q, P->t, out->t);
}

/* One assessment's working state. */
typedef struct state {
    const pkss__assess_input *in;
    const pkss__icp_result *w; /* the winner */
    double tie;                /* fits at or above it tie with the winner */
    pkss__pose alt_pose[PKSS__MAX_ALTERNATIVES]; /* pre-shape, per alt */
    double alt_turn[PKSS__MAX_ALTERNATIVES][9];  /* relative rotation */
    int alt_probe[PKSS__MAX_ALTERNATIVES];       /* found by a turn */
} state;

/* The rigid polish of a near tie: the turned or candidate pose settled on
 * all points, as the winner was (a few degrees of axis error would
 * otherwise grow with the turn). */
static const pkss__icp_schedule POLISH = PKSS_SCHEDULE_TIE_POLISH;

/* The winner turned by `deg` degrees about `axis` through the target's
 * centre, its fit and overlap; polished when it comes near a tie, and then
 * *moved by how far the polish took it (radians). */
static pkss_status probe(const state *S, const double *axis, double deg,
                         pkss__pose *pose, double *fit, double *overlap,
                         double *moved)
{
    double w[3] = {axis[0] * deg * DEG, axis[1] * deg * DEG, axis[2] * deg * DEG};
    double Q[9], rms;
    pkss__rotation_exp(w, Q);
    turn_pose(Q, &S->w->pose, pose);
    *moved = 0.0;
    if (S->in->svc && S->in->tvc) {
        /* a quarter of the points first: most turns are far from a tie */
        PKSS_FORWARD(pkss__icp_overlap(S->in->svc, S->in->tvc, pose, overlap, &rms, fit));
        if (*fit < S->tie - ASSESS_COARSE_MARGIN)
            return PKSS_OK;
    }
    PKSS_FORWARD(pkss__icp_overlap(S->in->sv, S->in->tv, pose, overlap, &rms, fit));
    if (*fit < S->tie - ASSESS_POLISH_MARGIN || !S->in->refine)
        return PKSS_OK;
    pkss__icp_result r;
    PKSS_FORWARD(pkss__icp_run(S->in->sv, S->in->tv, &POLISH, NULL, pose, &r));
    *moved = pkss__rotation_angle(r.pose.R, pose->R);
    *pose = r.pose;
    *fit = r.fit;
    *overlap = r.overlap;
    return PKSS_OK;
}

static int ties(const state *S, double fit)
{
    return fit >= S->tie;
}

/* Records an alternative at pre-shape pose P unless one in its basin is
 * listed already; caller-frame pose, turn and axis from the winner's. */
static void add_alternative(state *S, pkss__assessment *out,
                            const pkss__pose *P, double fit, double overlap,
                            int candidate)
{
    const pkss__assess_input *in = S->in;
    for (size_t i = 0; i < out->n_alt; ++i)
        if (same_basin(&S->alt_pose[i], P, in->tv->spacing))
            return;
    if (out->n_alt == PKSS__MAX_ALTERNATIVES)
        return;
    size_t k = out->n_alt++;
    pkss_alternative *a = &out->alt[k];
    memset(a, 0, sizeof *a);
    a->struct_size = sizeof *a;
    S->alt_pose[k] = *P;
    S->alt_probe[k] = candidate < 0;
    /* Q = P * W^-1 in pre-shape units: x -> q R x + u */
    const pkss__pose *W = &S->w->pose;
    double Wt[9], R[9], Wtt[3], u[3];
    pkss__mat3_transpose(W->R, Wt);
    pkss__mat3_mul(P->R, Wt, R);
    memcpy(S->alt_turn[k], R, sizeof R);
    double q = P->s / W->s;
    pkss__mat3_apply(R, W->t, Wtt);
    for (int d = 0; d < 3; ++d)
        u[d] = P->t[d] - q * Wtt[d];
    double angle, axis[3];
    rotation_log(R, &angle, axis);
    /* the point of the screw axis nearest the target's centre:
     * p = (u_perp + cot(angle / 2) axis x u_perp) / 2 */
    double ua = u[0] * axis[0] + u[1] * axis[1] + u[2] * axis[2], up[3], p[3];
    for (int d = 0; d < 3; ++d)
        up[d] = u[d] - ua * axis[d];
    double ct = angle > 1e-6 ? cos(0.5 * angle) / sin(0.5 * angle) : 0.0;
    double axu[3] = {axis[1] * up[2] - axis[2] * up[1],
                     axis[2] * up[0] - axis[0] * up[2],
                     axis[0] * up[1] - axis[1] * up[0]};
    for (int d = 0; d < 3; ++d)
        p[d] = angle > 1e-6 ? 0.5 * (up[d] + ct * axu[d]) : 0.0;
    const double sig = in->tgt_sigma, *c = in->tgt_centroid;
    a->angle_degrees = angle / DEG;
    for (int d = 0; d < 3; ++d) {
        a->axis[d] = axis[d];
        a->center[d] = sig * p[d] + c[d];
    }
    /* caller frame: M x = q R x + (c - q R c + sigma u), T = M * T_winner */
    double Rc[3], M[16] = {0};
    pkss__mat3_apply(R, c, Rc);
    for (int r = 0; r < 3; ++r) {
        for (int cc = 0; cc < 3; ++cc)
            M[4 * r + cc] = q * R[3 * r + cc];
        M[4 * r + 3] = c[r] - q * Rc[r] + sig * u[r];
    }
    M[15] = 1.0;
    const double *T = in->cand[in->winner].T_target_source;
    for (int r = 0; r < 4; ++r)
        for (int cc = 0; cc < 4; ++cc) {
            double v = 0.0;
            for (int j = 0; j < 4; ++j)
                v += M[4 * r + j] * T[4 * j + cc];
            a->T_target_source[4 * r + cc] = v;
        }
    a->fit = fit;
    a->overlap = overlap;
    a->candidate = candidate;
}

/* The target's principal axes (rows of axes) and variances, largest first. */
static void principal_axes(const pkss__icp_view *tv, double ev[3], double axes[3][3])
{
    double C[9] = {0}, V[9];
    for (size_t i = 0; i < tv->m; ++i) {
        const double *x = tv->pts + 3 * i;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                C[3 * r + c] += x[r] * x[c];
    }
    pkss__eig_sym3(C, ev, V);
    for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d)
            axes[k][d] = V[3 * d + k];
}

#define N_CONTINUOUS_TESTS (sizeof CONTINUOUS_TEST_DEG / sizeof CONTINUOUS_TEST_DEG[0])

/* *all = 1 when every continuous-test turn about axis (or, with axes, about
 * each of the three axes in turn) fits within the noise and stays put. */
static pkss_status continuous_turns(state *S, const double (*axes)[3], int n_axes,
                                    int *all)
{
    pkss__pose P;
    double fit, ov, moved;
    *all = 1;
    int n = n_axes > 1 ? n_axes : (int)N_CONTINUOUS_TESTS;
    for (int k = 0; k < n && *all; ++k) {
        const double *axis = axes[n_axes > 1 ? k : 0];
        PKSS_FORWARD(probe(S, axis, CONTINUOUS_TEST_DEG[(size_t)k % N_CONTINUOUS_TESTS],
                           &P, &fit, &ov, &moved));
        *all = ties(S, fit) && moved < ASSESS_SNAP;
    }
    return PKSS_OK;
}

/* The highest order n <= ASSESS_MAX_ORDER whose 360/n turn about axis ties:
 * its turns are alternatives. */
static pkss_status discrete_order(state *S, const double *axis, pkss__assessment *out)
{
    pkss__pose P;
    double fit, ov, moved;
    for (int n = ASSESS_MAX_ORDER; n >= 2 && out->order == 0; --n) {
        PKSS_FORWARD(probe(S, axis, 360.0 / n, &P, &fit, &ov, &moved));
        if (!ties(S, fit))
            continue;
        out->order = (uint32_t)n;
        memcpy(out->axis, axis, sizeof out->axis);
        add_alternative(S, out, &P, fit, ov, -1);
        for (int k = 2; k < n; ++k) {
            PKSS_FORWARD(probe(S, axis, 360.0 * k / n, &P, &fit, &ov, &moved));
            add_alternative(S, out, &P, fit, ov, -1);
        }
    }
    return PKSS_OK;
}

/* Half turns about each principal axis (but a symmetry axis already
 * covered); a tie is an alternative, and order 2 if nothing else was found. */
static pkss_status half_turns(state *S, const double (*axes)[3], int axis_k,
                              pkss__assessment *out)
{
    pkss__pose P;
    double fit, ov, moved;
    for (int k = 0; k < 3; ++k) {
        if (k == axis_k && (out->order % 2 == 0 || out->symmetry))
            continue; /* the half turn about the axis is covered already */
        PKSS_FORWARD(probe(S, axes[k], 180.0, &P, &fit, &ov, &moved));
        if (ties(S, fit)) {
            add_alternative(S, out, &P, fit, ov, -1);
            if (out->order == 0 && out->symmetry == PKSS_SYMMETRY_NONE) {
                out->order = 2;
                memcpy(out->axis, axes[k], sizeof out->axis);
            }
        }
    }
    return PKSS_OK;
}

/* The symmetry test on the data: where the target's PCA variances show a
 * degenerate pair (or triple), turns about the distinct axis by angles no
 * discrete symmetry has; then the orders n of 360/n turns about it, and
 * half turns about each principal axis. Every turn that fits within the
 * noise is an alternative. */
static pkss_status symmetry_test(state *S, pkss__assessment *out)
{
    double ev[3], axes[3][3];
    principal_axes(S->in->tv, ev, axes);
    int eq01 = ev[0] > 0 && (ev[0] - ev[1]) / ev[0] < ASSESS_EIG_EQUAL;
    int eq12 = ev[1] > 0 && (ev[1] - ev[2]) / ev[1] < ASSESS_EIG_EQUAL;
    int all;
    if (eq01 && eq12) {
        PKSS_FORWARD(continuous_turns(S, (const double (*)[3])axes, 3, &all));
        if (all) {
            out->symmetry = PKSS_SYMMETRY_SPHERICAL;
            return PKSS_OK;
        }
    }
    int axis_k = eq01 != eq12 ? (eq01 ? 2 : 0) : -1; /* a degenerate pair's distinct axis */
    if (axis_k >= 0) {
        PKSS_FORWARD(continuous_turns(S, (const double (*)[3])&axes[axis_k], 1, &all));
        if (all) {
            out->symmetry = PKSS_SYMMETRY_AXIAL;
            memcpy(out->axis, axes[axis_k], sizeof out->axis);
        } else {
            PKSS_FORWARD(discrete_order(S, axes[axis_k], out));
        }
    }
    return half_turns(S, (const double (*)[3])axes, axis_k, out);
}

/* A turn R (relative to the winner) that a found symmetry explains: listed
 * by the symmetry test, or mapping the axial symmetry's axis onto itself. */
static int explained(const state *S, const pkss__assessment *out,
                     const pkss__pose *P)
{
    if (out->symmetry == PKSS_SYMMETRY_SPHERICAL)
        return 1;
    /* an axial symmetry, or a turn of order >= 2 found about an axis (a
     * prism): any tying turn that takes the axis onto itself (either way) */
    if (out->symmetry == PKSS_SYMMETRY_AXIAL || out->order >= 2) {
        double Wt[9], R[9], Ra[3];
        pkss__mat3_transpose(S->w->pose.R, Wt);
        pkss__mat3_mul(P->R, Wt, R);
        pkss__mat3_apply(R, out->axis, Ra);
        if (fabs(Ra[0] * out->axis[0] + Ra[1] * out->axis[1] +
                 Ra[2] * out->axis[2]) > ASSESS_AXIS_COS)
            return 1;
    }
    for (size_t i = 0; i < out->n_alt; ++i)
        if (S->alt_probe[i] && same_basin(&S->alt_pose[i], P, S->in->tv->spacing))
            return 1;
    return 0;
}

double pkss__confidence(const double *x)
{
    double z = PKSS_CONF_BIAS;
    static const double w[PKSS__ASSESS_FEATURES] = {
        PKSS_CONF_W_FIT,   PKSS_CONF_W_OVERLAP,   PKSS_CONF_W_MARGIN,
        PKSS_CONF_W_RMS,   PKSS_CONF_W_ASYMMETRY, PKSS_CONF_W_COVER_MIN,
        PKSS_CONF_W_SCORE, PKSS_CONF_W_REFINED};
    for (int i = 0; i < PKSS__ASSESS_FEATURES; ++i)
        z += w[i] * x[i];
    return 1.0 / (1.0 + exp(-z));
}

/* Alternatives best fit first (insertion sort: a handful). */
static void sort_alternatives(pkss__assessment *out)
{
    for (size_t i = 1; i < out->n_alt; ++i) {
        pkss_alternative a = out->alt[i];
        size_t j = i;
        for (; j > 0 && out->alt[j - 1].fit < a.fit; --j)
            out->alt[j] = out->alt[j - 1];
        out->alt[j] = a;
    }
}

pkss_status pkss__assess(const pkss__assess_input *in, pkss__assessment *out)
{
    double t0 = pkss__now();
    memset(out, 0, sizeof *out);
    state S;
    memset(&S, 0, sizeof S);
    S.in = in;
    S.w = &in->ir[in->winner];
    double f = S.w->fit;
    size_t m = in->sv->m < in->tv->m ? in->sv->m : in->tv->m;
    double noise = fmax(ASSESS_NOISE_FLOOR,
                        ASSESS_NOISE_SIGMAS * sqrt(fmax(f * (1.0 - f), 0.0) / (double)(m ? m : 1)));
    S.tie = fmin(f, ASSESS_DECORRELATED_FIT) - noise;
    memcpy(out->center, in->tgt_centroid, sizeof out->center);
    PKSS_FORWARD(symmetry_test(&S, out));

    /* the refined candidates in other basins; near ties short of full
     * refinement get a rigid polish on all points first */
    double best_other = 0.0;
    for (size_t c = 0; c < in->n; ++c) {
        if ((int)c == in->winner)
            continue;
        pkss__icp_result r = in->ir[c];
        if (r.duplicate_of == in->winner ||
            same_basin(&r.pose, &S.w->pose, in->tv->spacing))
            continue;
        if (in->refine && in->cand[c].stage != PKSS_STAGE_REFINED &&
            r.fit >= S.tie - ASSESS_POLISH_MARGIN) {
            PKSS_FORWARD(pkss__icp_run(in->sv, in->tv, &POLISH, NULL, &in->ir[c].pose, &r));
            if (same_basin(&r.pose, &S.w->pose, in->tv->spacing))
                continue;
        }
        int expl = explained(&S, out, &r.pose);
        if (!expl && r.fit > best_other)
            best_other = r.fit;
        if (ties(&S, r.fit) &&
            !(expl && out->symmetry >= PKSS_SYMMETRY_AXIAL))
            add_alternative(&S, out, &r.pose, r.fit, r.overlap, (int)c);
    }
    sort_alternatives(out);
    if (out->symmetry == PKSS_SYMMETRY_NONE && out->n_alt > 0) {
        out->symmetry = PKSS_SYMMETRY_DISCRETE;
        if (out->order == 0) {
            /* no turn of the symmetry test fitted: the first alternative's */
            const pkss_alternative *a = &out->alt[0];
            memcpy(out->axis, a->axis, sizeof out->axis);
            double n = 360.0 / a->angle_degrees;
            if (fabs(n - floor(n + 0.5)) < 0.05 && n < ASSESS_MAX_ORDER + 0.5)
                out->order = (uint32_t)floor(n + 0.5);
        }
    } else if (out->symmetry == PKSS_SYMMETRY_NONE) {
        out->order = 0;
    }
    out->ambiguous = out->n_alt > 0 || out->symmetry >= PKSS_SYMMETRY_AXIAL;

    double *x = out->features;
    x[PKSS__FEAT_FIT] = f;
    x[PKSS__FEAT_OVERLAP] = S.w->overlap;
    x[PKSS__FEAT_MARGIN] = fmin(f - best_other, ASSESS_MARGIN_CAP);
    x[PKSS__FEAT_RMS] = fmin(S.w->rms / in->tv->spacing, ASSESS_RMS_CAP);
    x[PKSS__FEAT_ASYMMETRY] = fabs(S.w->cover[0] - S.w->cover[1]);
    x[PKSS__FEAT_COVER_MIN] = fmin(S.w->cover[0], S.w->cover[1]);
    x[PKSS__FEAT_SCORE] = in->cand[in->winner].score;
    x[PKSS__FEAT_REFINED] = in->cand[in->winner].stage == PKSS_STAGE_REFINED;
    out->confidence = pkss__confidence(x);
    out->seconds = pkss__now() - t0;
    return PKSS_OK;
}

void pkss__assess_store(const pkss__assessment *a, pkss_result *res)
{
    res->confidence = a->confidence;
    res->ambiguous = (uint32_t)a->ambiguous;
    res->n_alternatives = (uint32_t)a->n_alt;
    res->symmetry = a->symmetry;
    res->symmetry_order = a->order;
    int has_axis = a->symmetry == PKSS_SYMMETRY_AXIAL ||
                   a->symmetry == PKSS_SYMMETRY_DISCRETE;
    for (int d = 0; d < 3; ++d) {
        res->symmetry_axis[d] = has_axis ? a->axis[d] : 0.0;
        res->symmetry_center[d] = a->center[d];
    }
}
