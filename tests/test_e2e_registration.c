/* SPDX-License-Identifier: MIT
 * test_e2e_registration.c -- PKSS-Align end to end on real scans from
 * ../shared/data under seeded random similarity transforms (SPEC 7), the
 * exact-similarity pairs shipped with the data, and the prepared-cloud API.
 *
 * Backend: PKSS_TEST_BACKEND=reference|opencl|auto (default reference), so
 * the same program checks every backend against the same bars.
 */
#include "support.h"

#include "refine/icp.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_e2e_registration";

static int test_backend(void)
{
    const char *b = getenv("PKSS_TEST_BACKEND");
    if (b && strcmp(b, "opencl") == 0)
        return PKSS_BACKEND_OPENCL;
    if (b && strcmp(b, "auto") == 0)
        return PKSS_BACKEND_AUTO;
    return PKSS_BACKEND_REFERENCE;
}

static pkss_context *make_context(void)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, test_backend()), PKSS_OK);
    pkss_status st = pkss_context_prepare(ctx);
    if (st == PKSS_ERR_NO_DEVICE) {
        print_message("SKIP: no OpenCL device: %s\n", pkss_context_last_error(ctx));
        pkss_context_destroy(ctx);
        skip();
    }
    assert_int_equal(st, PKSS_OK);
    return ctx;
}

/* Registers src onto tgt and returns the pose error against the ground
 * truth T (target = T * source), measured at the source's centroid; a
 * failed registration fails the test with `what` and the library's detail. */
static pkss_test_err register_and_score(pkss_context *ctx, const double *src,
                                        size_t ns, const double *tgt, size_t nt,
                                        const double T[16], pkss_result *res,
                                        const char *what)
{
    pkss_result_init(res, sizeof *res);
    pkss_status st = pkss_register(ctx, src, ns, tgt, nt, res);
    if (st != PKSS_OK)
        fail_msg("%s: %s: %s", what, pkss_status_name(st), pkss_context_last_error(ctx));
    double at[3];
    pkss_test_centroid(src, ns, at);
    return pkss_test_pose_error(res->T_target_source, T, at);
}

/* The strict bars of SPEC 7 (rotation in degrees; scale and translation
 * relative, the translation against `diameter`). */
#define STRICT_DEG 5.0
#define STRICT_REL 0.02

static int is_strict(pkss_test_err e, double diameter)
{
    return e.rot_deg < STRICT_DEG && e.scale_rel < STRICT_REL && e.trans / diameter < STRICT_REL;
}

/* The same bars, each its own assertion (a failure names the one missed). */
static void assert_strict(pkss_test_err e, double diameter)
{
    assert_true(e.rot_deg < STRICT_DEG);
    assert_true(e.scale_rel < STRICT_REL);
    assert_true(e.trans / diameter < STRICT_REL);
}

typedef struct e2e_stats {
    int cases, ok;
} e2e_stats;

static void run_random_cases(const char *file, int n_cases, uint64_t seed,
                             e2e_stats *stats)
{
    size_t n = 0;
    double *cloud = pkss_test_load(file, &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    double diameter = pkss_test_diameter(cloud, n);
    pkss_context *ctx = make_context();
    pkss_test_rng rng = {seed};
    for (int c = 0; c < n_cases; ++c) {
        size_t ns, nt;
        double *src, *tgt, T[16];
        pkss_test_similar_pair(&rng, cloud, n, 0.7, &src, &ns, &tgt, &nt, T);
        assert_non_null(src);
        assert_non_null(tgt);
        pkss_result res;
        char what[256];
        snprintf(what, sizeof what, "%s case %d", file, c);
        pkss_test_err e = register_and_score(ctx, src, ns, tgt, nt, T, &res, what);
        double s_gt, R_gt[9];
        pkss_test_decompose(T, &s_gt, R_gt);
        double trans_rel = e.trans / (diameter * s_gt);
        int ok = e.rot_deg < 2.0 && e.scale_rel < 0.01 && trans_rel < 0.01;
        printf("  %-48s case %2d: rot %7.3f deg  scale %7.4f %%  trans %7.4f %% of diameter  "
               "overlap %.3f  %.2f s  %s\n",
               file, c, e.rot_deg, 100 * e.scale_rel, 100 * trans_rel, res.overlap,
               res.timings.total, ok ? "ok" : "FAIL");
        stats->cases++;
        stats->ok += ok;
        free(src);
        free(tgt);
    }
    fflush(stdout);
    pkss_context_destroy(ctx);
    free(cloud);
}

/* At least 40 cases over four real objects/scans; >= 95 % must meet
 * rotation < 2 deg, scale < 1 %, translation < 1 % of the diameter. */
static void test_random_similarity_real_scans(void **state)
{
    (void)state;
    uint64_t seed = pkss_test_seed(PROGRAM, 20261122);
    static const char *files[] = {
        "stanford_bunny/reconstruction/bun_zipper_res2.ply",
        "stanford_dragon_stand/converted/dragonStandRight_0.ply",
        "modelnet40_pkss/airplane_0001_t.ply",
        "lidar_small_gicp/source.ply",
    };
    e2e_stats stats = {0, 0};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; ++f)
        run_random_cases(files[f], 10, seed + 1000 * f, &stats);
    double rate = (double)stats.ok / stats.cases;
    printf("  random similarity on real scans: %d / %d within bars (%.1f %%)\n",
           stats.ok, stats.cases, 100 * rate);
    assert_true(stats.cases >= 40);
    if (rate < 0.95)
        fail_msg("only %d of %d cases met the bars (need >= 95 %%); seed %llu",
                 stats.ok, stats.cases, (unsigned long long)seed);
}

