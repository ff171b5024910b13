/* SPDX-License-Identifier: MIT
 * pkss_internal.h -- private declarations shared by the modules in src/.
 * Nothing here is part of the ABI. Non-static internals are prefixed pkss__.
 */
#ifndef PKSS_INTERNAL_H
#define PKSS_INTERNAL_H

#include "pkss.h"
#include "pkss_shared.h" /* PKSS_EDGES_SIZE, the shared search definitions */

#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define PKSS_DETAIL_SIZE 4096
/* pi, for the C side (the kernels do not need it) */
#define PKSS_PI 3.14159265358979323846

/* ---------------------------------------------------------------- params */
typedef struct pkss__params {
    int points;          /* m */
    int rotation_steps;  /* n */
    int offset_steps;    /* N */
    int cell_steps;      /* azimuth bins */
    int cull_mutual;     /* 0/1 */
    int cull_stat;       /* 0/1 */
    int use_features;    /* 0/1 */
    double feature_frac;
    int pca_prealign;    /* 0/1 */
    int rotation_set;    /* pkss_rotation_set, resolved */
    int rotation_count;
    int top_k;
    int refine;          /* 0/1 */
    long long seed;
    long long max_raw_points;
    int drop_nonfinite;  /* 0/1 */
    int min_points;
    int backend;         /* pkss_backend as set (AUTO allowed) */
} pkss__params;

void pkss__params_default(pkss__params *p);

/* ------------------------------------------------------------- assess */
/* What assess.c concludes about a registration (its inputs are declared in
 * the refine section). The features are the confidence model's inputs, kept
 * for the white-box fitting tool (tools/confidence/). */
#define PKSS__ASSESS_FEATURES 8
#define PKSS__MAX_ALTERNATIVES 48 /* candidates + the symmetry test's turns */
typedef struct pkss__assessment {
    double confidence;
    int ambiguous;
    int symmetry;               /* pkss_symmetry */
    uint32_t order;             /* pkss_result.symmetry_order */
    double axis[3], center[3];  /* target frame, caller units */
    pkss_alternative alt[PKSS__MAX_ALTERNATIVES];
    size_t n_alt;
    double features[PKSS__ASSESS_FEATURES];
    double seconds;             /* spent assessing (its cost, measured) */
} pkss__assessment;

/* ------------------------------------------------------------- context */
struct pkss__device; /* OpenCL state, device.c / evaluate_cl.c */

/* One call's progress and cancellation state (progress.c). */
/* The one extra thread of a call (helper.c). */
typedef struct pkss__helper {
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    pthread_t thread;
    int started, failed, busy, quit;
    void (*fn)(void *);
    void *arg;
    unsigned long submitted, completed;
    atomic_ulong posted, finished; /* copies of the two, for the spins */
} pkss__helper;

void pkss__helper_init(pkss__helper *h);
/* Ends the thread (after its job, if any). */
void pkss__helper_close(pkss__helper *h);
/* Hands fn(arg) to the helper: a ticket (> 0), or 0 if the helper is busy
 * or h is NULL, and the caller runs the job itself. */
unsigned long pkss__helper_offer(pkss__helper *h, void (*fn)(void *), void *arg);
/* Waits for the ticket's job: until it is done (seconds <= 0), or at most
 * `seconds`; returns 1 once it is done. */
int pkss__helper_wait(pkss__helper *h, unsigned long ticket, double seconds);
/* fn(a) on the caller and fn(b) on the helper if it is free (else on the
 * caller after a); returns once both are done. h may be NULL. */
void pkss__helper_both(pkss__helper *h, void (*fn)(void *), void *a, void *b);

typedef struct pkss__run {
    pkss_progress_fn fn;
    void *user;
    pthread_t caller;          /* the only thread that calls fn */
    double t0, last_call;
    int stage;                 /* as last reported, with its step */
    uint32_t step, steps;
    atomic_int cancelled;      /* read by every thread of the call */
    pkss__helper helper;       /* the call's one extra thread */
} pkss__run;

/* The helper thread of a call's run, NULL outside a call. */
static inline pkss__helper *pkss__run_helper(pkss__run *run)
{
    return run ? &run->helper : NULL;
}

