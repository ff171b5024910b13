/* SPDX-License-Identifier: MIT
 *
 * pkss.h -- robust global similarity registration of point clouds
 * (PKSS-Align: Lv & Huang, "Robust Point Cloud Registration on Pre-Kendall
 * Shape Space").
 *
 * This is the only public header. Read it top to bottom:
 *   Version      -- compile-time and run-time version numbers
 *   Status       -- every fallible call returns a pkss_status
 *   Context      -- one context holds parameters, the device and the last error
 *   Parameters   -- tunables, set one at a time; 0 always means "default"
 *   Devices      -- OpenCL devices as pkss sees them
 *   Clouds       -- a cloud prepared once and registered against many
 *   Evaluation   -- pkss_register() and its result
 *
 * FRAME CONVENTION (defined once, used everywhere):
 *   T_target_source maps source points into the target frame,
 *       x_t ~= s * R * x_s + t,   R in SO(3), s > 0,
 *   stored row-major as a 4x4 double matrix whose upper-left 3x3 is s*R.
 *
 * POINTS cross the ABI as caller-owned `const double *xyz` holding n points
 * row-major (x0 y0 z0 x1 y1 z1 ...). The library copies what it keeps and
 * never writes to caller input. Units are the caller's: no parameter is in
 * absolute units; distances are relative to each cloud's own size.
 *
 * THREAD SAFETY: global functions (version, status strings, parameter
 * bounds, device listing) are thread-safe. A context, and a cloud, must not
 * be used by two threads at once; use one context per thread. Different
 * contexts are independent and may run concurrently. Internally a call may
 * use one extra thread (the two clouds' pre-processing, the ICP's two
 * correspondence directions and its candidates run two at a time), plus
 * the OpenCL device's own threads.
 *
 * The declarations below contain no macros except PKSS_API, so that Python's
 * cffi can parse the block between the PKSS_CDEF markers as it is.
 */
#ifndef PKSS_H
#define PKSS_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32) && defined(PKSS_BUILDING_DLL)
#define PKSS_API __declspec(dllexport)
#elif defined(__GNUC__) && __GNUC__ >= 4
#define PKSS_API __attribute__((visibility("default")))
#else
#define PKSS_API
#endif

/* ===================================================================== */
/* Version                                                               */
/* ===================================================================== */
/* CMake reads these three lines: the version is defined here only. */
#define PKSS_VERSION_MAJOR 0
#define PKSS_VERSION_MINOR 1
#define PKSS_VERSION_PATCH 0
/* MAJOR*10000 + MINOR*100 + PATCH */
#define PKSS_VERSION_NUMBER 100

/* Largest number of candidates a result can hold (PKSS_PARAM_TOP_K max). */
#define PKSS_MAX_CANDIDATES 32
/* Size of the device name buffer in pkss_result and pkss_device_desc. */
#define PKSS_NAME_SIZE 128