static void register_pair_gt(const char *src_file, const char *tgt_file,
                             const char *gt_file, int shuffle, double max_rot_deg,
                             double max_scale_rel, double max_trans_rel)
{
    size_t ns, nt;
    double *src = pkss_test_load(src_file, &ns);
    assert_non_null(src); /* unreadable: reason printed */
    double *tgt = pkss_test_load(tgt_file, &nt);
    assert_non_null(tgt); /* unreadable: reason printed */
    double T[16];
    const char *gt_path = pkss_test_data_path(gt_file);
    assert_non_null(gt_path);
    assert_int_equal(pkss_test_read_matrix(gt_path, NULL, T), 0);
    if (shuffle) {
        pkss_test_rng rng = {pkss_test_seed(PROGRAM, 7)};
        pkss_test_shuffle(&rng, src, ns);
        pkss_test_shuffle(&rng, tgt, nt);
    }
    pkss_context *ctx = make_context();
    pkss_result res;
    pkss_test_err e = register_and_score(ctx, src, ns, tgt, nt, T, &res, src_file);
    double diameter = pkss_test_diameter(tgt, nt);
    printf("  %s -> %s: rot %.5f deg, scale %.5f %%, trans %.5f %% of diameter, "
           "overlap %.3f, %.2f s\n",
           src_file, tgt_file, e.rot_deg, 100 * e.scale_rel, 100 * e.trans / diameter,
           res.overlap, res.timings.total);
    fflush(stdout);
    assert_true(e.rot_deg < max_rot_deg);
    assert_true(e.scale_rel < max_scale_rel);
    assert_true(e.trans / diameter < max_trans_rel);
    pkss_context_destroy(ctx);
    free(src);
    free(tgt);
}

/* The ModelNet airplane pair is an exact similarity copy (rows shuffled
 * here): < 0.01 deg and < 0.01 % scale. */
static void test_airplane_exact_pair(void **state)
{
    (void)state;
    register_pair_gt("modelnet40_pkss/airplane_0001_s.ply",
                     "modelnet40_pkss/airplane_0001_t.ply",
                     "modelnet40_pkss/gt_similarity_s_to_t.txt", 1, 0.01, 1e-4, 1e-4);
}

/* The ETH car LiDAR scan and its exact scaled copy: density falls with
 * range, which a global kNN-distance outlier filter mistakes for outliers.
 * < 0.5 deg and < 0.5 % scale. */
static void test_car_lidar_scaled_pair(void **state)
{
    (void)state;
    register_pair_gt("libpointmatcher/car_cloud400.csv",
                     "libpointmatcher/car_cloud400_scaled.csv",
                     "libpointmatcher/car_cloud400_scaled_T.txt", 0, 0.5, 0.005, 0.005);
}

/* One template prepared once, many sources: the same answer as
 * pkss_register, and the cloud API reports its counts. */