struct pkss_context {
    pkss__params params;
    char *device_request;      /* PKSS_PARAM_DEVICE string, or NULL */
    char detail[PKSS_DETAIL_SIZE];
    char device_name[PKSS_NAME_SIZE];
    int prepared;              /* prepare() succeeded for current settings */
    int backend_in_use;        /* pkss_backend resolved by prepare() */
    struct pkss__device *dev;  /* NULL for the reference backend */
    char fallback_note[PKSS_NOTE_SIZE]; /* why AUTO fell back, or "" */
    pkss_progress_fn progress_fn;
    void *progress_user;
    pkss__run *run;            /* the call under way, or NULL */
    pkss_candidate candidates[PKSS_MAX_CANDIDATES]; /* last registration */
    size_t n_candidates;
    pkss__assessment assess;   /* of the last registration (n_candidates > 0) */
};

/* Progress and cancellation (progress.c). */
void pkss__run_begin(pkss_context *ctx, pkss__run *run);
void pkss__run_end(pkss_context *ctx);
int pkss__cancelled(const pkss__run *run);
/* Calls the progress callback when due (calling thread only); returns
 * PKSS_ERR_CANCELLED once a callback asked to stop. */
pkss_status pkss__checkpoint(pkss__run *run, int stage, uint32_t step,
                             uint32_t steps);
/* The same within the current stage and step (inner loops), from any
 * thread: only the caller's invokes the callback. */
pkss_status pkss__tick(pkss__run *run);
pkss_status pkss__cancel_fail(pkss_context *ctx);

/* Public struct growth (abi.c). */
void pkss__struct_init(void *p, size_t struct_size);
void pkss__deliver_result(pkss_result *dst, const pkss_result *src);
void pkss__clear_result(pkss_result *dst);
void pkss__deliver_candidate(pkss_candidate *dst, const pkss_candidate *src);
void pkss__deliver_param_info(pkss_param_info *dst, const pkss_param_info *src);
void pkss__deliver_alternative(pkss_alternative *dst,
                               const pkss_alternative *src);
/* 1 when the field tables name every field of their structs (tests). */
int pkss__abi_tables_complete(void);

