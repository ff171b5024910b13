/* SPDX-License-Identifier: MIT
 * test_assess.c -- assess.c on synthetic candidate sets: a box (three half
 * turns fit as well: ambiguous, each alternative's turn about a box axis),
 * the same box with a bump on one corner (no turn fits: not ambiguous), a
 * cylinder (an axial symmetry, reported as such), the alternative's pose
 * against its angle, axis and centre, and the confidence growing with the
 * margin to the best pose in another basin.
 */
#include "support.h"

#include "refine/assess.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define N_POINTS 12000 /* FPS to 3000 spreads them evenly, as a dense scan */

/* Points on the surface of the axis-aligned box of size a x b x c. */
static void box_surface(pkss_test_rng *rng, double a, double b, double c,
                        double *xyz, size_t n)
{
    const double dims[3] = {a, b, c};
    const double area[3] = {b * c, a * c, a * b};
    double total = 2 * (area[0] + area[1] + area[2]);
    for (size_t i = 0; i < n; ++i) {
        double u = pkss_test_uniform(rng) * total / 2, *p = xyz + 3 * i;
        int face = u < area[0] ? 0 : u < area[0] + area[1] ? 1 : 2;
        for (int d = 0; d < 3; ++d)
            p[d] = (pkss_test_uniform(rng) - 0.5) * dims[d];
        p[face] = (pkss_test_uniform(rng) < 0.5 ? -0.5 : 0.5) * dims[face];
    }
}

/* Lateral surface and caps of a cylinder of radius 1, height h, along z. */
static void cylinder_surface(pkss_test_rng *rng, double h, double *xyz, size_t n)
{
    double lateral = 2 * PKSS_PI * h, caps = 2 * PKSS_PI;
    for (size_t i = 0; i < n; ++i) {
        double *p = xyz + 3 * i;
        if (pkss_test_uniform(rng) < lateral / (lateral + caps)) {
            double t = 2 * PKSS_PI * pkss_test_uniform(rng);
            p[0] = cos(t);
            p[1] = sin(t);
            p[2] = (pkss_test_uniform(rng) - 0.5) * h;
        } else {
            double r = sqrt(pkss_test_uniform(rng)), t = 2 * PKSS_PI * pkss_test_uniform(rng);
            p[0] = r * cos(t);
            p[1] = r * sin(t);
            p[2] = pkss_test_uniform(rng) < 0.5 ? -0.5 * h : 0.5 * h;
        }
    }
}

/* A registration's end as register.c hands it to assess.c: source and
 * target are the same cloud, the winner (candidate 0) the identity, and
 * candidate 1 the identity turned 180 degrees about z, fully refined, its
 * fit measured. */
typedef struct fixture {
    pkss_context *ctx;
    pkss_cloud *cloud;
    pkss__icp_view v, vc;
    pkss__icp_result ir[2];
    pkss_candidate cand[2];
    pkss__assess_input in;
} fixture;

static void turn_z(double deg, double *R)
{
    double w[3] = {0, 0, deg * PKSS_PI / 180.0};
    pkss__rotation_exp(w, R);
}

static void setup(fixture *f, const double *xyz, size_t n, double winner_fit_drop)
{
    memset(f, 0, sizeof *f);
    assert_int_equal(pkss_context_create(&f->ctx), PKSS_OK);
    assert_int_equal(pkss_cloud_create(f->ctx, xyz, n, &f->cloud), PKSS_OK);
    pkss__icp_view_full(f->cloud, &f->v);
    for (int c = 0; c < 2; ++c) {
        pkss__icp_result *r = &f->ir[c];
        r->pose.s = 1.0;
        if (c == 0)
            pkss__mat3_identity(r->pose.R);
        else
            turn_z(180.0, r->pose.R);
        assert_int_equal(pkss__icp_overlap(&f->v, &f->v, &r->pose, &r->overlap, &r->rms,
                                           &r->fit), PKSS_OK);
        r->cover[0] = r->cover[1] = r->overlap;
        r->duplicate_of = -1;
        f->cand[c].struct_size = sizeof f->cand[c];
        f->cand[c].stage = PKSS_STAGE_REFINED;
        f->cand[c].score = 0.1;
        f->cand[c].fit = r->fit;
    }
    /* the winner as a noisy registration reads, not an exact copy's 1.0 */
    f->ir[0].fit -= winner_fit_drop;
    double *T = f->cand[0].T_target_source;
    T[0] = T[5] = T[10] = T[15] = 1.0;
    pkss__icp_view_coarse(f->cloud, &f->vc);
    f->in = (pkss__assess_input){&f->v, &f->v, &f->vc, &f->vc, f->cloud->sigma,
                                 f->cloud->centroid, f->ir, f->cand, 2, 0, 1};
}

