/* SPDX-License-Identifier: MIT
 * test_hostile.c -- the catalogue of hostile inputs to the C API: each row
 * is one input, the status it must get and a fragment its message must
 * hold. A row never crashes, hangs or returns a wrong pose as success; a
 * failed call leaves no pose behind. Rows marked (#21.N) are regressions
 * of the numbered items of issue #21. The second table is hostile files
 * through the readers (src/io, pkss_io.h; the fuzz corpus and format details are in
 * test_io.c).
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "pkss_internal.h"
#include "pkss_io.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const char *PROGRAM = "test_hostile";

/* The bundled sample pair, and scratch room for a modified copy. */
typedef struct fixture {
    double *s, *t, *x; /* source, target, scratch (n_s + 8 points) */
    size_t ns, nt;
    pkss_context *ctx;
    pkss_result res;
} fixture;

typedef pkss_status (*case_fn)(fixture *f);

typedef struct hostile {
    const char *name;
    case_fn run;
    pkss_status want;
    const char *fragment; /* in pkss_context_last_error(); "" = any */
} hostile;

static pkss_status reg(fixture *f, const double *s, size_t ns, const double *t, size_t nt)
{
    return pkss_register(f->ctx, s, ns, t, nt, &f->res);
}

/* the scratch copy of the source, n points */
static double *copy_source(fixture *f, size_t n)
{
    memcpy(f->x, f->s, (n < f->ns ? n : f->ns) * 3 * sizeof(double));
    return f->x;
}

/* ---------------------------------------------------------- pointers */
static pkss_status null_source(fixture *f) { return reg(f, NULL, f->ns, f->t, f->nt); }
static pkss_status null_target(fixture *f) { return reg(f, f->s, f->ns, NULL, f->nt); }
static pkss_status null_result(fixture *f)
{
    return pkss_register(f->ctx, f->s, f->ns, f->t, f->nt, NULL);
}
static pkss_status null_clouds(fixture *f)
{
    return pkss_register_clouds(f->ctx, NULL, NULL, &f->res);
}
static pkss_status null_cloud_out(fixture *f)
{
    return pkss_cloud_create(f->ctx, f->s, f->ns, NULL);
}
static pkss_status null_cloud_points(fixture *f)
{
    return pkss_cloud_create(f->ctx, NULL, 100, &(pkss_cloud *){NULL});
}

/* ------------------------------------------------------------- sizes */
static pkss_status empty_source(fixture *f) { return reg(f, f->s, 0, f->t, f->nt); }
static pkss_status empty_target(fixture *f) { return reg(f, f->s, f->ns, f->t, 0); }
static pkss_status ten_points(fixture *f) { return reg(f, f->s, 10, f->t, f->nt); }
static pkss_status huge_n(fixture *f) { return reg(f, f->s, SIZE_MAX / 2, f->t, f->nt); }
static pkss_status min_points_above_n(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_MIN_POINTS, 100000);
    return reg(f, f->s, f->ns, f->t, f->nt);
}
/* (#21.7) the smallest clouds: 32 vs 32 copies are refused, not guessed */
static pkss_status tiny_copies(fixture *f)
{
    double *x = copy_source(f, 32);
    return reg(f, x, 32, x, 32);
}
static pkss_status struct_size_zero(fixture *f)
{
    f->res.struct_size = 0;
    return reg(f, f->s, f->ns, f->t, f->nt);
}
static pkss_status struct_size_short(fixture *f)
{
    f->res.struct_size = PKSS_RESULT_MIN_SIZE - 8;
    return reg(f, f->s, f->ns, f->t, f->nt);
}