/* Records a formatted detail in ctx (if not NULL) and returns status. */
pkss_status pkss__fail(pkss_context *ctx, pkss_status status, const char *fmt,
                       ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
void pkss__clear_error(pkss_context *ctx);

#define PKSS_RETURN_IF(cond, ctx, status, ...)                                 \
    do {                                                                       \
        if (cond)                                                              \
            return pkss__fail((ctx), (status), __VA_ARGS__);                   \
    } while (0)

#define PKSS_FORWARD(expr)                                                     \
    do {                                                                       \
        pkss_status pkss__st = (expr);                                         \
        if (pkss__st != PKSS_OK)                                               \
            return pkss__st;                                                   \
    } while (0)

/* --------------------------------------------------------- allocation */
/* All allocation goes through these so a test can inject failures. */
void *pkss__malloc(size_t size);
void *pkss__calloc(size_t count, size_t size);
void *pkss__realloc(void *ptr, size_t size);
void pkss__free(void *ptr);
/* Test hook: fail every allocation after `budget` more succeed; -1 = never. */
void pkss__test_set_alloc_budget(long long budget);

/* --------------------------------------------------------------- time */
double pkss__now(void);

/* ------------------------------------------------------------- kd-tree */
/* A compact static kd-tree over float or double points (stored as double),
 * for k-nearest-neighbour queries (knn.c). */
typedef struct pkss__kdtree pkss__kdtree;

pkss_status pkss__kdtree_build(const double *xyz, size_t n,
                               pkss__kdtree **out);
void pkss__kdtree_free(pkss__kdtree *tree);
size_t pkss__kdtree_size(const pkss__kdtree *tree);
/* k nearest neighbours of q (sorted by distance, nearest first); `skip` is
 * an index to exclude (the query point itself) or SIZE_MAX. Returns how
 * many were found (min(k, n - excluded)). idx/d2 must hold k entries. */
size_t pkss__kdtree_knn(const pkss__kdtree *tree, const double q[3], size_t k,
                        size_t skip, uint32_t *idx, double *d2);
/* The same among the points within sqrt(max_d2) of q (inclusive): fewer
 * than k when fewer lie there; every point not returned lies farther than
 * the k-th returned or than sqrt(max_d2). */
size_t pkss__kdtree_knn_within(const pkss__kdtree *tree, const double q[3], size_t k,
                               size_t skip, double max_d2, uint32_t *idx, double *d2);
/* Nearest neighbour within sqrt(max_d2); returns index or UINT32_MAX. */
uint32_t pkss__kdtree_nearest(const pkss__kdtree *tree, const double q[3],
                              double max_d2, double *d2);
/* Whether a point lies within sqrt(max_d2) of q (strictly): the same answer
 * as pkss__kdtree_nearest(tree, q, max_d2, NULL) != UINT32_MAX, sooner. */
int pkss__kdtree_any_within(const pkss__kdtree *tree, const double q[3], double max_d2);
/* Every point within sqrt(max_d2) of q (inclusive), unordered, as positions
 * in the tree's own order with their squared distances; returns how many lie
 * there, of which only the first cap are written. */
size_t pkss__kdtree_within(const pkss__kdtree *tree, const double q[3], double max_d2,
                           size_t cap, uint32_t *pos, double *d2);
/* The tree's copy of the points (n x 3, tree order) and, per tree position,
 * the point's index in the array the tree was built from. */
const double *pkss__kdtree_points(const pkss__kdtree *tree);
const uint32_t *pkss__kdtree_order(const pkss__kdtree *tree);
/* kNN of every point of the tree itself (self excluded): idx/d2 are n*k.
 * xyz must be the array the tree was built from (n = its size); the tree's
 * own copy of the points is read. */
pkss_status pkss__knn_all(const pkss__kdtree *tree, const double *xyz,
                          size_t n, size_t k, uint32_t *idx, double *d2);

/* Exact nearest neighbours by cubes of space, built as queries arrive and
 * shared by the threads of a call (nn_field.c). NULL from _new where memory
 * is short: callers then ask the tree. */
typedef struct pkss__nn_field pkss__nn_field;
pkss__nn_field *pkss__nn_field_new(const pkss__kdtree *tree, double spacing);
/* The same with 2^slot_bits slots and room for pool_entries list entries
 * (_new: PKSS_FIELD_SLOT_BITS and PKSS_FIELD_POOL_ENTRIES; tests). */
pkss__nn_field *pkss__nn_field_sized(const pkss__kdtree *tree, double spacing,
                                     int slot_bits, size_t pool_entries);
void pkss__nn_field_free(pkss__nn_field *field);
/* Up to keep nearest points of q by (distance, index), nearest first, each
 * strictly nearer than *lb, and every point not returned at least *lb away.
 * Returns how many (0: none lies within lb), or -1 where the field has no
 * answer: ask the tree. */
int pkss__nn_field_near(pkss__nn_field *field, const double q[3], int keep,
                        uint32_t *idx, double *d2, double *lb);
/* Builds the lists of the cubes that pts[0..n) lie in, ahead of their
 * queries (field may be NULL), until *stop is set; returns how many. Other
 * threads may query the field meanwhile. */
size_t pkss__nn_field_warm(pkss__nn_field *field, const double *pts, size_t n,
                           const atomic_int *stop);

/* ------------------------------------------------------- preprocessing */
/* Each step takes an array of n points (double xyz) and writes a keep mask
 * or a new array. They never fail except for out-of-memory. */

/* The value of rank r (0-based, r < n) in v[0, n); reorders v (select.c:
 * medians and quantiles of the steps below). */
double pkss__select_value(double *v, size_t n, size_t r);

/* keep[i] = 0 for a repeat of an earlier point's exact position. */
pkss_status pkss__dedupe(const double *xyz, size_t n, unsigned char *keep,
                         size_t *n_unique);
/* SPEC 2.1: voxel-thin to about `target` points. *out is pkss__malloc'd. */
pkss_status pkss__thin_voxel(const double *xyz, size_t n, size_t target,
                             uint64_t seed, double **out, size_t *n_out);
/* A kNN graph (k neighbours of each of n points, self excluded) that the
 * two culling steps can share: each takes an optional cache; a step finding
 * a graph for the same n and k in it uses that, otherwise it computes one
 * and leaves it there. The caller frees it with pkss__knn_graph_free. */
typedef struct pkss__knn_graph {
    size_t n, k;
    uint32_t *idx;
    double *d2;
} pkss__knn_graph;
void pkss__knn_graph_free(pkss__knn_graph *g);
/* The graph of xyz in *g: kept if *g holds one for the same n and k, else
 * computed there (on failure *g is left empty). */
pkss_status pkss__knn_graph_of(const double *xyz, size_t n, size_t k, pkss__knn_graph *g);
/* Carries a graph over to the points kept by keep[] (xyz: the compacted
 * points, n_new of them): indices are renumbered and only the rows that
 * lost a neighbour are recomputed. The result equals a fresh graph. On
 * failure the graph is freed (a later step recomputes it). */
pkss_status pkss__knn_graph_compact(pkss__knn_graph *g,
                                    const unsigned char *keep,
                                    const double *xyz, size_t n_new);

/* SPEC 2.2: mutual-kNN culling (Eq. 3). keep[i] = 1 if point i has at least
 * one mutual neighbour among its k nearest. graph may be NULL. */
pkss_status pkss__cull_mutual(const double *xyz, size_t n, size_t k,
                              unsigned char *keep, pkss__knn_graph *graph);
/* SPEC 2.3: density-aware statistical filter. keep[i] = 0 for outliers.
 * graph may be NULL (k = 12). */
pkss_status pkss__cull_stat(const double *xyz, size_t n, unsigned char *keep,
                            pkss__knn_graph *graph);
/* SPEC 2.4: farthest-point sampling of m points, starting from the point
 * farthest from the centroid; idx receives min(m, n) indices. */
pkss_status pkss__fps(const double *xyz, size_t n, size_t m, uint32_t *idx,
                      size_t *m_out);

/* ------------------------------------------------------------- geometry */
/* Row-major 3x3 helpers in double (geometry.c). */
void pkss__mat3_mul(const double *A, const double *B, double *C);
void pkss__mat3_transpose(const double *A, double *T);
void pkss__mat3_identity(double *A);
/* y = A x (y may be x); inline, as the ICP applies it per point */
static inline void pkss__mat3_apply(const double *A, const double *x, double *y)
{
    double r0 = A[0] * x[0] + A[1] * x[1] + A[2] * x[2];
    double r1 = A[3] * x[0] + A[4] * x[1] + A[5] * x[2];
    double r2 = A[6] * x[0] + A[7] * x[1] + A[8] * x[2];
    y[0] = r0;
    y[1] = r1;
    y[2] = r2;
}
/* Squared distance between two 3-vectors (kd-tree and ICP hot loops). */
static inline double pkss__dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}
/* R = Rz(c) * Ry(b) * Rx(a) (SPEC 5). */
void pkss__euler_zyx(double a, double b, double c, double *R);
/* Geodesic angle between two rotations, radians. */
double pkss__rotation_angle(const double *R1, const double *R2);
/* Symmetric 3x3 eigen-decomposition (Jacobi, double): eigenvalues in w
 * descending, eigenvectors as columns of V (row-major). */
