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

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern const char pkss__kernel_source[];
extern const size_t pkss__kernel_source_size;

/* Lanes per work-item (PKSS_VW in kernels/pkss_shared.h) and work-group
 * sizes, explicit everywhere (PoCL crawls without a local size). CPUs: 16
 * float lanes per work-item (one AVX-512 or two AVX2 registers; PoCL does
 * not vectorise across work-items of kernels with inner loops) and small
 * groups (a group runs on one core). GPUs: one lane; SIMT hardware runs
 * 64-wide groups in lock step. The environment variable
 * PKSS_CL_VECTOR_WIDTH (1, 2, 4, 8 or 16) overrides the lanes, e.g. to
 * test the GPU code path on a CPU. Group sizes are lowered at prepare() if
 * a device allows less, and passed to the kernels as -DPKSS_WG_*. */
#define PKSS_VW_CPU 16
#define PKSS_WG_SCORE_CPU 8
#define PKSS_WG_BIN_CPU 8
#define PKSS_WG_SCORE_GPU 64
#define PKSS_WG_BIN_GPU 32

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
};

/* ------------------------------------------------------------ release */
void pkss__cl_release(pkss_context *ctx)
{
    if (!ctx || !ctx->dev)
        return;
    struct pkss__device *d = ctx->dev;
    if (d->queue)
        (void)clFinish(d->queue);
    for (int i = 0; i < B_COUNT; ++i)
        PKSS_CL_RELEASE(clReleaseMemObject, d->buf[i].mem);
    PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_source);
    PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_template);
    PKSS_CL_RELEASE(clReleaseKernel, d->k_score);
    PKSS_CL_RELEASE(clReleaseProgram, d->program);
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

/* Builds the embedded program for d->device with the work-group sizes as
 * -D defines; the user's PKSS_CL_BUILD_OPTIONS come last. */