/* ------------------------------------------------------------ values */
static pkss_status set_point(fixture *f, size_t i, double x, double y, double z)
{
    double *p = copy_source(f, f->ns);
    p[3 * i] = x;
    p[3 * i + 1] = y;
    p[3 * i + 2] = z;
    return reg(f, p, f->ns, f->t, f->nt);
}
static pkss_status nan_point(fixture *f) { return set_point(f, 17, NAN, 0, 0); }
static pkss_status inf_point(fixture *f) { return set_point(f, 3, 0, INFINITY, 0); }
static pkss_status neg_inf_target(fixture *f)
{
    memcpy(f->x, f->t, 3 * sizeof(double) * (f->nt < f->ns ? f->nt : f->ns));
    f->x[3 * 5 + 2] = -INFINITY;
    return reg(f, f->s, f->ns, f->x, f->nt < f->ns ? f->nt : f->ns);
}
static pkss_status nan_dropped(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_DROP_NONFINITE, PKSS_SWITCH_ON);
    return set_point(f, 17, NAN, NAN, NAN);
}
static pkss_status all_nan_dropped(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_DROP_NONFINITE, PKSS_SWITCH_ON);
    for (size_t i = 0; i < 3 * f->ns; ++i)
        f->x[i] = NAN;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status identical(fixture *f)
{
    for (size_t i = 0; i < f->ns; ++i)
        for (int d = 0; d < 3; ++d)
            f->x[3 * i + d] = 1.5 + d;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status few_distinct(fixture *f)
{
    for (size_t i = 0; i < f->ns; ++i)
        memcpy(f->x + 3 * i, f->s + 3 * (i % 5), 3 * sizeof(double));
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status collinear(fixture *f)
{
    for (size_t i = 0; i < f->ns; ++i) {
        f->x[3 * i] = (double)i;
        f->x[3 * i + 1] = 2.0 * (double)i;
        f->x[3 * i + 2] = -1.0 * (double)i;
    }
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status coplanar(fixture *f)
{
    for (size_t i = 0; i < f->ns; ++i) {
        f->x[3 * i] = f->s[3 * i];
        f->x[3 * i + 1] = f->s[3 * i + 1];
        f->x[3 * i + 2] = 0.25 * f->s[3 * i] - 0.5 * f->s[3 * i + 1];
    }
    return reg(f, f->x, f->ns, f->t, f->nt);
}
/* (#21.2) the verdict names the shape of the bulk, not of a far point */
static pkss_status coplanar_and_far(fixture *f)
{
    coplanar(f);
    f->x[0] = 0;
    f->x[1] = 0;
    f->x[2] = 3e7;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status line_and_far(fixture *f)
{
    collinear(f);
    f->x[3 * 7 + 1] = -1e9;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
/* (#21.2) one or two far points do not reject an object */
static pkss_status far_point(fixture *f) { return set_point(f, 0, 3e7, 0, 0); }
static pkss_status flt_max_sentinel(fixture *f) { return set_point(f, 9, FLT_MAX, FLT_MAX, 0); }
static pkss_status two_far_points(fixture *f)
{
    double *p = copy_source(f, f->ns);
    p[0] = 3e7;
    p[3 * 50 + 2] = -2e8;
    return reg(f, p, f->ns, f->t, f->nt);
}
static pkss_status huge_coordinates(fixture *f) { return set_point(f, 4, 1e200, 0, 0); }
/* (#21.8) a lower range limit with its own message */
static pkss_status tiny_coordinates(fixture *f)
{
    for (size_t i = 0; i < 3 * f->ns; ++i)
        f->x[i] = f->s[i] * 1e-200;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status sub_precision_spread(fixture *f)
{
    for (size_t i = 0; i < 3 * f->ns; ++i)
        f->x[i] = 1e9 + f->s[i] * 1e-3;
    return reg(f, f->x, f->ns, f->t, f->nt);
}
static pkss_status exact_copies(fixture *f) { return reg(f, f->s, f->ns, f->s, f->ns); }
/* (#21.6) valid parameters that once kept 3 feature points */
static pkss_status few_feature_points(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_POINTS, 256);
    pkss_context_set_double(f->ctx, PKSS_PARAM_FEATURE_FRAC, 0.01);
    return reg(f, f->s, f->ns, f->s, f->ns);
}
static pkss_status thinned_input(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_MAX_RAW_POINTS, 1000);
    return reg(f, f->s, f->ns, f->t, f->nt);
}

/* -------------------------------------------------------- parameters */
static pkss_status unknown_param(fixture *f) { return pkss_context_set_int(f->ctx, 999, 1); }
static pkss_status points_low(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_POINTS, 100);
}
static pkss_status odd_rotation_steps(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_ROTATION_STEPS, 13);
}
static pkss_status even_offset_steps(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_OFFSET_STEPS, 4);
}
static pkss_status nan_param(fixture *f)
{
    return pkss_context_set_double(f->ctx, PKSS_PARAM_FEATURE_FRAC, NAN);
}
static pkss_status fractional_int(fixture *f)
{
    return pkss_context_set_double(f->ctx, PKSS_PARAM_TOP_K, 2.5);
}
static pkss_status string_on_numeric(fixture *f)
{
    return pkss_context_set_string(f->ctx, PKSS_PARAM_POINTS, "1000");
}
static pkss_status int_on_string(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_DEVICE, 1);
}
static pkss_status long_device(fixture *f)
{
    char s[301];
    memset(s, 'x', 300);
    s[300] = '\0';
    return pkss_context_set_string(f->ctx, PKSS_PARAM_DEVICE, s);
}
static pkss_status bad_backend(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_BACKEND, 5);
}
static pkss_status bad_switch(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_REFINE, 3);
}
static pkss_status negative_seed(fixture *f)
{
    return pkss_context_set_int(f->ctx, PKSS_PARAM_SEED, -1);
}
static pkss_status bad_reset(fixture *f) { return pkss_context_reset(f->ctx, (pkss_reset)9); }
static pkss_status param_index_out(fixture *f)
{
    (void)f;
    pkss_param_info info;
    pkss_param_info_init(&info, sizeof info);
    return pkss_param_at(pkss_param_count(), &info);
}
static pkss_status param_unknown_name(fixture *f)
{
    (void)f;
    pkss_param id;
    return pkss_param_find("pionts", &id);
}
static pkss_status candidate_before_any(fixture *f)
{
    pkss_candidate c;
    pkss_candidate_init(&c, sizeof c);
    return pkss_context_candidate(f->ctx, 0, &c);
}
static pkss_status cloud_points_capacity(fixture *f)
{
    pkss_cloud *c = NULL;
    pkss_status st = pkss_cloud_create(f->ctx, f->s, f->ns, &c);
    if (st != PKSS_OK)
        return st;
    st = pkss_cloud_points(c, f->x, 10);
    pkss_cloud_destroy(c);
    return st;
}

