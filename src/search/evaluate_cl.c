/* SPDX-License-Identifier: MIT
 * evaluate_cl.c -- the OpenCL backend of the global search (SPEC 5): the
 * context's device state, the program built once per context (the kernels
 * in kernels/, behind kernels/pkss_shared.h, embedded at build time), device buffers
 * sized once and grown only when a larger problem arrives, and the three
 * launches of one search:
 *   bin_source   -- kernels/search.cl: one work-item per source binning
 *                   rotation and cloud kind (contour, feature)
 *   bin_template -- one work-item per template offset and cloud kind
 *   score_pairs  -- one work-item per (rotation, PKSS_VW offsets): G_contour,
 *                   G_feature and G_K = max (SPEC 4.5), one pair per lane
 * The scores come back to the host, where pkss__select_top_k (search_ref.c)
 * keeps the candidates, as for the reference backend.
 */
#include "pkss_cl.h"

#ifdef PKSS_WITH_OPENCL

#include "pkss_shared.h"
#include "device/program_cache.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern const char pkss__kernel_source[];
extern const size_t pkss__kernel_source_size;

/* Lanes per work-item (PKSS_VW in kernels/pkss_shared.h) and work-group
 * sizes (src/tuning.h) are chosen in one place, group_shape(). The environment variable
 * PKSS_CL_VECTOR_WIDTH (1, 2, 4, 8 or 16) overrides the lanes, e.g. to
 * test the GPU code path on a CPU. */

typedef struct cl_buf {
    cl_mem mem;
    size_t bytes;
} cl_buf;

enum {
    B_EDGES,
    B_SRC_PTS,     /* contour points then feature points */
    B_TGT_PTS,
    B_BIN_R,       /* n_binnings x 9 */
    B_ROT_INFO,    /* n_rotations x 2 int: binning, shift */
    B_OFFSETS,     /* n_offsets x 3 */
    B_SRC_TAB,     /* kinds x n_binnings rep tables */
    B_SRC_OCC,     /* kinds x n_binnings occupied-cell counts */
    B_TGT_TAB,     /* kinds x n_offsets rep tables */
    B_TGT_OCC,     /* kinds x n_offsets occupied-cell counts */
    B_SCORES,      /* 3 x n_rotations x n_offsets: G_K, G_c, G_f */
    B_COUNT
};

struct pkss__device {
    cl_platform_id platform;
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    cl_kernel k_bin_source, k_bin_template, k_score;
    int vw;                    /* lanes per work-item (PKSS_VW) */
    cl_ulong max_alloc;        /* CL_DEVICE_MAX_MEM_ALLOC_SIZE */
    size_t wg_bin, wg_score;
    cl_buf buf[B_COUNT];
    float *stage;              /* host staging of the SoA points, grown */
    size_t stage_floats;
    double last_bin_s, last_score_s; /* device time of the last search */
    pkss__cache_outcome cache_outcome; /* of the last program build */
    char cache_note[512];
};

/* ------------------------------------------------------------ release */
static void release_program(struct pkss__device *d)
{
    PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_source);
    PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_template);
    PKSS_CL_RELEASE(clReleaseKernel, d->k_score);
    PKSS_CL_RELEASE(clReleaseProgram, d->program);
}

void pkss__cl_release(pkss_context *ctx)
{
    if (!ctx || !ctx->dev)
        return;
    struct pkss__device *d = ctx->dev;
    if (d->queue)
        (void)clFinish(d->queue);
    for (int i = 0; i < B_COUNT; ++i)
        PKSS_CL_RELEASE(clReleaseMemObject, d->buf[i].mem);
    release_program(d);
    PKSS_CL_RELEASE(clReleaseCommandQueue, d->queue);
    PKSS_CL_RELEASE(clReleaseContext, d->context);
    pkss__free(d->stage);
    pkss__free(d);
    ctx->dev = NULL;
}

/* ------------------------------------------------------------ prepare */
/* Copies the build log into the detail: its head (where the first error
 * is) and, if it is long, its tail, so that it fits PKSS_DETAIL_SIZE. */
