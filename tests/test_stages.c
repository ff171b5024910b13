/* SPDX-License-Identifier: MIT
 * test_stages.c -- the refinement's stage rules (src/refine/stages.c,
 * basin.c) on synthetic candidate sets: who gets a full run, the winner,
 * the scale pairs, the same-basin test and the table of minima.
 */
#include "support.h"

#include "refine/stages.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static pkss__pose pose_at(double deg_about_z, double s, double tx)
{
    pkss__pose p;
    double a = deg_about_z * PKSS_PI / 180.0;
    double R[9] = {cos(a), -sin(a), 0, sin(a), cos(a), 0, 0, 0, 1};
    memcpy(p.R, R, sizeof R);
    p.s = s;
    p.t[0] = tx;
    p.t[1] = p.t[2] = 0.0;
    return p;
}

static void test_same_basin_tolerances(void **state)
{
    (void)state;
    const double h = 0.01;
    pkss__pose a = pose_at(0.0, 1.0, 0.0);
    /* during a run: 3 degrees, 1 % scale, 1 h */
    pkss__pose b = pose_at(2.9, 1.009, 0.99 * h);
    assert_true(pkss__same_basin(&a, &b, h, &pkss__run_basin));
    b = pose_at(3.1, 1.0, 0.0);
    assert_false(pkss__same_basin(&a, &b, h, &pkss__run_basin));
    b = pose_at(0.0, 1.011, 0.0);
    assert_false(pkss__same_basin(&a, &b, h, &pkss__run_basin));
    b = pose_at(0.0, 1.0, 1.01 * h);
    assert_false(pkss__same_basin(&a, &b, h, &pkss__run_basin));
    /* before a full run: 5 degrees, 5 % scale, 5 h */
    b = pose_at(4.9, 1.049, 4.9 * h);
    assert_true(pkss__same_basin(&a, &b, h, &pkss__start_basin));
    b = pose_at(5.1, 1.0, 0.0);
    assert_false(pkss__same_basin(&a, &b, h, &pkss__start_basin));
    b = pose_at(0.0, 1.0, 5.1 * h);
    assert_false(pkss__same_basin(&a, &b, h, &pkss__start_basin));
    /* the test is symmetric in its poses */
    b = pose_at(4.0, 1.02, 2.0 * h);
    assert_int_equal(pkss__same_basin(&a, &b, h, &pkss__start_basin),
                     pkss__same_basin(&b, &a, h, &pkss__start_basin));
}

/* An empty table of run minima. */
static pkss__basins *new_basins(void)
{
    pkss__basins *b = calloc(1, sizeof *b);
    assert_non_null(b);
    return b;
}

static void test_basins_skip_own_and_bound(void **state)
{
    (void)state;
    pkss__basins *b = new_basins();
    const double h = 0.01;
    pkss__pose p = pose_at(10.0, 1.0, 0.0), q = pose_at(11.0, 1.0, 0.0);
    pkss__basins_add(b, &p, 7, 0.5);
    assert_int_equal(pkss__basins_find(b, &q, h, 3, 0.0), 7);
    assert_int_equal(pkss__basins_find(b, &q, h, 7, 0.0), -1); /* its own minimum */
    pkss__pose far = pose_at(40.0, 1.0, 0.0);
    assert_int_equal(pkss__basins_find(b, &far, h, 3, 0.0), -1);
    int cap = (int)(sizeof b->owner / sizeof *b->owner);
    for (int k = 0; k < cap + 5; ++k)
        pkss__basins_add(b, &far, k, 0.0);
    assert_int_equal(b->n, cap);
    pkss__basins_add(NULL, &far, 1, 0.0); /* no table: nothing recorded */
    free(b);
}

/* The minimum of an abandoned run stands only for runs judged at least as
 * strictly: a later search's run, judged by a lower bar, goes on. */
