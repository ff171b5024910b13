/* SPDX-License-Identifier: MIT
 * test_cl_search.c -- the OpenCL backend (device.c, evaluate_cl.c,
 * kernels/search.cl) against the C reference (search_ref.c): every
 * candidate score (G_K, G_contour, G_feature of all rotation x offset
 * pairs) within SCORE_TOL and identical top-k lists, on real scans from
 * ../shared/data, for the Euler set, the uniform set, non-default
 * cell/rotation/offset steps, features off, the wide second search with the
 * trimmed measure, and the one-lane (GPU) kernel variant; device listing
 * and selection; error reporting. Skips with a reason when there is no
 * OpenCL device.
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "pkss_cl.h"
#include "pkss_internal.h"

#include <ctype.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_cl_search";

#ifdef PKSS_WITH_OPENCL
#include "search_fixture.h"

/* Kernel vs reference, absolute, radians (G is in [0, pi]). */
#define SCORE_TOL 1e-5

static uint64_t g_seed;

static pkss_context *opencl_context(void)
{
    pkss_test_need_device();
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL),
                     PKSS_OK);
    pkss_status st = pkss_context_prepare(ctx);
    if (st != PKSS_OK)
        fail_msg("prepare: %s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    assert_int_equal(ctx->backend_in_use, PKSS_BACKEND_OPENCL);
    return ctx;
}

typedef struct compare_stats {
    double max_diff;
    size_t pairs;
    size_t bit_equal;
} compare_stats;

/* Builds the search input of (a 70 % subset of) `file` against a random
 * similarity copy of another 70 % subset, on the paper's offset grid or
 * (wide) on the second search's wide grid with the trimmed measure, runs
 * both backends and compares every score and the top-k selection. */