static void teardown(fixture *f)
{
    pkss_cloud_destroy(f->cloud);
    pkss_context_destroy(f->ctx);
}

/* |axis . e_k| for the box axis e_k it is nearest to; *k receives k. */
static double along_axis(const double *axis, int *k)
{
    *k = 0;
    for (int d = 1; d < 3; ++d)
        if (fabs(axis[d]) > fabs(axis[*k]))
            *k = d;
    return fabs(axis[*k]);
}

static void test_box_half_turns_are_alternatives(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_assess", 1)};
    double *xyz = malloc(3 * N_POINTS * sizeof *xyz);
    assert_non_null(xyz);
    box_surface(&rng, 1.0, 0.7, 0.45, xyz, N_POINTS);
    fixture f;
    setup(&f, xyz, N_POINTS, 0.07);
    pkss__assessment a;
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    print_message("box: ambiguous %d symmetry %d order %u alternatives %zu confidence %.3f\n",
                  a.ambiguous, a.symmetry, (unsigned)a.order, a.n_alt, a.confidence);
    assert_true(a.ambiguous);
    assert_int_equal(a.symmetry, PKSS_SYMMETRY_DISCRETE);
    assert_int_equal(a.order, 2);
    assert_int_equal(a.n_alt, 3);
    int seen[3] = {0, 0, 0};
    for (size_t i = 0; i < a.n_alt; ++i) {
        int k;
        print_message("  %.1f deg about (%.3f %.3f %.3f), fit %.3f, candidate %d\n",
                      a.alt[i].angle_degrees, a.alt[i].axis[0], a.alt[i].axis[1],
                      a.alt[i].axis[2], a.alt[i].fit, a.alt[i].candidate);
        assert_true(fabs(a.alt[i].angle_degrees - 180.0) < 3.0);
        assert_true(along_axis(a.alt[i].axis, &k) > 0.99);
        seen[k] = 1;
    }
    assert_true(seen[0] && seen[1] && seen[2]);
    /* the symmetric images do not count against the winner */
    assert_true(a.features[PKSS__FEAT_MARGIN] > 0.1);
    teardown(&f);
    free(xyz);
}

/* The turned pose of an alternative is its angle about its axis through
 * its centre applied to the winner's aligned points. */
static void test_alternative_pose_matches_its_turn(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_assess", 2)};
    double *xyz = malloc(3 * N_POINTS * sizeof *xyz);
    assert_non_null(xyz);
    box_surface(&rng, 1.0, 0.7, 0.45, xyz, N_POINTS);
    for (size_t i = 0; i < N_POINTS; ++i) { /* off the origin */
        xyz[3 * i] += 3.0;
        xyz[3 * i + 2] -= 1.5;
    }
    fixture f;
    setup(&f, xyz, N_POINTS, 0.07);
    pkss__assessment a;
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    assert_true(a.n_alt > 0);
    for (size_t i = 0; i < a.n_alt; ++i) {
        const pkss_alternative *alt = &a.alt[i];
        double w[3], Q[9];
        for (int d = 0; d < 3; ++d)
            w[d] = alt->axis[d] * alt->angle_degrees * PKSS_PI / 180.0;
        pkss__rotation_exp(w, Q);
        for (size_t j = 0; j < N_POINTS; j += 997) {
            const double *p = xyz + 3 * j;
            double q[3], rel[3], turned[3];
            pkss_test_apply(alt->T_target_source, p, 1, q);
            for (int d = 0; d < 3; ++d)
                rel[d] = p[d] - alt->center[d]; /* the winner is the identity */
            pkss__mat3_apply(Q, rel, turned);
            for (int d = 0; d < 3; ++d)
                assert_true(fabs(turned[d] + alt->center[d] - q[d]) < 0.05);
        }
    }
    teardown(&f);
    free(xyz);
}