static void test_prepared_cloud_reuse(void **state)
{
    (void)state;
    size_t n;
    double *cloud = pkss_test_load("stanford_bunny/reconstruction/bun_zipper_res2.ply", &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    pkss_context *ctx = make_context();
    pkss_cloud *tpl = NULL;
    assert_int_equal(pkss_cloud_create(ctx, cloud, n, &tpl), PKSS_OK);
    pkss_counts counts;
    assert_int_equal(pkss_cloud_counts(tpl, &counts), PKSS_OK);
    assert_int_equal(counts.input, n);
    assert_int_equal(counts.resampled, 3000);
    assert_int_equal(pkss_cloud_size(tpl), 3000);
    double *pts = malloc(3000 * 3 * sizeof(double));
    assert_int_equal(pkss_cloud_points(tpl, pts, 2999), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_cloud_points(tpl, pts, 3000), PKSS_OK);
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 99)};
    double diameter = pkss_test_diameter(cloud, n);
    for (int c = 0; c < 3; ++c) {
        double T[16];
        pkss_test_random_similarity(&rng, diameter, T);
        /* template = T * source  <=>  source = T^-1 * template */
        double Ti[16];
        pkss_test_inverse_similarity(T, Ti);
        double *src = malloc(n * 3 * sizeof(double));
        pkss_test_apply(Ti, cloud, n, src);
        pkss_cloud *sc = NULL;
        assert_int_equal(pkss_cloud_create(ctx, src, n, &sc), PKSS_OK);
        pkss_result a, b;
        pkss_result_init(&a, sizeof a);
        pkss_result_init(&b, sizeof b);
        assert_int_equal(pkss_register_clouds(ctx, sc, tpl, &a), PKSS_OK);
        assert_int_equal(pkss_register(ctx, src, n, cloud, n, &b), PKSS_OK);
        for (int i = 0; i < 16; ++i)
            assert_float_equal(a.T_target_source[i], b.T_target_source[i], 1e-9);
        double at[3];
        pkss_test_centroid(src, n, at);
        pkss_test_err e = pkss_test_pose_error(a.T_target_source, T, at);
        printf("  prepared template, source %d: rot %.4f deg scale %.4f %%\n", c,
               e.rot_deg, 100 * e.scale_rel);
        assert_true(e.rot_deg < 1.0);
        assert_true(e.scale_rel < 0.005);
        pkss_cloud_destroy(sc);
        free(src);
    }
    pkss_cloud_destroy(tpl);
    pkss_context_destroy(ctx);
    free(pts);
    free(cloud);
}

#define PARASAUROLOPHUS "uwa_opencv/parasaurolophus_6700.ply"
#define MILK "pcl/converted/milk.ply"
#define CHEF "pcl/converted/chef.ply"

/* Where a part is cut: around the extreme point along `axis` (max, or min
 * with from_min) or, with axis < 0, around the point `at` of the file. */
typedef struct part_cut {
    int axis, from_min;
    size_t at;
    double share; /* of the points, nearest that point, cut away */
} part_cut;

/* Which search the winner must come from (register.c). */
enum part_winner {
    ANY_SEARCH,   /* only the strict bars */
    WIDE_SEARCH,  /* the second search, on the wide grid */
    FIRST_ALONE   /* the first search, and no search for parts ran after it */
};

/* The cloud with the cut pc made (a copy of it when pc.share is 0). */
static double *cut_part(const double *cloud, size_t n, part_cut pc, size_t *n_part)
{
    if (pc.share == 0.0) {
        double *copy = malloc(3 * n * sizeof(double));
        assert_non_null(copy);
        memcpy(copy, cloud, 3 * n * sizeof(double));
        *n_part = n;
        return copy;
    }
    assert_true(pc.axis >= 0 || pc.at < n);
    size_t top = pc.axis >= 0 ? pkss_test_extreme(cloud, n, pc.axis, pc.from_min) : pc.at;
    double *part = pkss_test_cut_near(cloud, n, top, pc.share, n_part);
    assert_non_null(part);
    return part;
}

/* The object in `file` with the cut `pc` made, registered onto the object
 * with the cut `tc` made (none: share 0) under a fixed similarity: strict
 * success, and the winner from the search `from`. */
