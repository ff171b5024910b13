/* SPDX-License-Identifier: MIT
 * test_search.c -- the shape measurement and the global search (SPEC 4-5):
 * G = 0 and the right pose for a cloud against its exactly rotated copy,
 * the candidate rotation sets (744 distinct Euler rotations, the azimuth
 * shift factorisation, the uniform set) and top-k selection.
 */
#include "support.h"

#include "pkss_internal.h"
#include "pkss_shared.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_search";
#define PI 3.14159265358979323846

static void test_euler_set_is_744_distinct(void **state)
{
    (void)state;
    pkss__params p;
    pkss__params_default(&p);
    pkss__rotation_set rs;
    assert_int_equal(pkss__rotations_build(&p, &rs), PKSS_OK);
    assert_int_equal(rs.n_rotations, 744);
    /* SPEC 5 counts 144 (= 12 x 12) binnings; keeping each distinct
     * rotation at its first triple needs only the (ix, iy) pairs used. */
    printf("  744 rotations from %zu source binnings (+ azimuth shifts)\n", rs.n_binnings);
    assert_true(rs.n_binnings <= 144);
    double min_gap = 10;
    for (size_t i = 0; i < rs.n_rotations; ++i)
        for (size_t j = i + 1; j < rs.n_rotations; ++j) {
            double a = pkss__rotation_angle(rs.R + 9 * i, rs.R + 9 * j);
            if (a < min_gap)
                min_gap = a;
        }
    printf("  744 Euler rotations, smallest pairwise angle %.2f deg\n", min_gap * 180 / PI);
    assert_true(min_gap > 1e-6);
    /* every one of the 1728 triples is one of the 744 */
    double step = 2 * PI / 12;
    for (int a = 0; a < 12; ++a)
        for (int b = 0; b < 12; ++b)
            for (int c = 0; c < 12; ++c) {
                double R[9];
                pkss__euler_zyx(a * step, b * step, c * step, R);
                int found = 0;
                for (size_t k = 0; k < rs.n_rotations && !found; ++k)
                    found = pkss__rotation_angle(R, rs.R + 9 * k) < 1e-6;
                assert_true(found);
            }
    /* factorisation: R = Rz(shift * 30 deg) * binning rotation */
    for (size_t k = 0; k < rs.n_rotations; ++k) {
        double ang = rs.shift[k] * 2 * PI / 12;
        double Rz[9] = {cos(ang), -sin(ang), 0, sin(ang), cos(ang), 0, 0, 0, 1};
        double B[9], RB[9];
        for (int e = 0; e < 9; ++e)
            B[e] = rs.bin_R[9 * rs.binning[k] + e];
        pkss__mat3_mul(Rz, B, RB);
        for (int e = 0; e < 9; ++e)
            assert_float_equal(RB[e], rs.R[9 * k + e], 1e-6);
    }
    pkss__rotations_free(&rs);
}

static void test_uniform_set_covers_so3(void **state)
{
    (void)state;
    pkss__params p;
    pkss__params_default(&p);
    p.rotation_set = PKSS_ROTATIONS_UNIFORM;
    p.rotation_count = 1728;
    pkss__rotation_set rs;
    assert_int_equal(pkss__rotations_build(&p, &rs), PKSS_OK);
    assert_int_equal(rs.n_rotations, 1728);
    /* covering radius: a random rotation's nearest set member */
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 11)};
    double worst = 0;
    for (int t = 0; t < 2000; ++t) {
        double R[9], best = 10;
        pkss_test_random_rotation(&rng, R);
        for (size_t k = 0; k < rs.n_rotations; ++k) {
            double a = pkss__rotation_angle(R, rs.R + 9 * k);
            if (a < best)
                best = a;
        }
        if (best > worst)
            worst = best;
        double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
        assert_float_equal(det, 1.0, 1e-9);
    }
    printf("  uniform set of 1728: covering radius (2000 probes) %.1f deg\n", worst * 180 / PI);
    /* 1728 points on SO(3) (volume pi^2): a covering radius near 15 deg */
    assert_true(worst * 180 / PI < 20.0);
    pkss__rotations_free(&rs);
}

