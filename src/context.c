/* SPDX-License-Identifier: MIT
 * context.c -- context lifecycle, parameters (zstd style: one at a time,
 * 0 = default, bounds queryable), version and build information. */
#include "pkss_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------- version */
unsigned pkss_version_number(void) { return PKSS_VERSION_NUMBER; }

#define PKSS_STR2(x) #x
#define PKSS_STR(x) PKSS_STR2(x)
const char *pkss_version_string(void)
{
    return PKSS_STR(PKSS_VERSION_MAJOR) "." PKSS_STR(PKSS_VERSION_MINOR) "." PKSS_STR(PKSS_VERSION_PATCH);
}

unsigned pkss_max_candidates(void) { return PKSS_MAX_CANDIDATES; }

#ifndef PKSS_COMPILER
#define PKSS_COMPILER "unknown compiler"
#endif
const char *pkss_build_info(void)
{
    return "pkss " PKSS_STR(PKSS_VERSION_MAJOR) "." PKSS_STR(PKSS_VERSION_MINOR) "." PKSS_STR(PKSS_VERSION_PATCH)
           " (" PKSS_COMPILER
#ifdef PKSS_WITH_OPENCL
           ", OpenCL backend: yes (OpenCL 1.2 API, float32 kernels)"
#else
           ", OpenCL backend: no (reference backend only)"
#endif
#ifdef __SANITIZE_ADDRESS__
           ", sanitizers"
#endif
           ")";
}

/* ---------------------------------------------------------- parameters */
typedef enum { P_INT, P_DOUBLE, P_SWITCH, P_STRING } ptype;

typedef struct param_desc {
    pkss_param id;
    const char *name;
    ptype type;
    double lo, hi, def;
    size_t offset;   /* into pkss__params (int, double or long long) */
    int is_ll;       /* long long field */
} param_desc;

#define OFF(f) offsetof(pkss__params, f)
static const param_desc PARAMS[] = {
    {PKSS_PARAM_POINTS, "points", P_INT, 256, 20000, 3000, OFF(points), 0},
    {PKSS_PARAM_ROTATION_STEPS, "rotation_steps", P_INT, 4, 36, 12, OFF(rotation_steps), 0},
    {PKSS_PARAM_OFFSET_STEPS, "offset_steps", P_INT, 1, 9, 5, OFF(offset_steps), 0},
    {PKSS_PARAM_CELL_STEPS, "cell_steps", P_INT, 4, 48, 12, OFF(cell_steps), 0},
    {PKSS_PARAM_CULL_MUTUAL, "cull_mutual", P_SWITCH, 0, 2, 1, OFF(cull_mutual), 0},
    {PKSS_PARAM_CULL_STAT, "cull_stat", P_SWITCH, 0, 2, 1, OFF(cull_stat), 0},
    {PKSS_PARAM_USE_FEATURES, "use_features", P_SWITCH, 0, 2, 1, OFF(use_features), 0},
    {PKSS_PARAM_FEATURE_FRAC, "feature_frac", P_DOUBLE, 0.01, 0.5, 0.10, OFF(feature_frac), 0},
    {PKSS_PARAM_PCA_PREALIGN, "pca_prealign", P_SWITCH, 0, 2, 1, OFF(pca_prealign), 0},
    {PKSS_PARAM_ROTATION_SET, "rotation_set", P_INT, 0, 2, PKSS_ROTATIONS_EULER, OFF(rotation_set), 0},
    {PKSS_PARAM_ROTATION_COUNT, "rotation_count", P_INT, 24, 20000, 1728, OFF(rotation_count), 0},
    {PKSS_PARAM_TOP_K, "top_k", P_INT, 1, PKSS_MAX_CANDIDATES, 10, OFF(top_k), 0},
    {PKSS_PARAM_REFINE, "refine", P_SWITCH, 0, 2, 1, OFF(refine), 0},
    {PKSS_PARAM_SEED, "seed", P_INT, 0, 2147483647.0, 0, OFF(seed), 1},
    {PKSS_PARAM_MAX_RAW_POINTS, "max_raw_points", P_INT, 1000, 100000000.0, 200000, OFF(max_raw_points), 1},
    {PKSS_PARAM_DROP_NONFINITE, "drop_nonfinite", P_SWITCH, 0, 2, 0, OFF(drop_nonfinite), 0},
    {PKSS_PARAM_MIN_POINTS, "min_points", P_INT, 16, 1000000, 32, OFF(min_points), 0},
    {PKSS_PARAM_BACKEND, "backend", P_INT, 0, 2, PKSS_BACKEND_AUTO, OFF(backend), 0},
    {PKSS_PARAM_DEVICE, "device", P_STRING, 0, 0, 0, 0, 0},
};
#undef OFF
#define N_PARAMS (sizeof PARAMS / sizeof PARAMS[0])

static const param_desc *find_param(pkss_param id)
{
    for (size_t i = 0; i < N_PARAMS; ++i)
        if (PARAMS[i].id == id)
            return &PARAMS[i];
    return NULL;
}

