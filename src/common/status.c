/* SPDX-License-Identifier: MIT
 * status.c -- the one table of status names and sentences, and the
 * per-context error detail. */
#include "pkss_internal.h"

#include <stdio.h>
#include <string.h>

/* X-macro list: (enum, sentence). The public enum stays literal for cffi. */
#define PKSS_STATUS_LIST(X)                                                    \
    X(PKSS_OK, "Success.")                                                     \
    X(PKSS_ERR_NULL_ARGUMENT, "A required pointer argument was NULL.")         \
    X(PKSS_ERR_INVALID_ARGUMENT, "An argument or parameter value is out of its valid range.") \
    X(PKSS_ERR_EMPTY_INPUT, "The point cloud is empty (n = 0).")               \
    X(PKSS_ERR_TOO_FEW_POINTS, "The point cloud has fewer usable points than min_points.") \
    X(PKSS_ERR_NONFINITE, "The point cloud holds a NaN or infinite coordinate.") \
    X(PKSS_ERR_DEGENERATE, "The points are identical, collinear or coplanar: shape and pose are undefined.") \
    X(PKSS_ERR_OUT_OF_RANGE, "Coordinates are too large to be processed in float32 after centring.") \
    X(PKSS_ERR_UNKNOWN_PARAMETER, "The parameter identifier is not known.")    \
    X(PKSS_ERR_WRONG_PARAMETER_TYPE, "The parameter has another type than the setter used.") \
    X(PKSS_ERR_CANCELLED, "The progress callback cancelled the call.")         \
    X(PKSS_ERR_FORMAT, "The file's content is malformed or truncated.")       \
    X(PKSS_ERR_UNSUPPORTED_FORMAT, "The file is of a valid variant that no reader handles.") \
    X(PKSS_ERR_CORRUPT_DATA, "The serialised data is truncated, corrupt or not a pkss cloud.") \
    X(PKSS_ERR_STALE_DATA, "The serialised cloud comes from another library version or other parameters.") \
    X(PKSS_ERR_OUT_OF_MEMORY, "Memory allocation failed.")                     \
    X(PKSS_ERR_IO, "A file cannot be opened, read or written.")               \
    X(PKSS_ERR_NO_DEVICE, "No OpenCL device is available.")                    \
    X(PKSS_ERR_DEVICE, "An OpenCL call failed.")                               \
    X(PKSS_ERR_KERNEL_BUILD, "The OpenCL kernels failed to compile for the device.") \
    X(PKSS_ERR_UNSUPPORTED, "The device or this build lacks a required feature.") \
    X(PKSS_ERR_NO_CONSENSUS, "The search found no valid candidate pose.")      \
    X(PKSS_ERR_INTERNAL, "Internal error in pkss; please report it.")

const char *pkss_status_name(pkss_status status)
{
    switch (status) {
#define PKSS_X(sym, text) case sym: return #sym;
        PKSS_STATUS_LIST(PKSS_X)
#undef PKSS_X
    }
    return "PKSS_UNKNOWN_STATUS";
}

const char *pkss_status_string(pkss_status status)
{
    switch (status) {
#define PKSS_X(sym, text) case sym: return text;
        PKSS_STATUS_LIST(PKSS_X)
#undef PKSS_X
    }
    return "Unknown status code.";
}

pkss_status pkss__fail(pkss_context *ctx, pkss_status status, const char *fmt,
                       ...)
{
    if (ctx) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(ctx->detail, sizeof ctx->detail, fmt, ap);
        va_end(ap);
    }
    return status;
}

void pkss__clear_error(pkss_context *ctx)
{
    if (ctx)
        ctx->detail[0] = '\0';
}

const char *pkss_context_last_error(const pkss_context *ctx)
{
    if (!ctx)
        return "pkss_context_last_error: ctx is NULL";
    return ctx->detail;
}