/* ----------------------------------------------------------- devices */
static pkss_status opencl_no_such_device(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_OPENCL);
    pkss_context_set_string(f->ctx, PKSS_PARAM_DEVICE, "garbage-device");
    return reg(f, f->s, f->ns, f->t, f->nt);
}
/* (#21.8) AUTO with a device string that matches nothing says so */
static pkss_status auto_no_such_device(fixture *f)
{
    pkss_context_set_int(f->ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_AUTO);
    pkss_context_set_string(f->ctx, PKSS_PARAM_DEVICE, "garbage-device");
    pkss_status st = reg(f, f->s, f->ns, f->t, f->nt);
    if (st == PKSS_OK && !(f->res.flags & PKSS_FLAG_FELL_BACK))
        return PKSS_ERR_INTERNAL;
    return st;
}

/* (#21.5) cancellation */
static int cancel_now(void *user, const pkss_progress *p)
{
    (void)user;
    return p->stage == PKSS_PROGRESS_SEARCH;
}
static pkss_status cancelled(fixture *f)
{
    pkss_context_set_progress(f->ctx, cancel_now, NULL);
    return reg(f, f->s, f->ns, f->t, f->nt);
}

/* (#21.9) a NULL context clears an earlier pose */
static pkss_status null_ctx_after_success(fixture *f)
{
    if (reg(f, f->s, f->ns, f->t, f->nt) != PKSS_OK)
        return PKSS_ERR_INTERNAL;
    pkss_status st = pkss_register(NULL, f->s, f->ns, f->t, f->nt, &f->res);
    if (f->res.n_candidates != 0 || f->res.T_target_source[15] != 0.0)
        return PKSS_ERR_INTERNAL;
    return st;
}

