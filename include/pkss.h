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
 *   Progress     -- a callback that reports progress and can cancel
 *   Clouds       -- a cloud prepared once and registered against many
 *   Evaluation   -- pkss_register(), its result and its candidates
 *   Batches      -- serialised clouds, one source against many templates
 *
 * COMPATIBILITY (docs/compatibility.md): within 1.x nothing declared here is
 * removed, renumbered or changes meaning. Structs that may grow start with
 * `size_t struct_size`, set by their *_init(ptr, sizeof *ptr): the library
 * fills only the whole fields that size covers, so a caller built against
 * an older 1.x header stays safe. Fields marked EXPERIMENTAL may change in
 * a minor release (they sit after the stable ones).
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
 * contexts are independent and may run concurrently. Internally a call
 * uses one extra thread, created at its first use and joined before the
 * call returns, for the two clouds' pre-processing, candidates two at a
 * time and the two directions of a correspondence pass; plus the OpenCL
 * device's own threads. The first pkss_register() of a process that needs
 * a device also starts the OpenCL driver (loading it is process-wide) on a
 * short-lived thread while the clouds are pre-processed, joined before the
 * device is opened.
 *
 * "SPEC N" is section N of docs/spec.md, which pins down what the paper
 * leaves open; "Eq. N" is the paper's equation N.
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
#define PKSS_VERSION_MAJOR 1
#define PKSS_VERSION_MINOR 0
#define PKSS_VERSION_PATCH 0
/* MAJOR*10000 + MINOR*100 + PATCH */
#define PKSS_VERSION_NUMBER 10000

/* Largest number of candidates a result can hold (PKSS_PARAM_TOP_K max). */
#define PKSS_MAX_CANDIDATES 32
/* Size of the device name buffer in pkss_result and pkss_device_desc. */
#define PKSS_NAME_SIZE 128
/* Size of pkss_result.note. */
#define PKSS_NOTE_SIZE 256

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
    PKSS_ERR_CANCELLED = 10,       /* the progress callback asked to stop */
    PKSS_ERR_FORMAT = 11,          /* a file's content is malformed or truncated */
    PKSS_ERR_UNSUPPORTED_FORMAT = 12, /* a valid file variant no reader handles */
    PKSS_ERR_CORRUPT_DATA = 13,    /* serialised bytes truncated, corrupt or
                                      not a pkss cloud (see detail) */
    PKSS_ERR_STALE_DATA = 14,      /* serialised by another library version or
                                      format, or prepared under other
                                      parameters (see detail) */
    PKSS_ERR_OUT_OF_MEMORY = 100,
    PKSS_ERR_IO = 101,             /* a file cannot be opened, read or written */
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
 * Switches take pkss_switch values. The range, default, unit and a one-line
 * description of every parameter come from pkss_param_at(): that table is
 * the one source of these facts (the CLI, the Python binding and the
 * README are generated from it or checked against it). */