static void compare_on(pkss_context *ctx, const char *file, uint64_t seed,
                       int wide, compare_stats *total)
{
    size_t n = 0;
    double *cloud = pkss_test_load(file, &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    pkss_test_rng rng = {seed};
    size_t ns, nt;
    double *src, *tgt, T[16];
    pkss_test_similar_pair(&rng, cloud, n, 0.7, &src, &ns, &tgt, &nt, T);
    assert_non_null(src);
    assert_non_null(tgt);

    search_fixture f;
    pkss_status st = search_fixture_build(ctx, src, ns, tgt, nt, &f);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    if (wide) {
        assert_int_equal(pkss__search_setup_widen(&ctx->params, f.tgt, &f.setup), PKSS_OK);
        assert_true(f.setup.in.keep < 1.0f);
        assert_true(f.setup.in.src_cover > 0.0f); /* both guards compared */
    }
    size_t total_pairs = f.setup.rot.n_rotations * (size_t)f.setup.n_offsets;
    float *ref = malloc(3 * total_pairs * sizeof(float));
    float *dev = malloc(3 * total_pairs * sizeof(float));
    assert_non_null(ref);
    assert_non_null(dev);
    /* poison: every entry must be written */
    for (size_t i = 0; i < 3 * total_pairs; ++i)
        dev[i] = NAN;
    assert_int_equal(pkss__search_ref(ctx, &f.setup.in, ref, ref + total_pairs,
                                      ref + 2 * total_pairs), PKSS_OK);
    st = pkss__search_cl(ctx, &f.setup.in, dev, dev + total_pairs, dev + 2 * total_pairs);
    if (st != PKSS_OK)
        fail_msg("pkss__search_cl: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));

    double max_diff = 0;
    size_t worst = 0, equal = 0, guarded = 0;
    for (size_t i = 0; i < 3 * total_pairs; ++i) {
        double d = fabs((double)ref[i] - (double)dev[i]);
        if (!(d <= max_diff)) { /* also catches NaN */
            max_diff = isnan(d) ? INFINITY : d;
            worst = i;
        }
        equal += memcmp(&ref[i], &dev[i], sizeof(float)) == 0;
        guarded += i < total_pairs && ref[i] == (float)(3.14159265358979323846 / 2);
    }
    printf("  %-52s %4zu rot x %3d off, cells %2d: max |diff| %.3g (%s[%zu]), "
           "%.2f %% bit-equal, %zu guarded\n",
           file, f.setup.rot.n_rotations, f.setup.n_offsets, f.setup.in.n_az, max_diff,
           worst < total_pairs ? "G_K" : worst < 2 * total_pairs ? "G_c" : "G_f",
           worst % total_pairs, 100.0 * equal / (3.0 * total_pairs), guarded);
    fflush(stdout);
    if (!(max_diff <= SCORE_TOL))
        fail_msg("%s: score %zu differs: reference %.9g, device %.9g (seed %llu)",
                 file, worst, ref[worst], dev[worst], (unsigned long long)g_seed);
    /* a search where every pair is guarded would test nothing */
    assert_true(guarded < total_pairs);

    int top_k = ctx->params.top_k;
    const float *gf_ref = f.setup.in.use_features ? ref + 2 * total_pairs : NULL;
    const float *gf_dev = f.setup.in.use_features ? dev + 2 * total_pairs : NULL;
    pkss__pick a[PKSS_MAX_CANDIDATES], b[PKSS_MAX_CANDIDATES];
    size_t ka = pkss__select_top_k(ref, ref + total_pairs, gf_ref, &f.setup.rot,
                                   (size_t)f.setup.n_offsets, (size_t)top_k, a);
    size_t kb = pkss__select_top_k(dev, dev + total_pairs, gf_dev, &f.setup.rot,
                                   (size_t)f.setup.n_offsets, (size_t)top_k, b);
    assert_int_equal(ka, kb);
    assert_true(ka > 0);
    for (size_t i = 0; i < ka; ++i) {
        if (a[i].rotation != b[i].rotation || a[i].offset != b[i].offset)
            fail_msg("%s: top-k entry %zu: reference (%u, %u) G %.9g, device "
                     "(%u, %u) G %.9g (seed %llu)",
                     file, i, a[i].rotation, a[i].offset, a[i].score,
                     b[i].rotation, b[i].offset, b[i].score,
                     (unsigned long long)g_seed);
        assert_true(fabs(a[i].score - b[i].score) <= SCORE_TOL);
    }
    if (total) {
        if (max_diff > total->max_diff)
            total->max_diff = max_diff;
        total->pairs += total_pairs;
        total->bit_equal += equal;
    }
    free(ref);
    free(dev);
    search_fixture_free(&f);
    free(src);
    free(tgt);
    free(cloud);
}

static const char *const REAL_SCANS[] = {
    "stanford_bunny/reconstruction/bun_zipper_res2.ply",
    "stanford_dragon_stand/converted/dragonStandRight_0.ply",
    "modelnet40_pkss/airplane_0001_t.ply",
    "lidar_small_gicp/source.ply",
};
#define N_SCANS (sizeof REAL_SCANS / sizeof REAL_SCANS[0])

/* ------------------------------------------------------------- listing */
static void test_device_listing(void **state)
{
    (void)state;
    pkss_test_need_device();
    unsigned count = 0;
    assert_int_equal(pkss_device_count(&count), PKSS_OK);
    assert_true(count >= 1);
    assert_int_equal(pkss_device_count(NULL), PKSS_ERR_NULL_ARGUMENT);
    for (unsigned i = 0; i < count; ++i) {
        pkss_device_desc d;
        assert_int_equal(pkss_device_info(i, &d), PKSS_OK);
        printf("  device %u: %s | %s | %s | %s | %s, fp64 %d, %u CUs, %.1f GiB\n", i,
               d.name, d.vendor, d.platform, d.version, d.is_gpu ? "GPU" : "not GPU",
               d.has_fp64, d.compute_units, d.global_mem_bytes / 1073741824.0);
        assert_true(d.name[0] && d.vendor[0] && d.platform[0] && d.version[0]);
        assert_true(strlen(d.name) < sizeof d.name);
        assert_true(d.compute_units >= 1);
        assert_true(d.global_mem_bytes > 0);
        assert_true(strncmp(d.version, "OpenCL ", 7) == 0);
    }
    pkss_device_desc d;
    assert_int_equal(pkss_device_info(count, &d), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_device_info(1000000u, &d), PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_device_info(0, NULL), PKSS_ERR_NULL_ARGUMENT);
    /* with devices present the reason says so, and is never NULL */
    assert_non_null(pkss_no_device_reason());
}

/* --------------------------------------------------------- selection */
static pkss_status prepare_with(const char *request, pkss_context **out)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL),
                     PKSS_OK);
    if (request)
        assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, request),
                         PKSS_OK);
    pkss_status st = pkss_context_prepare(ctx);
    *out = ctx;
    return st;
}

