/* SPDX-License-Identifier: MIT
 * test_cells.c -- the cell partition of SPEC 3 (kernels/pkss_shared.h):
 * hand-checked directions, the poles, the +-pi azimuth seam, agreement
 * with the acos/atan2 definition away from bin edges, and the binning's
 * farthest-point representatives.
 */
#include "support.h"

#include "pkss_internal.h"
#include "pkss_shared.h"

#include <math.h>
#include <stdio.h>

static const char *PROGRAM = "test_cells";
#define DEG (3.14159265358979323846 / 180.0)

static int cell_of(double theta_deg, double phi_deg, int n_az, const float *edges)
{
    double t = theta_deg * DEG, p = phi_deg * DEG;
    return pkss_cell_index((float)(sin(t) * cos(p)), (float)(sin(t) * sin(p)),
                           (float)cos(t), n_az, edges);
}

static void test_hand_checked_directions(void **state)
{
    (void)state;
    float e[PKSS_EDGES_SIZE];
    pkss__cell_edges(12, e); /* 30-degree bins: 6 elevation x 12 azimuth */
    /* +x: theta 90 -> elevation bin 3, phi 0 -> azimuth bin 0 */
    assert_int_equal(pkss_cell_index(1, 0, 0, 12, e), 12 * 3 + 0);
    /* +y: phi 90 -> bin 3 */
    assert_int_equal(pkss_cell_index(0, 1, 0, 12, e), 12 * 3 + 3);
    /* -x: phi 180 -> bin 6; -y: phi 270 -> bin 9 */
    assert_int_equal(pkss_cell_index(-1, 0, 0, 12, e), 12 * 3 + 6);
    assert_int_equal(pkss_cell_index(0, -1, 0, 12, e), 12 * 3 + 9);
    /* poles: azimuth undefined -> bin 0; north in elevation 0, south in 5 */
    assert_int_equal(pkss_cell_index(0, 0, 1, 12, e), 0);
    assert_int_equal(pkss_cell_index(0, 0, -2.5f, 12, e), 12 * 5);
    /* the +-pi seam: just below 360 degrees is the last bin, just above 0
     * the first (at theta = 100: theta = 90 lies exactly on an elevation
     * edge, where float rounding of cos(pi/2) decides) */
    assert_int_equal(cell_of(100, 359.9, 12, e), 12 * 3 + 11);
    assert_int_equal(cell_of(100, -0.1, 12, e), 12 * 3 + 11);
    assert_int_equal(cell_of(100, 0.1, 12, e), 12 * 3 + 0);
    assert_int_equal(cell_of(100, 179.9, 12, e), 12 * 3 + 5);
    assert_int_equal(cell_of(100, 180.1, 12, e), 12 * 3 + 6);
    /* interior points of bins */
    assert_int_equal(cell_of(45, 45, 12, e), 12 * 1 + 1);
    assert_int_equal(cell_of(100, 200, 12, e), 12 * 3 + 6);
    assert_int_equal(cell_of(175, 350, 12, e), 12 * 5 + 11);
    assert_int_equal(cell_of(5, 100, 12, e), 12 * 0 + 3);
    assert_int_equal(cell_of(125, 275, 12, e), 12 * 4 + 9);
    /* r = 0 is skipped */
    assert_int_equal(pkss_cell_index(0, 0, 0, 12, e), -1);
    /* scale invariance */
    assert_int_equal(pkss_cell_index(1e-20f, 2e-20f, 3e-20f, 12, e),
                     pkss_cell_index(1, 2, 3, 12, e));
    /* 12 x 24 grid (cell_steps = 24): 15-degree bins */
    float e24[PKSS_EDGES_SIZE];
    pkss__cell_edges(24, e24);
    assert_int_equal(cell_of(50, 50, 24, e24), 24 * 3 + 3);
    assert_int_equal(cell_of(179, 359, 24, e24), 24 * 11 + 23);
}

