/* SPDX-License-Identifier: MIT
 * test_cl_nodevice.c -- a machine without any OpenCL platform: the ICD
 * loader (ocl-icd) is pointed at an empty vendor list before the first
 * OpenCL call (it caches platforms, hence a program of its own). Then the
 * device listing is empty, the reason says how to install PoCL,
 * PKSS_BACKEND_OPENCL fails with PKSS_ERR_NO_DEVICE, and PKSS_BACKEND_AUTO
 * (and PKSS_BACKEND_REFERENCE) still register on the reference backend.
 * ctest runs it a second time as test_cl_noloader, with
 * PKSS_OPENCL_LIBRARY=/nonexistent: a machine without the ICD loader
 * itself (libpkss dlopen()s it, src/device/cl_loader.c), where the same holds and
 * the reason names the loader.
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *PROGRAM = "test_cl_nodevice";

static void skip_if_no_opencl_build(void)
{
    unsigned count = 1;
    if (pkss_device_count(&count) == PKSS_ERR_UNSUPPORTED) {
        print_message("SKIP: built without OpenCL: %s\n", pkss_no_device_reason());
        skip();
    }
}

static void test_listing_is_empty(void **state)
{
    (void)state;
    skip_if_no_opencl_build();
    unsigned count = 99;
    assert_int_equal(pkss_device_count(&count), PKSS_OK);
    assert_int_equal(count, 0);
    pkss_device_desc d;
    assert_int_equal(pkss_device_info(0, &d), PKSS_ERR_INVALID_ARGUMENT);
    const char *why = pkss_no_device_reason();
    printf("  reason: %s\n", why);
    const char *lib = getenv("PKSS_OPENCL_LIBRARY");
    if (lib && lib[0]) {
        assert_non_null(strstr(why, "the OpenCL ICD loader (libOpenCL.so.1) could not "
                                    "be loaded: "));
        assert_non_null(strstr(why, lib)); /* dlerror() names the path */
        assert_non_null(strstr(why, "install ocl-icd-libopencl1 and pocl-opencl-icd"));
    } else {
        assert_non_null(strstr(why, "apt-get install pocl-opencl-icd ocl-icd-libopencl1"));
    }
    assert_non_null(strstr(why, "PKSS_BACKEND_REFERENCE"));
}

static void test_opencl_backend_fails(void **state)
{
    (void)state;
    skip_if_no_opencl_build();
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL),
                     PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_ERR_NO_DEVICE);
    const char *msg = pkss_context_last_error(ctx);
    printf("  PKSS_BACKEND_OPENCL: %s\n", msg);
    assert_non_null(strstr(msg, "pocl-opencl-icd"));
    assert_string_equal(pkss_context_device_name(ctx), "");
    /* an explicit device request says the same */
    assert_int_equal(pkss_context_set_string(ctx, PKSS_PARAM_DEVICE, "0"), PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_ERR_NO_DEVICE);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    size_t n;
    double *cloud = pkss_test_load_bundled("airplane_0001_t.ply", &n); /* never skips */
    assert_non_null(cloud); /* unreadable: reason printed */
    assert_int_equal(pkss_register(ctx, cloud, n, cloud, n, &res), PKSS_ERR_NO_DEVICE);
    assert_int_equal(res.n_candidates, 0);
    free(cloud);
    pkss_context_destroy(ctx);
}

static void register_with(int backend)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend), PKSS_OK);
    assert_int_equal(pkss_context_prepare(ctx), PKSS_OK);
    assert_string_equal(pkss_context_device_name(ctx), "reference (C, CPU)");
    size_t n;
    double *cloud = pkss_test_load_bundled("airplane_0001_t.ply", &n); /* never skips */
    assert_non_null(cloud); /* unreadable: reason printed */
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 5)};
    double T[16];
    pkss_test_random_similarity(&rng, pkss_test_diameter(cloud, n), T);
    double *tgt = malloc(n * 3 * sizeof(double));
    pkss_test_apply(T, cloud, n, tgt);
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_register(ctx, cloud, n, tgt, n, &res);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), pkss_context_last_error(ctx));
    assert_int_equal(res.backend, PKSS_BACKEND_REFERENCE);
    assert_string_equal(res.device, "reference (C, CPU)");
    double at[3];
    pkss_test_centroid(cloud, n, at);
    pkss_test_err e = pkss_test_pose_error(res.T_target_source, T, at);
    printf("  backend %d -> reference: rot %.4f deg, scale %.4f %%\n", backend, e.rot_deg,
           100 * e.scale_rel);
    assert_true(e.rot_deg < 1.0);
    assert_true(e.scale_rel < 0.005);
    free(tgt);
    free(cloud);
    pkss_context_destroy(ctx);
}

static void test_auto_falls_back(void **state)
{
    (void)state;
    register_with(PKSS_BACKEND_AUTO);
}

static void test_reference_works(void **state)
{
    (void)state;
    register_with(PKSS_BACKEND_REFERENCE);
}

int main(void)
{
    /* Before the first OpenCL call: ocl-icd reads its vendor list once. */
    setenv("OCL_ICD_VENDORS", "/nonexistent-pkss-test", 1);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_listing_is_empty),
        cmocka_unit_test(test_opencl_backend_fails),
        cmocka_unit_test(test_auto_falls_back),
        cmocka_unit_test(test_reference_works),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