typedef enum pkss_param {
    PKSS_PARAM_POINTS = 100,          /* int: m, resampled points per cloud */
    PKSS_PARAM_ROTATION_STEPS = 101,  /* int: n, Euler grid steps per axis */
    PKSS_PARAM_OFFSET_STEPS = 102,    /* int: N, centre offsets per PCA axis */
    PKSS_PARAM_CELL_STEPS = 103,      /* int: azimuth bins of the cells */
    PKSS_PARAM_CULL_MUTUAL = 110,     /* switch: mutual-kNN culling, Eq. 3 */
    PKSS_PARAM_CULL_STAT = 111,       /* switch: statistical outlier filter */
    PKSS_PARAM_USE_FEATURES = 112,    /* switch: feature cells, Eq. 7_3 */
    PKSS_PARAM_FEATURE_FRAC = 113,    /* double: share kept as features */
    PKSS_PARAM_PCA_PREALIGN = 114,    /* switch: PCA pre-alignment */
    PKSS_PARAM_ROTATION_SET = 120,    /* choice: pkss_rotation_set */
    PKSS_PARAM_ROTATION_COUNT = 121,  /* int: rotations of the uniform set */
    PKSS_PARAM_TOP_K = 122,           /* int: candidates kept per search */
    PKSS_PARAM_REFINE = 123,          /* switch: similarity ICP */
    PKSS_PARAM_SEED = 130,            /* int: seed of every random choice */
    PKSS_PARAM_MAX_RAW_POINTS = 131,  /* int: voxel-thin inputs above this */
    PKSS_PARAM_DROP_NONFINITE = 132,  /* switch: drop NaN/Inf points */
    PKSS_PARAM_MIN_POINTS = 133,      /* int: fewest usable points */
    PKSS_PARAM_BACKEND = 140,         /* choice: pkss_backend */
    PKSS_PARAM_DEVICE = 141           /* string: OpenCL device */
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

/** Kinds of parameter value (pkss_param_info.type). */
typedef enum pkss_param_type {
    PKSS_TYPE_INT = 1,    /* integer in [lower, upper] */
    PKSS_TYPE_DOUBLE = 2, /* real in [lower, upper] */
    PKSS_TYPE_SWITCH = 3, /* pkss_switch: 0 default, 1 on, 2 off */
    PKSS_TYPE_CHOICE = 4, /* an enum: values 0..upper named in `choices` */
    PKSS_TYPE_STRING = 5  /* pkss_context_set_string() */
} pkss_param_type;

/** Everything known about one parameter. Strings are static storage. */
typedef struct pkss_param_info {
    size_t struct_size;      /* set by pkss_param_info_init() */
    int32_t id;              /* pkss_param */
    int32_t type;            /* pkss_param_type */
    const char *name;        /* as pkss_param_name() */
    double lower, upper;     /* valid range (0 = default is always valid) */
    double default_value;    /* switches and choices: the value's number */
    const char *unit;        /* "points", "steps", "fraction", "" ... */
    const char *choices;     /* switch/choice: '|'-separated names of the
                                values 0, 1, 2, ...; "" otherwise */
    const char *constraint;  /* "even", "odd" or "" */
    const char *doc;         /* one line, no trailing period */
} pkss_param_info;

/** pkss_param_info_init() : zeroes struct_size bytes, sets struct_size. */
PKSS_API void pkss_param_info_init(pkss_param_info *info, size_t struct_size);

/** pkss_param_count() : @return the number of parameters (pkss_param_at). */
PKSS_API size_t pkss_param_count(void);

/** pkss_param_at() : describes parameter `index` (0 .. count-1), in the
 *  order of the pkss_param enum.
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT, PKSS_ERR_INVALID_ARGUMENT
 *          (index out of range or struct_size too small). */
PKSS_API pkss_status pkss_param_at(size_t index, pkss_param_info *info);

/** pkss_param_find() : the parameter called `name` (as pkss_param_name).
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT or PKSS_ERR_UNKNOWN_PARAMETER. */
PKSS_API pkss_status pkss_param_find(const char *name, pkss_param *param);

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
/* Progress                                                              */
/* ===================================================================== */
/** The stage a call is in (pkss_progress.stage), in pipeline order. */
typedef enum pkss_progress_stage {
    PKSS_PROGRESS_DEVICE = 1,     /* opening the device, building kernels */
    PKSS_PROGRESS_PREPROCESS = 2, /* validation .. PCA of the clouds */
    PKSS_PROGRESS_SEARCH = 3,     /* the global search (step: batch) */
    PKSS_PROGRESS_REFINE = 4,     /* refinement (step: candidate) */
    PKSS_PROGRESS_DONE = 5        /* the call is about to return */
} pkss_progress_stage;

/** What the progress callback is told. Library-owned, valid during the
 *  callback only. */
typedef struct pkss_progress {
    size_t struct_size;  /* the library's sizeof(pkss_progress) */
    int32_t stage;       /* pkss_progress_stage */
    uint32_t step;       /* work done within the stage ... */
    uint32_t steps;      /* ... out of this much (0: unknown) */
    double elapsed;      /* seconds since the call began */
} pkss_progress;

/** A progress callback: return 0 to go on, anything else to cancel; the
 *  call then returns PKSS_ERR_CANCELLED promptly (within one refinement
 *  iteration or search batch) and holds no pose. It runs on the thread
 *  that made the call, never concurrently, at each stage change and about
 *  every 20 ms of work (less often only inside a step that cannot be cut,
 *  such as one kd-tree build). It must not call pkss on the same context. */
typedef int (*pkss_progress_fn)(void *user_data, const pkss_progress *progress);

/** pkss_context_set_progress() : installs fn (NULL removes it) for the
 *  calls on ctx that pre-process or register.
 *  @return PKSS_OK or PKSS_ERR_NULL_ARGUMENT (ctx). */
PKSS_API pkss_status pkss_context_set_progress(pkss_context *ctx,
                                               pkss_progress_fn fn,
                                               void *user_data);

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
    uint64_t thinned;     /* after dropping duplicates, voxel thinning and
                             the uniform subset culling sees (at most a
                             fixed multiple of m: docs/design.md step 4b) */
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

/** One candidate pose kept by the search (SPEC 5) and refined (SPEC 6);
 *  read with pkss_context_candidate(). The pipeline that produced it, and
 *  which candidates get which refinement, is in docs/design.md. */
typedef struct pkss_candidate {
    size_t struct_size;         /* set by pkss_candidate_init() */
    double T_target_source[16]; /* its pose, row-major 4x4 */
    double scale;               /* s of T_target_source */
    double score;               /* G_K of the search, radians, [0, pi]
                                   (trimmed G for the wide search) */
    double score_contour;       /* G of the contour representatives */
    double score_feature;       /* G of the feature representatives */
    double rms;                 /* RMS of final mutual pairs, target units */
    double overlap;             /* sqrt(f_s f_t), f = share of each cloud's
                                   resampled points within 2 spacings of
                                   the other, in [0, 1] */
    double fit;                 /* the same within 1 spacing; the winner
                                   among refined candidates has the highest
                                   fit * fit / overlap (docs/design.md) */
    uint32_t stage;             /* pkss_candidate_stage: how far it got */
    uint32_t rotation_index;    /* index into the rotation candidate set */
    uint32_t offset_index;      /* index into the offset set of its search */
    uint32_t search;            /* 0: the paper's offset grid; 1: the wide
                                   second search; 2: a shift of the winner
                                   (its rotation and scale, another
                                   translation; added after 1.0); 3: a
                                   local-feature match where both clouds
                                   are parts (no grid: rotation_index and
                                   offset_index UINT32_MAX; scores: the
                                   paper's G at its start pose; added
                                   after 1.0); 4: a shift of a candidate
                                   at another rotation, where the winner
                                   lies astray (its rotation and scale,
                                   another translation; added after 1.0);
                                   5: the winner at another scale where
                                   both clouds are parts (its rotation,
                                   another scale and translation; added
                                   after 1.0). Shifts (2, 4, 5) keep their
                                   source's grid indices: UINT32_MAX if it
                                   was a 3 */
} pkss_candidate;

/** How far a candidate's refinement went (pkss_candidate.stage). */
typedef enum pkss_candidate_stage {
    PKSS_STAGE_SEARCH = 0,  /* the search's pose (Eq. 7-9), scored on all
                               points: refine off, or left out */
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

/** pkss_result.flags: what the call did that the caller may not expect. */
typedef enum pkss_result_flag {
    /* backend AUTO found no usable device (or none matching the device
     * string) and ran on the reference backend; the reason is in note */
    PKSS_FLAG_FELL_BACK = 1
} pkss_result_flag;

/** Everything pkss_register() returns. The caller owns it (stack is fine);
 *  initialise it with pkss_result_init(&res, sizeof res). */
typedef struct pkss_result {
    size_t struct_size;         /* set by pkss_result_init() */
    double T_target_source[16]; /* row-major 4x4, upper-left 3x3 = s*R */
    double scale;               /* s > 0 */
    double rotation[9];         /* R, row-major, det +1 */
    double translation[3];      /* t */
    double score;               /* winner's G_K, radians (smaller = better) */
    double rms;                 /* winner's RMS, target units */
    double overlap;             /* winner's overlap score in [0, 1] */
    double fit;                 /* winner's fit in [0, 1] (fit <= overlap) */
    uint32_t winner;            /* the winner's candidate index */
    uint32_t n_candidates;      /* candidates (pkss_context_candidate) */
    uint32_t n_rotations;       /* rotation candidates searched */
    uint32_t n_offsets;         /* offset candidates per search */
    uint64_t n_evaluations;     /* shape measurements computed */
    pkss_counts source_counts;
    pkss_counts target_counts;
    pkss_timings timings;
    int32_t backend;            /* pkss_backend actually used */
    uint32_t flags;             /* pkss_result_flag bits */
    char device[128];           /* device name (PKSS_NAME_SIZE) */
    char note[256];             /* why a flag is set, or "" (PKSS_NOTE_SIZE) */
    /* EXPERIMENTAL (may change in a 1.x minor release): */
    double prepare_seconds;     /* device preparation within this call */
    /* Added after 1.0 (stable; filled when struct_size covers them): how
     * far to trust the pose (docs/design.md, "Confidence and ambiguity"). */
    double confidence;          /* estimated probability in [0, 1] that the
                                   pose is right: rotation < 5 deg,
                                   translation < 2 % of the diameter, scale
                                   < 2 %, or equivalent under a symmetry */
    uint32_t ambiguous;         /* 1: other poses fit as well as this one
                                   within the fit's noise (the
                                   alternatives, or a continuous symmetry) */
    uint32_t n_alternatives;    /* poses read by pkss_context_alternative() */
    int32_t symmetry;           /* pkss_symmetry, tested on the data */
    uint32_t symmetry_order;    /* DISCRETE: n of the 360/n-degree turn
                                   about symmetry_axis that fits (0: none
                                   is a whole fraction of a turn) */
    double symmetry_axis[3];    /* unit axis in the target frame through
                                   symmetry_center: AXIAL the shape's axis,
                                   DISCRETE the first alternative's; else 0 */
    double symmetry_center[3];  /* a point on that axis (the target's
                                   centroid), target units */
} pkss_result;

/** Symmetry of the registered shape (pkss_result.symmetry), found by turning
 *  the aligned source about the target's centre and measuring the fit. */
typedef enum pkss_symmetry {
    PKSS_SYMMETRY_NONE = 0,      /* no other pose fits as well */
    PKSS_SYMMETRY_DISCRETE = 1,  /* a few other poses fit as well: listed
                                    by pkss_context_alternative() */
    PKSS_SYMMETRY_AXIAL = 2,     /* any turn about symmetry_axis fits
                                    (a cylinder, a cone): not listed */
    PKSS_SYMMETRY_SPHERICAL = 3  /* any turn fits (a sphere) */
} pkss_symmetry;

/** Another pose that fits as well as the result's (pkss_result.ambiguous);
 *  read with pkss_context_alternative(). */
typedef struct pkss_alternative {
    size_t struct_size;         /* set by pkss_alternative_init() */
    double T_target_source[16]; /* its pose, row-major 4x4 */
    double fit;                 /* as pkss_candidate.fit */
    double overlap;             /* as pkss_candidate.overlap */
    double angle_degrees;       /* the turn that takes the result's aligned
                                   source onto this pose's, (0, 180] ... */
    double axis[3];             /* ... about this unit axis (target frame)
                                   through center */
    double center[3];           /* target units */
    int32_t candidate;          /* the candidate it was refined from, or -1
                                   for a turn found by the symmetry test */
} pkss_alternative;

/** pkss_alternative_init() : zeroes struct_size bytes, sets struct_size. */
PKSS_API void pkss_alternative_init(pkss_alternative *alternative,
                                    size_t struct_size);

/** pkss_context_alternative() :
 *  Alternative `index` (0 .. n_alternatives-1, best fit first) of the last
 *  successful registration on ctx; valid until the next registration call.
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT or PKSS_ERR_INVALID_ARGUMENT
 *          (index out of range, or struct_size too small). */
PKSS_API pkss_status pkss_context_alternative(const pkss_context *ctx,
                                              size_t index,
                                              pkss_alternative *alternative);

/** pkss_result_init() : zeroes the struct_size bytes of *result and sets
 *  result->struct_size; pass sizeof *result. */
PKSS_API void pkss_result_init(pkss_result *result, size_t struct_size);

/** pkss_candidate_init() : the same for a pkss_candidate. */
PKSS_API void pkss_candidate_init(pkss_candidate *candidate,
                                  size_t struct_size);

/** pkss_context_candidate() :
 *  Candidate `index` (0 .. n_candidates-1, best search score first within
 *  each search) of the last successful registration on ctx; valid until
 *  the next registration call on ctx. The winner is result.winner.
 *  @return PKSS_OK, PKSS_ERR_NULL_ARGUMENT or PKSS_ERR_INVALID_ARGUMENT
 *          (index out of range, or struct_size too small). */
PKSS_API pkss_status pkss_context_candidate(const pkss_context *ctx,
                                            size_t index,
                                            pkss_candidate *candidate);

/** pkss_register() :
 *  Registers source onto target: finds s, R, t with target ~= s*R*source+t
 *  without an initial guess. Both inputs are n x 3 row-major doubles and are
 *  only read. Equivalent to creating two clouds and calling
 *  pkss_register_clouds().
 *  @return PKSS_OK and a filled *result, or an error status with the detail
 *          in pkss_context_last_error(); on error (a NULL ctx included)
 *          *result holds no pose (n_candidates = 0, T all zero) and ctx no
 *          candidates. Blocks until done (see pkss_context_set_progress). */
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

/* ===================================================================== */
/* Batches: serialised clouds and template retrieval                      */
/* ===================================================================== */
/* A template library is prepared once, serialised, shipped to workers or
 * cached on disk, and restored without repeating the pre-processing. */

/** pkss_cloud_serialize() :
 *  Writes `cloud` into buf (capacity bytes), zstd style: with buf NULL (or
 *  capacity too small) only *needed is set. The bytes are self-describing
 *  and portable (little-endian throughout): magic "PKSSCLD", format
 *  version, library version, the pre-processing parameters the cloud was
 *  prepared under, sizes, and an FNV-1a 64 checksum over everything after
 *  it. The kd-trees are not stored (rebuilt on load, deterministically).
 *  Thread-safe for concurrent readers of one cloud.
 *  @return PKSS_OK (bytes written, *needed = their count),
 *          PKSS_ERR_NULL_ARGUMENT (cloud or needed), or
 *          PKSS_ERR_INVALID_ARGUMENT when buf is not NULL and capacity <
 *          *needed (nothing written). */
PKSS_API pkss_status pkss_cloud_serialize(const pkss_cloud *cloud, void *buf,
                                          size_t capacity, size_t *needed);

/** pkss_cloud_deserialize() :
 *  Restores a cloud from the bytes of pkss_cloud_serialize(). Registering
 *  with it gives bit for bit the result of registering with the original.
 *  The bytes must come from this exact library version (preparation may
 *  change numerically in any release) and the cloud must have been
 *  prepared under the pre-processing parameters of ctx (points,
 *  cull_mutual, cull_stat, use_features, feature_frac, seed,
 *  max_raw_points, drop_nonfinite, min_points): otherwise a registration
 *  would mix two preparations. The input is only read and may be hostile.
 *  @return PKSS_OK; PKSS_ERR_NULL_ARGUMENT; PKSS_ERR_CORRUPT_DATA (not a
 *          pkss cloud, truncated, checksum mismatch, or inconsistent
 *          fields; the detail says which); PKSS_ERR_STALE_DATA (another
 *          format or library version, or another value of a parameter,
 *          named in the detail); PKSS_ERR_OUT_OF_MEMORY. *out is NULL on
 *          failure. */
PKSS_API pkss_status pkss_cloud_deserialize(pkss_context *ctx, const void *buf,
                                            size_t size, pkss_cloud **out);

/** pkss_register_templates() :
 *  Registers one prepared source against n prepared templates (retrieval:
 *  which template does the source show, and in what pose). results[i]
 *  (each initialised with pkss_result_init) receives exactly what
 *  pkss_register_clouds(ctx, source, templates[i], &results[i]) gives, bit
 *  for bit. order (n entries, may be NULL) receives the template indices
 *  ranked best first: by fit, then overlap, both descending, then index
 *  ascending; templates whose registration failed come last, in index
 *  order. status (n entries, may be NULL) receives each template's
 *  status; a failed template's result holds no pose (n_candidates = 0).
 *  Afterwards ctx holds the candidates of the last template registered.
 *  The progress callback sees each template's registration in turn.
 *  @return PKSS_OK when every template was tried (some may have failed:
 *          see status; the context detail holds the first such failure,
 *          prefixed "template i: "); PKSS_ERR_NULL_ARGUMENT,
 *          PKSS_ERR_INVALID_ARGUMENT (n = 0, a NULL template or a bad
 *          struct_size), or a status that stops the batch
 *          (PKSS_ERR_CANCELLED, PKSS_ERR_OUT_OF_MEMORY, device statuses),
 *          which sets order to SIZE_MAX and clears the untried results. */
PKSS_API pkss_status pkss_register_templates(pkss_context *ctx,
                                             const pkss_cloud *source,
                                             const pkss_cloud *const *templates,
                                             size_t n, pkss_result *results,
                                             pkss_status *status,
                                             size_t *order);

/* PKSS_CDEF_END */

/* The smallest struct_size pkss_register() accepts: the stable fields of
 * pkss_result 1.0 (everything before the EXPERIMENTAL block). */
#define PKSS_RESULT_MIN_SIZE offsetof(pkss_result, prepare_seconds)

/* Array sizes in the declarations above are literals (cffi reads them);
 * these tie them to their macros. */
#if defined(__cplusplus)
#define PKSS_STATIC_ASSERT(c, m) static_assert(c, m)
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define PKSS_STATIC_ASSERT(c, m) _Static_assert(c, m)
#endif
#ifdef PKSS_STATIC_ASSERT
PKSS_STATIC_ASSERT(sizeof(((pkss_result *)0)->device) == PKSS_NAME_SIZE,
                   "pkss_result.device is PKSS_NAME_SIZE");
PKSS_STATIC_ASSERT(sizeof(((pkss_result *)0)->note) == PKSS_NOTE_SIZE,
                   "pkss_result.note is PKSS_NOTE_SIZE");
PKSS_STATIC_ASSERT(sizeof(((pkss_device_desc *)0)->name) == PKSS_NAME_SIZE,
                   "pkss_device_desc.name is PKSS_NAME_SIZE");
#endif

#ifdef __cplusplus
}
#endif

#endif /* PKSS_H */