/* Builds the pipeline's pre-shape cloud of a real scan. */
static pkss_cloud *load_cloud(pkss_context *ctx, const char *file, double **raw, size_t *n)
{
    *raw = pkss_test_load(file, n);
    assert_non_null(*raw); /* unreadable: reason printed */
    pkss_cloud *c = NULL;
    pkss_status st = pkss__cloud_build(ctx, *raw, *n, "test", &c);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    return c;
}

/* Template = R_k * source for a candidate rotation R_k of the grid: the
 * search finds k with G ~ 0, and the unrefined pose is R_k, scale 1. */
static void test_exact_rotated_copy(void **state)
{
    (void)state;
    pkss_context *ctx;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_PCA_PREALIGN, PKSS_SWITCH_OFF), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 1), PKSS_OK);
    double *raw;
    size_t n;
    pkss_cloud *src = load_cloud(ctx, "stanford_bunny/reconstruction/bun_zipper_res2.ply", &raw, &n);
    pkss__rotation_set rs;
    assert_int_equal(pkss__rotations_build(&ctx->params, &rs), PKSS_OK);
    const uint32_t picks[] = {5, 137, 401, 700};
    float edges[PKSS_EDGES_SIZE];
    pkss__cell_edges(12, edges);
    for (size_t t = 0; t < sizeof picks / sizeof picks[0]; ++t) {
        uint32_t k = picks[t];
        /* template points: R_k applied to the resampled pre-shape source */
        size_t m = src->m;
        float *sp = malloc(m * 3 * sizeof(float)), *tp = malloc(m * 3 * sizeof(float));
        for (size_t i = 0; i < m; ++i) {
            double y[3];
            pkss__mat3_apply(rs.R + 9 * k, src->pre + 3 * i, y);
            for (int d = 0; d < 3; ++d) {
                sp[3 * i + d] = (float)src->pre[3 * i + d];
                tp[3 * i + d] = (float)y[d];
            }
        }
        float offset[3] = {0, 0, 0};
        pkss__search_input in = {.n_az = 12, .edges = edges, .src_pts = sp, .n_src = (int)m,
                                 .src_feat = sp, .n_src_feat = 0, .tgt_pts = tp,
                                 .n_tgt = (int)m, .tgt_feat = tp, .n_tgt_feat = 0,
                                 .rot = &rs, .n_offsets = 1, .offsets = offset,
                                 .use_features = 0};
        float *scores = malloc(rs.n_rotations * sizeof(float));
        assert_int_equal(pkss__search_ref(ctx, &in, scores, NULL, NULL), PKSS_OK);
        size_t best = 0;
        for (size_t r = 1; r < rs.n_rotations; ++r)
            if (scores[r] < scores[best])
                best = r;
        printf("  template = R_%u * source: argmin %zu, G = %.2e\n", k, best, scores[best]);
        assert_int_equal(best, k);
        assert_true(scores[best] < 2e-3); /* acos(1 - float eps) ~ 5e-4 */
        free(sp);
        free(tp);
        free(scores);
    }
    /* Through the public API with refine off: the raw pose is R_k. */
    uint32_t k = 137;
    double *tgt = malloc(n * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i)
        pkss__mat3_apply(rs.R + 9 * k, raw + 3 * i, tgt + 3 * i);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_REFINE, PKSS_SWITCH_OFF), PKSS_OK);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    assert_int_equal(pkss_register(ctx, raw, n, tgt, n, &res), PKSS_OK);
    double ang = pkss__rotation_angle(res.rotation, rs.R + 9 * k) * 180 / PI;
    printf("  unrefined pose vs R_%u: %.4f deg, scale %.6f, G %.2e\n", k, ang, res.scale, res.score);
    assert_true(ang < 0.05);
    assert_float_equal(res.scale, 1.0, 1e-3);
    assert_true(res.score < 2e-3);
    free(tgt);
    pkss__rotations_free(&rs);
    pkss_cloud_destroy(src);
    free(raw);
    pkss_context_destroy(ctx);
}

/* The paper's raw (unrefined) accuracy is ~10 degrees: check the search
 * alone lands near arbitrary rotations. */