static void test_select_by_index_and_name(void **state)
{
    (void)state;
    pkss_test_need_device();
    unsetenv("PKSS_DEVICE");
    unsigned count = 0;
    assert_int_equal(pkss_device_count(&count), PKSS_OK);
    for (unsigned i = 0; i < count; ++i) {
        pkss_device_desc d;
        assert_int_equal(pkss_device_info(i, &d), PKSS_OK);
        char idx[16];
        snprintf(idx, sizeof idx, "%u", i);
        pkss_context *ctx;
        pkss_status st = prepare_with(idx, &ctx);
        if (st != PKSS_OK)
            fail_msg("device \"%s\": %s: %s", idx, pkss_status_name(st),
                     pkss_context_last_error(ctx));
        assert_string_equal(pkss_context_device_name(ctx), d.name);
        pkss_context_destroy(ctx);
    }
    /* by a name substring, in another case */
    pkss_device_desc d0;
    assert_int_equal(pkss_device_info(0, &d0), PKSS_OK);
    char sub[32];
    size_t len = strlen(d0.name) < 6 ? strlen(d0.name) : 6;
    for (size_t i = 0; i < len; ++i)
        sub[i] = (char)(isupper((unsigned char)d0.name[i])
                            ? tolower((unsigned char)d0.name[i])
                            : toupper((unsigned char)d0.name[i]));
    sub[len] = '\0';
    pkss_context *ctx;
    pkss_status st = prepare_with(sub, &ctx);
    if (st != PKSS_OK)
        fail_msg("device \"%s\": %s: %s", sub, pkss_status_name(st),
                 pkss_context_last_error(ctx));
    /* the first device whose name contains it */
    unsigned first = 0;
    for (unsigned i = 0; i < count; ++i) {
        pkss_device_desc d;
        assert_int_equal(pkss_device_info(i, &d), PKSS_OK);
        if (strncmp(d.name, d0.name, len) == 0) {
            first = i;
            break;
        }
    }
    pkss_device_desc df;
    assert_int_equal(pkss_device_info(first, &df), PKSS_OK);
    assert_string_equal(pkss_context_device_name(ctx), df.name);
    pkss_context_destroy(ctx);

    /* PKSS_DEVICE is used when the parameter is not set */
    setenv("PKSS_DEVICE", "0", 1);
    st = prepare_with(NULL, &ctx);
    assert_int_equal(st, PKSS_OK);
    assert_string_equal(pkss_context_device_name(ctx), d0.name);
    pkss_context_destroy(ctx);
    /* ... and the parameter wins over it */
    setenv("PKSS_DEVICE", "no-such-device-from-env", 1);
    st = prepare_with("0", &ctx);
    assert_int_equal(st, PKSS_OK);
    pkss_context_destroy(ctx);
    st = prepare_with(NULL, &ctx);
    assert_int_equal(st, PKSS_ERR_NO_DEVICE);
    printf("  PKSS_DEVICE=no-such-device-from-env: %s\n", pkss_context_last_error(ctx));
    assert_non_null(strstr(pkss_context_last_error(ctx), "PKSS_DEVICE"));
    assert_non_null(strstr(pkss_context_last_error(ctx), "no-such-device-from-env"));
    pkss_context_destroy(ctx);
    unsetenv("PKSS_DEVICE");

    /* no request, no variable: the first GPU, else the first CPU */
    st = prepare_with(NULL, &ctx);
    assert_int_equal(st, PKSS_OK);
    int expect = -1;
    for (unsigned i = 0; i < count && expect < 0; ++i) {
        pkss_device_desc d;
        assert_int_equal(pkss_device_info(i, &d), PKSS_OK);
        if (d.is_gpu)
            expect = (int)i;
    }
    if (expect >= 0) {
        pkss_device_desc d;
        assert_int_equal(pkss_device_info((unsigned)expect, &d), PKSS_OK);
        assert_string_equal(pkss_context_device_name(ctx), d.name);
    }
    printf("  default device: %s\n", pkss_context_device_name(ctx));
    pkss_context_destroy(ctx);
}

