/* SPDX-License-Identifier: MIT
 * test_correspond.c -- the ICP engine's correspondences (correspond.c).
 *
 * A work that remembers its queries (pkss__work_alloc(..., 1)) must give
 * the answers of one that queries afresh every time, bit for bit: the same
 * partners (ties to the lowest index) and the same squared distances, both
 * ways, along walks of poses with small steps (answers remembered), jumps
 * (renewed), gates that shrink, hold and reopen, and clouds with duplicate
 * points and exact ties; and so must its lookups when the call's helper
 * thread shares them.
 */
#include "support.h"

#include "refine/icp_parts.h"
#include "refine/work_counts.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_correspond";
static uint64_t g_seed;

/* n points on a wavy sheet; with `ties`, on an integer grid of it and with
 * every tenth point duplicated (stacks of identical points). */
static double *make_sheet(pkss_test_rng *r, size_t n, int ties)
{
    double *x = malloc(3 * n * sizeof(double));
    assert_non_null(x);
    for (size_t i = 0; i < n; ++i) {
        double u = 4.0 * pkss_test_uniform(r) - 2.0, v = 4.0 * pkss_test_uniform(r) - 2.0;
        if (ties) {
            u = floor(u * 8.0) / 8.0;
            v = floor(v * 8.0) / 8.0;
        }
        x[3 * i] = u;
        x[3 * i + 1] = v;
        x[3 * i + 2] = ties ? 0.0 : 0.3 * sin(2.0 * u) * cos(1.5 * v);
        if (ties && i % 10 == 9)
            memcpy(x + 3 * i, x + 3 * (i - 1), 3 * sizeof(double));
    }
    return x;
}

static pkss__pose identity_pose(void)
{
    pkss__pose T;
    pkss__mat3_identity(T.R);
    T.s = 1.0;
    T.t[0] = T.t[1] = T.t[2] = 0.0;
    return T;
}

typedef struct side {
    double *pts;
    pkss__kdtree *tree;
    pkss__icp_view view;
} side;

static void side_make(side *s, double *pts, size_t n)
{
    memset(s, 0, sizeof *s);
    s->pts = pts;
    assert_int_equal(pkss__kdtree_build(pts, n, &s->tree), PKSS_OK);
    s->view.pts = pts;
    s->view.m = n;
    s->view.tree = s->tree;
    s->view.spacing = 4.0 / sqrt((double)n);
}

static void side_free(side *s)
{
    pkss__kdtree_free(s->tree);
    free(s->pts);
}

/* A small random change of T: rotation by up to `turn` rad, translation up
 * to `shift`, scale by up to `grow` (relative). */
static void nudge(pkss_test_rng *r, double turn, double shift, double grow,
                  pkss__pose *T)
{
    double w[3] = {pkss_test_normal(r), pkss_test_normal(r), pkss_test_normal(r)};
    double len = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double a = turn * pkss_test_uniform(r), Q[9];
    for (int d = 0; d < 3; ++d)
        w[d] *= a / len;
    pkss__rotation_exp(w, Q);
    double R[9];
    pkss__mat3_mul(Q, T->R, R);
    memcpy(T->R, R, sizeof R);
    for (int d = 0; d < 3; ++d)
        T->t[d] += shift * (2.0 * pkss_test_uniform(r) - 1.0);
    T->s *= 1.0 + grow * (2.0 * pkss_test_uniform(r) - 1.0);
}

static void assert_same_answers(const pkss__icp_work *a, const pkss__icp_work *b,
                                size_t ns, size_t nt, int step)
{
    for (size_t i = 0; i < ns; ++i) {
        if (a->fwd[i] != b->fwd[i] || a->fwd_d2[i] != b->fwd_d2[i])
            fail_msg("step %d: forward answer %zu differs: %u (%a) vs %u (%a)", step, i,
                     a->fwd[i], a->fwd_d2[i], b->fwd[i], b->fwd_d2[i]);
    }
    for (size_t j = 0; j < nt; ++j) {
        if (a->bwd[j] != b->bwd[j] || a->bwd_d2[j] != b->bwd_d2[j])
            fail_msg("step %d: backward answer %zu differs: %u (%a) vs %u (%a)", step, j,
                     a->bwd[j], a->bwd_d2[j], b->bwd[j], b->bwd_d2[j]);
    }
}

