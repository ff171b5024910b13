/* SPDX-License-Identifier: MIT
 * pkss_cl.h -- private declarations shared by the OpenCL modules only
 * (device.c: listing and selection; evaluate_cl.c: context state, program,
 * buffers and launches). Included only when PKSS_WITH_OPENCL is defined.
 */
#ifndef PKSS_CL_H
#define PKSS_CL_H

#include "pkss_internal.h"

/* Device seconds of the binning kernels and of the scoring kernel in the
 * last pkss__search_cl on ctx (from OpenCL event profiling); 0 when there
 * was none. For benchmarks (tools/bench_search.c). */
void pkss__cl_stage_seconds(const pkss_context *ctx, double *binning,
                            double *scoring);

#ifdef PKSS_WITH_OPENCL

#include <string.h>

#ifdef __APPLE__
#include <OpenCL/cl.h>
#else
#include <CL/cl.h>
#endif

/* The cl* calls go through a table filled at run time (no link to
 * libOpenCL; see cl_loader.h). */
#include "device/cl_loader.h"

/* Most devices pkss lists (all platforms together). */
#define PKSS_CL_MAX_DEVICES 64

/* "CL_OUT_OF_RESOURCES" for -5; "CL_UNKNOWN_ERROR" for codes not known. */
const char *pkss__cl_error_name(cl_int err);

/* Records "<function>: <CL_NAME> (<code>)" in the context detail and returns
 * PKSS_ERR_DEVICE. `what` may be a whole call's text: only the function name
 * (up to the first '(') is kept. */
pkss_status pkss__cl_fail(pkss_context *ctx, cl_int err, const char *what);

/* PKSS_CL_CHECK(ctx, call): runs an OpenCL call returning cl_int; on failure
 * records e.g. "clEnqueueNDRangeKernel: CL_OUT_OF_RESOURCES (-5)", sets the
 * local `st` and jumps to the function's `cleanup` label.
 * PKSS_CL_CHECK_ERR(ctx, err, "clCreateBuffer") does the same for calls
 * that report through an errcode_ret argument. */
#define PKSS_CL_CHECK(ctx, call)                                               \
    do {                                                                       \
        cl_int pkss__cl_e = (call);                                            \
        if (pkss__cl_e != CL_SUCCESS) {                                        \
            st = pkss__cl_fail((ctx), pkss__cl_e, #call);                      \
            goto cleanup;                                                      \
        }                                                                      \
    } while (0)

#define PKSS_CL_CHECK_ERR(ctx, err, name)                                      \
    do {                                                                       \
        if ((err) != CL_SUCCESS) {                                             \
            st = pkss__cl_fail((ctx), (err), (name));                          \
            goto cleanup;                                                      \
        }                                                                      \
    } while (0)

/* Release during cleanup: a failure there is ignored (it never changes the
 * status being returned). */
#define PKSS_CL_RELEASE(fn, obj)                                               \
    do {                                                                       \
        if (obj) {                                                             \
            (void)fn(obj);                                                     \
            (obj) = NULL;                                                      \
        }                                                                      \
    } while (0)

/* Selects the device for ctx (SPEC/STYLE 11): ctx->device_request (index or
 * case-insensitive name substring), then $PKSS_DEVICE, then the first GPU,
 * then the first CPU, then the first device of any type. On success fills
 * *platform, *device and ctx->device_name. Fails with PKSS_ERR_NO_DEVICE and
 * a detail that names the request and lists what exists. */
pkss_status pkss__cl_select(pkss_context *ctx, cl_platform_id *platform,
                            cl_device_id *device);

#endif /* PKSS_WITH_OPENCL */
#endif /* PKSS_CL_H */