static void register_parts(const char *file, const char *name, part_cut pc,
                           part_cut tc, enum part_winner from)
{
    size_t n;
    double *cloud = pkss_test_load(file, &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    size_t n_part, n_whole;
    double *part = cut_part(cloud, n, pc, &n_part);
    double *whole = cut_part(cloud, n, tc, &n_whole);
    /* target = T * whole, T = 1.7 Rx(-60) Ry(25) Rz(40) + (0.3, -0.2, 0.5) d */
    const double deg = 3.14159265358979323846 / 180.0, ax = -60 * deg, ay = 25 * deg, az = 40 * deg;
    double Rx[16] = {1, 0, 0, 0, 0, cos(ax), -sin(ax), 0, 0, sin(ax), cos(ax), 0, 0, 0, 0, 1};
    double Ry[16] = {cos(ay), 0, sin(ay), 0, 0, 1, 0, 0, -sin(ay), 0, cos(ay), 0, 0, 0, 0, 1};
    double Rz[16] = {cos(az), -sin(az), 0, 0, sin(az), cos(az), 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    double Ryz[16], T[16];
    pkss_test_mul4(Ry, Rz, Ryz);
    pkss_test_mul4(Rx, Ryz, T);
    double d = pkss_test_diameter(cloud, n);
    const double t[3] = {0.3 * d, -0.2 * d, 0.5 * d};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            T[4 * r + c] *= 1.7;
        T[4 * r + 3] = t[r];
    }
    double *target = malloc(n_whole * 3 * sizeof(double));
    assert_non_null(target);
    pkss_test_apply(T, whole, n_whole, target);
    pkss_context *ctx = make_context();
    pkss_result res;
    pkss_test_err e = register_and_score(ctx, part, n_part, target, n_whole, T, &res, name);
    const pkss_candidate wc = pkss_test_candidate(ctx, res.winner), *w = &wc;
    char where[32];
    if (pc.axis >= 0)
        snprintf(where, sizeof where, "%s %c", pc.from_min ? "min" : "max", "xyz"[pc.axis]);
    else
        snprintf(where, sizeof where, "point %zu", pc.at);
    printf("  %s, %.0f %% nearest %s cut away (%.0f %% of the target): rot %.3f deg, "
           "scale %.3f %%, trans %.3f %% of diameter, overlap %.3f, fit %.3f, winner's "
           "offset %u of %u (%s grid), %llu evaluations\n",
           name, 100 * pc.share, where, 100 * tc.share, e.rot_deg, 100 * e.scale_rel,
           100 * e.trans / (1.7 * d), res.overlap, res.fit, w->offset_index, res.n_offsets,
           w->search ? "wide" : "paper", (unsigned long long)res.n_evaluations);
    fflush(stdout);
    assert_strict(e, 1.7 * d);
    if (from == WIDE_SEARCH) { /* found by the second search, on the wide grid */
        assert_int_equal(res.n_evaluations,
                         2 * (uint64_t)res.n_rotations * res.n_offsets);
        assert_int_equal(w->search, 1);
        assert_true(w->offset_index < res.n_offsets);
    }
    if (from == FIRST_ALONE) { /* in contact: neither the wide nor the local search ran */
        assert_int_equal(res.n_evaluations, (uint64_t)res.n_rotations * res.n_offsets);
        for (uint32_t c = 0; c < res.n_candidates; ++c) {
            pkss_candidate ci = pkss_test_candidate(ctx, c);
            assert_true(ci.search == 0 || ci.search == 2); /* first, or a shift of it */
        }
        assert_int_equal(w->search, 0);
    }
    pkss_context_destroy(ctx);
    free(target);
    free(whole);
    free(part);
    free(cloud);
}

/* The part pc registered onto the whole object. */
static void register_part(const char *file, const char *name, part_cut pc, int wide)
{
    register_parts(file, name, pc, (part_cut){0, 0, 0, 0.0},
                   wide ? WIDE_SEARCH : ANY_SEARCH);
}

/* A part of an object whose centroid lies beyond the reach of the paper's
 * offset grid (+-E/4 along the template's PCA axes, SPEC 5): half of it,
 * around the max-x point, cut away. The first search's winner covers
 * neither cloud; the second search, on the wide grid, finds the part.
 * (The 40 % cuts around the max-y and the max-x point, this test's and
 * test_part_rim_pairs_do_not_lead's cases until the source-side coverage
 * guard: that guard loses both, 121 and 172 degrees off. For the max-x
 * cut no rotation within 25 degrees of its truth ranks above 109th of 744
 * on the wide grid, behind pairings of 12-16 matched cells that pass the
 * guard with G 0.19. See PKSS_WIDE_SRC_COVER.) */
static void test_part_beyond_offset_grid(void **state)
{
    (void)state;
    register_part(PARASAUROLOPHUS, "parasaurolophus", (part_cut){0, 0, 0, 0.5}, 1);
}

/* Half of it cut away around point 1675 (of 6700): on the wide grid,
 * pairings that match only a few cells fit them almost perfectly under a
 * free rotation and held the top places; at c28b2fc the part ended 132.2
 * degrees off. The source-side coverage guard (PKSS_WIDE_SRC_COVER)
 * refuses them. */
static void test_part_among_few_cell_pairings(void **state)
{
    (void)state;
    register_part(PARASAUROLOPHUS, "parasaurolophus", (part_cut){-1, 0, 1675, 0.5}, 1);
}

/* Half of the chef, around its min-x point, cut away: the whole's points
 * beyond the part's rim pair with that rim and pulled a half turn ahead of
 * the truth in the first search. With the rigid stages' pairs beneath their
 * points (ICP_BENEATH) the first search places the part, in contact, and no
 * other search runs. */
static void test_part_rim_pairs_do_not_lead(void **state)
{
    (void)state;
    register_parts(CHEF, "chef", (part_cut){0, 1, 0, 0.5}, (part_cut){0, 0, 0, 0.0},
                   FIRST_ALONE);
}

/* A part of a box (one RGB-D view of a milk carton) 20-30 % too large at
 * the pre-shape scale ratio overhangs the whole on all sides and leaves
 * both coverages alike, so the asymmetry does not call for the scale
 * search; the search now runs wherever neither cloud is covered
 * (register.c, PKSS_PART_COVERED). At 3950e81: 3.9 degrees, scale 22.7 % off. */
static void test_part_too_large_at_preshape_scale(void **state)
{
    (void)state;
    register_part(MILK, "milk carton", (part_cut){1, 0, 0, 0.4}, 0);
}

/* A part of a box whose pose point-to-point pairs cannot pin down: on the
 * carton's flat faces they pull only through the rims, and both runs near
 * the truth stopped 4.5-6.6 % off in scale and 5.5-8.9 % of the diameter
 * along the box, where a pose turned 180 degrees outscored them (overlap
 * 0.81; at afaab15 it won, 179.6 degrees and 6.1 % off in scale). The
 * point-to-plane stage (icp.c) takes them to the truth (overlap 0.82). */
static void test_box_part_slides_on_its_faces(void **state)
{
    (void)state;
    register_part(MILK, "milk carton", (part_cut){1, 1, 0, 0.4}, 0);
}

/* Two parts of one object, 40 % of the chef cut away around its max-x
 * point and 30 % of the target around its max-y point: the first search's
 * winner lies on the target in contact (its overlapping points within the
 * fit distance, PKSS_CONTACT), so the searches for a part's place, the
 * wide grid and the local-shape starts, do not run. */
static void test_parts_in_contact_end_the_part_searches(void **state)
{
    (void)state;
    register_parts(CHEF, "chef", (part_cut){0, 0, 0, 0.4}, (part_cut){1, 0, 0, 0.3},
                   FIRST_ALONE);
}

/* A complete object, each side an independent 70 % subset (so no pose
 * fits exactly) under a fixed similarity: the first fully refined
 * candidate covers both clouds, and no other candidate gets a full
 * refinement after it (each is reported after its coarse level, or at the
 * search's pose; see register.c). Without that rule a second candidate of
 * the milk carton here ran its full refinement (60 rigid iterations and a
 * scale stage) before falling behind. */
static void complete_object_one_full_refinement(const char *file, const char *name,
                                                uint64_t seed)
{
    size_t n;
    double *cloud = pkss_test_load(file, &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    pkss_test_rng rng = {seed};
    size_t ns, nt;
    double *src, *tgt, T[16];
    pkss_test_similar_pair(&rng, cloud, n, 0.7, &src, &ns, &tgt, &nt, T);
    assert_non_null(src);
    assert_non_null(tgt);
    double d = pkss_test_diameter(cloud, n);
    pkss_context *ctx = make_context();
    pkss_result res;
    pkss_test_err e = register_and_score(ctx, src, ns, tgt, nt, T, &res, name);
    double s_gt, R_gt[9];
    pkss_test_decompose(T, &s_gt, R_gt);
    int n_full = 0, n_coarse = 0;
    for (uint32_t c = 0; c < res.n_candidates; ++c) {
        n_full += pkss_test_candidate(ctx, c).stage >= PKSS_STAGE_STOPPED;
        n_coarse += pkss_test_candidate(ctx, c).stage == PKSS_STAGE_COARSE;
    }
    printf("  %s, complete: rot %.3f deg, scale %.3f %%, trans %.3f %% of diameter, "
           "overlap %.3f; %u candidates: %d fully refined, %d coarse\n",
           name, e.rot_deg, 100 * e.scale_rel, 100 * e.trans / (d * s_gt), res.overlap,
           (unsigned)res.n_candidates, n_full, n_coarse);
    fflush(stdout);
    assert_strict(e, d * s_gt);
    assert_true(res.overlap >= 0.98);
    assert_int_equal(pkss_test_candidate(ctx, res.winner).stage, PKSS_STAGE_REFINED);
    assert_true(res.n_candidates >= 2);
    assert_int_equal(n_full, 1);
    for (uint32_t c = 0; c < res.n_candidates; ++c)
        if (c != res.winner)
            assert_true(pkss_test_candidate(ctx, c).stage == PKSS_STAGE_COARSE ||
                        pkss_test_candidate(ctx, c).stage == PKSS_STAGE_SEARCH);
    pkss_context_destroy(ctx);
    free(src);
    free(tgt);
    free(cloud);
}

static void test_complete_object_one_full_refinement(void **state)
{
    (void)state;
    uint64_t seed = pkss_test_seed(PROGRAM, 20261130);
    complete_object_one_full_refinement(MILK, "milk carton", seed);
    complete_object_one_full_refinement(CHEF, "chef", seed + 1);
}

/* A bundled pair: tests/data/<stem>_s.ply onto <stem>_t.ply, its truth
 * T_target_source in <stem>_T.txt (provenance in tests/data/README.md). */
typedef struct bundled_pair {
    double *src, *tgt, T[16];
    size_t ns, nt;
} bundled_pair;

static bundled_pair load_bundled_pair(const char *stem)
{
    bundled_pair p;
    char name[256];
    snprintf(name, sizeof name, "%s_s.ply", stem);
    p.src = pkss_test_load_bundled(name, &p.ns);
    snprintf(name, sizeof name, "%s_t.ply", stem);
    p.tgt = pkss_test_load_bundled(name, &p.nt);
    assert_non_null(p.src);
    assert_non_null(p.tgt);
    snprintf(name, sizeof name, PKSS_TEST_DATA_DIR "/%s_T.txt", stem);
    assert_int_equal(pkss_test_read_matrix(name, NULL, p.T), 0);
    return p;
}

static void free_bundled_pair(bundled_pair *p)
{
    free(p->src);
    free(p->tgt);
}

/* One registration of a bundled pair on a fresh context, scored against its
 * truth; the caller inspects ctx and res, then calls end_bundled_run. */
typedef struct bundled_run {
    bundled_pair p;
    pkss_context *ctx;
    pkss_result res;
    pkss_test_err e;
    double d;     /* the target's diameter */
    double at[3]; /* where pose errors are taken, as register_and_score does */
} bundled_run;

static void run_bundled(const char *stem, const char *label, bundled_run *r)
{
    r->p = load_bundled_pair(stem);
    r->d = pkss_test_diameter(r->p.tgt, r->p.nt);
    pkss_test_centroid(r->p.src, r->p.ns, r->at);
    r->ctx = make_context();
    r->e = register_and_score(r->ctx, r->p.src, r->p.ns, r->p.tgt, r->p.nt, r->p.T, &r->res,
                              label);
}

/* Whether candidate k of the run lies within the strict bars. */
static int candidate_strict(const bundled_run *r, const pkss_candidate *k)
{
    return is_strict(pkss_test_pose_error(k->T_target_source, r->p.T, r->at), r->d);
}

/* Whether a candidate of r's result whose origin is not in skip (a bit per
 * pkss_candidate.search) lies within the strict bars. */
static int any_candidate_strict(const bundled_run *r, unsigned skip)
{
    int right = 0;
    for (uint32_t c = 0; c < r->res.n_candidates; ++c) {
        const pkss_candidate k = pkss_test_candidate(r->ctx, c);
        if (!(skip & 1u << k.search))
            right |= candidate_strict(r, &k);
    }
    return right;
}

static void end_bundled_run(bundled_run *r)
{
    pkss_context_destroy(r->ctx);
    free_bundled_pair(&r->p);
}

/* partial/parasaurolophus/1 at base seed 4: no search cell fits it; the
 * local RANSAC's one right hypothesis has the least accepted evidence (8
 * inliers of 155 matches), which samples sized by that evidence
 * (local_match.c: sample_count) find for every seed. */
static void test_partial_pair_found_by_local_shape_for_every_seed(void **state)
{
    (void)state;
    bundled_pair p = load_bundled_pair("parasaurolophus_partial");
    const double d = pkss_test_diameter(p.tgt, p.nt);
    pkss_context *ctx = make_context();
    for (int seed = 1; seed <= 4; ++seed) {
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_SEED, seed), PKSS_OK);
        pkss_result res;
        pkss_test_err e =
            register_and_score(ctx, p.src, p.ns, p.tgt, p.nt, p.T, &res, "partial pair");
        const pkss_candidate w = pkss_test_candidate(ctx, res.winner);
        printf("  partial parasaurolophus, seed %d: rot %.3f deg, scale %.3f %%, trans %.3f "
               "%% of the target's diameter, winner from search %u\n",
               seed, e.rot_deg, 100 * e.scale_rel, 100 * e.trans / d, w.search);
        fflush(stdout);
        assert_strict(e, d);
        assert_int_equal(w.search, 3);
    }
    pkss_context_destroy(ctx);
    free_bundled_pair(&p);
}