/* One walk: the remembering work against a fresh query at every step;
 * with `shared`, the remembering work's lookups are shared with that run's
 * helper thread, the fresh ones answered on this thread alone. */
static void walk(pkss_test_rng *r, int ties, size_t ns, size_t nt, pkss__run *shared)
{
    side src, tgt;
    side_make(&src, make_sheet(r, ns, ties), ns);
    side_make(&tgt, make_sheet(r, nt, ties), nt);
    const double h = tgt.view.spacing;
    pkss__icp_work memo, fresh;
    assert_true(pkss__work_alloc(&memo, ns, nt, 1));
    pkss__pose T = identity_pose();
    double gate = 12.0 * h;
    size_t remembered = 0, asked = 0;
    for (int step = 0; step < 120; ++step) {
        if (step % 40 == 39)
            nudge(r, 0.5, 10.0 * h, 0.2, &T); /* a jump: answers renewed */
        else
            nudge(r, 0.01, 0.05 * h, 0.003, &T); /* an ICP-sized step */
        if (step % 40 == 20)
            gate = 8.0 * h; /* reopened, as the scale stage does */
        else if (gate > 3.0 * h)
            gate *= 0.85;
        src.view.run = tgt.view.run = shared;
        pkss__correspond(&src.view, &tgt.view, &T, gate, &memo);
        src.view.run = tgt.view.run = NULL;
        assert_true(pkss__work_alloc(&fresh, ns, nt, 0));
        pkss__correspond(&src.view, &tgt.view, &T, gate, &fresh);
        assert_same_answers(&memo, &fresh, ns, nt, step);
        for (size_t i = 0; i < ns; ++i) {
            double q[3];
            pkss__pose_apply(&T, src.pts + 3 * i, q);
            remembered += pkss__dist2(q, memo.fwd_memo.q0 + 3 * i) > 0.0;
            ++asked;
        }
        pkss__work_free(&fresh);
    }
    /* the walk must have exercised the memo, not only fresh queries */
    assert_true(remembered > asked / 4);
    pkss__work_free(&memo);
    side_free(&src);
    side_free(&tgt);
}

/* pkss__cover_within gives the coverages of a correspond() at the same
 * gate, bit for bit, at poses near and far, with a scale, with ties, and
 * at gates from below a spacing to several. */
static void test_cover_within_equals_correspond(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 7};
    for (int ties = 0; ties <= 1; ++ties) {
        side src, tgt;
        side_make(&src, make_sheet(&r, 1500, ties), 1500);
        side_make(&tgt, make_sheet(&r, 1800, ties), 1800);
        const double h = tgt.view.spacing;
        pkss__icp_work w;
        assert_true(pkss__work_alloc(&w, 1500, 1800, 0));
        pkss__pose T = identity_pose();
        double lo = 1.0, hi = 0.0;
        for (int step = 0; step < 40; ++step) {
            nudge(&r, 0.05, 0.5 * h, 0.02, &T);
            double dist = h * (0.5 + 0.25 * (step % 12));
            double want[2], got[2];
            pkss__correspond(&src.view, &tgt.view, &T, dist, &w);
            pkss__coverage_from_pairs(&src.view, &tgt.view, &T, dist, &w, want);
            pkss__cover_within(&src.view, &tgt.view, &T, dist, got);
            if (got[0] != want[0] || got[1] != want[1])
                fail_msg("step %d (ties %d): cover (%.17g, %.17g), correspond says "
                         "(%.17g, %.17g)", step, ties, got[0], got[1], want[0], want[1]);
            lo = fmin(lo, fmin(got[0], got[1]));
            hi = fmax(hi, fmax(got[0], got[1]));
        }
        assert_true(lo < 0.9 && hi > 0.5); /* the walk met partial coverages */
        pkss__work_free(&w);
        side_free(&src);
        side_free(&tgt);
    }
}

/* pkss__fit_reaching returns cover_within's fit bit for bit whenever it
 * counts to the end, and -1 only when that fit lies below the bar: bars
 * below, at and above the fit, at poses near and far, with ties. */