static pkss_status build_failure(pkss_context *ctx, struct pkss__device *d,
                                 cl_int err, const char *options)
{
    size_t size = 0;
    char *log = NULL;
    if (clGetProgramBuildInfo(d->program, d->device, CL_PROGRAM_BUILD_LOG, 0,
                              NULL, &size) == CL_SUCCESS && size > 0) {
        log = pkss__malloc(size + 1);
        if (log && clGetProgramBuildInfo(d->program, d->device,
                                         CL_PROGRAM_BUILD_LOG, size, log,
                                         NULL) != CL_SUCCESS)
            log[0] = '\0';
        if (log)
            log[size] = '\0';
    }
    const char *text = log ? log : "(no build log)";
    size_t len = strlen(text);
    const size_t room = 2800; /* of the 4 KiB detail, for the log */
    pkss_status st;
    if (len <= room)
        st = pkss__fail(ctx, PKSS_ERR_KERNEL_BUILD,
                        "clBuildProgram: %s (%d) with options \"%s\"; build "
                        "log:\n%s",
                        pkss__cl_error_name(err), (int)err, options, text);
    else
        st = pkss__fail(ctx, PKSS_ERR_KERNEL_BUILD,
                        "clBuildProgram: %s (%d) with options \"%s\"; build "
                        "log (%zu bytes, middle cut):\n%.*s\n[...]\n%s",
                        pkss__cl_error_name(err), (int)err, options, len,
                        (int)(room / 2), text, text + len - room / 2);
    pkss__free(log);
    return st;
}

static size_t kernel_wg_limit(cl_kernel k, cl_device_id dev, size_t want)
{
    size_t lim = 0;
    if (clGetKernelWorkGroupInfo(k, dev, CL_KERNEL_WORK_GROUP_SIZE,
                                 sizeof lim, &lim, NULL) != CL_SUCCESS ||
        lim == 0)
        return want;
    return lim < want ? lim : want;
}

/* The build options: correctly rounded float division and sqrt make the
 * kernels compute what the C reference computes (SPEC 4; only devices that
 * report the capability accept the option; FP contraction is off by the
 * pragma in pkss_shared.h), the lanes and group sizes as -D defines, and
 * the user's PKSS_CL_BUILD_OPTIONS last. */
static void program_options(const struct pkss__device *d, char *out,
                            size_t size)
{
    cl_device_fp_config fp = 0;
    (void)clGetDeviceInfo(d->device, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp,
                          &fp, NULL);
    const char *user = getenv("PKSS_CL_BUILD_OPTIONS");
    snprintf(out, size,
             "%s -DPKSS_VW=%d -DPKSS_WG_SCORE=%zu -DPKSS_WG_BIN=%zu %s",
             (fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT)
                 ? "-cl-fp32-correctly-rounded-divide-sqrt" : "",
             d->vw, d->wg_score, d->wg_bin, user ? user : "");
}