static const hostile CASES[] = {
    {"NULL source points", null_source, PKSS_ERR_NULL_ARGUMENT, "source points pointer is NULL"},
    {"NULL target points", null_target, PKSS_ERR_NULL_ARGUMENT, "target points pointer is NULL"},
    {"NULL result", null_result, PKSS_ERR_NULL_ARGUMENT, "result is NULL"},
    {"NULL clouds", null_clouds, PKSS_ERR_NULL_ARGUMENT, "source cloud is NULL"},
    {"NULL cloud out", null_cloud_out, PKSS_ERR_NULL_ARGUMENT, "out is NULL"},
    {"NULL cloud points", null_cloud_points, PKSS_ERR_NULL_ARGUMENT, "pointer is NULL"},
    {"empty source", empty_source, PKSS_ERR_EMPTY_INPUT, "source cloud is empty"},
    {"empty target", empty_target, PKSS_ERR_EMPTY_INPUT, "target cloud is empty"},
    {"ten points", ten_points, PKSS_ERR_TOO_FEW_POINTS, "at least"},
    {"n = SIZE_MAX / 2", huge_n, PKSS_ERR_INVALID_ARGUMENT, "too large"},
    {"min_points above n", min_points_above_n, PKSS_ERR_TOO_FEW_POINTS, "min_points"},
    {"(#21.7) 32 vs 32 copies", tiny_copies, PKSS_ERR_TOO_FEW_POINTS, "min_points"},
    {"struct_size 0", struct_size_zero, PKSS_ERR_INVALID_ARGUMENT, "pkss_result_init"},
    {"struct_size below 1.0", struct_size_short, PKSS_ERR_INVALID_ARGUMENT, "smaller than pkss_result 1.0"},
    {"NaN point", nan_point, PKSS_ERR_NONFINITE, "point 17"},
    {"Inf point", inf_point, PKSS_ERR_NONFINITE, "point 3"},
    {"-Inf target point", neg_inf_target, PKSS_ERR_NONFINITE, "target point 5"},
    {"NaN dropped", nan_dropped, PKSS_OK, ""},
    {"all NaN dropped", all_nan_dropped, PKSS_ERR_TOO_FEW_POINTS, "0 finite points"},
    {"identical points", identical, PKSS_ERR_DEGENERATE, "identical"},
    {"5 distinct points", few_distinct, PKSS_ERR_TOO_FEW_POINTS, "distinct"},
    {"collinear", collinear, PKSS_ERR_DEGENERATE, "collinear"},
    {"coplanar", coplanar, PKSS_ERR_DEGENERATE, "coplanar"},
    {"(#21.2) coplanar + far point", coplanar_and_far, PKSS_ERR_DEGENERATE, "1 far points left out) are coplanar"},
    {"(#21.2) line + far point", line_and_far, PKSS_ERR_DEGENERATE, "collinear"},
    {"(#21.2) object + point at 3e7", far_point, PKSS_OK, ""},
    {"(#21.2) object + FLT_MAX sentinel", flt_max_sentinel, PKSS_OK, ""},
    {"(#21.2) object + two far points", two_far_points, PKSS_OK, ""},
    {"coordinate 1e200", huge_coordinates, PKSS_ERR_OUT_OF_RANGE, "too large"},
    {"(#21.8) coordinates 1e-200", tiny_coordinates, PKSS_ERR_OUT_OF_RANGE, "too small"},
    {"sub-precision spread", sub_precision_spread, PKSS_ERR_DEGENERATE, "precision"},
    {"exact copies", exact_copies, PKSS_OK, ""},
    {"(#21.6) 256 points, feature_frac 0.01", few_feature_points, PKSS_OK, ""},
    {"thinned to max_raw_points", thinned_input, PKSS_OK, ""},
    {"unknown parameter", unknown_param, PKSS_ERR_UNKNOWN_PARAMETER, "999"},
    {"points below range", points_low, PKSS_ERR_INVALID_ARGUMENT, "[256, 20000]"},
    {"odd rotation_steps", odd_rotation_steps, PKSS_ERR_INVALID_ARGUMENT, "even"},
    {"even offset_steps", even_offset_steps, PKSS_ERR_INVALID_ARGUMENT, "odd"},
    {"NaN parameter", nan_param, PKSS_ERR_INVALID_ARGUMENT, "not finite"},
    {"fractional integer", fractional_int, PKSS_ERR_WRONG_PARAMETER_TYPE, "integer"},
    {"string on numeric", string_on_numeric, PKSS_ERR_WRONG_PARAMETER_TYPE, "numeric"},
    {"int on string", int_on_string, PKSS_ERR_WRONG_PARAMETER_TYPE, "string"},
    {"300-character device", long_device, PKSS_ERR_INVALID_ARGUMENT, "longer than 255"},
    {"backend 5", bad_backend, PKSS_ERR_INVALID_ARGUMENT, "backend"},
    {"switch 3", bad_switch, PKSS_ERR_INVALID_ARGUMENT, "switch"},
    {"negative seed", negative_seed, PKSS_ERR_INVALID_ARGUMENT, "seed"},
    {"reset 9", bad_reset, PKSS_ERR_INVALID_ARGUMENT, "must be 1, 2 or 3"},
    {"parameter index out of range", param_index_out, PKSS_ERR_INVALID_ARGUMENT, ""},
    {"parameter name misspelt", param_unknown_name, PKSS_ERR_UNKNOWN_PARAMETER, ""},
    {"candidate before any registration", candidate_before_any, PKSS_ERR_INVALID_ARGUMENT, ""},
    {"cloud points capacity 10", cloud_points_capacity, PKSS_ERR_INVALID_ARGUMENT, ""},
    {"OpenCL, no such device", opencl_no_such_device, PKSS_ERR_NO_DEVICE, "no OpenCL device"},
    {"(#21.8) AUTO, no such device", auto_no_such_device, PKSS_OK, ""},
    {"(#21.5) cancelled", cancelled, PKSS_ERR_CANCELLED, "cancelled by the progress callback"},
    {"(#21.9) NULL ctx after success", null_ctx_after_success, PKSS_ERR_NULL_ARGUMENT, ""},
};