static void test_fit_reaching_bounds_the_fit(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 11};
    static const double bars[] = {-1.0, 0.0, 0.5, 0.999, 1.0, 1.001, 1.5, 2.0};
    for (int ties = 0; ties <= 1; ++ties) {
        side src, tgt;
        side_make(&src, make_sheet(&r, 1500, ties), 1500);
        side_make(&tgt, make_sheet(&r, 1800, ties), 1800);
        const double h = tgt.view.spacing;
        pkss__pose T = identity_pose();
        int stopped = 0, counted = 0;
        for (int step = 0; step < 30; ++step) {
            nudge(&r, 0.05, 0.5 * h, 0.02, &T);
            double dist = h * (0.5 + 0.25 * (step % 12)), f[2];
            pkss__cover_within(&src.view, &tgt.view, &T, dist, f);
            const double fit = sqrt(f[0] * f[1]);
            for (size_t b = 0; b < sizeof bars / sizeof *bars; ++b) {
                double bar = bars[b] * fit;
                double got = pkss__fit_reaching(&src.view, &tgt.view, &T, dist, bar);
                if (got == -1.0) {
                    if (!(fit < bar))
                        fail_msg("step %d: stopped below bar %.17g, but the fit is %.17g",
                                 step, bar, fit);
                    ++stopped;
                } else {
                    if (got != fit)
                        fail_msg("step %d: fit %.17g, cover_within's %.17g", step, got, fit);
                    ++counted;
                }
            }
        }
        assert_true(stopped > 0 && counted > 0); /* both outcomes were met */
        side_free(&src);
        side_free(&tgt);
    }
}

static void test_remembered_answers_equal_fresh_queries(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed};
    walk(&r, 0, 1500, 1800, NULL);
    walk(&r, 0, 3000, 700, NULL);
}

/* A flat grid sheet, x in [x0, x0 + (nx - 1) g], y in [y0, ...], z = 0, its
 * points mapped by the inverse of T (world = T x), with T's normals. */
static double *flat_grid(double x0, double y0, int nx, int ny, double g,
                         const pkss__pose *T, double **normal)
{
    double *x = malloc(3 * (size_t)(nx * ny) * sizeof(double));
    *normal = malloc(3 * (size_t)(nx * ny) * sizeof(double));
    assert_non_null(x);
    assert_non_null(*normal);
    const double up[3] = {0.0, 0.0, 1.0};
    double zero[3] = {0.0, 0.0, 0.0}, origin[3], tip[3];
    pkss__pose_inverse_apply(T, zero, origin);
    pkss__pose_inverse_apply(T, up, tip);
    for (int i = 0; i < nx * ny; ++i) {
        double world[3] = {x0 + g * (i % nx), y0 + g * (i / nx), 0.0};
        pkss__pose_inverse_apply(T, world, x + 3 * i);
        for (int d = 0; d < 3; ++d) /* R^T e_z: T's inverse is R^T (y - t) / s */
            (*normal)[3 * i + d] = (tip[d] - origin[d]) * T->s;
    }
    return x;
}

/* Pairs beneath (pkss__correspond_beneath, pkss__beneath_pairs): two flat
 * sheets overlapping on half their width, the source under a similarity. A
 * point beyond the other sheet's rim pairs with the rim, beside it: such
 * pairs go, in both directions; the overlap's pairs stay. tol is in each
 * side's units. A view without normals keeps every pair. */