/* partial/milk/0 at base seed 5: a half turn of the source part covers more
 * of the other part within 1 spacing than the truth does (fit 0.588 against
 * 0.522), but less of what it covers within 2 spacings lies that close (0.83
 * against 0.95). The winner is picked by merit, fit^2 / overlap (stages.c);
 * the half turn, which the fit alone would take, is listed as an
 * alternative. */
static void test_partial_pair_won_by_merit_not_fit(void **state)
{
    (void)state;
    bundled_run r;
    run_bundled("milk_partial", "milk parts", &r);
    const pkss_result *res = &r.res;
    /* a refined candidate with a higher fit and a lower merit */
    const pkss__icp_result won = {.fit = res->fit, .overlap = res->overlap};
    int looser = -1;
    for (uint32_t c = 0; c < res->n_candidates; ++c) {
        const pkss_candidate k = pkss_test_candidate(r.ctx, c);
        const pkss__icp_result as_k = {.fit = k.fit, .overlap = k.overlap};
        if (c != res->winner && k.stage == PKSS_STAGE_REFINED && k.fit > res->fit &&
            pkss__icp_merit(&as_k) < pkss__icp_merit(&won))
            looser = (int)c;
    }
    printf("  partial milk carton: rot %.3f deg, scale %.3f %%, trans %.3f %% of the target's "
           "diameter, fit %.4f within overlap %.4f; a looser candidate: %d; %u alternatives\n",
           r.e.rot_deg, 100 * r.e.scale_rel, 100 * r.e.trans / r.d, res->fit, res->overlap,
           looser, res->n_alternatives);
    fflush(stdout);
    assert_strict(r.e, r.d);
    assert_true(looser >= 0);
    assert_true(res->ambiguous && res->n_alternatives >= 1);
    end_bundled_run(&r);
}