void pkss__eig_sym3(const double *S, double *w, double *V);
/* Double-precision 3x3 SVD H = U diag(s) V^T, s descending. */
void pkss__svd3(const double *H, double *U, double *s, double *V);
/* Best rotation R (det +1) maximising tr(R H), H = sum x y^T: R = V D U^T. */
void pkss__procrustes_rotation(const double *H, double *R);
/* The rotation by |w| radians about w (Rodrigues). */
void pkss__rotation_exp(const double *w, double *R);
/* a . b and c = a x b of 3-vectors. */
double pkss__dot3(const double *a, const double *b);
void pkss__cross3(const double *a, const double *b, double *c);
/* The next value of a splitmix64 stream (the seeded draws of thin.c and
 * local_match.c). */
uint64_t pkss__splitmix64(uint64_t *state);
/* Its next value as a uniform double in [0, 1) (53 bits; thin.c, cloud.c). */
double pkss__splitmix64_unit(uint64_t *state);
/* Solves A x = b for a symmetric positive definite n x n A (row-major;
 * overwritten by its Cholesky factor); x replaces b. Returns 0, leaving b
 * undefined, when A is not positive definite. */
int pkss__solve_spd(double *A, double *b, int n);

/* --------------------------------------------------------------- clouds */
struct pkss_cloud {
    pkss_counts counts;
    size_t m;             /* resampled points */
    double *pre;          /* m x 3 pre-shape coordinates (centred, unit RMS) */
    double centroid[3];   /* x-bar of the resampled cloud, caller units */
    double sigma;         /* RMS radius of the resampled cloud (Eq. 2) */
    size_t n_feat;
    uint32_t *feat;       /* indices into pre of feature points */
    double *normal;       /* m x 3 unit normals of the local PCA planes */
    double axes[9];       /* PCA axes as columns, right-handed, sign fixed */
    double half_extent[3];/* half-extent along each axis (pre-shape units) */
    double spacing;       /* median NN spacing (pre-shape units) */
    pkss__kdtree *tree;   /* over pre */
    /* The first m_coarse points of pre (an FPS prefix, itself uniformly
     * spread) with their own tree: the coarse refinement level. */
    size_t m_coarse;
    pkss__kdtree *tree_coarse;
    double spacing_coarse;
    /* The points culling kept (at most PKSS_CULL_SUBSET m), in pre-shape
     * coordinates and a seeded random order, with their tree, normals and
     * spacing: the dense view of the last steps (refine/fine.c). A
     * registration's source from points has no tree or normals (pair.c). */
    size_t m_dense;
    double *dense;
    double *normal_dense;
    pkss__kdtree *tree_dense;
    double spacing_dense;
    double prep_seconds;
    double validate_seconds;
    /* the parameters it was prepared under (cloud_bytes.c checks them) */
    pkss__params prep;
};