/* Stored value of a switch is 0/1 (resolved); default is desc->def. */
static void store(pkss__params *p, const param_desc *d, double v)
{
    char *base = (char *)p;
    if (d->type == P_DOUBLE)
        *(double *)(base + d->offset) = v;
    else if (d->is_ll)
        *(long long *)(base + d->offset) = (long long)v;
    else
        *(int *)(base + d->offset) = (int)v;
}

static double load(const pkss__params *p, const param_desc *d)
{
    const char *base = (const char *)p;
    if (d->type == P_DOUBLE)
        return *(const double *)(base + d->offset);
    if (d->is_ll)
        return (double)*(const long long *)(base + d->offset);
    return (double)*(const int *)(base + d->offset);
}

void pkss__params_default(pkss__params *p)
{
    memset(p, 0, sizeof *p);
    for (size_t i = 0; i < N_PARAMS; ++i) {
        const param_desc *d = &PARAMS[i];
        if (d->type == P_STRING)
            continue;
        store(p, d, d->def);
    }
    /* cell_steps follows rotation_steps unless set explicitly. */
    p->cell_steps = 0;
}

const char *pkss_param_name(pkss_param param)
{
    const param_desc *d = find_param(param);
    return d ? d->name : NULL;
}

pkss_status pkss_param_bounds(pkss_param param, double *lower, double *upper,
                              double *default_value)
{
    const param_desc *d = find_param(param);
    if (!d || d->type == P_STRING)
        return PKSS_ERR_UNKNOWN_PARAMETER;
    if (lower)
        *lower = d->type == P_SWITCH ? 0 : d->lo;
    if (upper)
        *upper = d->hi;
    if (default_value)
        *default_value = d->type == P_SWITCH ? (d->def ? PKSS_SWITCH_ON : PKSS_SWITCH_OFF) : d->def;
    return PKSS_OK;
}

static void release_device(pkss_context *ctx)
{
    pkss__cl_release(ctx);
    ctx->prepared = 0;
    ctx->device_name[0] = '\0';
}

static pkss_status set_numeric(pkss_context *ctx, pkss_param param, double v,
                               int from_int)
{
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    const param_desc *d = find_param(param);
    PKSS_RETURN_IF(!d, ctx, PKSS_ERR_UNKNOWN_PARAMETER,
                   "unknown parameter id %d", (int)param);
    PKSS_RETURN_IF(d->type == P_STRING, ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
                   "parameter '%s' takes a string (pkss_context_set_string)",
                   d->name);
    PKSS_RETURN_IF(!isfinite(v), ctx, PKSS_ERR_INVALID_ARGUMENT,
                   "parameter '%s': value is not finite", d->name);
    if (d->type != P_DOUBLE && !from_int) {
        PKSS_RETURN_IF(v != floor(v), ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
                       "parameter '%s' is an integer; got %g", d->name, v);
    }
    double value;
    if (d->type == P_SWITCH) {
        PKSS_RETURN_IF(v != 0 && v != PKSS_SWITCH_ON && v != PKSS_SWITCH_OFF,
                       ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "parameter '%s' is a switch: 0 (default), 1 (on) or 2 (off); got %g",
                       d->name, v);
        value = v == 0 ? d->def : (v == PKSS_SWITCH_ON ? 1 : 0);
    } else if (v == 0 && d->id != PKSS_PARAM_SEED) {
        value = d->def;
    } else {
        PKSS_RETURN_IF(v < d->lo || v > d->hi, ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "parameter '%s' must be in [%.15g, %.15g] (0 = default %.15g); got %.15g",
                       d->name, d->lo, d->hi, d->def, v);
        value = v;
    }
    if (param == PKSS_PARAM_ROTATION_STEPS || param == PKSS_PARAM_CELL_STEPS) {
        PKSS_RETURN_IF(((long long)value) % 2 != 0, ctx,
                       PKSS_ERR_INVALID_ARGUMENT,
                       "parameter '%s' must be even; got %g", d->name, value);
    }
    if (param == PKSS_PARAM_OFFSET_STEPS) {
        PKSS_RETURN_IF(((long long)value) % 2 != 1, ctx,
                       PKSS_ERR_INVALID_ARGUMENT,
                       "parameter 'offset_steps' must be odd; got %g", value);
    }
    if (param == PKSS_PARAM_CELL_STEPS && v == 0) {
        ctx->params.cell_steps = 0; /* follow rotation_steps */
        return PKSS_OK;
    }
    if (param == PKSS_PARAM_BACKEND && (int)value != ctx->params.backend)
        release_device(ctx);
    store(&ctx->params, d, value);
    return PKSS_OK;
}

pkss_status pkss_context_set_int(pkss_context *ctx, pkss_param param,
                                 long long value)
{
    return set_numeric(ctx, param, (double)value, 1);
}

pkss_status pkss_context_set_double(pkss_context *ctx, pkss_param param,
                                    double value)
{
    return set_numeric(ctx, param, value, 0);
}

