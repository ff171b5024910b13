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
typedef struct param_desc {
    pkss_param id;
    const char *name;
    pkss_param_type type;
    double lo, hi, def;
    size_t offset;   /* into pkss__params (int, double or long long) */
    int is_ll;       /* long long field */
    const char *unit, *choices, *constraint, *doc;
} param_desc;

/* The one table of parameter facts (pkss_param_at() publishes it; the CLI,
 * the Python binding and the README are generated from it or checked
 * against it by tests). Section numbers refer to docs/spec.md. */
#define OFF(f) offsetof(pkss__params, f)
#define SW "default|on|off"
static const param_desc PARAMS[] = {
    {PKSS_PARAM_POINTS, "points", PKSS_TYPE_INT, 256, 20000, 3000, OFF(points), 0,
     "points", "", "",
     "m, points each cloud is resampled to (SPEC 2.4)"},
    {PKSS_PARAM_ROTATION_STEPS, "rotation_steps", PKSS_TYPE_INT, 4, 36, 12, OFF(rotation_steps), 0,
     "steps", "", "even",
     "n, Euler grid steps per axis; the step is 2*pi/n (SPEC 5)"},
    {PKSS_PARAM_OFFSET_STEPS, "offset_steps", PKSS_TYPE_INT, 1, 9, 5, OFF(offset_steps), 0,
     "steps", "", "odd",
     "N, centre offsets per PCA axis (N^3 in all); 1 disables the offset search (SPEC 5)"},
    {PKSS_PARAM_CELL_STEPS, "cell_steps", PKSS_TYPE_INT, 4, 48, 12, OFF(cell_steps), 0,
     "bins", "", "even",
     "azimuth bins of the cell partition, elevation bins half of it; default follows rotation_steps (SPEC 3)"},
    {PKSS_PARAM_CULL_MUTUAL, "cull_mutual", PKSS_TYPE_SWITCH, 0, 2, 1, OFF(cull_mutual), 0,
     "", SW, "",
     "mutual-kNN outlier culling, Eq. 3 (SPEC 2.2)"},
    {PKSS_PARAM_CULL_STAT, "cull_stat", PKSS_TYPE_SWITCH, 0, 2, 1, OFF(cull_stat), 0,
     "", SW, "",
     "density-aware statistical outlier filter (SPEC 2.3)"},
    {PKSS_PARAM_USE_FEATURES, "use_features", PKSS_TYPE_SWITCH, 0, 2, 1, OFF(use_features), 0,
     "", SW, "",
     "feature representatives and G_K = max(G_c, G_f), Eq. 7_3 (SPEC 2.6, 4.5)"},
    {PKSS_PARAM_FEATURE_FRAC, "feature_frac", PKSS_TYPE_DOUBLE, 0.01, 0.5, 0.10, OFF(feature_frac), 0,
     "fraction", "", "",
     "share of the resampled points kept as feature points by D_pca (SPEC 2.6)"},
    {PKSS_PARAM_PCA_PREALIGN, "pca_prealign", PKSS_TYPE_SWITCH, 0, 2, 1, OFF(pca_prealign), 0,
     "", SW, "",
     "PCA pre-alignment of the source to the template (SPEC 2.7)"},
    {PKSS_PARAM_ROTATION_SET, "rotation_set", PKSS_TYPE_CHOICE, 0, 2, PKSS_ROTATIONS_EULER, OFF(rotation_set), 0,
     "", "default|euler|uniform", "",
     "rotation candidates: the Eq. 10 Euler grid (744 distinct) or a near-uniform SO(3) set"},
    {PKSS_PARAM_ROTATION_COUNT, "rotation_count", PKSS_TYPE_INT, 24, 20000, 1728, OFF(rotation_count), 0,
     "rotations", "", "",
     "rotations in the uniform set (rotation_set uniform)"},
    {PKSS_PARAM_TOP_K, "top_k", PKSS_TYPE_INT, 1, PKSS_MAX_CANDIDATES, 10, OFF(top_k), 0,
     "candidates", "", "",
     "candidates kept by each search and refined (SPEC 5)"},
    {PKSS_PARAM_REFINE, "refine", PKSS_TYPE_SWITCH, 0, 2, 1, OFF(refine), 0,
     "", SW, "",
     "overlap-aware similarity ICP; off returns the best search candidate unrefined (SPEC 6)"},
    {PKSS_PARAM_SEED, "seed", PKSS_TYPE_INT, 0, 2147483647.0, 0, OFF(seed), 1,
     "", "", "",
     "seed of every random choice"},
    {PKSS_PARAM_MAX_RAW_POINTS, "max_raw_points", PKSS_TYPE_INT, 1000, 100000000.0, 200000, OFF(max_raw_points), 1,
     "points", "", "",
     "inputs larger than this are voxel-thinned first (SPEC 2.1)"},
    {PKSS_PARAM_DROP_NONFINITE, "drop_nonfinite", PKSS_TYPE_SWITCH, 0, 2, 0, OFF(drop_nonfinite), 0,
     "", SW, "",
     "drop NaN/Inf points instead of failing (SPEC 1)"},
    {PKSS_PARAM_MIN_POINTS, "min_points", PKSS_TYPE_INT, 16, 1000000, 64, OFF(min_points), 0,
     "points", "", "",
     "fewest usable points accepted per cloud; below 64 a wrong pose may be returned (SPEC 1)"},
    {PKSS_PARAM_BACKEND, "backend", PKSS_TYPE_CHOICE, 0, 2, PKSS_BACKEND_AUTO, OFF(backend), 0,
     "", "auto|reference|opencl", "",
     "auto: OpenCL if a device exists, else the C reference; opencl fails without a device"},
    {PKSS_PARAM_DEVICE, "device", PKSS_TYPE_STRING, 0, 0, 0, 0, 0,
     "", "", "",
     "OpenCL device by index or case-insensitive name substring; default $PKSS_DEVICE, then the first GPU, then the first CPU"},
};
#undef SW
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
    if (d->type == PKSS_TYPE_DOUBLE)
        *(double *)(base + d->offset) = v;
    else if (d->is_ll)
        *(long long *)(base + d->offset) = (long long)v;
    else
        *(int *)(base + d->offset) = (int)v;
}