static void test_pairs_beneath_drop_rim_pairs(void **state)
{
    (void)state;
    const double g = 0.1, tol = 1.5 * g, c = cos(0.7), s = sin(0.7);
    pkss__pose T = {.s = 2.0, .R = {1, 0, 0, 0, c, -s, 0, s, c}, .t = {1.0, 2.0, 3.0}};
    pkss__pose I = identity_pose();
    double *tgt_normal, *src_normal;
    side tgt, src;
    side_make(&tgt, flat_grid(0.0, -2.0, 41, 41, g, &I, &tgt_normal), 41 * 41);
    side_make(&src, flat_grid(-1.95, -1.95, 40, 40, g, &T, &src_normal), 40 * 40);
    tgt.view.normal = tgt_normal;
    src.view.normal = src_normal;
    tgt.view.spacing = g;
    src.view.spacing = g / T.s;
    pkss__icp_work w;
    assert_true(pkss__work_alloc(&w, src.view.m, tgt.view.m, 0));
    pkss__correspond_beneath(&src.view, &tgt.view, &T, 6.0 * g, tol, &w);
    double d2max = 0.0;
    size_t kept;
    const size_t n = pkss__beneath_pairs(&w, src.view.m, tgt.view.m, &kept, &d2max);
    int beyond = 0, k = 0;
    for (size_t i = 0; i < src.view.m; ++i) {
        double x = -1.95 + g * (double)(i % 40);
        beyond += x < -tol && w.fwd[i] != UINT32_MAX;
        int is_kept = k < (int)kept && w.pi[k] == i;
        k += is_kept;
        if (x >= 0.0)
            assert_true(is_kept);
        if (x < -tol)
            assert_false(is_kept);
    }
    assert_true(beyond > 0); /* the gate let rim pairs in */
    k = (int)kept;
    for (size_t j = 0; j < tgt.view.m; ++j) {
        double x = g * (double)(j % 41);
        int is_kept = k < (int)n && w.pj[k] == j;
        k += is_kept;
        if (x <= 1.95)
            assert_true(is_kept);
        if (x > 1.95 + tol + 1e-9)
            assert_false(is_kept);
    }
    tgt.view.normal = NULL;
    pkss__correspond_beneath(&src.view, &tgt.view, &T, 6.0 * g, tol, &w);
    pkss__beneath_pairs(&w, src.view.m, tgt.view.m, &kept, &d2max);
    assert_int_equal(kept, pkss__forward_pairs(&w, src.view.m, 0, &d2max));
    pkss__work_free(&w);
    side_free(&src);
    side_free(&tgt);
    free(tgt_normal);
    free(src_normal);
}

/* A context's run begun, whose helper thread the views' lookups share. */
static pkss_context *shared_run(pkss__run *run)
{
    pkss_context *ctx;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    pkss__run_begin(ctx, run);
    return ctx;
}

static void shared_run_end(pkss_context *ctx)
{
    pkss__run_end(ctx);
    pkss_context_destroy(ctx);
}

/* Unit normals of make_sheet's wavy sheet (ties = 0) at its points. */
static double *sheet_normals(const double *x, size_t n)
{
    double *nrm = malloc(3 * n * sizeof(double));
    assert_non_null(nrm);
    for (size_t i = 0; i < n; ++i) {
        double u = x[3 * i], v = x[3 * i + 1];
        double g[3] = {-0.6 * cos(2.0 * u) * cos(1.5 * v), 0.45 * sin(2.0 * u) * sin(1.5 * v),
                       1.0};
        double len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        for (int d = 0; d < 3; ++d)
            nrm[3 * i + d] = g[d] / len;
    }
    return nrm;
}

/* Whether point p's partner q (normal nq) lies beneath p within sqrt(tol2),
 * derived here from the pair: within tol2, or offset along the surface
 * within it. */