/* A cloud through every pre-processing stage (cloud.c): its dense view's
 * planes and kd-tree included, over both threads of the call where its
 * helper is free. */
pkss_status pkss__cloud_build(pkss_context *ctx, const double *xyz, size_t n,
                              const char *which, pkss_cloud **out);
/* The same in three steps, for the two clouds of a registration (pair.c),
 * where only the template's dense view needs planes and a tree (fine.c):
 * a cloud in the making through every stage but those (NULL after a
 * failure, described on ctx), ... */
typedef struct pkss__prep pkss__prep;
pkss_status pkss__prep_open(pkss_context *ctx, const double *xyz, size_t n,
                            const char *which, pkss__prep **out);
/* ... its dense view's planes and kd-tree (on helper too, if free), ... */
pkss_status pkss__prep_planes(pkss__prep *w, pkss__helper *helper);
/* ... and its end: the cloud handed to *out, or destroyed with out NULL;
 * the working state freed (w may be NULL). */
void pkss__prep_close(pkss__prep *w, pkss_cloud **out);
/* Both clouds of a registration, the target on the call's helper thread
 * (preshape/pair.c); the source's error is reported first. */
pkss_status pkss__cloud_build_pair(pkss_context *ctx, const double *source,
                                   size_t n_source, const double *target,
                                   size_t n_target, pkss_cloud **src,
                                   pkss_cloud **tgt);

/* --------------------------------------------------------------- search */
/* Rotation candidates (candidates.c): each rotation is a binning rotation
 * (applied to the source points before binning) plus an azimuth shift.
 * The full candidate rotation is Rz(shift*2pi/n_az) * binning rotation. */
typedef struct pkss__rotation_set {
    size_t n_rotations;
    size_t n_binnings;
    double *R;          /* n_rotations x 9: full candidate rotations */
    float *bin_R;       /* n_binnings x 9 */
    int32_t *binning;   /* n_rotations: binning index */
    int32_t *shift;     /* n_rotations: azimuth shift */
} pkss__rotation_set;

pkss_status pkss__rotations_build(const pkss__params *p,
                                  pkss__rotation_set *out);
void pkss__rotations_free(pkss__rotation_set *rs);

/* Fills the float edge table of pkss_shared.h for n_az azimuth bins. */
void pkss__cell_edges(int n_az, float *edges);