static void test_nonexistent_device(void **state)
{
    (void)state;
    pkss_test_need_device();
    unsetenv("PKSS_DEVICE");
    pkss_context *ctx;
    assert_int_equal(prepare_with("no-such-device-xyz", &ctx), PKSS_ERR_NO_DEVICE);
    const char *msg = pkss_context_last_error(ctx);
    printf("  %s\n", msg);
    assert_non_null(strstr(msg, "no-such-device-xyz"));
    assert_non_null(strstr(msg, "devices: 0: "));
    pkss_device_desc d0;
    assert_int_equal(pkss_device_info(0, &d0), PKSS_OK);
    assert_non_null(strstr(msg, d0.name));
    assert_string_equal(pkss_context_device_name(ctx), "");
    /* registration reports it too, and the context stays usable */
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    double pts[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    assert_int_equal(pkss_register(ctx, pts, 4, pts, 4, &res), PKSS_ERR_NO_DEVICE);
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, "0"), PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_OK);
    pkss_context_destroy(ctx);

    unsigned count = 0;
    assert_int_equal(pkss_device_count(&count), PKSS_OK);
    char idx[16];
    snprintf(idx, sizeof idx, "%u", count);
    assert_int_equal(prepare_with(idx, &ctx), PKSS_ERR_NO_DEVICE);
    assert_non_null(strstr(pkss_context_last_error(ctx), idx));
    pkss_context_destroy(ctx);
}

/* ------------------------------------------------------------ errors */
static void test_error_reporting(void **state)
{
    (void)state;
    pkss_test_need_device();
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    /* release without a device is a no-op */
    pkss__cl_release(ctx);
    pkss__cl_release(NULL);
    assert_int_equal(pkss__cl_fail(ctx, CL_OUT_OF_RESOURCES,
                                   "clEnqueueNDRangeKernel(q, k, 1, NULL, &global, &local, 0, NULL, NULL)"),
                     PKSS_ERR_DEVICE);
    assert_string_equal(pkss_context_last_error(ctx),
                        "clEnqueueNDRangeKernel: CL_OUT_OF_RESOURCES (-5)");
    assert_string_equal(pkss__cl_error_name(-1001), "CL_PLATFORM_NOT_FOUND_KHR");
    assert_string_equal(pkss__cl_error_name(12345), "CL_UNKNOWN_ERROR");
    pkss_context_destroy(ctx);

    /* a kernel build failure: PKSS_ERR_KERNEL_BUILD with the build log, also
     * under BACKEND_AUTO (a broken build is not "no device") */
    setenv("PKSS_CL_BUILD_OPTIONS", "-Dpkss_score_lanes=(", 1);
    for (int backend = PKSS_BACKEND_AUTO; backend <= PKSS_BACKEND_OPENCL; backend += 2) {
        assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend), PKSS_OK);
        assert_int_equal(pkss_context_prepare(ctx), PKSS_ERR_KERNEL_BUILD);
        const char *msg = pkss_context_last_error(ctx);
        assert_true(strlen(msg) < PKSS_DETAIL_SIZE);
        assert_non_null(strstr(msg, "clBuildProgram"));
        assert_non_null(strstr(msg, "error"));
        if (backend == PKSS_BACKEND_OPENCL)
            printf("  build failure detail (%zu bytes): %.200s...\n", strlen(msg), msg);
        pkss_context_destroy(ctx);
    }
    unsetenv("PKSS_CL_BUILD_OPTIONS");

    setenv("PKSS_CL_VECTOR_WIDTH", "3", 1);
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL),
                     PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(pkss_context_last_error(ctx), "PKSS_CL_VECTOR_WIDTH"));
    pkss_context_destroy(ctx);
    unsetenv("PKSS_CL_VECTOR_WIDTH");

    /* prepare, release (by a parameter change), prepare again */
    ctx = opencl_context();
    assert_non_null(ctx->dev);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE),
                     PKSS_OK);
    assert_null(ctx->dev);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL),
                     PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_OK);
    assert_int_equal(pkss_context_reset(ctx, PKSS_RESET_DEVICE), PKSS_OK);
    assert_null(ctx->dev);
    pkss_context_destroy(ctx);
}

/* ----------------------------------------------------------- scores */
/* compare_on over every scan in REAL_SCANS, with a summary line. */
static void compare_all_scans(const char *label, uint64_t seed, int wide)
{
    pkss_context *ctx = opencl_context();
    compare_stats s = {0, 0, 0};
    for (size_t i = 0; i < N_SCANS; ++i)
        compare_on(ctx, REAL_SCANS[i], seed + 17 * i, wide, &s);
    printf("  %s, %zu pairs x 3 scores: max |diff| %.3g, %.2f %% bit-equal\n", label,
           s.pairs, s.max_diff, 100.0 * s.bit_equal / (3.0 * s.pairs));
    pkss_context_destroy(ctx);
}