pkss_status pkss_context_set_string(pkss_context *ctx, pkss_param param,
                                    const char *value)
{
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    const param_desc *d = find_param(param);
    PKSS_RETURN_IF(!d, ctx, PKSS_ERR_UNKNOWN_PARAMETER,
                   "unknown parameter id %d", (int)param);
    PKSS_RETURN_IF(d->type != P_STRING, ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
                   "parameter '%s' is numeric (use pkss_context_set_int/double)",
                   d->name);
    char *copy = NULL;
    if (value && value[0]) {
        size_t len = strlen(value);
        PKSS_RETURN_IF(len >= 256, ctx, PKSS_ERR_INVALID_ARGUMENT,
                       "device string longer than 255 characters");
        copy = pkss__malloc(len + 1);
        PKSS_RETURN_IF(!copy, ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "out of memory copying the device string");
        memcpy(copy, value, len + 1);
    }
    pkss__free(ctx->device_request);
    ctx->device_request = copy;
    release_device(ctx);
    return PKSS_OK;
}

pkss_status pkss_context_get_double(const pkss_context *ctx, pkss_param param,
                                    double *value)
{
    if (!ctx || !value)
        return PKSS_ERR_NULL_ARGUMENT;
    const param_desc *d = find_param(param);
    if (!d)
        return PKSS_ERR_UNKNOWN_PARAMETER;
    if (d->type == P_STRING)
        return PKSS_ERR_WRONG_PARAMETER_TYPE;
    if (param == PKSS_PARAM_CELL_STEPS && ctx->params.cell_steps == 0)
        *value = ctx->params.rotation_steps;
    else if (d->type == P_SWITCH) /* report pkss_switch values, as set */
        *value = load(&ctx->params, d) ? PKSS_SWITCH_ON : PKSS_SWITCH_OFF;
    else
        *value = load(&ctx->params, d);
    return PKSS_OK;
}

pkss_status pkss_context_get_int(const pkss_context *ctx, pkss_param param,
                                 long long *value)
{
    double v;
    if (!value)
        return PKSS_ERR_NULL_ARGUMENT;
    pkss_status st = pkss_context_get_double(ctx, param, &v);
    if (st != PKSS_OK)
        return st;
    const param_desc *d = find_param(param);
    if (d->type == P_DOUBLE)
        return PKSS_ERR_WRONG_PARAMETER_TYPE;
    *value = (long long)v;
    return PKSS_OK;
}

/* ------------------------------------------------------------ lifecycle */
pkss_status pkss_context_create(pkss_context **out)
{
    if (!out)
        return PKSS_ERR_NULL_ARGUMENT;
    *out = NULL;
    pkss_context *ctx = pkss__calloc(1, sizeof *ctx);
    if (!ctx)
        return PKSS_ERR_OUT_OF_MEMORY;
    pkss__params_default(&ctx->params);
    *out = ctx;
    return PKSS_OK;
}

void pkss_context_destroy(pkss_context *ctx)
{
    if (!ctx)
        return;
    release_device(ctx);
    pkss__free(ctx->device_request);
    pkss__free(ctx);
}

pkss_status pkss_context_reset(pkss_context *ctx, pkss_reset what)
{
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    PKSS_RETURN_IF(what < PKSS_RESET_PARAMS || what > PKSS_RESET_ALL, ctx,
                   PKSS_ERR_INVALID_ARGUMENT,
                   "pkss_context_reset: 'what' must be 1, 2 or 3; got %d",
                   (int)what);
    if (what & PKSS_RESET_PARAMS) {
        int backend = ctx->params.backend;
        pkss__params_default(&ctx->params);
        if (backend != ctx->params.backend || ctx->device_request)
            release_device(ctx);
        pkss__free(ctx->device_request);
        ctx->device_request = NULL;
    }
    if (what & PKSS_RESET_DEVICE)
        release_device(ctx);
    return PKSS_OK;
}

const char *pkss_context_device_name(const pkss_context *ctx)
{
    return ctx ? ctx->device_name : "";
}

pkss_status pkss_context_prepare(pkss_context *ctx)
{
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    if (ctx->prepared)
        return PKSS_OK;
    pkss__clear_error(ctx);
    int backend = ctx->params.backend;
    if (backend == PKSS_BACKEND_REFERENCE) {
        ctx->backend_in_use = PKSS_BACKEND_REFERENCE;
        snprintf(ctx->device_name, sizeof ctx->device_name,
                 "reference (C, CPU)");
        ctx->prepared = 1;
        return PKSS_OK;
    }
    pkss_status st = pkss__cl_prepare(ctx);
    if (st == PKSS_OK) {
        ctx->backend_in_use = PKSS_BACKEND_OPENCL;
        ctx->prepared = 1;
        return PKSS_OK;
    }
    if (backend == PKSS_BACKEND_AUTO &&
        (st == PKSS_ERR_NO_DEVICE || st == PKSS_ERR_UNSUPPORTED)) {
        /* AUTO falls back to the reference backend when there is no usable
         * device; the detail of why stays readable until the next call. */
        ctx->backend_in_use = PKSS_BACKEND_REFERENCE;
        snprintf(ctx->device_name, sizeof ctx->device_name,
                 "reference (C, CPU)");
        ctx->prepared = 1;
        return PKSS_OK;
    }
    return st;
}