static void test_catalogue(void **state)
{
    (void)state;
    fixture f = {0};
    f.s = pkss_test_load_bundled("airplane_0001_s.ply", &f.ns);
    f.t = pkss_test_load_bundled("airplane_0001_t.ply", &f.nt);
    assert_non_null(f.s);
    assert_non_null(f.t);
    f.x = malloc((f.ns + f.nt + 8) * 3 * sizeof(double));
    int failed = 0;
    size_t n = sizeof CASES / sizeof CASES[0];
    for (size_t i = 0; i < n; ++i) {
        const hostile *h = &CASES[i];
        assert_int_equal(pkss_context_create(&f.ctx), PKSS_OK);
        pkss_context_set_int(f.ctx, PKSS_PARAM_BACKEND, PKSS_BACKEND_REFERENCE);
        pkss_context_set_int(f.ctx, PKSS_PARAM_POINTS, 400);
        pkss_result_init(&f.res, sizeof f.res);
        pkss_status st = h->run(&f);
        const char *detail = pkss_context_last_error(f.ctx);
        int ok = st == h->want && strstr(detail, h->fragment) != NULL;
        /* a failed registration holds no pose */
        if (st != PKSS_OK && f.res.struct_size >= PKSS_RESULT_MIN_SIZE)
            ok = ok && f.res.T_target_source[15] == 0.0 && f.res.n_candidates == 0;
        printf("  %-3zu %-40s %-28s %s %s\n", i + 1, h->name, pkss_status_name(st),
               ok ? "ok  " : "FAIL", detail);
        if (!ok) {
            printf("      expected %s with \"%s\"\n", pkss_status_name(h->want), h->fragment);
            ++failed;
        }
        pkss_context_destroy(f.ctx);
    }
    printf("  %zu hostile inputs, %d failed\n", n, failed);
    assert_int_equal(failed, 0);
    free(f.s);
    free(f.t);
    free(f.x);
}