/* Everything a backend needs to score all (rotation, offset) pairs. */
typedef struct pkss__search_input {
    int n_az;
    const float *edges;         /* PKSS_EDGES_SIZE */
    /* source, pre-aligned pre-shape coordinates (float) */
    const float *src_pts;  int n_src;
    const float *src_feat; int n_src_feat;   /* feature points (copies) */
    /* template, pre-shape coordinates */
    const float *tgt_pts;  int n_tgt;
    const float *tgt_feat; int n_tgt_feat;
    const pkss__rotation_set *rot;
    int n_offsets;
    const float *offsets;       /* n_offsets x 3 binning centres */
    int use_features;
    /* Share of the matched pairs the measure keeps: 1 = the paper's G,
     * < 1 = the trimmed G of the wide second search (pkss_shared.h). */
    float keep;
    /* Share of the source's occupied cells the matched cells must reach
     * (coverage guard, pkss_shared.h): 0 in the paper's search,
     * PKSS_WIDE_SRC_COVER in the wide one. */
    float src_cover;
} pkss__search_input;

/* The assembled search of two clouds (search_setup.c): everything in
 * pkss__search_input plus the storage it points into. `in` points into this
 * struct: do not copy or move it after building. */
typedef struct pkss__search_setup {
    int n_az;
    float edges[PKSS_EDGES_SIZE];
    double R_pre[9];            /* PCA pre-alignment of the source */
    pkss__rotation_set rot;
    int n_offsets;
    float *offsets;
    float *src_pts, *tgt_pts, *src_feat, *tgt_feat;
    pkss__search_input in;
} pkss__search_setup;

pkss_status pkss__search_setup_build(const pkss__params *p,
                                     const pkss_cloud *src,
                                     const pkss_cloud *tgt,
                                     pkss__search_setup *s);
void pkss__search_setup_free(pkss__search_setup *s);
/* Replaces the offsets by the wide grid: the same N^3 offsets at twice the
 * step, reaching +-E/2 along each axis, and the measure by the trimmed G
 * (keep = PKSS_WIDE_KEEP): the second search of register.c. */
pkss_status pkss__search_setup_widen(const pkss__params *p,
                                     const pkss_cloud *tgt,
                                     pkss__search_setup *s);

/* scores: n_rotations * n_offsets G_K values, rotation-major. Gc/Gf may be
 * NULL; otherwise they get G_contour and G_feature. */
pkss_status pkss__search_ref(pkss_context *ctx, const pkss__search_input *in,
                             float *scores, float *g_contour,
                             float *g_feature);

/* One kept candidate before refinement. */
typedef struct pkss__pick {
    uint32_t rotation, offset;
    float score, g_contour, g_feature;
} pkss__pick;
/* SPEC 5 selection: best top_k by score with 45-degree suppression.
 * Returns how many were kept, or SIZE_MAX when out of memory. */
size_t pkss__select_top_k(const float *scores, const float *gc,
                          const float *gf, const pkss__rotation_set *rot,
                          size_t n_offsets, size_t top_k, pkss__pick *out);

/* The search's measure at one pose (R applied to in's pre-aligned source
 * points, the template's cells about t): G_contour, G_feature (0 without
 * features) and G_K = their max into out's scores (no trimming, no guard
 * beyond pkss_score_pair's). */
pkss_status pkss__score_pose(const pkss__search_input *in, const double *R,
                             const double *t, pkss__pick *out);

/* refine: src/refine/icp.h (the ICP engine), src/refine/stages.h */

/* assess: src/refine/assess.h (confidence, alternatives, symmetry) */

/* ------------------------------------------------------------ OpenCL */
/* evaluate_cl.c; all return PKSS_ERR_UNSUPPORTED when built without it. */
pkss_status pkss__cl_prepare(pkss_context *ctx);
void pkss__cl_release(pkss_context *ctx);
/* The driver's process-wide start-up (device.c): the ICD loader, the
 * platforms and their devices -- loading PoCL and LLVM is most of a first
 * prepare. pkss_register runs it on a short-lived thread while it builds
 * the clouds, when ctx needs a device, none is prepared and no listing has
 * been done in the process yet; end joins that thread (no-op otherwise). */
typedef struct pkss__cl_warmup {
    pthread_t thread;
    int started;
} pkss__cl_warmup;
void pkss__cl_warmup_begin(const pkss_context *ctx, pkss__cl_warmup *w);
void pkss__cl_warmup_end(pkss__cl_warmup *w);
pkss_status pkss__search_cl(pkss_context *ctx, const pkss__search_input *in,
                            float *scores, float *g_contour, float *g_feature);

#endif /* PKSS_INTERNAL_H */
