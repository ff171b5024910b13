/* SPDX-License-Identifier: MIT
 * opencl_none.c -- the device entry points of a build without OpenCL
 * (-DPKSS_WITH_OPENCL=OFF or no OpenCL headers found): every device call says
 * so clearly, and the reference backend keeps working. */
#include "pkss_internal.h"

#ifndef PKSS_WITH_OPENCL

#define PKSS_NO_CL_MSG                                                         \
    "this pkss was built without OpenCL support; rebuild with the OpenCL "     \
    "headers installed (Debian: apt-get install opencl-headers; to run: "      \
    "ocl-icd-libopencl1 pocl-opencl-icd) or use PKSS_BACKEND_REFERENCE"

pkss_status pkss__cl_prepare(pkss_context *ctx)
{
    return pkss__fail(ctx, PKSS_ERR_UNSUPPORTED, "%s", PKSS_NO_CL_MSG);
}

void pkss__cl_release(pkss_context *ctx) { (void)ctx; }

void pkss__cl_warmup_begin(const pkss_context *ctx, pkss__cl_warmup *w)
{
    (void)ctx;
    w->started = 0;
}

void pkss__cl_warmup_end(pkss__cl_warmup *w) { (void)w; }

pkss_status pkss__search_cl(pkss_context *ctx, const pkss__search_input *in,
                            float *scores, float *g_contour, float *g_feature)
{
    (void)in; (void)scores; (void)g_contour; (void)g_feature;
    return pkss__fail(ctx, PKSS_ERR_UNSUPPORTED, "%s", PKSS_NO_CL_MSG);
}

pkss_status pkss_device_count(unsigned *count)
{
    if (!count)
        return PKSS_ERR_NULL_ARGUMENT;
    *count = 0;
    return PKSS_ERR_UNSUPPORTED;
}

pkss_status pkss_device_info(unsigned index, pkss_device_desc *out)
{
    (void)index;
    if (!out)
        return PKSS_ERR_NULL_ARGUMENT;
    return PKSS_ERR_UNSUPPORTED;
}

const char *pkss_no_device_reason(void) { return PKSS_NO_CL_MSG; }

#else
/* ISO C forbids an empty translation unit. */
typedef int pkss__opencl_none_unused;
#endif