static pkss_status build_from_source(pkss_context *ctx,
                                     struct pkss__device *d,
                                     const char *options)
{
    pkss_status st = PKSS_OK;
    cl_int err;
    const char *sources[1] = {pkss__kernel_source};
    size_t lengths[1] = {pkss__kernel_source_size};
    d->program = clCreateProgramWithSource(d->context, 1, sources, lengths,
                                           &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateProgramWithSource");
    err = clBuildProgram(d->program, 1, &d->device, options, NULL, NULL);
    if (err == CL_COMPILER_NOT_AVAILABLE)
        return pkss__fail(ctx, PKSS_ERR_UNSUPPORTED,
                          "the device '%s' has no OpenCL C compiler "
                          "(clBuildProgram: CL_COMPILER_NOT_AVAILABLE)",
                          ctx->device_name);
    if (err == CL_BUILD_PROGRAM_FAILURE || err == CL_INVALID_BUILD_OPTIONS)
        return build_failure(ctx, d, err, options);
    PKSS_CL_CHECK_ERR(ctx, err, "clBuildProgram");
cleanup:
    return st;
}

/* Builds the embedded program for d->device -- from the program cache
 * (program_cache.c) when it holds a valid entry, else from source, then
 * stored there -- and creates the kernels. */
static pkss_status build_program(pkss_context *ctx, struct pkss__device *d)
{
    pkss_status st = PKSS_OK;
    cl_int err;
    char options[1024];
    program_options(d, options, sizeof options);
    pkss__cache_key key;
    pkss__cache_key_init(&key, d->platform, d->device, options,
                         pkss__kernel_source, pkss__kernel_source_size);
    d->program = pkss__cache_load(&key, d->context, d->device, options);
    if (!d->program) {
        st = build_from_source(ctx, d, options);
        if (st != PKSS_OK)
            return st;
        pkss__cache_store(&key, d->program);
    }
    d->cache_outcome = key.outcome;
    snprintf(d->cache_note, sizeof d->cache_note, "%s", key.note);
    d->k_bin_source = clCreateKernel(d->program, "bin_source", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(bin_source)");
    d->k_bin_template = clCreateKernel(d->program, "bin_template", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(bin_template)");
    d->k_score = clCreateKernel(d->program, "score_pairs", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(score_pairs)");
cleanup:
    return st;
}

/* Required capabilities, checked here and not mid-run (STYLE 11). */
static pkss_status check_device(pkss_context *ctx, struct pkss__device *d,
                                size_t *max_wg, cl_device_type *type)
{
    pkss_status st = PKSS_OK;
    cl_bool avail = CL_FALSE, compiler = CL_FALSE;
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_AVAILABLE,
                                       sizeof avail, &avail, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_COMPILER_AVAILABLE,
                                       sizeof compiler, &compiler, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_MAX_WORK_GROUP_SIZE,
                                       sizeof *max_wg, max_wg, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_MAX_MEM_ALLOC_SIZE,
                                       sizeof d->max_alloc, &d->max_alloc, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_TYPE, sizeof *type,
                                       type, NULL));
    if (!avail || !compiler)
        st = pkss__fail(ctx, PKSS_ERR_UNSUPPORTED,
                        "OpenCL device '%s' is %s", ctx->device_name,
                        !avail ? "not available" : "without a compiler");
cleanup:
    return st;
}

/* The one place lanes and work-group sizes are chosen per device type.
 * CPUs (PoCL): 16 float lanes per work-item (one AVX-512 or two AVX2
 * registers; PoCL does not vectorise across work-items of kernels with
 * inner loops) and groups of 8 (a group runs on one core; PoCL crawls
 * without an explicit local size). GPUs and accelerators: one lane, groups
 * of 128 (scoring) and 64 (binning), multiples of every SIMT width in use
 * (32, 64); fit_groups() then lowers them to the kernels' limits and to a
 * multiple of the preferred multiple the driver reports. */
static pkss_status group_shape(pkss_context *ctx, struct pkss__device *d,
                               cl_device_type type, size_t max_wg)
{
    int cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
    size_t want_s = cpu ? PKSS_WG_SCORE_CPU : PKSS_WG_SCORE_GPU;
    size_t want_b = cpu ? PKSS_WG_BIN_CPU : PKSS_WG_BIN_GPU;
    d->vw = cpu ? PKSS_VW_CPU : 1;
    const char *vw_env = getenv("PKSS_CL_VECTOR_WIDTH");
    if (vw_env && vw_env[0]) {
        int v = atoi(vw_env);
        PKSS_RETURN_IF(v != 1 && v != 2 && v != 4 && v != 8 && v != 16, ctx,
                       PKSS_ERR_INVALID_ARGUMENT,
                       "PKSS_CL_VECTOR_WIDTH='%s': must be 1, 2, 4, 8 or 16",
                       vw_env);
        d->vw = v;
    }
    d->wg_score = max_wg < want_s ? max_wg : want_s;
    d->wg_bin = max_wg < want_b ? max_wg : want_b;
    return PKSS_OK;
}

/* A group size within the kernel's limit and, on a GPU, a multiple of the
 * kernel's preferred multiple when that leaves at least one multiple. */
static size_t fitted_group(cl_kernel k, cl_device_id dev, size_t want,
                           int gpu)
{
    size_t lim = kernel_wg_limit(k, dev, want), pref = 0;
    if (gpu && clGetKernelWorkGroupInfo(
                   k, dev, CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE,
                   sizeof pref, &pref, NULL) == CL_SUCCESS &&
        pref > 0 && lim >= pref)
        lim -= lim % pref;
    return lim;
}

/* A device may allow smaller groups for these kernels than in general
 * (register pressure on GPUs): then rebuild once with the fitted sizes. */
static pkss_status fit_groups(pkss_context *ctx, struct pkss__device *d,
                              cl_device_type type)
{
    int gpu = (type & CL_DEVICE_TYPE_CPU) == 0;
    size_t lim_s = fitted_group(d->k_score, d->device, d->wg_score, gpu);
    size_t lim_b = fitted_group(d->k_bin_source, d->device, d->wg_bin, gpu);
    lim_b = fitted_group(d->k_bin_template, d->device, lim_b, gpu);
    if (lim_s == d->wg_score && lim_b == d->wg_bin)
        return PKSS_OK;
    d->wg_score = lim_s;
    d->wg_bin = lim_b;
    release_program(d);
    return build_program(ctx, d);
}

/* A cache that could not be used, or an entry that had to be rebuilt, is
 * said in the detail of the successful call (it never fails one). */
static void note_cache(pkss_context *ctx, const struct pkss__device *d)
{
    if (d->cache_outcome == PKSS__CACHE_UNWRITABLE ||
        d->cache_outcome == PKSS__CACHE_REBUILT)
        snprintf(ctx->detail, sizeof ctx->detail, "%s", d->cache_note);
}

pkss_status pkss__cl_prepare(pkss_context *ctx)
{
    pkss_status st = PKSS_OK;
    cl_int err;
    pkss__cl_release(ctx);
    struct pkss__device *d = pkss__calloc(1, sizeof *d);
    PKSS_RETURN_IF(!d, ctx, PKSS_ERR_OUT_OF_MEMORY,
                   "out of memory for the OpenCL device state");
    ctx->dev = d;
    size_t max_wg = 0;
    cl_device_type type = 0;
    if ((st = pkss__cl_select(ctx, &d->platform, &d->device)) != PKSS_OK ||
        (st = check_device(ctx, d, &max_wg, &type)) != PKSS_OK ||
        (st = group_shape(ctx, d, type, max_wg)) != PKSS_OK)
        goto cleanup;
    d->context = clCreateContext(NULL, 1, &d->device, NULL, NULL, &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateContext");
    /* Profiling gives the per-stage device times (pkss__cl_stage_seconds)
     * at the cost of two timestamps per launch. */
    d->queue = clCreateCommandQueue(d->context, d->device,
                                    CL_QUEUE_PROFILING_ENABLE, &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateCommandQueue");
    if ((st = build_program(ctx, d)) != PKSS_OK ||
        (st = fit_groups(ctx, d, type)) != PKSS_OK)
        goto cleanup;
    note_cache(ctx, d);
    return PKSS_OK;

cleanup:
    /* the detail stays; what was made is released */
    pkss__cl_release(ctx);
    ctx->device_name[0] = '\0';
    return st;
}

pkss__cache_outcome pkss__cl_cache_outcome(const pkss_context *ctx,
                                           const char **note)
{
    const struct pkss__device *d = ctx ? ctx->dev : NULL;
    if (note)
        *note = d ? d->cache_note : "";
    return d ? d->cache_outcome : PKSS__CACHE_NONE;
}

/* ------------------------------------------------------------- search */
/* Makes buffer i at least `bytes` large (grown, never shrunk; the old
 * contents are not kept). */
static pkss_status ensure(pkss_context *ctx, struct pkss__device *d, int i,
                          size_t bytes, cl_mem_flags flags)
{
    pkss_status st = PKSS_OK;
    cl_int err;
    if (bytes == 0)
        bytes = 16;
    if (d->buf[i].mem && d->buf[i].bytes >= bytes)
        return PKSS_OK;
    PKSS_RETURN_IF(d->max_alloc && bytes > d->max_alloc, ctx,
                   PKSS_ERR_OUT_OF_MEMORY,
                   "the search needs a %.1f MiB device buffer; '%s' allows %.1f "
                   "MiB per buffer (fewer rotations, offsets or cells fit)",
                   bytes / 1048576.0, ctx->device_name,
                   (double)d->max_alloc / 1048576.0);
    PKSS_CL_RELEASE(clReleaseMemObject, d->buf[i].mem);
    d->buf[i].bytes = 0;
    /* grow with headroom so that slightly larger problems reuse it */
    size_t want = bytes + bytes / 4;
    if (d->max_alloc && want > d->max_alloc)
        want = (size_t)d->max_alloc;
    d->buf[i].mem = clCreateBuffer(d->context, flags, want, NULL, &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateBuffer");
    d->buf[i].bytes = want;
cleanup:
    return st;
}

static size_t round_up(size_t n, size_t m) { return (n + m - 1) / m * m; }

/* Copies n points (float[n][3]) into SoA blocks x[pad] y[pad] z[pad]
 * (padding lanes zero) at out. */
static void to_soa(const float *pts, size_t n, size_t pad, float *out)
{
    for (size_t d = 0; d < 3; ++d) {
        float *col = out + d * pad;
        for (size_t i = 0; i < n; ++i)
            col[i] = pts[3 * i + d];
        for (size_t i = n; i < pad; ++i)
            col[i] = 0.0f;
    }
}

static double event_seconds(cl_event first, cl_event last)
{
    cl_ulong t0 = 0, t1 = 0;
    if (clGetEventProfilingInfo(first, CL_PROFILING_COMMAND_START, sizeof t0,
                                &t0, NULL) != CL_SUCCESS ||
        clGetEventProfilingInfo(last, CL_PROFILING_COMMAND_END, sizeof t1, &t1,
                                NULL) != CL_SUCCESS || t1 < t0)
        return 0.0;
    return (double)(t1 - t0) * 1e-9;
}

void pkss__cl_stage_seconds(const pkss_context *ctx, double *binning,
                            double *scoring)
{
    const struct pkss__device *d = ctx ? ctx->dev : NULL;
    if (binning)
        *binning = d ? d->last_bin_s : 0.0;
    if (scoring)
        *scoring = d ? d->last_score_s : 0.0;
}

/* The sizes of one search, derived once from its input. */
typedef struct search_dims {
    cl_int n_az, n_bin, n_rot, n_off, n_off_pad, kinds;
    cl_int n_src, n_tgt, n_src_feat, n_tgt_feat;
    cl_int pad_src, pad_tgt, pad_src_feat, pad_tgt_feat;
    size_t table;              /* floats of one rep table */
    size_t total;              /* rotation x offset pairs */
    size_t src_floats, tgt_floats;
} search_dims;

static pkss_status search_dims_of(pkss_context *ctx, const pkss__search_input *in,
                                  size_t vw, search_dims *s)
{
    const pkss__rotation_set *rot = in->rot;
    s->n_az = in->n_az;
    s->table = (size_t)s->n_az * (size_t)(s->n_az / 2) * 4;
    s->n_bin = (cl_int)rot->n_binnings;
    s->n_rot = (cl_int)rot->n_rotations;
    s->n_off = in->n_offsets;
    s->n_off_pad = (cl_int)round_up((size_t)s->n_off, vw);
    s->kinds = in->use_features ? 2 : 1;
    s->n_src = in->n_src;
    s->n_tgt = in->n_tgt;
    s->n_src_feat = in->use_features ? in->n_src_feat : 0;
    s->n_tgt_feat = in->use_features ? in->n_tgt_feat : 0;
    s->pad_src = (cl_int)round_up((size_t)s->n_src, vw);
    s->pad_tgt = (cl_int)round_up((size_t)s->n_tgt, vw);
    s->pad_src_feat = (cl_int)round_up((size_t)s->n_src_feat, vw);
    s->pad_tgt_feat = (cl_int)round_up((size_t)s->n_tgt_feat, vw);
    s->total = (size_t)s->n_rot * (size_t)s->n_off;
    s->src_floats = 3 * (size_t)(s->pad_src + s->pad_src_feat);
    s->tgt_floats = 3 * (size_t)(s->pad_tgt + s->pad_tgt_feat);
    PKSS_RETURN_IF(s->n_az > PKSS_MAX_AZ || s->n_az < 4 || s->n_off < 1 ||
                   s->n_rot < 1, ctx, PKSS_ERR_INTERNAL,
                   "search sizes out of range (cells %d, offsets %d, rotations %d)",
                   (int)s->n_az, (int)s->n_off, (int)s->n_rot);
    return PKSS_OK;
}

/* Host staging: the SoA points of both clouds, then the rotation table
 * (binning, shift) -- grown, never shrunk. */
static pkss_status stage_host(pkss_context *ctx, struct pkss__device *d,
                              const pkss__search_input *in,
                              const search_dims *s)
{
    size_t need = s->src_floats + s->tgt_floats + 2 * (size_t)s->n_rot;
    if (d->stage_floats < need) {
        pkss__free(d->stage);
        d->stage_floats = 0;
        d->stage = pkss__malloc(need * sizeof(float));
        PKSS_RETURN_IF(!d->stage, ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "out of memory for %zu staged floats", need);
        d->stage_floats = need;
    }
    float *src_soa = d->stage, *tgt_soa = d->stage + s->src_floats;
    int32_t *rot_info = (int32_t *)(tgt_soa + s->tgt_floats);
    to_soa(in->src_pts, (size_t)s->n_src, (size_t)s->pad_src, src_soa);
    if (s->n_src_feat > 0)
        to_soa(in->src_feat, (size_t)s->n_src_feat, (size_t)s->pad_src_feat,
               src_soa + 3 * (size_t)s->pad_src);
    to_soa(in->tgt_pts, (size_t)s->n_tgt, (size_t)s->pad_tgt, tgt_soa);
    if (s->n_tgt_feat > 0)
        to_soa(in->tgt_feat, (size_t)s->n_tgt_feat, (size_t)s->pad_tgt_feat,
               tgt_soa + 3 * (size_t)s->pad_tgt);
    for (cl_int r = 0; r < s->n_rot; ++r) {
        rot_info[2 * r] = in->rot->binning[r];
        rot_info[2 * r + 1] = in->rot->shift[r];
    }
    return PKSS_OK;
}

static pkss_status ensure_buffers(pkss_context *ctx, struct pkss__device *d,
                                  const search_dims *s)
{
    pkss_status st;
    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    const size_t kb = (size_t)s->kinds * (size_t)s->n_bin;
    const size_t ko = (size_t)s->kinds * (size_t)s->n_off_pad;
    if ((st = ensure(ctx, d, B_EDGES, PKSS_EDGES_SIZE * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_SRC_PTS, s->src_floats * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_TGT_PTS, s->tgt_floats * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_BIN_R, (size_t)s->n_bin * 9 * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_ROT_INFO, (size_t)s->n_rot * 2 * sizeof(int32_t), RO)) ||
        (st = ensure(ctx, d, B_OFFSETS, (size_t)s->n_off * 3 * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_SRC_TAB, kb * s->table * sizeof(float), RW)) ||
        (st = ensure(ctx, d, B_SRC_OCC, kb * sizeof(cl_int), RW)) ||
        (st = ensure(ctx, d, B_TGT_TAB, ko * s->table * sizeof(float), RW)) ||
        (st = ensure(ctx, d, B_TGT_OCC, ko * sizeof(cl_int), RW)) ||
        (st = ensure(ctx, d, B_SCORES, 3 * s->total * sizeof(float), RW)))
        return st;
    return PKSS_OK;
}

static pkss_status write_inputs(pkss_context *ctx, struct pkss__device *d,
                                const pkss__search_input *in,
                                const search_dims *s)
{
    pkss_status st = PKSS_OK;
    cl_command_queue q = d->queue;
    const float *src_soa = d->stage, *tgt_soa = d->stage + s->src_floats;
    const int32_t *rot_info = (const int32_t *)(tgt_soa + s->tgt_floats);
#define WRITE(i, bytes, ptr)                                                   \
    PKSS_CL_CHECK(ctx, clEnqueueWriteBuffer(q, d->buf[i].mem, CL_FALSE, 0,     \
                                            (bytes), (ptr), 0, NULL, NULL))
    WRITE(B_EDGES, PKSS_EDGES_SIZE * sizeof(float), in->edges);
    WRITE(B_SRC_PTS, s->src_floats * sizeof(float), src_soa);
    WRITE(B_TGT_PTS, s->tgt_floats * sizeof(float), tgt_soa);
    WRITE(B_BIN_R, (size_t)s->n_bin * 9 * sizeof(float), in->rot->bin_R);
    WRITE(B_ROT_INFO, (size_t)s->n_rot * 2 * sizeof(int32_t), rot_info);
    WRITE(B_OFFSETS, (size_t)s->n_off * 3 * sizeof(float), in->offsets);
#undef WRITE
cleanup:
    return st;
}

#define ARG(k, a, v) PKSS_CL_CHECK(ctx, clSetKernelArg((k), (a)++, sizeof(v), &(v)))

/* bin_source: one work-item per source binning rotation and cloud kind. */
static pkss_status launch_bin_source(pkss_context *ctx, struct pkss__device *d,
                                     const search_dims *s, cl_event *ev)
{
    pkss_status st = PKSS_OK;
    cl_kernel k = d->k_bin_source;
    cl_uint a = 0;
    ARG(k, a, d->buf[B_SRC_PTS].mem);
    ARG(k, a, s->n_src);
    ARG(k, a, s->pad_src);
    ARG(k, a, s->n_src_feat);
    ARG(k, a, s->pad_src_feat);
    ARG(k, a, d->buf[B_BIN_R].mem);
    ARG(k, a, s->n_bin);
    ARG(k, a, d->buf[B_EDGES].mem);
    ARG(k, a, s->n_az);
    ARG(k, a, s->kinds);
    ARG(k, a, d->buf[B_SRC_TAB].mem);
    ARG(k, a, d->buf[B_SRC_OCC].mem);
    size_t local = d->wg_bin;
    size_t global = round_up((size_t)s->n_bin * s->kinds, local);
    PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global,
                                              &local, 0, NULL, ev));
cleanup:
    return st;
}

/* bin_template: one work-item per template offset and cloud kind. */
static pkss_status launch_bin_template(pkss_context *ctx,
                                       struct pkss__device *d,
                                       const search_dims *s, cl_event *ev)
{
    pkss_status st = PKSS_OK;
    cl_kernel k = d->k_bin_template;
    cl_uint a = 0;
    ARG(k, a, d->buf[B_TGT_PTS].mem);
    ARG(k, a, s->n_tgt);
    ARG(k, a, s->pad_tgt);
    ARG(k, a, s->n_tgt_feat);
    ARG(k, a, s->pad_tgt_feat);
    ARG(k, a, d->buf[B_OFFSETS].mem);
    ARG(k, a, s->n_off);
    ARG(k, a, s->n_off_pad);
    ARG(k, a, d->buf[B_EDGES].mem);
    ARG(k, a, s->n_az);
    ARG(k, a, s->kinds);
    ARG(k, a, d->buf[B_TGT_TAB].mem);
    ARG(k, a, d->buf[B_TGT_OCC].mem);
    size_t local = d->wg_bin;
    size_t global = round_up((size_t)s->n_off_pad * s->kinds, local);
    PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global,
                                              &local, 0, NULL, ev));
cleanup:
    return st;
}

/* score_pairs: one work-item per (rotation, PKSS_VW offsets). */
static pkss_status launch_score(pkss_context *ctx, struct pkss__device *d,
                                const pkss__search_input *in,
                                const search_dims *s, cl_event *ev)
{
    pkss_status st = PKSS_OK;
    cl_kernel k = d->k_score;
    cl_uint a = 0;
    const cl_float keep = in->keep, src_cover = in->src_cover;
    ARG(k, a, d->buf[B_SRC_TAB].mem);
    ARG(k, a, d->buf[B_SRC_OCC].mem);
    ARG(k, a, d->buf[B_TGT_TAB].mem);
    ARG(k, a, d->buf[B_TGT_OCC].mem);
    ARG(k, a, d->buf[B_ROT_INFO].mem);
    ARG(k, a, s->n_bin);
    ARG(k, a, s->n_rot);
    ARG(k, a, s->n_off);
    ARG(k, a, s->n_off_pad);
    ARG(k, a, s->n_az);
    ARG(k, a, s->kinds);
    ARG(k, a, keep);
    ARG(k, a, src_cover);
    ARG(k, a, d->buf[B_SCORES].mem);
    size_t local = d->wg_score;
    size_t global = round_up((size_t)s->n_rot * (size_t)(s->n_off_pad / d->vw),
                             local);
    PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global,
                                              &local, 0, NULL, ev));