/* The same family at base seed 6 (tests/data/README.md): the searches'
 * refined winner holds the source slid along the carton (2.3 deg, 19 % of
 * the target's diameter off), where it covers more of the target than at
 * the truth (overlap 0.62 against 0.54) at about the same fit. The shift
 * search's vote, a count of coverage, has no peak 5 % above the held
 * translation; its peaks draw 99-104 % of its votes, all are refined
 * (PKSS_SHIFT_SHARE), and the one that reaches the truth wins by merit. */
static void test_partial_pair_slid_back_by_the_shift_search(void **state)
{
    (void)state;
    bundled_run r;
    run_bundled("milk_slid", "milk slid", &r);
    const pkss_candidate w = pkss_test_candidate(r.ctx, r.res.winner);
    double widest = 0.0; /* the most covering refined candidate */
    for (uint32_t c = 0; c < r.res.n_candidates; ++c) {
        const pkss_candidate k = pkss_test_candidate(r.ctx, c);
        if (k.stage == PKSS_STAGE_REFINED)
            widest = fmax(widest, k.overlap);
    }
    printf("  slid milk carton: rot %.3f deg, scale %.3f %%, trans %.3f %% of the target's "
           "diameter; winner from search %u, overlap %.4f (the widest refined %.4f)\n",
           r.e.rot_deg, 100 * r.e.scale_rel, 100 * r.e.trans / r.d, w.search, r.res.overlap,
           widest);
    fflush(stdout);
    assert_strict(r.e, r.d);
    assert_int_equal(w.search, 2);
    assert_true(widest > r.res.overlap + 0.03);
    end_bundled_run(&r);
}