static void test_abandoned_basins(void **state)
{
    (void)state;
    pkss__basins *b = new_basins();
    const double h = 0.01;
    pkss__pose p = pose_at(10.0, 1.0, 0.0), q = pose_at(11.0, 1.0, 0.0);
    pkss__pose p5 = pose_at(60.0, 1.0, 0.0), q5 = pose_at(60.5, 1.0, 0.0);
    pkss__basins_add(b, &p, 4, 0.7);
    pkss__basins_add(b, &p5, 5, 0.7);
    /* while run 4 goes on (or ended refined), any run stops in its minimum */
    assert_int_equal(pkss__basins_find(b, &q, h, 9, 0.0), 4);
    pkss__basins_abandon(b, 4);
    assert_int_equal(pkss__basins_find(b, &q, h, 9, 0.7), 4);
    assert_int_equal(pkss__basins_find(b, &q, h, 9, 0.8), 4);
    assert_int_equal(pkss__basins_find(b, &q, h, 9, 0.69), -1);
    assert_int_equal(pkss__basins_find(b, &q, h, 9, -1.0), -1); /* no bar stops it */
    /* run 5's minimum is not marked */
    assert_int_equal(pkss__basins_find(b, &q5, h, 9, 0.0), 5);
    pkss__basins_abandon(NULL, 4); /* no table: nothing to mark */
    free(b);
}

/* Candidates 0..n-1 of one search with these coarse overlaps, poses spread
 * 30 degrees apart (distinct basins). */
static pkss__refinement *set_of(const double *overlap, size_t n)
{
    pkss__refinement *rs = calloc(1, sizeof *rs);
    assert_non_null(rs);
    for (size_t c = 0; c < n; ++c) {
        rs->ir[c].overlap = overlap[c];
        rs->ir[c].pose = pose_at(30.0 * (double)c, 1.0, 0.0);
    }
    rs->n = n;
    return rs;
}