static pkss_status build_program(pkss_context *ctx, struct pkss__device *d)
{
    pkss_status st = PKSS_OK;
    cl_int err;
    char options[1024];
    const char *sources[1] = {pkss__kernel_source};
    size_t lengths[1] = {pkss__kernel_source_size};
    /* Correctly rounded float division and sqrt make the kernels compute
     * what the C reference computes (SPEC 4); only devices that report the
     * capability accept the option. FP contraction is switched off by the
     * pragma in pkss_shared.h. */
    cl_device_fp_config fp = 0;
    (void)clGetDeviceInfo(d->device, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp,
                          &fp, NULL);
    const char *user = getenv("PKSS_CL_BUILD_OPTIONS");
    snprintf(options, sizeof options,
             "%s -DPKSS_VW=%d -DPKSS_WG_SCORE=%zu -DPKSS_WG_BIN=%zu %s",
             (fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT)
                 ? "-cl-fp32-correctly-rounded-divide-sqrt" : "",
             d->vw, d->wg_score, d->wg_bin, user ? user : "");
    d->program = clCreateProgramWithSource(d->context, 1, sources, lengths,
                                           &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateProgramWithSource");
    err = clBuildProgram(d->program, 1, &d->device, options, NULL, NULL);
    if (err == CL_BUILD_PROGRAM_FAILURE || err == CL_INVALID_BUILD_OPTIONS ||
        err == CL_COMPILER_NOT_AVAILABLE) {
        st = err == CL_COMPILER_NOT_AVAILABLE
                 ? pkss__fail(ctx, PKSS_ERR_UNSUPPORTED,
                              "the device '%s' has no OpenCL C compiler "
                              "(clBuildProgram: CL_COMPILER_NOT_AVAILABLE)",
                              ctx->device_name)
                 : build_failure(ctx, d, err, options);
        goto cleanup;
    }
    PKSS_CL_CHECK_ERR(ctx, err, "clBuildProgram");
    d->k_bin_source = clCreateKernel(d->program, "bin_source", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(bin_source)");
    d->k_bin_template = clCreateKernel(d->program, "bin_template", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(bin_template)");
    d->k_score = clCreateKernel(d->program, "score_pairs", &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateKernel(score_pairs)");
cleanup:
    return st;
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
    st = pkss__cl_select(ctx, &d->platform, &d->device);
    if (st != PKSS_OK)
        goto cleanup;

    /* Required capabilities, checked here and not mid-run (STYLE 11). */
    cl_bool avail = CL_FALSE, compiler = CL_FALSE;
    size_t max_wg = 0;
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_AVAILABLE,
                                       sizeof avail, &avail, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_COMPILER_AVAILABLE,
                                       sizeof compiler, &compiler, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_MAX_WORK_GROUP_SIZE,
                                       sizeof max_wg, &max_wg, NULL));
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_MAX_MEM_ALLOC_SIZE,
                                       sizeof d->max_alloc, &d->max_alloc, NULL));
    if (!avail || !compiler) {
        st = pkss__fail(ctx, PKSS_ERR_UNSUPPORTED,
                        "OpenCL device '%s' is %s", ctx->device_name,
                        !avail ? "not available" : "without a compiler");
        goto cleanup;
    }
    cl_device_type type = 0;
    PKSS_CL_CHECK(ctx, clGetDeviceInfo(d->device, CL_DEVICE_TYPE, sizeof type,
                                       &type, NULL));
    int cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
    d->vw = cpu ? PKSS_VW_CPU : 1;
    const char *vw_env = getenv("PKSS_CL_VECTOR_WIDTH");
    if (vw_env && vw_env[0]) {
        int v = atoi(vw_env);
        if (v != 1 && v != 2 && v != 4 && v != 8 && v != 16) {
            st = pkss__fail(ctx, PKSS_ERR_INVALID_ARGUMENT,
                            "PKSS_CL_VECTOR_WIDTH='%s': must be 1, 2, 4, 8 or 16",
                            vw_env);
            goto cleanup;
        }
        d->vw = v;
    }
    size_t want_s = cpu ? PKSS_WG_SCORE_CPU : PKSS_WG_SCORE_GPU;
    size_t want_b = cpu ? PKSS_WG_BIN_CPU : PKSS_WG_BIN_GPU;
    d->wg_score = max_wg < want_s ? max_wg : want_s;
    d->wg_bin = max_wg < want_b ? max_wg : want_b;

    d->context = clCreateContext(NULL, 1, &d->device, NULL, NULL, &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateContext");
    /* Profiling gives the per-stage device times (pkss__cl_stage_seconds)
     * at the cost of two timestamps per launch. */
    d->queue = clCreateCommandQueue(d->context, d->device,
                                    CL_QUEUE_PROFILING_ENABLE, &err);
    PKSS_CL_CHECK_ERR(ctx, err, "clCreateCommandQueue");
    st = build_program(ctx, d);
    if (st != PKSS_OK)
        goto cleanup;
    /* A device may allow smaller groups for these kernels than in general
     * (register pressure on GPUs): then rebuild once with the limit. */
    size_t lim_s = kernel_wg_limit(d->k_score, d->device, d->wg_score);
    size_t lim_b = kernel_wg_limit(d->k_bin_source, d->device, d->wg_bin);
    lim_b = kernel_wg_limit(d->k_bin_template, d->device, lim_b);
    if (lim_s < d->wg_score || lim_b < d->wg_bin) {
        d->wg_score = lim_s;
        d->wg_bin = lim_b;
        PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_source);
        PKSS_CL_RELEASE(clReleaseKernel, d->k_bin_template);
        PKSS_CL_RELEASE(clReleaseKernel, d->k_score);
        PKSS_CL_RELEASE(clReleaseProgram, d->program);
        st = build_program(ctx, d);
        if (st != PKSS_OK)
            goto cleanup;
    }
    return PKSS_OK;

cleanup:
    /* the detail stays; what was made is released */
    pkss__cl_release(ctx);
    ctx->device_name[0] = '\0';
    return st;
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

pkss_status pkss__search_cl(pkss_context *ctx, const pkss__search_input *in,
                            float *scores, float *g_contour, float *g_feature)
{
    pkss_status st = PKSS_OK;
    struct pkss__device *d = ctx->dev;
    int32_t *rot_info = NULL;
    cl_event ev[3] = {NULL, NULL, NULL};
    PKSS_RETURN_IF(!d, ctx, PKSS_ERR_INTERNAL,
                   "pkss__search_cl called without a prepared device");
    const pkss__rotation_set *rot = in->rot;
    const size_t vw = (size_t)d->vw;
    const cl_int n_az = in->n_az;
    const size_t n_cells = (size_t)n_az * (size_t)(n_az / 2);
    const size_t table = n_cells * 4; /* floats */
    const cl_int n_bin = (cl_int)rot->n_binnings;
    const cl_int n_rot = (cl_int)rot->n_rotations;
    const cl_int n_off = in->n_offsets;
    const cl_int n_off_pad = (cl_int)round_up((size_t)n_off, vw);
    const cl_int kinds = in->use_features ? 2 : 1;
    const cl_float keep = in->keep;
    const cl_float src_cover = in->src_cover;
    const cl_int n_src = in->n_src, n_tgt = in->n_tgt;
    const cl_int n_src_feat = in->use_features ? in->n_src_feat : 0;
    const cl_int n_tgt_feat = in->use_features ? in->n_tgt_feat : 0;
    const cl_int pad_src = (cl_int)round_up((size_t)n_src, vw);
    const cl_int pad_tgt = (cl_int)round_up((size_t)n_tgt, vw);
    const cl_int pad_src_feat = (cl_int)round_up((size_t)n_src_feat, vw);
    const cl_int pad_tgt_feat = (cl_int)round_up((size_t)n_tgt_feat, vw);
    const size_t total = (size_t)n_rot * (size_t)n_off;
    PKSS_RETURN_IF(n_az > PKSS_MAX_AZ || n_az < 4 || n_off < 1 || n_rot < 1,
                   ctx, PKSS_ERR_INTERNAL,
                   "search sizes out of range (cells %d, offsets %d, rotations %d)",
                   (int)n_az, (int)n_off, (int)n_rot);

    /* Host staging: the SoA points of both clouds, then the rotation
     * table (binning, shift) -- grown, never shrunk. */
    size_t src_floats = 3 * (size_t)(pad_src + pad_src_feat);
    size_t tgt_floats = 3 * (size_t)(pad_tgt + pad_tgt_feat);
    size_t need = src_floats + tgt_floats + 2 * (size_t)n_rot;
    if (d->stage_floats < need) {
        pkss__free(d->stage);
        d->stage_floats = 0;
        d->stage = pkss__malloc(need * sizeof(float));
        PKSS_RETURN_IF(!d->stage, ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "out of memory for %zu staged floats", need);
        d->stage_floats = need;
    }
    float *src_soa = d->stage, *tgt_soa = d->stage + src_floats;
    rot_info = (int32_t *)(tgt_soa + tgt_floats);
    to_soa(in->src_pts, (size_t)n_src, (size_t)pad_src, src_soa);
    if (n_src_feat > 0)
        to_soa(in->src_feat, (size_t)n_src_feat, (size_t)pad_src_feat,
               src_soa + 3 * (size_t)pad_src);
    to_soa(in->tgt_pts, (size_t)n_tgt, (size_t)pad_tgt, tgt_soa);
    if (n_tgt_feat > 0)
        to_soa(in->tgt_feat, (size_t)n_tgt_feat, (size_t)pad_tgt_feat,
               tgt_soa + 3 * (size_t)pad_tgt);
    for (cl_int r = 0; r < n_rot; ++r) {
        rot_info[2 * r] = rot->binning[r];
        rot_info[2 * r + 1] = rot->shift[r];
    }

    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    if ((st = ensure(ctx, d, B_EDGES, PKSS_EDGES_SIZE * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_SRC_PTS, src_floats * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_TGT_PTS, tgt_floats * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_BIN_R, (size_t)n_bin * 9 * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_ROT_INFO, (size_t)n_rot * 2 * sizeof(int32_t), RO)) ||
        (st = ensure(ctx, d, B_OFFSETS, (size_t)n_off * 3 * sizeof(float), RO)) ||
        (st = ensure(ctx, d, B_SRC_TAB, (size_t)kinds * n_bin * table * sizeof(float), RW)) ||
        (st = ensure(ctx, d, B_SRC_OCC, (size_t)kinds * n_bin * sizeof(cl_int), RW)) ||
        (st = ensure(ctx, d, B_TGT_TAB, (size_t)kinds * n_off_pad * table * sizeof(float), RW)) ||
        (st = ensure(ctx, d, B_TGT_OCC, (size_t)kinds * n_off_pad * sizeof(cl_int), RW)) ||
        (st = ensure(ctx, d, B_SCORES, 3 * total * sizeof(float), RW)))
        goto cleanup;

    cl_command_queue q = d->queue;
#define WRITE(i, bytes, ptr)                                                   \
    PKSS_CL_CHECK(ctx, clEnqueueWriteBuffer(q, d->buf[i].mem, CL_FALSE, 0,     \
                                            (bytes), (ptr), 0, NULL, NULL))
    WRITE(B_EDGES, PKSS_EDGES_SIZE * sizeof(float), in->edges);
    WRITE(B_SRC_PTS, src_floats * sizeof(float), src_soa);
    WRITE(B_TGT_PTS, tgt_floats * sizeof(float), tgt_soa);
    WRITE(B_BIN_R, (size_t)n_bin * 9 * sizeof(float), rot->bin_R);
    WRITE(B_ROT_INFO, (size_t)n_rot * 2 * sizeof(int32_t), rot_info);
    WRITE(B_OFFSETS, (size_t)n_off * 3 * sizeof(float), in->offsets);
#undef WRITE
#define ARG(k, a, v) PKSS_CL_CHECK(ctx, clSetKernelArg((k), (a)++, sizeof(v), &(v)))
    {
        cl_kernel k = d->k_bin_source;
        cl_uint a = 0;
        ARG(k, a, d->buf[B_SRC_PTS].mem);
        ARG(k, a, n_src);
        ARG(k, a, pad_src);
        ARG(k, a, n_src_feat);
        ARG(k, a, pad_src_feat);
        ARG(k, a, d->buf[B_BIN_R].mem);
        ARG(k, a, n_bin);
        ARG(k, a, d->buf[B_EDGES].mem);
        ARG(k, a, n_az);
        ARG(k, a, kinds);
        ARG(k, a, d->buf[B_SRC_TAB].mem);
        ARG(k, a, d->buf[B_SRC_OCC].mem);
        size_t local = d->wg_bin;
        size_t global = round_up((size_t)n_bin * kinds, local);
        PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(q, k, 1, NULL, &global, &local,
                                                  0, NULL, &ev[0]));
    }
    {
        cl_kernel k = d->k_bin_template;
        cl_uint a = 0;
        ARG(k, a, d->buf[B_TGT_PTS].mem);
        ARG(k, a, n_tgt);
        ARG(k, a, pad_tgt);
        ARG(k, a, n_tgt_feat);
        ARG(k, a, pad_tgt_feat);
        ARG(k, a, d->buf[B_OFFSETS].mem);
        ARG(k, a, n_off);
        ARG(k, a, n_off_pad);
        ARG(k, a, d->buf[B_EDGES].mem);
        ARG(k, a, n_az);
        ARG(k, a, kinds);
        ARG(k, a, d->buf[B_TGT_TAB].mem);
        ARG(k, a, d->buf[B_TGT_OCC].mem);
        size_t local = d->wg_bin;
        size_t global = round_up((size_t)n_off_pad * kinds, local);
        PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(q, k, 1, NULL, &global, &local,
                                                  0, NULL, &ev[1]));
    }
    {
        cl_kernel k = d->k_score;
        cl_uint a = 0;
        ARG(k, a, d->buf[B_SRC_TAB].mem);
        ARG(k, a, d->buf[B_SRC_OCC].mem);
        ARG(k, a, d->buf[B_TGT_TAB].mem);
        ARG(k, a, d->buf[B_TGT_OCC].mem);
        ARG(k, a, d->buf[B_ROT_INFO].mem);
        ARG(k, a, n_bin);
        ARG(k, a, n_rot);
        ARG(k, a, n_off);
        ARG(k, a, n_off_pad);
        ARG(k, a, n_az);
        ARG(k, a, kinds);
        ARG(k, a, keep);
        ARG(k, a, src_cover);
        ARG(k, a, d->buf[B_SCORES].mem);
        size_t local = d->wg_score;
        size_t global = round_up((size_t)n_rot * (size_t)(n_off_pad / d->vw), local);
        PKSS_CL_CHECK(ctx, clEnqueueNDRangeKernel(q, k, 1, NULL, &global, &local,
                                                  0, NULL, &ev[2]));
    }
#undef ARG
#define READ(part, ptr)                                                        \
    PKSS_CL_CHECK(ctx, clEnqueueReadBuffer(q, d->buf[B_SCORES].mem, CL_FALSE,  \
                                           (part) * total * sizeof(float),     \
                                           total * sizeof(float), (ptr), 0,    \
                                           NULL, NULL))
    READ(0, scores);
    if (g_contour)
        READ(1, g_contour);
    if (g_feature)
        READ(2, g_feature);
#undef READ
    PKSS_CL_CHECK(ctx, clFinish(q));
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