static int lies_beneath(const double *p, const double *q, const double *nq, double d2,
                        double tol2)
{
    double d[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
    double across = d[0] * nq[0] + d[1] * nq[1] + d[2] * nq[2];
    return d2 <= tol2 || (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - across * across <= tol2;
}

/* One direction of a pass: its queries `from` (carried by T, or by its
 * inverse when backward), their partners in `to` with to_normal. */
typedef struct one_way {
    const pkss__icp_work *w;
    int backward;
    const side *from, *to;
    const double *to_normal;
    const pkss__pose *T;
    double tol2;
} one_way;

/* Checks the direction's pairs beneath, listed from *k up to end, against
 * those derived from its answers, raising *d2max to its farthest answer
 * (template units); returns how many answers were dropped. */
static size_t check_one_way(const one_way *o, int step, size_t *k, size_t end,
                            double *d2max)
{
    const pkss__icp_work *w = o->w;
    const uint32_t *nn = o->backward ? w->bwd : w->fwd;
    const double *d2 = o->backward ? w->bwd_d2 : w->fwd_d2;
    const double s2 = o->backward ? o->T->s * o->T->s : 1.0;
    size_t dropped = 0;
    for (size_t i = 0; i < o->from->view.m; ++i) {
        uint32_t u = nn[i];
        if (u == UINT32_MAX)
            continue;
        *d2max = fmax(*d2max, s2 * d2[i]);
        double y[3];
        if (o->backward)
            pkss__pose_inverse_apply(o->T, o->from->pts + 3 * i, y);
        else
            pkss__pose_apply(o->T, o->from->pts + 3 * i, y);
        if (!lies_beneath(y, o->to->pts + 3 * (size_t)u, o->to_normal + 3 * (size_t)u, d2[i],
                          o->tol2)) {
            ++dropped;
            continue;
        }
        uint32_t pi = o->backward ? u : (uint32_t)i, pj = o->backward ? (uint32_t)i : u;
        if (*k >= end || w->pi[*k] != pi || w->pj[*k] != pj)
            fail_msg("step %d: pair %zu is not (%u, %u)", step, *k, pi, pj);
        ++*k;
    }
    assert_int_equal(*k, end);
    return dropped;
}

/* The pairs beneath and the coverages that a pass gathers chunk by chunk
 * on both threads equal those derived from its answers afterwards, bit for
 * bit: forward then backward pairs in index order, the farthest answer, the
 * overlap at the coverage distance (or -1 with a narrower gate). */
static void test_pass_lists_equal_derived(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 13};
    pkss__run run;
    pkss_context *ctx = shared_run(&run);
    const size_t ns = 1500, nt = 1800;
    side src, tgt;
    side_make(&src, make_sheet(&r, ns, 0), ns);
    side_make(&tgt, make_sheet(&r, nt, 0), nt);
    double *src_normal = sheet_normals(src.pts, ns), *tgt_normal = sheet_normals(tgt.pts, nt);
    src.view.normal = src_normal;
    tgt.view.normal = tgt_normal;
    src.view.run = tgt.view.run = &run;
    const double h = tgt.view.spacing;
    pkss__icp_work w;
    assert_true(pkss__work_alloc(&w, ns, nt, 1));
    pkss__pose T = identity_pose();
    double gate = 12.0 * h;
    size_t dropped = 0, narrow = 0;
    for (int step = 0; step < 60; ++step) {
        nudge(&r, 0.03, 0.3 * h, 0.01, &T);
        gate = step == 30 ? 12.0 * h : fmax(0.85 * gate, 1.5 * h);
        const double tol = 0.5 * gate, tol_s = tol / T.s;
        pkss__correspond_beneath(&src.view, &tgt.view, &T, gate, tol, &w);
        double d2max = 0.0, want_d2max = 0.0;
        size_t n_forward, k = 0;
        const size_t n = pkss__beneath_pairs(&w, ns, nt, &n_forward, &d2max);
        const one_way fwd = {&w, 0, &src, &tgt, tgt_normal, &T, tol * tol};
        const one_way bwd = {&w, 1, &tgt, &src, src_normal, &T, tol_s * tol_s};
        dropped += check_one_way(&fwd, step, &k, n_forward, &want_d2max);
        dropped += check_one_way(&bwd, step, &k, n, &want_d2max);
        if (d2max != want_d2max)
            fail_msg("step %d: farthest answer %a, derived %a", step, d2max, want_d2max);
        double cg = pkss__coverage_gate(&src.view, &tgt.view, &T), f[2];
        pkss__coverage_from_pairs(&src.view, &tgt.view, &T, cg, &w, f);
        double ov = pkss__overlap_from_pairs(&src.view, &tgt.view, gate, &w);
        double want = gate >= cg ? sqrt(f[0] * f[1]) : -1.0;
        narrow += gate < cg;
        if (ov != want)
            fail_msg("step %d: overlap %.17g, derived %.17g", step, ov, want);
    }
    assert_true(dropped > 0 && narrow > 0); /* pairs went, gates fell below cg */
    pkss__work_free(&w);
    side_free(&src);
    side_free(&tgt);
    free(src_normal);
    free(tgt_normal);
    shared_run_end(ctx);
}

/* Lookups shared with the call's helper thread in chunks answer as one
 * thread does, bit for bit, whichever thread took which chunk. */
static void test_shared_answers_equal_one_thread(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 4};
    pkss__run run;
    pkss_context *ctx = shared_run(&run);
    walk(&r, 0, 1500, 1800, &run);
    walk(&r, 1, 1200, 1200, &run);
    walk(&r, 0, 3000, 300, &run);
    shared_run_end(ctx);
}