static double load(const pkss__params *p, const param_desc *d)
{
    const char *base = (const char *)p;
    if (d->type == PKSS_TYPE_DOUBLE)
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
        if (d->type == PKSS_TYPE_STRING)
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

void pkss_param_info_init(pkss_param_info *info, size_t struct_size)
{
    if (info)
        pkss__struct_init(info, struct_size);
}

size_t pkss_param_count(void) { return N_PARAMS; }

pkss_status pkss_param_at(size_t index, pkss_param_info *info)
{
    if (!info)
        return PKSS_ERR_NULL_ARGUMENT;
    if (index >= N_PARAMS || info->struct_size < sizeof(size_t))
        return PKSS_ERR_INVALID_ARGUMENT;
    const param_desc *d = &PARAMS[index];
    pkss_param_info full = {sizeof full, (int32_t)d->id, (int32_t)d->type,
                            d->name, d->type == PKSS_TYPE_SWITCH ? 0 : d->lo,
                            d->hi, 0, d->unit, d->choices, d->constraint,
                            d->doc};
    full.default_value = d->type == PKSS_TYPE_SWITCH
                             ? (d->def ? PKSS_SWITCH_ON : PKSS_SWITCH_OFF)
                             : d->def;
    pkss__deliver_param_info(info, &full);
    return PKSS_OK;
}

pkss_status pkss_param_find(const char *name, pkss_param *param)
{
    if (!name || !param)
        return PKSS_ERR_NULL_ARGUMENT;
    for (size_t i = 0; i < N_PARAMS; ++i)
        if (strcmp(PARAMS[i].name, name) == 0) {
            *param = PARAMS[i].id;
            return PKSS_OK;
        }
    return PKSS_ERR_UNKNOWN_PARAMETER;
}

pkss_status pkss_context_set_progress(pkss_context *ctx, pkss_progress_fn fn,
                                      void *user_data)
{
    if (!ctx)
        return PKSS_ERR_NULL_ARGUMENT;
    ctx->progress_fn = fn;
    ctx->progress_user = user_data;
    return PKSS_OK;
}

pkss_status pkss_context_candidate(const pkss_context *ctx, size_t index,
                                   pkss_candidate *candidate)
{
    if (!ctx || !candidate)
        return PKSS_ERR_NULL_ARGUMENT;
    if (index >= ctx->n_candidates || candidate->struct_size < sizeof(size_t))
        return PKSS_ERR_INVALID_ARGUMENT;
    pkss__deliver_candidate(candidate, &ctx->candidates[index]);
    return PKSS_OK;
}

pkss_status pkss_context_alternative(const pkss_context *ctx, size_t index,
                                     pkss_alternative *alternative)
{
    if (!ctx || !alternative)
        return PKSS_ERR_NULL_ARGUMENT;
    /* a failed call leaves no candidates, hence no alternatives either */
    if (ctx->n_candidates == 0 || index >= ctx->assess.n_alt ||
        alternative->struct_size < sizeof(size_t))
        return PKSS_ERR_INVALID_ARGUMENT;
    pkss__deliver_alternative(alternative, &ctx->assess.alt[index]);
    return PKSS_OK;
}

pkss_status pkss_param_bounds(pkss_param param, double *lower, double *upper,
                              double *default_value)
{
    const param_desc *d = find_param(param);
    if (!d || d->type == PKSS_TYPE_STRING)
        return PKSS_ERR_UNKNOWN_PARAMETER;
    if (lower)
        *lower = d->type == PKSS_TYPE_SWITCH ? 0 : d->lo;
    if (upper)
        *upper = d->hi;
    if (default_value)
        *default_value = d->type == PKSS_TYPE_SWITCH ? (d->def ? PKSS_SWITCH_ON : PKSS_SWITCH_OFF) : d->def;
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
    PKSS_RETURN_IF(d->type == PKSS_TYPE_STRING, ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
                   "parameter '%s' takes a string (pkss_context_set_string)",
                   d->name);
    PKSS_RETURN_IF(!isfinite(v), ctx, PKSS_ERR_INVALID_ARGUMENT,
                   "parameter '%s': value is not finite", d->name);
    if (d->type != PKSS_TYPE_DOUBLE && !from_int) {
        PKSS_RETURN_IF(v != floor(v), ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
                       "parameter '%s' is an integer; got %g", d->name, v);
    }
    double value;
    if (d->type == PKSS_TYPE_SWITCH) {
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
    PKSS_RETURN_IF(d->type != PKSS_TYPE_STRING, ctx, PKSS_ERR_WRONG_PARAMETER_TYPE,
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
    if (d->type == PKSS_TYPE_STRING)
        return PKSS_ERR_WRONG_PARAMETER_TYPE;
    if (param == PKSS_PARAM_CELL_STEPS && ctx->params.cell_steps == 0)
        *value = ctx->params.rotation_steps;
    else if (d->type == PKSS_TYPE_SWITCH) /* report pkss_switch values, as set */
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
    if (d->type == PKSS_TYPE_DOUBLE)
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
    ctx->fallback_note[0] = '\0';
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
         * device; the reason goes into every result (PKSS_FLAG_FELL_BACK)
         * and stays readable in the detail until the next call. */
        snprintf(ctx->fallback_note, sizeof ctx->fallback_note,
                 "no OpenCL device used (%.200s): ran on the reference backend",
                 ctx->detail);
        ctx->backend_in_use = PKSS_BACKEND_REFERENCE;
        snprintf(ctx->device_name, sizeof ctx->device_name,
                 "reference (C, CPU)");
        ctx->prepared = 1;
        return PKSS_OK;
    }
    return st;
}