#ifdef __cplusplus
extern "C" {
#endif

/* PKSS_CDEF_BEGIN */

/** pkss_version_number() :
 *  @return PKSS_VERSION_NUMBER of the library actually loaded at run time. */
PKSS_API unsigned pkss_version_number(void);

/** pkss_version_string() :
 *  @return "MAJOR.MINOR.PATCH", static storage. */
PKSS_API const char *pkss_version_string(void);

/** pkss_max_candidates() :
 *  @return PKSS_MAX_CANDIDATES, for bindings that cannot see macros. */
PKSS_API unsigned pkss_max_candidates(void);

/** pkss_build_info() :
 *  @return a static one-line description of how the library was built
 *          (version, compiler, whether OpenCL support is compiled in). */
PKSS_API const char *pkss_build_info(void);

/* ===================================================================== */
/* Status                                                                */
/* ===================================================================== */
/* Values are fixed and never reused. 1-99: caller errors; 100-199:
 * resources; 200-299: device/OpenCL; 300+: numerical. */
typedef enum pkss_status {
    PKSS_OK = 0,
    PKSS_ERR_NULL_ARGUMENT = 1,    /* a required pointer was NULL */
    PKSS_ERR_INVALID_ARGUMENT = 2, /* a value out of range / unknown enum */
    PKSS_ERR_EMPTY_INPUT = 3,      /* n = 0 */
    PKSS_ERR_TOO_FEW_POINTS = 4,   /* fewer than min_points usable points */
    PKSS_ERR_NONFINITE = 5,        /* NaN or Inf coordinate */
    PKSS_ERR_DEGENERATE = 6,       /* identical, collinear or coplanar points */
    PKSS_ERR_OUT_OF_RANGE = 7,     /* coordinates too large for float32 work */
    PKSS_ERR_UNKNOWN_PARAMETER = 8,/* pkss_param value not known */
    PKSS_ERR_WRONG_PARAMETER_TYPE = 9, /* int setter on a double param etc. */
    PKSS_ERR_OUT_OF_MEMORY = 100,
    PKSS_ERR_NO_DEVICE = 200,      /* no OpenCL platform/device available */
    PKSS_ERR_DEVICE = 201,         /* an OpenCL call failed (see detail) */
    PKSS_ERR_KERNEL_BUILD = 202,   /* kernel compilation failed (log in detail) */
    PKSS_ERR_UNSUPPORTED = 203,    /* device lacks a required feature, or the
                                      library was built without OpenCL */
    PKSS_ERR_NO_CONSENSUS = 300,   /* the search found no valid candidate */
    PKSS_ERR_INTERNAL = 399        /* a bug: please report it */
} pkss_status;

/** pkss_status_name() :
 *  @return the symbol, e.g. "PKSS_ERR_NONFINITE"; "PKSS_UNKNOWN_STATUS" for
 *          values not in the enum. Static storage, never NULL. */
PKSS_API const char *pkss_status_name(pkss_status status);

/** pkss_status_string() :
 *  @return a one-sentence description. Static storage, never NULL. */
PKSS_API const char *pkss_status_string(pkss_status status);

/* ===================================================================== */
/* Context                                                               */
/* ===================================================================== */
typedef struct pkss_context pkss_context;

/** pkss_context_create() :
 *  Allocates a context with default parameters. Opens no device.
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT or PKSS_ERR_OUT_OF_MEMORY;
 *          *out is NULL on failure. */
PKSS_API pkss_status pkss_context_create(pkss_context **out);

/** pkss_context_destroy() : frees everything; accepts NULL. */
PKSS_API void pkss_context_destroy(pkss_context *ctx);

/** pkss_context_prepare() :
 *  Opens the selected device and builds the kernels (OpenCL backend), or
 *  does nothing (reference backend). Registration calls it lazily, so
 *  calling it is optional; call it to fail early or to time it apart.
 *  Changing PKSS_PARAM_BACKEND or PKSS_PARAM_DEVICE afterwards releases the
 *  device; the next call prepares again. Blocks until done.
 *  @return PKSS_OK or a device status; the detail is in
 *          pkss_context_last_error(). */
PKSS_API pkss_status pkss_context_prepare(pkss_context *ctx);

/** pkss_context_last_error() :
 *  @return the detail of this context's last failure ("" if none). Valid
 *          until the next call on this context. Never NULL (for a NULL ctx
 *          returns a static message). */
PKSS_API const char *pkss_context_last_error(const pkss_context *ctx);

/** pkss_context_device_name() :
 *  @return the name of the device the context runs on after prepare:
 *          "reference (C, CPU)" or the OpenCL device name; "" before. */
PKSS_API const char *pkss_context_device_name(const pkss_context *ctx);

typedef enum pkss_reset {
    PKSS_RESET_PARAMS = 1, /* all parameters back to default */
    PKSS_RESET_DEVICE = 2, /* release the device and kernels */
    PKSS_RESET_ALL = 3
} pkss_reset;

/** pkss_context_reset() : @return PKSS_OK or PKSS_ERR_INVALID_ARGUMENT. */
PKSS_API pkss_status pkss_context_reset(pkss_context *ctx, pkss_reset what);

/* ===================================================================== */
/* Parameters                                                            */
/* ===================================================================== */
/* Every parameter: value 0 means "library default"; settings stick until
 * pkss_context_reset(ctx, PKSS_RESET_PARAMS). Out-of-range values are
 * rejected with PKSS_ERR_INVALID_ARGUMENT and leave the setting unchanged.
 * Switches take pkss_switch values. Section numbers refer to SPEC.md. */
typedef enum pkss_param {
    /* int: m, resampled points per cloud (SPEC 2.4). Default 3000,
     * range 256..20000. */
    PKSS_PARAM_POINTS = 100,
    /* int: n, rotation steps per axis of the Euler grid; the step is 2*pi/n
     * (SPEC 5). Default 12, range 4..36, even. */
    PKSS_PARAM_ROTATION_STEPS = 101,
    /* int: N, offsets per PCA axis of the translation search (SPEC 5).
     * Default 5 (125 offsets), range 1..9, odd; 1 disables the search. */
    PKSS_PARAM_OFFSET_STEPS = 102,
    /* int: azimuth bins of the cell partition; elevation bins are half of it
     * (SPEC 3). Default = rotation steps, range 4..48, even, and a multiple
     * of the rotation steps or not (then no shift factorisation). */
    PKSS_PARAM_CELL_STEPS = 103,
    /* switch: mutual-kNN outlier culling, Eq. 3 (SPEC 2.2). Default on. */
    PKSS_PARAM_CULL_MUTUAL = 110,
    /* switch: density-aware statistical outlier filter (SPEC 2.3).
     * Default on. */
    PKSS_PARAM_CULL_STAT = 111,
    /* switch: feature representatives and G_K = max(G_c, G_f), Eq. 7_3
     * (SPEC 2.6, 4.5). Default on. */
    PKSS_PARAM_USE_FEATURES = 112,
    /* double: share of resampled points kept as feature points by D_pca.
     * Default 0.10, range 0.01..0.5. */
    PKSS_PARAM_FEATURE_FRAC = 113,
    /* switch: PCA pre-alignment of the source to the template (SPEC 2.7).
     * Default on. */
    PKSS_PARAM_PCA_PREALIGN = 114,
    /* int: pkss_rotation_set. Default PKSS_ROTATIONS_EULER (744 distinct). */
    PKSS_PARAM_ROTATION_SET = 120,
    /* int: rotations in the uniform set. Default 1728, range 24..20000. */
    PKSS_PARAM_ROTATION_COUNT = 121,
    /* int: candidates kept after the search and refined (SPEC 5).
     * Default 10, range 1..PKSS_MAX_CANDIDATES. A second search (see
     * pkss_candidate) keeps as many more, up to PKSS_MAX_CANDIDATES in
     * all. */
    PKSS_PARAM_TOP_K = 122,
    /* switch: overlap-aware similarity ICP (SPEC 6). Default on; off
     * returns the best search candidate unrefined. */
    PKSS_PARAM_REFINE = 123,
    /* int: seed for every random choice. Default 0, range 0..2^31-1. */
    PKSS_PARAM_SEED = 130,
    /* int: above this many points an input is voxel-thinned first
     * (SPEC 2.1). Default 200000, range 1000..100000000. */
    PKSS_PARAM_MAX_RAW_POINTS = 131,
    /* switch: drop NaN/Inf points instead of failing (SPEC 1). Default off. */
    PKSS_PARAM_DROP_NONFINITE = 132,
    /* int: fewest finite points accepted (SPEC 1). Default 32, range
     * 16..1000000. */
    PKSS_PARAM_MIN_POINTS = 133,
    /* int: pkss_backend. Default PKSS_BACKEND_AUTO. */
    PKSS_PARAM_BACKEND = 140,
    /* string: device by index ("0", "1", ...) or by case-insensitive name
     * substring ("cpu", "pthread", "NVIDIA"). Default: the PKSS_DEVICE
     * environment variable, then the first GPU, then the first CPU. */
    PKSS_PARAM_DEVICE = 141
} pkss_param;

typedef enum pkss_switch {
    PKSS_SWITCH_DEFAULT = 0,
    PKSS_SWITCH_ON = 1,
    PKSS_SWITCH_OFF = 2
} pkss_switch;

typedef enum pkss_rotation_set {
    PKSS_ROTATIONS_DEFAULT = 0,
    PKSS_ROTATIONS_EULER = 1,  /* Eq. 10 grid, duplicates removed */
    PKSS_ROTATIONS_UNIFORM = 2 /* near-uniform super-Fibonacci SO(3) set */
} pkss_rotation_set;

typedef enum pkss_backend {
    PKSS_BACKEND_AUTO = 0,      /* OpenCL if a device exists, else reference */
    PKSS_BACKEND_REFERENCE = 1, /* plain C on the calling thread */
    PKSS_BACKEND_OPENCL = 2     /* OpenCL; fails with NO_DEVICE if none */
} pkss_backend;

/** pkss_context_set_int() / pkss_context_set_double() /
 *  pkss_context_set_string() :
 *  Sets one parameter. Integer parameters also accept set_double with an
 *  integral value; double parameters accept set_int.
 *  @return PKSS_OK, PKSS_ERR_UNKNOWN_PARAMETER, PKSS_ERR_WRONG_PARAMETER_TYPE
 *          or PKSS_ERR_INVALID_ARGUMENT (value out of range; detail says the
 *          range). set_string copies the string; NULL means default. */
PKSS_API pkss_status pkss_context_set_int(pkss_context *ctx, pkss_param param,
                                          long long value);
PKSS_API pkss_status pkss_context_set_double(pkss_context *ctx,
                                             pkss_param param, double value);
PKSS_API pkss_status pkss_context_set_string(pkss_context *ctx,
                                             pkss_param param,
                                             const char *value);

/** pkss_context_get_int() / pkss_context_get_double() :
 *  The value in force (the default resolved, never 0 for "default").
 *  get_double works for every numeric parameter. */
PKSS_API pkss_status pkss_context_get_int(const pkss_context *ctx,
                                          pkss_param param, long long *value);
PKSS_API pkss_status pkss_context_get_double(const pkss_context *ctx,
                                             pkss_param param, double *value);

/** pkss_param_bounds() :
 *  Valid range and default of a numeric parameter (switches: 0..2).
 *  @return PKSS_OK or PKSS_ERR_UNKNOWN_PARAMETER (also for string params). */
PKSS_API pkss_status pkss_param_bounds(pkss_param param, double *lower,
                                       double *upper, double *default_value);

/** pkss_param_name() : @return "points", "rotation_steps", ... or NULL for
 *  an unknown parameter. The names the bindings and tools use. */
PKSS_API const char *pkss_param_name(pkss_param param);

/* ===================================================================== */
/* Devices                                                               */
/* ===================================================================== */
typedef struct pkss_device_desc {
    char name[128];     /* PKSS_NAME_SIZE */
    char vendor[128];
    char platform[128];
    char version[128];  /* CL_DEVICE_VERSION */
    int is_gpu;         /* 1 GPU, 0 CPU or other */
    int has_fp64;
    unsigned compute_units;
    unsigned long long global_mem_bytes;
} pkss_device_desc;

/** pkss_device_count() :
 *  Lists OpenCL devices of all platforms, in platform then device order;
 *  the indices are those PKSS_PARAM_DEVICE takes.
 *  @return PKSS_OK (possibly with *count = 0 when no platform is
 *          installed), PKSS_ERR_NULL_ARGUMENT or PKSS_ERR_UNSUPPORTED
 *          (built without OpenCL). Thread-safe. */
PKSS_API pkss_status pkss_device_count(unsigned *count);

/** pkss_device_info() : describes device `index` (see pkss_device_count).
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT, PKSS_ERR_INVALID_ARGUMENT
 *          (index out of range) or PKSS_ERR_UNSUPPORTED. */
PKSS_API pkss_status pkss_device_info(unsigned index, pkss_device_desc *out);

/** pkss_no_device_reason() : @return a static sentence saying why no
 *  device is listed and how to install one (PoCL on Debian). */
PKSS_API const char *pkss_no_device_reason(void);

/* ===================================================================== */
/* Clouds                                                                */
/* ===================================================================== */
/* A cloud holds one input after pre-processing (SPEC 2: validation,
 * thinning, outlier culling, resampling to m points, pre-shape mapping,
 * features, PCA). Prepare a template once and register many sources against
 * it. Pre-processing uses the parameters of the context at creation time. */
typedef struct pkss_cloud pkss_cloud;

/** Points kept after each pre-processing step of one cloud. */
typedef struct pkss_counts {
    uint64_t input;       /* n given */
    uint64_t nonfinite;   /* dropped as NaN/Inf (drop_nonfinite on) */
    uint64_t thinned;     /* after dropping duplicates and voxel thinning */
    uint64_t after_mutual;/* after mutual-kNN culling */
    uint64_t after_stat;  /* after the statistical filter */
    uint64_t resampled;   /* m, or fewer if the cleaned cloud is smaller */
    uint64_t features;    /* feature points */
    uint64_t duplicates;  /* exact duplicate points dropped (before thinning) */
} pkss_counts;

/** pkss_cloud_create() :
 *  Validates and pre-processes xyz (n points, row-major). Copies the data.
 *  @return PKSS_OK or a caller/numerical status with the detail in the
 *          context (e.g. "point 17 has a NaN coordinate"). *out is NULL on
 *          failure. Blocks until done. */
PKSS_API pkss_status pkss_cloud_create(pkss_context *ctx, const double *xyz,
                                       size_t n, pkss_cloud **out);

/** pkss_cloud_destroy() : accepts NULL. */
PKSS_API void pkss_cloud_destroy(pkss_cloud *cloud);

/** pkss_cloud_counts() : points kept by each step. */
PKSS_API pkss_status pkss_cloud_counts(const pkss_cloud *cloud,
                                       pkss_counts *out);

/** pkss_cloud_size() : @return the number of resampled points (0 for NULL). */
PKSS_API size_t pkss_cloud_size(const pkss_cloud *cloud);

/** pkss_cloud_points() :
 *  Copies the resampled points, in the caller's original coordinates, into
 *  xyz (capacity points). @return PKSS_ERR_INVALID_ARGUMENT if capacity is
 *  smaller than pkss_cloud_size(). */
PKSS_API pkss_status pkss_cloud_points(const pkss_cloud *cloud, double *xyz,
                                       size_t capacity);

/* ===================================================================== */
/* Evaluation                                                            */
/* ===================================================================== */

/** One candidate pose kept by the search (SPEC 5) and refined (SPEC 6).
 *  Its pose is the search's (Eq. 7-9, unrefined) if refine is off, or if
 *  one of the two best-scored candidates already covered both clouds
 *  (overlap >= 0.98 after its coarse level): the others are then only
 *  scored, not refined.
 *  When the winner of the search covers neither cloud (a part of an object
 *  whose centroid lies beyond the paper's offset grid, or two partial
 *  scans), a second search runs on a wide offset grid (the same
 *  offset_steps^3 offsets at twice the step, +-E/2 along the template's PCA
 *  axes) and its candidates follow the first search's; the winner is the
 *  best of both. The second search scores with a trimmed G: the 80 % of
 *  the matched cells that the pairs' best rotation fits best (the cells
 *  that look into a missing part are left out), so its candidates' score,
 *  score_contour and score_feature are trimmed G values.
 *  Once a fully refined candidate covers both clouds (overlap >= 0.98),
 *  the search's remaining candidates get no full refinement: they are
 *  reported after their coarse level (or at the search's pose, above).
 *  The winner is the fully refined candidate with the highest fit
 *  (pkss_result.candidate_fit: the overlap score within 1 spacing instead
 *  of 2), ties within 0.003 going to the lower rms.
 *  How far each candidate got is in pkss_result.candidate_stage. */
typedef struct pkss_candidate {
    double T_target_source[16]; /* refined pose (see above) */
    double scale;               /* s of T_target_source */
    double score;               /* G_K of the search, radians, [0, pi] */
    double score_contour;       /* G of the contour representatives */
    double score_feature;       /* G of the feature representatives */
    double rms;                 /* RMS of final mutual pairs, target units */
    double overlap;             /* overlap score in [0, 1]: sqrt(f_s f_t),
                                   f = share of each cloud's resampled
                                   points within 2 spacings of the other */
    uint32_t rotation_index;    /* index into the rotation candidate set */
    uint32_t offset_index;      /* index into the offset candidate set;
                                   n_offsets + i: offset i of the wide
                                   grid (second search) */
} pkss_candidate;

/** How far a candidate's refinement went (pkss_result.candidate_stage). */
typedef enum pkss_candidate_stage {
    PKSS_STAGE_SEARCH = 0,  /* the search's pose (Eq. 7-9), scored on all
                               points: refine off, or left out (above) */
    PKSS_STAGE_COARSE = 1,  /* the coarse rigid level (a quarter of the
                               points), then scored on all points */
    PKSS_STAGE_STOPPED = 2, /* full refinement stopped short: projected to
                               end behind the refined leader, or arrived
                               in a refined candidate's minimum */
    PKSS_STAGE_REFINED = 3  /* full refinement to its end: may win */
} pkss_candidate_stage;

/** Seconds spent in each stage (wall clock). */
typedef struct pkss_timings {
    double validate;
    double preprocess; /* thinning + culling + resampling + features + PCA */
    double search;     /* binning + scoring + selection */
    double refine;
    double total;
} pkss_timings;

/** Everything pkss_register() returns. The caller owns it (stack is fine).
 *  Set struct_size = sizeof(pkss_result) (pkss_result_init does that):
 *  a later library version then writes only the fields this caller knows. */
typedef struct pkss_result {
    size_t struct_size;
    double T_target_source[16]; /* row-major 4x4, upper-left 3x3 = s*R */
    double scale;               /* s > 0 */
    double rotation[9];         /* R, row-major, det +1 */
    double translation[3];      /* t */
    double score;               /* winner's G_K, radians (smaller = better;
                                   trimmed if from the second search) */
    double rms;                 /* winner's RMS, target units */
    double overlap;             /* winner's overlap score in [0, 1] */
    uint32_t winner;            /* index of the winner in candidates[] */
    uint32_t n_candidates;      /* entries used in candidates[] */
    pkss_candidate candidates[32]; /* PKSS_MAX_CANDIDATES, best score
                                      first (each search's, see above) */
    uint32_t n_rotations;       /* rotation candidates searched */
    uint32_t n_offsets;         /* offset candidates per search */
    uint64_t n_evaluations;     /* shape measurements computed (both
                                   searches, if a second one ran) */
    pkss_counts source_counts;
    pkss_counts target_counts;
    pkss_timings timings;
    int backend;                /* pkss_backend actually used */
    char device[128];           /* device name (PKSS_NAME_SIZE) */
    /* Appended (a caller built against an older pkss.h sets a smaller
     * struct_size and does not receive them): */
    double fit;                 /* winner's fit in [0, 1]: the overlap score
                                   within 1 spacing instead of 2, which
                                   picks the winner among the refined
                                   candidates (fit <= overlap) */
    double candidate_fit[32];   /* each candidate's fit, as candidates[] */
    uint32_t candidate_stage[32]; /* each candidate's pkss_candidate_stage,
                                     as candidates[] */
} pkss_result;

/** pkss_result_init() : zeroes *result and sets struct_size. */
PKSS_API void pkss_result_init(pkss_result *result);

/** pkss_register() :
 *  Registers source onto target: finds s, R, t with target ~= s*R*source+t
 *  without an initial guess. Both inputs are n x 3 row-major doubles and are
 *  only read. Equivalent to creating two clouds and calling
 *  pkss_register_clouds().
 *  @return PKSS_OK and a filled *result, or an error status with the detail
 *          in pkss_context_last_error(); on error *result holds no pose
 *          (n_candidates = 0, T all zero). Blocks until done. */
PKSS_API pkss_status pkss_register(pkss_context *ctx, const double *source,
                                   size_t n_source, const double *target,
                                   size_t n_target, pkss_result *result);

/** pkss_register_clouds() :
 *  Same as pkss_register() on prepared clouds (from any context). The
 *  search and refinement parameters are this context's; pre-processing was
 *  done at cloud creation. */
PKSS_API pkss_status pkss_register_clouds(pkss_context *ctx,
                                          const pkss_cloud *source,
                                          const pkss_cloud *target,
                                          pkss_result *result);

/* PKSS_CDEF_END */

#ifdef __cplusplus
}
#endif

#endif /* PKSS_H */