/* ------------------------------------------------------------- files */
typedef struct hostile_file {
    const char *name;
    const char *path;     /* read as it is when contents is NULL */
    const char *contents; /* else written to a temporary file first */
    size_t size;          /* of contents (0: strlen) */
    pkss_status want;
    const char *fragment;
} hostile_file;

#define PLY_HEAD(n, props) "ply\nformat ascii 1.0\nelement vertex " n "\n" props "end_header\n"
#define XYZ_PROPS "property float x\nproperty float y\nproperty float z\n"

static const hostile_file FILES[] = {
    {"(#21.1) /dev/zero", "/dev/zero", NULL, 0, PKSS_ERR_INVALID_ARGUMENT, "cannot tell the format"},
    {"(#21.1) /dev/zero as .ply", NULL, NULL, 0, PKSS_ERR_FORMAT, "not 'ply'"},
    {"(#21.1) /dev/urandom", "/dev/urandom", NULL, 0, PKSS_ERR_INVALID_ARGUMENT, "cannot tell the format"},
    {"(#21.1) 2 GB sparse .ply", NULL, NULL, 0, PKSS_ERR_FORMAT, "not 'ply'"},
    {"(#21.1) truncated binary PLY", NULL,
     "ply\nformat binary_little_endian 1.0\nelement vertex 100\n" XYZ_PROPS "end_header\n0123456789",
     0, PKSS_ERR_FORMAT, "truncated at byte"},
    {"(#21.11) duplicate property x", NULL,
     PLY_HEAD("1", "property float x\nproperty float x\nproperty float z\n") "1 2 3\n", 0,
     PKSS_ERR_FORMAT, "second property 'x'"},
    {"(#21.11) second vertex element", NULL,
     "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_PROPS "element vertex 1\n" XYZ_PROPS
     "end_header\n1 2 3\n4 5 6\n", 0, PKSS_ERR_FORMAT, "second 'vertex' element"},
    {"(#21.11) rows after the declared count", NULL,
     PLY_HEAD("2", XYZ_PROPS) "1 2 3\n4 5 6\n7 8 9\n", 0, PKSS_ERR_FORMAT,
     "data after the 2 vertices"},
    {"(#21.11) UTF-8 BOM before PLY", NULL, "\xEF\xBB\xBF" PLY_HEAD("1", XYZ_PROPS) "1 2 3\n", 0,
     PKSS_OK, ""},
    {"(#21.11) UTF-8 BOM before PCD", NULL,
     "\xEF\xBB\xBFVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
     "HEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n", 0, PKSS_OK, ""},
    {"(#21.11) UTF-8 BOM before OFF", NULL, "\xEF\xBB\xBFOFF\n1 0 0\n1 2 3\n", 0, PKSS_OK, ""},
    {"(#21.11) decimal commas, blanks", NULL, "0,5 1,5 2,5\n3,5 4,5 5,5\n", 0,
     PKSS_ERR_FORMAT, "decimal commas"},
    {"(#21.11) decimal commas, semicolons", NULL, "0,5;1,5;2,5\n3,5;4,5;5,5\n", 0,
     PKSS_ERR_FORMAT, "decimal commas"},
    {"NUL byte in a text file", NULL, "1 2 3\n4 5\0 6\n", 12, PKSS_ERR_FORMAT, "NUL byte"},
    {"empty file", NULL, "", 0, PKSS_ERR_EMPTY_INPUT, "empty"},
    {"/dev/zero as .npy", NULL, NULL, 0, PKSS_ERR_FORMAT, "no \\x93NUMPY magic"},
    {"/dev/zero as .npz", NULL, NULL, 0, PKSS_ERR_FORMAT, "no zip end-of-directory"},
    {"2 GB sparse .npy", NULL, NULL, 0, PKSS_ERR_FORMAT, "no \\x93NUMPY magic"},
    {"2 GB sparse .npz", NULL, NULL, 0, PKSS_ERR_FORMAT, "no zip end-of-directory"},
    {".npy header of 10^15 rows", NULL,
     "\x93NUMPY\x01\x00\x49\x00{'descr': '<f8', 'fortran_order': False, "
     "'shape': (1000000000000000, 3)}\n\0\0\0\0\0\0\0\0", 91, PKSS_ERR_FORMAT,
     "expected 1000000000000000 points"},
    {".npy header of 4 GB", NULL, "\x93NUMPY\x02\x00\xff\xff\xff\xff{", 13, PKSS_ERR_FORMAT,
     "at most 65536"},
    {"a directory", "/tmp", NULL, 0, PKSS_ERR_IO, ""},
    {"a missing file", "/nonexistent/cloud.ply", NULL, 0, PKSS_ERR_IO, "cannot open"},
};