static void test_full_run_choice(void **state)
{
    (void)state;
    const double h = 0.01;
    /* the best PKSS_FULL_REFINE (3) by overlap, less those below 0.6 x best */
    const double ov1[5] = {0.5, 0.9, 0.8, 0.7, 0.3};
    pkss__refinement *rs = set_of(ov1, 5);
    int order[5];
    pkss__order_by_overlap(rs->ir, 5, order);
    assert_int_equal(order[0], 1);
    assert_int_equal(order[4], 4);
    assert_int_equal(pkss__initial_full_count(rs->ir, order, 5), 3);
    const double ov2[3] = {0.9, 0.5, 0.4};
    pkss__refinement *r2 = set_of(ov2, 3);
    int o2[3];
    pkss__order_by_overlap(r2->ir, 3, o2);
    assert_int_equal(pkss__initial_full_count(r2->ir, o2, 3), 1);

    /* the 4th by overlap is refined too when it reaches the leader's */
    size_t n_full = 3;
    rs->lead_overlap = 0.45;
    assert_true(pkss__wants_full_run(rs, rs->ir, order, 3, &n_full, h));
    assert_int_equal(n_full, 4);
    /* ... but not when it stays below */
    n_full = 3;
    rs->lead_overlap = 0.75;
    assert_false(pkss__wants_full_run(rs, rs->ir, order, 3, &n_full, h));
    assert_int_equal(n_full, 3);
    /* one in the start basin of a candidate ranked before it is not */
    rs->lead_overlap = 0.0;
    rs->ir[order[1]].pose = pose_at(30.0 * order[0] + 2.0, 1.0, 0.0);
    n_full = 3;
    assert_false(pkss__wants_full_run(rs, rs->ir, order, 1, &n_full, h));
    assert_true(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    /* a refined candidate of this search covering both clouds ends them */
    rs->lead_here = PKSS_COARSE_COMPLETE;
    assert_false(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    /* ... and so does one on which one cloud lies wholly: a part explained */
    rs->lead_here = 0.5;
    rs->explained_here = PKSS_EXPLAINED - 0.01;
    assert_true(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    rs->explained_here = PKSS_EXPLAINED;
    assert_false(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    /* ... and so does one in contact: a part placed */
    rs->explained_here = 0.5;
    assert_true(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    rs->contact_here = 1;
    assert_false(pkss__wants_full_run(rs, rs->ir, order, 2, &n_full, h));
    free(rs);
    free(r2);
}

static void test_winner_rule(void **state)
{
    (void)state;
    const double ov[4] = {0.9, 0.9, 0.9, 0.9};
    pkss__refinement *rs = set_of(ov, 4);
    /* none refined (refine off): the first by search score */
    assert_int_equal(pkss__pick_winner(rs), 0);
    double fit[4] = {0.80, 0.95, 0.70, 0.99};
    double rms[4] = {0.01, 0.02, 0.01, 0.01};
    for (int c = 0; c < 4; ++c) {
        rs->ir[c].fit = fit[c];
        rs->ir[c].rms = rms[c];
    }
    rs->refined[0] = rs->refined[1] = rs->refined[2] = 1; /* 3: stopped */
    assert_int_equal(pkss__pick_winner(rs), 1); /* highest merit among refined */
    /* a merit within PKSS_OVERLAP_TIE is a tie that the lower RMS breaks */
    const double merit1 = pkss__icp_merit(&rs->ir[1]);
    rs->ir[0].fit = sqrt((merit1 - 0.5 * PKSS_OVERLAP_TIE) * rs->ir[0].overlap);
    assert_int_equal(pkss__pick_winner(rs), 0);
    rs->ir[0].fit = sqrt((merit1 - 2.0 * PKSS_OVERLAP_TIE) * rs->ir[0].overlap);
    assert_int_equal(pkss__pick_winner(rs), 1);
    /* a lower fit that lies on the surface beats a higher one that lies near
     * it: partial/milk/0 of tools/identity's base 5, the truth (fit 0.5216,
     * overlap 0.5486) against a half turn (0.5880 within 0.7110) */
    rs->ir[0].fit = 0.5880;
    rs->ir[0].overlap = 0.7110;
    rs->ir[1].fit = 0.5216;
    rs->ir[1].overlap = 0.5486;
    rs->refined[2] = 0;
    assert_int_equal(pkss__pick_winner(rs), 1);
    free(rs);
}

static void test_contact_rule(void **state)
{
    (void)state;
    const double ov[2] = {0.5, 0.5};
    pkss__refinement *rs = set_of(ov, 2);
    rs->ir[0].overlap = 0.5;
    rs->ir[0].fit = PKSS_CONTACT * 0.5;
    /* only a fully refined candidate can be in contact */
    assert_false(pkss__in_contact(rs, 0));
    rs->refined[0] = 1;
    assert_true(pkss__in_contact(rs, 0));
    /* points near the surface but not on it: no contact */
    rs->ir[0].fit = PKSS_CONTACT * 0.5 - 0.01;
    assert_false(pkss__in_contact(rs, 0));
    /* nothing overlapping is no contact */
    rs->refined[1] = 1;
    rs->ir[1].overlap = rs->ir[1].fit = 0.0;
    assert_false(pkss__in_contact(rs, 1));
    free(rs);
}

/* A winner that lies on the template at a ratio between PKSS_PLACED and
 * PKSS_CONTACT has placed the part (no search for its place runs: wide,
 * local, shift), though as a single candidate it would not end its
 * search's full runs. */
static void test_placed_rule(void **state)
{
    (void)state;
    const double ov[1] = {0.5};
    pkss__refinement *rs = set_of(ov, 1);
    const double between = 0.5 * (PKSS_PLACED + PKSS_CONTACT);
    assert_true(PKSS_PLACED < PKSS_CONTACT);
    rs->refined[0] = 1;
    rs->ir[0].overlap = 0.5;
    rs->ir[0].cover[0] = 0.6;
    rs->ir[0].cover[1] = 0.5;
    rs->ir[0].fit = between * 0.5;
    assert_false(pkss__in_contact(rs, 0));
    assert_false(pkss__part_unplaced(rs, 0));
    assert_false(pkss__shift_wanted(rs, 0));
    /* below the placed ratio: the searches for the part's place run */
    rs->ir[0].fit = PKSS_PLACED * 0.5 - 0.01;
    assert_true(pkss__part_unplaced(rs, 0));
    assert_true(pkss__shift_wanted(rs, 0));
    /* a part covered wholly is placed whatever the ratio; the shift search
     * still runs while the other cloud is not covered wholly */
    rs->ir[0].cover[0] = PKSS_PART_COVERED;
    assert_false(pkss__part_unplaced(rs, 0));
    assert_true(pkss__shift_wanted(rs, 0));
    rs->ir[0].cover[1] = PKSS_PART_COVERED;
    assert_false(pkss__shift_wanted(rs, 0));
    rs->ir[0].cover[1] = 0.5;
    /* a winner not fully refined has placed nothing */
    rs->ir[0].cover[0] = 0.6;
    rs->ir[0].fit = between * 0.5;
    rs->refined[0] = 0;
    assert_true(pkss__part_unplaced(rs, 0));
    assert_false(pkss__shift_wanted(rs, 0));
    free(rs);
}

/* The scale sweep runs where both clouds are parts, over the steps
 * (rounded) between the winner's scale and the pre-shape ratio, either
 * way. */
static void test_rescale_steps(void **state)
{
    (void)state;
    const double ov[1] = {0.5};
    pkss__refinement *rs = set_of(ov, 1);
    const double half = sqrt(PKSS_RESCALE_STEP);
    rs->ir[0].cover[0] = 0.8;
    rs->ir[0].cover[1] = 0.5;
    rs->ir[0].pose.s = 0.8;
    assert_int_equal(pkss__rescale_steps(rs, 0), 0); /* not refined */
    rs->refined[0] = 1;
    assert_int_equal(pkss__rescale_steps(rs, 0), 2); /* 0.8 = 1.15^-1.6 */
    rs->ir[0].pose.s = 1.0 / 0.8;
    assert_int_equal(pkss__rescale_steps(rs, 0), 2);
    rs->ir[0].pose.s = 1.01 / half;
    assert_int_equal(pkss__rescale_steps(rs, 0), 0); /* within half a step */
    rs->ir[0].pose.s = 0.99 / half;
    assert_int_equal(pkss__rescale_steps(rs, 0), 1);
    rs->ir[0].pose.s = 0.1;
    assert_int_equal(pkss__rescale_steps(rs, 0), PKSS_RESCALE_STEPS);
    /* a cloud covered wholly fixes the scale (the part modes): no sweep */
    rs->ir[0].cover[0] = PKSS_PART_COVERED;
    assert_int_equal(pkss__rescale_steps(rs, 0), 0);
    free(rs);
}

static void test_part_mode(void **state)
{
    (void)state;
    /* a source lying wholly on the template, covering clearly more of it */
    assert_int_equal(pkss__part_mode(0.95, 0.60, PKSS__SCALE_MUTUAL),
                     PKSS__SCALE_SOURCE_PART);
    assert_int_equal(pkss__part_mode(0.55, 0.93, PKSS__SCALE_MUTUAL),
                     PKSS__SCALE_TEMPLATE_PART);
    /* both whole, or neither wholly on the other: mutual pairs */
    assert_int_equal(pkss__part_mode(0.97, 0.96, PKSS__SCALE_MUTUAL), PKSS__SCALE_MUTUAL);
    assert_int_equal(pkss__part_mode(0.70, 0.40, PKSS__SCALE_MUTUAL), PKSS__SCALE_MUTUAL);
}

static void test_schedules_defined_once(void **state)
{
    (void)state;
    /* the coarse level is rigid, the full run frees the scale and polishes */
    assert_int_equal(pkss__schedule_coarse.free_scale, 0);
    assert_int_equal(pkss__schedule_coarse.rigid_iters, pkss__schedule_coarse.max_iters);
    assert_int_equal(pkss__schedule_full.free_scale, PKSS__SCALE_MUTUAL);
    assert_true(pkss__schedule_full.rigid_iters < pkss__schedule_full.max_iters);
    assert_true(pkss__schedule_full.plane_iters > 0);
    assert_int_equal(pkss__schedule_polish.max_iters, 0);
    assert_true(pkss__schedule_polish.plane_iters > 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_basin_tolerances),
        cmocka_unit_test(test_basins_skip_own_and_bound),
        cmocka_unit_test(test_abandoned_basins),
        cmocka_unit_test(test_full_run_choice),
        cmocka_unit_test(test_winner_rule),
        cmocka_unit_test(test_contact_rule),
        cmocka_unit_test(test_placed_rule),
        cmocka_unit_test(test_rescale_steps),
        cmocka_unit_test(test_part_mode),
        cmocka_unit_test(test_schedules_defined_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