static void test_scores_real_scans_default(void **state)
{
    (void)state;
    compare_all_scans("default search", g_seed, 0);
}

static void test_scores_uniform_rotations(void **state)
{
    (void)state;
    pkss_context *ctx = opencl_context();
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_SET, PKSS_ROTATIONS_UNIFORM),
                     PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_COUNT, 1000), PKSS_OK);
    compare_on(ctx, REAL_SCANS[0], g_seed + 101, 0, NULL);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_COUNT, 300), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 3), PKSS_OK);
    compare_on(ctx, REAL_SCANS[3], g_seed + 102, 0, NULL);
    pkss_context_destroy(ctx);
}

/* The wide second search (register.c): the wide grid, the trimmed
 * measure, whose bisection and second fit the kernel must run as the
 * reference does (within SCORE_TOL, with the same top-k), and the
 * source-side coverage guard, which refuses the same pairs on both. */
static void test_scores_trimmed_wide_grid(void **state)
{
    (void)state;
    compare_all_scans("wide trimmed search", g_seed + 400, 1);
}

/* Finer and coarser partitions, other grids, features off, a template of
 * fewer points than a lane group: buffers grow and are reused on one
 * context. */
static void test_scores_other_steps(void **state)
{
    (void)state;
    pkss_context *ctx = opencl_context();
    static const struct {
        int cells, rot, off, points, features;
    } combos[] = {
        {24, 8, 3, 0, 1},   /* finer cells than rotation steps */
        {16, 16, 1, 1000, 1},/* no translation search, fewer points */
        {12, 12, 5, 0, 2},  /* features off */
        {48, 4, 3, 256, 1}, /* the largest partition, smallest m */
        {8, 12, 7, 0, 1},   /* coarser cells: no shift factorisation */
    };
    for (size_t i = 0; i < sizeof combos / sizeof combos[0]; ++i) {
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_CELL_STEPS, combos[i].cells), PKSS_OK);
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_STEPS, combos[i].rot), PKSS_OK);
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, combos[i].off), PKSS_OK);
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_POINTS, combos[i].points), PKSS_OK);
        assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_USE_FEATURES, combos[i].features), PKSS_OK);
        compare_on(ctx, REAL_SCANS[i % N_SCANS], g_seed + 200 + i, 0, NULL);
    }
    pkss_context_destroy(ctx);
}

/* The one-lane kernels that GPUs run, here on the CPU device. */
static void test_scores_one_lane_variant(void **state)
{
    (void)state;
    pkss_test_need_device();
    setenv("PKSS_CL_VECTOR_WIDTH", "1", 1);
    pkss_context *ctx = opencl_context();
    unsetenv("PKSS_CL_VECTOR_WIDTH");
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 3), PKSS_OK);
    compare_on(ctx, REAL_SCANS[2], g_seed + 300, 0, NULL);
    compare_on(ctx, REAL_SCANS[0], g_seed + 301, 1, NULL);
    pkss_context_destroy(ctx);
}