static void test_files(void **state)
{
    (void)state;
    char dir[] = "/tmp/pkss_hostile_XXXXXX";
    assert_non_null(mkdtemp(dir));
    int failed = 0;
    size_t n = sizeof FILES / sizeof FILES[0];
    for (size_t i = 0; i < n; ++i) {
        const hostile_file *h = &FILES[i];
        char path[512];
        const char *ext = strstr(h->name, ".npy") ? "npy" : strstr(h->name, ".npz") ? "npz"
                        : strstr(h->name, "PCD") ? "pcd" : strstr(h->name, "OFF") ? "off"
                        : strstr(h->name, "decimal") || strstr(h->name, "NUL") ? "xyz" : "ply";
        snprintf(path, sizeof path, "%s/case%zu.%s", dir, i, ext);
        if (h->path) {
            snprintf(path, sizeof path, "%s", h->path);
        } else if (h->contents) {
            FILE *f = fopen(path, "wb");
            assert_non_null(f);
            fwrite(h->contents, 1, h->size ? h->size : strlen(h->contents), f);
            fclose(f);
        } else if (strstr(h->name, "sparse")) {
            FILE *f = fopen(path, "wb");
            assert_non_null(f);
            fclose(f);
            assert_int_equal(truncate(path, 2LL << 30), 0);
        } else { /* /dev/zero under a .ply name */
            assert_int_equal(symlink("/dev/zero", path), 0);
        }
        double *xyz = NULL;
        size_t np = 0;
        char err[1024] = "";
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        pkss_status st = pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &np, err, sizeof err);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double secs = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        int ok = st == h->want && strstr(err, h->fragment) != NULL && secs < 1.0;
        printf("  %-3zu %-40s %-22s %.3f s %s %s\n", i + 1, h->name, pkss_status_name(st), secs,
               ok ? "ok  " : "FAIL", err);
        if (!ok) {
            printf("      expected %s with \"%s\" in < 1 s\n", pkss_status_name(h->want),
                   h->fragment);
            ++failed;
        }
        pkss_points_free(xyz);
        if (!h->path)
            unlink(path);
    }
    rmdir(dir);
    printf("  %zu hostile files, %d failed\n", n, failed);
    assert_int_equal(failed, 0);
}

int main(void)
{
    pkss_test_seed(PROGRAM, 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_catalogue),
        cmocka_unit_test(test_files),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