cleanup:
    return st;
}
#undef ARG

/* Queues the copies of G_K (and G_contour, G_feature when asked) back to
 * the host; the caller's clFinish completes them. */
static pkss_status read_scores(pkss_context *ctx, struct pkss__device *d,
                               size_t total, float *scores, float *g_contour,
                               float *g_feature)
{
    pkss_status st = PKSS_OK;
    float *dst[3] = {scores, g_contour, g_feature};
    for (size_t part = 0; part < 3; ++part)
        if (dst[part])
            PKSS_CL_CHECK(ctx, clEnqueueReadBuffer(
                                   d->queue, d->buf[B_SCORES].mem, CL_FALSE,
                                   part * total * sizeof(float),
                                   total * sizeof(float), dst[part], 0, NULL,
                                   NULL));
cleanup:
    return st;
}

pkss_status pkss__search_cl(pkss_context *ctx, const pkss__search_input *in,
                            float *scores, float *g_contour, float *g_feature)
{
    pkss_status st = PKSS_OK;
    struct pkss__device *d = ctx->dev;
    cl_event ev[3] = {NULL, NULL, NULL};
    PKSS_RETURN_IF(!d, ctx, PKSS_ERR_INTERNAL,
                   "pkss__search_cl called without a prepared device");
    search_dims s;
    PKSS_FORWARD(search_dims_of(ctx, in, (size_t)d->vw, &s));
    PKSS_FORWARD(stage_host(ctx, d, in, &s));
    if ((st = ensure_buffers(ctx, d, &s)) != PKSS_OK ||
        (st = write_inputs(ctx, d, in, &s)) != PKSS_OK ||
        (st = launch_bin_source(ctx, d, &s, &ev[0])) != PKSS_OK ||
        (st = launch_bin_template(ctx, d, &s, &ev[1])) != PKSS_OK ||
        (st = launch_score(ctx, d, in, &s, &ev[2])) != PKSS_OK ||
        (st = read_scores(ctx, d, s.total, scores, g_contour, g_feature)) !=
            PKSS_OK)
        goto cleanup;
    PKSS_CL_CHECK(ctx, clFinish(d->queue));
    d->last_bin_s = event_seconds(ev[0], ev[1]);
    d->last_score_s = event_seconds(ev[2], ev[2]);

cleanup:
    if (st != PKSS_OK && d->queue)
        (void)clFinish(d->queue); /* host buffers must outlive the copies */
    for (int i = 0; i < 3; ++i)
        PKSS_CL_RELEASE(clReleaseEvent, ev[i]);
    return st;
}

#else
/* Without OpenCL (the other entry points are in opencl_none.c). */
void pkss__cl_stage_seconds(const pkss_context *ctx, double *binning,
                            double *scoring)
{
    (void)ctx;
    if (binning)
        *binning = 0.0;
    if (scoring)
        *scoring = 0.0;
}
#endif /* PKSS_WITH_OPENCL */