/* partial/car6/0 at held-out base seed 5 (tests/data/README.md), a LiDAR
 * car's side cut on both sides: every candidate of the searches at the
 * right rotation lies slid 24 % of the target's diameter along the car,
 * and the winner, 15 degrees off, lies astray (less than PKSS_ASTRAY of
 * its overlap within the fit distance). Its own shift search cannot turn
 * it; the one from the other candidates' rotations finds the truth. */
static void test_partial_pair_slid_back_from_another_rotation(void **state)
{
    (void)state;
    bundled_run r;
    run_bundled("car6_slid", "car slid", &r);
    const pkss_candidate w = pkss_test_candidate(r.ctx, r.res.winner);
    const unsigned shifts = 1u << 2 | 1u << 4;
    /* a candidate of the searches within the strict bars */
    const int searched_right = any_candidate_strict(&r, shifts);
    double lead = -1.0, lead_fit = 0.0, lead_overlap = 0.0; /* theirs by merit */
    for (uint32_t c = 0; c < r.res.n_candidates; ++c) {
        const pkss_candidate k = pkss_test_candidate(r.ctx, c);
        const pkss__icp_result as_k = {.fit = k.fit, .overlap = k.overlap};
        if (shifts & 1u << k.search)
            continue;
        if (k.stage == PKSS_STAGE_REFINED && pkss__icp_merit(&as_k) > lead) {
            lead = pkss__icp_merit(&as_k);
            lead_fit = k.fit;
            lead_overlap = k.overlap;
        }
    }
    printf("  slid car: rot %.3f deg, scale %.3f %%, trans %.3f %% of the target's diameter; "
           "winner from search %u; the searches' best merit %.4f (fit %.4f within overlap "
           "%.4f), any of theirs right: %d\n",
           r.e.rot_deg, 100 * r.e.scale_rel, 100 * r.e.trans / r.d, w.search, lead, lead_fit,
           lead_overlap, searched_right);
    fflush(stdout);
    assert_strict(r.e, r.d);
    assert_int_equal(w.search, 4);
    assert_false(searched_right);
    assert_true(lead_fit < PKSS_ASTRAY * lead_overlap);
    end_bundled_run(&r);
}