static void test_unrefined_search_accuracy(void **state)
{
    (void)state;
    pkss_context *ctx;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_REFINE, PKSS_SWITCH_OFF), PKSS_OK);
    size_t n;
    double *raw = pkss_test_load("modelnet40_pkss/airplane_0001_t.ply", &n);
    assert_non_null(raw); /* unreadable: reason printed */
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 21)};
    double *tgt = malloc(n * 3 * sizeof(double));
    double *src = malloc(n * 3 * sizeof(double));
    double errs[8];
    for (int t = 0; t < 8; ++t) {
        double T[16];
        pkss_test_random_similarity(&rng, 1.0, T);
        /* independent 70 % subsets: the representatives are not the same
         * points in both clouds */
        size_t ns = 0, nt = 0;
        for (size_t i = 0; i < n; ++i) {
            if (pkss_test_uniform(&rng) < 0.7)
                memcpy(src + 3 * ns++, raw + 3 * i, 3 * sizeof(double));
            if (pkss_test_uniform(&rng) < 0.7)
                memcpy(tgt + 3 * nt++, raw + 3 * i, 3 * sizeof(double));
        }
        pkss_test_apply(T, tgt, nt, tgt);
        pkss_result res;
        pkss_result_init(&res, sizeof res);
        assert_int_equal(pkss_register(ctx, src, ns, tgt, nt, &res), PKSS_OK);
        double at[3];
        pkss_test_centroid(raw, n, at);
        errs[t] = pkss_test_pose_error(res.T_target_source, T, at).rot_deg;
        double best_cand = 180;
        for (uint32_t c = 0; c < res.n_candidates; ++c) {
            double e = pkss_test_pose_error(pkss_test_candidate(ctx, c).T_target_source, T, at).rot_deg;
            if (e < best_cand)
                best_cand = e;
        }
        printf("  unrefined case %d: best-G rotation error %.2f deg, best of %u "
               "candidates %.2f deg\n", t, errs[t], res.n_candidates, best_cand);
        /* near-symmetric shapes can put the best G ~180 deg off, which is
         * why top-k candidates are kept; one of them must be right */
        assert_true(best_cand < 25.0); /* well inside the ICP basin */
    }
    int within = 0;
    for (int t = 0; t < 8; ++t)
        within += errs[t] < 15.0;
    assert_true(within >= 5);
    free(src);
    free(tgt);
    free(raw);
    pkss_context_destroy(ctx);
}

/* Top-k: sorted by G, guard values (pi/2) never kept, kept rotations at
 * least 45 degrees apart. */
static void test_top_k_selection(void **state)
{
    (void)state;
    pkss__params p;
    pkss__params_default(&p);
    pkss__rotation_set rs;
    assert_int_equal(pkss__rotations_build(&p, &rs), PKSS_OK);
    size_t n_off = 3, total = rs.n_rotations * n_off;
    float *scores = malloc(total * sizeof(float));
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 31)};
    for (size_t k = 0; k < total; ++k)
        scores[k] = (pkss_test_uniform(&rng) < 0.3) ? PKSS_HALF_PI_F
                                                     : (float)pkss_test_uniform(&rng);
    pkss__pick picks[PKSS_MAX_CANDIDATES];
    size_t kept = pkss__select_top_k(scores, scores, NULL, &rs, n_off, 10, picks);
    assert_int_equal(kept, 10);
    /* the global minimum is always first */
    size_t best = 0;
    for (size_t k = 1; k < total; ++k)
        if (scores[k] < scores[best])
            best = k;
    assert_int_equal(picks[0].rotation * n_off + picks[0].offset, best);
    for (size_t i = 0; i < kept; ++i) {
        assert_true(picks[i].score < PKSS_HALF_PI_F);
        if (i)
            assert_true(picks[i].score >= picks[i - 1].score);
        for (size_t j = 0; j < i; ++j)
            assert_true(pkss__rotation_angle(rs.R + 9 * picks[i].rotation,
                                             rs.R + 9 * picks[j].rotation) >= 45 * PI / 180);
    }
    /* all guarded: nothing to keep */
    for (size_t k = 0; k < total; ++k)
        scores[k] = PKSS_HALF_PI_F;
    assert_int_equal(pkss__select_top_k(scores, scores, NULL, &rs, n_off, 10, picks), 0);
    free(scores);
    pkss__rotations_free(&rs);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_euler_set_is_744_distinct),
        cmocka_unit_test(test_uniform_set_covers_so3),
        cmocka_unit_test(test_top_k_selection),
        cmocka_unit_test(test_exact_rotated_copy),
        cmocka_unit_test(test_unrefined_search_accuracy),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