/* Away from the edges, the comparison binning equals floor(angle / step)
 * with theta = acos(z/r) and phi = atan2(y, x) in [0, 2pi). */
static void test_matches_angle_definition(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 5)};
    const int grids[] = {4, 8, 12, 16, 24, 36, 48};
    long checked = 0;
    for (size_t g = 0; g < sizeof grids / sizeof grids[0]; ++g) {
        int n_az = grids[g];
        float e[PKSS_EDGES_SIZE];
        pkss__cell_edges(n_az, e);
        double step = 2 * 3.14159265358979323846 / n_az;
        for (int k = 0; k < 20000; ++k) {
            double v[3] = {pkss_test_normal(&rng), pkss_test_normal(&rng), pkss_test_normal(&rng)};
            float f[3] = {(float)v[0], (float)v[1], (float)v[2]};
            double x = f[0], y = f[1], z = f[2];
            double r = sqrt(x * x + y * y + z * z);
            double th = acos(z / r), ph = atan2(y, x);
            if (ph < 0)
                ph += 2 * 3.14159265358979323846;
            double ft = th / step, fp = ph / step;
            if (fabs(ft - floor(ft + 0.5)) < 1e-4 || fabs(fp - floor(fp + 0.5)) < 1e-4)
                continue; /* too close to an edge for the float comparison */
            int bt = (int)floor(ft), bp = (int)floor(fp) % n_az;
            int expect = n_az * bt + bp;
            int got = pkss_cell_index(f[0], f[1], f[2], n_az, e);
            if (got != expect)
                fail_msg("n_az %d: v = (%g, %g, %g): cell %d, expected %d", n_az, x, y, z,
                         got, expect);
            ++checked;
        }
    }
    printf("  %ld random directions agree with acos/atan2 binning\n", checked);
}

/* The representative of a cell is its farthest point from the centre (3-D
 * coordinates kept, first index on ties); empty cells are marked r^2 < 0. */
static void test_binning_representatives(void **state)
{
    (void)state;
    float e[PKSS_EDGES_SIZE];
    pkss__cell_edges(12, e);
    const float pts[] = {
        1, 0.1f, 0,   /* cell 36, r^2 = 1.01 */
        3, 0.2f, 0,   /* cell 36, farther: the representative */
        2, 0.1f, 0,   /* cell 36 */
        0, 0, 5,      /* north pole: cell 0 */
        0, 0, 0,      /* at the centre: skipped */
        -3, -0.2f, 0, /* phi just above 180: cell 42 */
    };
    const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    float reps[PKSS_MAX_CELLS * 4];
    pkss_bin_points(pts, 6, I, 0, 0, 0, 12, e, reps);
    assert_int_equal(pkss_count_occupied(reps, 72), 3);
    assert_float_equal(reps[4 * 36 + 0], 3.0f, 0);
    assert_float_equal(reps[4 * 36 + 1], 0.2f, 0);
    assert_float_equal(reps[4 * 0 + 2], 5.0f, 0);
    assert_float_equal(reps[4 * 42 + 0], -3.0f, 0);
    assert_true(reps[4 * 1 + 3] < 0);
    /* a centre offset moves the points relative to the centre */
    pkss_bin_points(pts, 6, I, 10, 0, 0, 12, e, reps);
    /* every point now lies at phi ~ 180 deg from the centre (10, 0, 0) */
    assert_true(reps[4 * 42 + 3] > 0 || reps[4 * 41 + 3] > 0);
    /* rotation: 90 degrees about z moves cell 36 (phi 0) to cell 39 */
    const float Rz[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    pkss_bin_points(pts, 3, Rz, 0, 0, 0, 12, e, reps);
    assert_true(reps[4 * 39 + 3] > 0);
    assert_int_equal(pkss_count_occupied(reps, 72), 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hand_checked_directions),
        cmocka_unit_test(test_matches_angle_definition),
        cmocka_unit_test(test_binning_representatives),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