static void bumped_box(pkss_test_rng *rng, double *xyz, size_t n)
{
    size_t n_box = n * 3 / 4;
    box_surface(rng, 1.0, 0.7, 0.45, xyz, n_box);
    for (size_t i = n_box; i < n; ++i) { /* a ball on one corner */
        double v[3], r = 0.0;
        for (int d = 0; d < 3; ++d) {
            v[d] = pkss_test_normal(rng);
            r += v[d] * v[d];
        }
        r = sqrt(r);
        const double c[3] = {0.4, 0.25, 0.2};
        for (int d = 0; d < 3; ++d)
            xyz[3 * i + d] = c[d] + 0.2 * v[d] / r;
    }
}

static void test_bumped_box_is_not_ambiguous(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_assess", 3)};
    double *xyz = malloc(3 * N_POINTS * sizeof *xyz);
    assert_non_null(xyz);
    bumped_box(&rng, xyz, N_POINTS);
    fixture f;
    setup(&f, xyz, N_POINTS, 0.07);
    pkss__assessment a;
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    print_message("bumped box: ambiguous %d symmetry %d alternatives %zu fit %.3f vs %.3f, "
                  "confidence %.3f\n", a.ambiguous, a.symmetry, a.n_alt, f.ir[0].fit,
                  f.ir[1].fit, a.confidence);
    assert_false(a.ambiguous);
    assert_int_equal(a.symmetry, PKSS_SYMMETRY_NONE);
    assert_int_equal(a.n_alt, 0);
    /* the margin to the turned pose (saturating at 0.3) */
    assert_true(a.features[PKSS__FEAT_MARGIN] >
                fmin(f.ir[0].fit - f.ir[1].fit, 0.3) - 1e-9);
    teardown(&f);
    free(xyz);
}

static void test_cylinder_is_axial(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_assess", 4)};
    double *xyz = malloc(3 * N_POINTS * sizeof *xyz);
    assert_non_null(xyz);
    cylinder_surface(&rng, 1.2, xyz, N_POINTS);
    fixture f;
    setup(&f, xyz, N_POINTS, 0.07);
    pkss__assessment a;
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    print_message("cylinder: ambiguous %d symmetry %d axis (%.3f %.3f %.3f), alternatives %zu\n",
                  a.ambiguous, a.symmetry, a.axis[0], a.axis[1], a.axis[2], a.n_alt);
    assert_true(a.ambiguous);
    assert_int_equal(a.symmetry, PKSS_SYMMETRY_AXIAL);
    assert_true(fabs(a.axis[2]) > 0.99);
    /* turns about the axis are not listed; only the flips, if any */
    for (size_t i = 0; i < a.n_alt; ++i)
        assert_true(fabs(a.alt[i].axis[2]) < 0.1);
    teardown(&f);
    free(xyz);
}

static void test_confidence_grows_with_margin(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed("test_assess", 5)};
    double *xyz = malloc(3 * N_POINTS * sizeof *xyz);
    assert_non_null(xyz);
    bumped_box(&rng, xyz, N_POINTS);
    fixture f;
    setup(&f, xyz, N_POINTS, 0.07);
    pkss__assessment a;
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    double x[PKSS__ASSESS_FEATURES], last = -1.0;
    memcpy(x, a.features, sizeof x);
    for (int k = 0; k <= 10; ++k) {
        x[PKSS__FEAT_MARGIN] = 0.03 * k;
        double c = pkss__confidence(x);
        assert_true(c >= 0.0 && c <= 1.0);
        assert_true(c > last);
        last = c;
    }
    /* and a second candidate that fits as well lowers the winner's */
    double before = a.confidence;
    f.ir[1].fit = f.ir[0].fit;
    f.ir[1].pose.t[0] = 0.5; /* another basin, no symmetry of the shape */
    assert_int_equal(pkss__assess(&f.in, &a), PKSS_OK);
    assert_true(a.ambiguous);
    assert_true(a.confidence < before);
    teardown(&f);
    free(xyz);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_box_half_turns_are_alternatives),
        cmocka_unit_test(test_alternative_pose_matches_its_turn),
        cmocka_unit_test(test_bumped_box_is_not_ambiguous),
        cmocka_unit_test(test_cylinder_is_axial),
        cmocka_unit_test(test_confidence_grows_with_margin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