static void test_remembered_answers_keep_ties(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 1};
    walk(&r, 1, 1200, 1200, NULL);
}

/* Fewer points than a memo keeps: every answer still exact. */
static void test_tiny_clouds(void **state)
{
    (void)state;
    pkss_test_rng r = {g_seed + 2};
    walk(&r, 0, 2, 3, NULL);
    walk(&r, 1, 5, 1, NULL);
}

/* A PKSS_COUNT_WORK build counts every lookup, and how each was answered:
 * a first pass queries the tree for every point, a pass at the same pose
 * answers all from memory, a work without memory queries once per point. */
static void test_work_counts(void **state)
{
    (void)state;
#ifndef PKSS_COUNT_WORK
    skip(); /* counted in the sanitizer build (tools/run-tests.sh) */
#else
    pkss_test_rng r = {g_seed + 3};
    const size_t ns = 500, nt = 600;
    side src, tgt;
    side_make(&src, make_sheet(&r, ns, 0), ns);
    side_make(&tgt, make_sheet(&r, nt, 0), nt);
    pkss__icp_work memo, fresh;
    assert_true(pkss__work_alloc(&memo, ns, nt, 1));
    assert_true(pkss__work_alloc(&fresh, ns, nt, 0));
    pkss__pose T = identity_pose();
    T.t[0] = 0.01;
    const double gate = 6.0 * tgt.view.spacing;
    unsigned long n[PKSS_WORK_COUNTS];
    pkss__work_counts(n); /* from zero */
    pkss__correspond(&src.view, &tgt.view, &T, gate, &memo);
    pkss__work_counts(n);
    assert_int_equal(n[PKSS_WORK_LOOKUPS], ns + nt);
    assert_int_equal(n[PKSS_WORK_FIRST], ns + nt);
    assert_int_equal(n[PKSS_WORK_MOVED] + n[PKSS_WORK_SINGLE], 0);
    pkss__correspond(&src.view, &tgt.view, &T, gate, &memo);
    pkss__work_counts(n);
    assert_int_equal(n[PKSS_WORK_LOOKUPS], ns + nt);
    assert_int_equal(n[PKSS_WORK_FIRST] + n[PKSS_WORK_MOVED] + n[PKSS_WORK_SINGLE], 0);
    T.t[0] += 20.0 * tgt.view.spacing; /* far beyond every margin */
    pkss__correspond(&src.view, &tgt.view, &T, gate, &memo);
    pkss__work_counts(n);
    assert_int_equal(n[PKSS_WORK_MOVED], ns + nt);
    pkss__correspond(&src.view, &tgt.view, &T, gate, &fresh);
    pkss__work_counts(n);
    assert_int_equal(n[PKSS_WORK_SINGLE], ns + nt);
    assert_int_equal(n[PKSS_WORK_LOOKUPS], ns + nt);
    pkss__work_free(&memo);
    pkss__work_free(&fresh);
    side_free(&src);
    side_free(&tgt);
#endif
}

int main(void)
{
    g_seed = pkss_test_seed(PROGRAM, 20261202);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_remembered_answers_equal_fresh_queries),
        cmocka_unit_test(test_shared_answers_equal_one_thread),
        cmocka_unit_test(test_cover_within_equals_correspond),
        cmocka_unit_test(test_fit_reaching_bounds_the_fit),
        cmocka_unit_test(test_remembered_answers_keep_ties),
        cmocka_unit_test(test_tiny_clouds),
        cmocka_unit_test(test_work_counts),
        cmocka_unit_test(test_pairs_beneath_drop_rim_pairs),
        cmocka_unit_test(test_pass_lists_equal_derived),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