/* pkss_register through the OpenCL backend reports it. */
static void test_register_reports_device(void **state)
{
    (void)state;
    pkss_context *ctx = opencl_context();
    size_t n;
    double *cloud = pkss_test_load(REAL_SCANS[2], &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    pkss_test_rng rng = {g_seed + 400};
    double T[16];
    pkss_test_random_similarity(&rng, pkss_test_diameter(cloud, n), T);
    double *tgt = malloc(n * 3 * sizeof(double));
    pkss_test_apply(T, cloud, n, tgt);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_register(ctx, cloud, n, tgt, n, &res);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    assert_int_equal(res.backend, PKSS_BACKEND_OPENCL);
    assert_string_equal(res.device, pkss_context_device_name(ctx));
    double at[3];
    pkss_test_centroid(cloud, n, at);
    pkss_test_err e = pkss_test_pose_error(res.T_target_source, T, at);
    printf("  register on %s: rot %.4f deg, scale %.4f %%, search %.3f s, total %.3f s\n",
           res.device, e.rot_deg, 100 * e.scale_rel, res.timings.search, res.timings.total);
    assert_true(e.rot_deg < 1.0);
    free(tgt);
    free(cloud);
    pkss_context_destroy(ctx);
}

/* ----------------------------------------------------------- threads */
/* Device listing from many threads at once, and one context per thread
 * searching concurrently: each thread's scores equal the reference's. */
typedef struct thread_job {
    const search_fixture *f;
    const float *ref;
    size_t total;
    int listings_ok;
    double max_diff;
    pkss_status st;
} thread_job;

static void *thread_main(void *arg)
{
    thread_job *job = arg;
    job->listings_ok = 1;
    for (int i = 0; i < 20; ++i) {
        unsigned count = 0;
        pkss_device_desc d;
        if (pkss_device_count(&count) != PKSS_OK || count == 0 ||
            pkss_device_info(0, &d) != PKSS_OK || !d.name[0])
            job->listings_ok = 0;
    }
    pkss_context *ctx = NULL;
    job->st = pkss_context_create(&ctx);
    if (job->st == PKSS_OK)
        job->st = pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL);
    if (job->st == PKSS_OK)
        job->st = pkss_context_prepare(ctx);
    float *dev = malloc(3 * job->total * sizeof(float));
    for (int rep = 0; rep < 3 && job->st == PKSS_OK && dev; ++rep) {
        job->st = pkss__search_cl(ctx, &job->f->setup.in, dev, dev + job->total,
                                  dev + 2 * job->total);
        for (size_t i = 0; job->st == PKSS_OK && i < 3 * job->total; ++i) {
            double d = fabs((double)dev[i] - (double)job->ref[i]);
            if (!(d <= job->max_diff))
                job->max_diff = isnan(d) ? INFINITY : d;
        }
    }
    free(dev);
    pkss_context_destroy(ctx);
    return NULL;
}

static void test_threads(void **state)
{
    (void)state;
    pkss_context *ctx = opencl_context();
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 3), PKSS_OK);
    size_t n;
    double *cloud = pkss_test_load(REAL_SCANS[0], &n);
    assert_non_null(cloud); /* unreadable: reason printed */
    search_fixture f;
    assert_int_equal(search_fixture_build(ctx, cloud, n, cloud, n, &f), PKSS_OK);
    size_t total = f.setup.rot.n_rotations * (size_t)f.setup.n_offsets;
    float *ref = malloc(3 * total * sizeof(float));
    assert_int_equal(pkss__search_ref(ctx, &f.setup.in, ref, ref + total, ref + 2 * total), PKSS_OK);
    enum { N_THREADS = 4 };
    pthread_t th[N_THREADS];
    thread_job job[N_THREADS];
    for (int i = 0; i < N_THREADS; ++i) {
        job[i] = (thread_job){&f, ref, total, 0, 0.0, PKSS_OK};
        assert_int_equal(pthread_create(&th[i], NULL, thread_main, &job[i]), 0);
    }
    for (int i = 0; i < N_THREADS; ++i) {
        assert_int_equal(pthread_join(th[i], NULL), 0);
        printf("  thread %d: %s, listings %s, max |diff| %.3g\n", i,
               pkss_status_name(job[i].st), job[i].listings_ok ? "ok" : "FAILED",
               job[i].max_diff);
        assert_int_equal(job[i].st, PKSS_OK);
        assert_true(job[i].listings_ok);
        assert_true(job[i].max_diff <= SCORE_TOL);
    }
    free(ref);
    search_fixture_free(&f);
    free(cloud);
    pkss_context_destroy(ctx);
}

#endif /* PKSS_WITH_OPENCL */

#ifndef PKSS_WITH_OPENCL
static void test_built_without_opencl(void **state)
{
    (void)state;
    print_message("SKIP: pkss was built without OpenCL: %s\n", pkss_no_device_reason());
    skip();
}
#endif

int main(void)
{
#ifndef PKSS_WITH_OPENCL
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_built_without_opencl)};
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
#else
    g_seed = pkss_test_seed(PROGRAM, 20261122);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_device_listing),
        cmocka_unit_test(test_select_by_index_and_name),
        cmocka_unit_test(test_nonexistent_device),
        cmocka_unit_test(test_error_reporting),
        cmocka_unit_test(test_scores_real_scans_default),
        cmocka_unit_test(test_scores_uniform_rotations),
        cmocka_unit_test(test_scores_other_steps),
        cmocka_unit_test(test_scores_trimmed_wide_grid),
        cmocka_unit_test(test_scores_one_lane_variant),
        cmocka_unit_test(test_register_reports_device),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
#endif
}