/* partial/milk/0 at base seed 1 (tests/data/README.md): the first search's
 * one refined candidate has the rotation right (0.9 deg) and the source's
 * part 24 % small, held in a corner of the other's faces, where it covers more
 * than at the truth (overlap 0.61 against 0.56) and reads as placed. Its
 * scale lies two sweep steps from the pre-shape ratio; a step's vote finds
 * the truth's translation. */
static void test_partial_pair_grown_back_by_the_scale_sweep(void **state)
{
    (void)state;
    bundled_run r;
    run_bundled("milk_shrunk", "milk shrunk", &r);
    const pkss_candidate w = pkss_test_candidate(r.ctx, r.res.winner);
    /* a candidate before the sweep within the strict bars */
    const int earlier_right = any_candidate_strict(&r, 1u << 5);
    printf("  shrunk milk carton: rot %.3f deg, scale %.3f %%, trans %.3f %% of the target's "
           "diameter; winner from search %u, overlap %.4f; any earlier candidate right: %d\n",
           r.e.rot_deg, 100 * r.e.scale_rel, 100 * r.e.trans / r.d, w.search, r.res.overlap,
           earlier_right);
    fflush(stdout);
    assert_strict(r.e, r.d);
    assert_int_equal(w.search, 5);
    assert_false(earlier_right);
    end_bundled_run(&r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_airplane_exact_pair),
        cmocka_unit_test(test_car_lidar_scaled_pair),
        cmocka_unit_test(test_prepared_cloud_reuse),
        cmocka_unit_test(test_random_similarity_real_scans),
        cmocka_unit_test(test_part_beyond_offset_grid),
        cmocka_unit_test(test_part_rim_pairs_do_not_lead),
        cmocka_unit_test(test_part_among_few_cell_pairings),
        cmocka_unit_test(test_part_too_large_at_preshape_scale),
        cmocka_unit_test(test_box_part_slides_on_its_faces),
        cmocka_unit_test(test_parts_in_contact_end_the_part_searches),
        cmocka_unit_test(test_partial_pair_found_by_local_shape_for_every_seed),
        cmocka_unit_test(test_partial_pair_won_by_merit_not_fit),
        cmocka_unit_test(test_partial_pair_slid_back_by_the_shift_search),
        cmocka_unit_test(test_partial_pair_slid_back_from_another_rotation),
        cmocka_unit_test(test_partial_pair_grown_back_by_the_scale_sweep),
        cmocka_unit_test(test_complete_object_one_full_refinement),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
