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
typedef struct pkss__run {
    pkss_progress_fn fn;
    void *user;
    pthread_t caller;          /* the only thread that calls fn */
    double t0, last_call;
    int stage;                 /* as last reported, with its step */
    uint32_t step, steps;
    atomic_int cancelled;      /* read by every thread of the call */
} pkss__run;

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
/* Nearest neighbour within sqrt(max_d2); returns index or UINT32_MAX. */
uint32_t pkss__kdtree_nearest(const pkss__kdtree *tree, const double q[3],
                              double max_d2, double *d2);
/* kNN of every point of the tree itself (self excluded): idx/d2 are n*k.
 * xyz must be the array the tree was built from (n = its size); the tree's
 * own copy of the points is read. */
pkss_status pkss__knn_all(const pkss__kdtree *tree, const double *xyz,
                          size_t n, size_t k, uint32_t *idx, double *d2);

/* ------------------------------------------------------- preprocessing */
/* Each step takes an array of n points (double xyz) and writes a keep mask
 * or a new array. They never fail except for out-of-memory. */

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
void pkss__mat3_apply(const double *A, const double *x, double *y);
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
    double prep_seconds;
    double validate_seconds;
};

pkss_status pkss__cloud_build(pkss_context *ctx, const double *xyz, size_t n,
                              const char *which, pkss_cloud **out);

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
/* Share of the matched pairs the wide search's measure keeps (trimmed G,
 * pkss_shared.h; docs/tuning.md). */
#define PKSS_WIDE_KEEP 0.8f
/* The wide search's second coverage guard (SPEC 4.4; a deviation): the
 * matched cells must reach this share of the source's occupied cells, not
 * only 20 % of the template's: on the wide grid, pairings of 5-6 cells, which
 * a free rotation fits almost perfectly, held the top places. The source is
 * binned about its own centroid, so at the truth most of its cells match
 * (docs/tuning.md). */
#define PKSS_WIDE_SRC_COVER 0.4f
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

/* ------------------------------------------------------------- refine */
typedef struct pkss__pose {
    double s;        /* scale */
    double R[9];
    double t[3];
} pkss__pose;

/* Points an ICP level works on: a prefix of a cloud's pre-shape points. */
typedef struct pkss__icp_view {
    const double *pts;
    size_t m;
    const pkss__kdtree *tree;
    const double *normal; /* unit normal at each point (cloud.c) */
    double spacing;  /* median NN spacing h of this view */
    pkss__run *run;  /* the call's cancellation state, or NULL */
} pkss__icp_view;

void pkss__icp_view_full(const pkss_cloud *c, pkss__icp_view *v);
void pkss__icp_view_coarse(const pkss_cloud *c, pkss__icp_view *v);

/* Pairs that drive the free scale. Mutual pairs by default; where one cloud
 * shows a part of the other, every point of the part has its partner on
 * the whole, so the part's one-way pairs are all genuine and pull an
 * overhanging part back (register.c decides by coverage). */
enum pkss__scale_pairs {
    PKSS__SCALE_MUTUAL = 1,
    PKSS__SCALE_SOURCE_PART = 2,   /* source -> template pairs */
    PKSS__SCALE_TEMPLATE_PART = 3  /* template -> source pairs */
};

typedef struct pkss__icp_schedule {
    double gate_start;   /* in units of the template view's h */
    int rigid_iters;     /* iterations with the scale frozen */
    int max_iters;       /* all iterations */
    int free_scale;      /* 0: rigid only; else a pkss__scale_pairs */
    double rigid_min_overlap; /* stop a rigid stage that ends, or is
                                 projected to end, below this overlap */
    double scale_min_overlap; /* stop a scale stage projected to end
                                 below this overlap */
    int plane_iters;     /* most point-to-plane iterations after the scale
                            stage (0: none) */
} pkss__icp_schedule;

typedef struct pkss__icp_result {
    pkss__pose pose;
    double rms;      /* of the final mutual pairs, pre-shape template units */
    double overlap;  /* overlap score on the views used (icp.c) */
    double cover[2]; /* its parts: shares of source, template covered */
    double fit;      /* the overlap within 1 spacing (icp.c, ICP_FIT_DIST) */
    double overlap_unpolished; /* the overlap before the point-to-plane
                                  stage (= overlap without one): the bar
                                  that other runs' stages are held to */
    int iterations;
    int abandoned;   /* stopped short of a bar (rigid_min_overlap,
                        scale_min_overlap) */
    int duplicate_of; /* owner of the known rigid minimum it stopped at, or -1 */
} pkss__icp_result;

/* Minima already reached by earlier runs (full schedule): the end of each
 * run's rigid stage and its final pose. A run that arrives at one of them
 * stops there, since from the same minimum it would end where that run
 * ended. */
typedef struct pkss__icp_basins {
    pkss__pose pose[2 * PKSS_MAX_CANDIDATES];
    int owner[2 * PKSS_MAX_CANDIDATES]; /* caller's id of the run that found it */
    int n;
} pkss__icp_basins;

/* SPEC 6: overlap-aware similarity ICP of the source view onto the template
 * view from init (pre-shape coordinates of both). With basins (may be
 * NULL) and a free scale: stops early with out->duplicate_of = the owner of
 * a known minimum the run reached, else records the run's own rigid
 * minimum and final pose under id. */
pkss_status pkss__icp_run(const pkss__icp_view *src, const pkss__icp_view *tgt,
                          const pkss__icp_schedule *sched,
                          const pkss__pose *init, pkss__icp_basins *basins,
                          int id, pkss__icp_result *out);
/* The scale that maximises the overlap score, by a pattern search in log
 * scale (steps of log_step, at most 4 moves) with a short rigid settle at
 * each trial; io holds the start pose on entry and the best pose found
 * (with its overlap, RMS and coverages) on exit. */
pkss_status pkss__icp_scale_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double log_step,
                                   pkss__icp_result *io);
/* A search along the direction in which the template's surface under the
 * source constrains the translation least (a part of a box or a cylinder
 * slides along it): trial shifts of io's pose scored by their fit, the best
 * polished (point-to-plane steps); io receives the polished pose if its fit
 * beats io's by more than min_gain. */
pkss_status pkss__icp_slide_search(const pkss__icp_view *src,
                                   const pkss__icp_view *tgt, double min_gain,
                                   pkss__icp_result *io);
/* Overlap score (coverage, icp.c), RMS of the mutual pairs and the fit
 * (the overlap within 1 spacing; fit may be NULL) at pose. */
pkss_status pkss__icp_overlap(const pkss__icp_view *src,
                              const pkss__icp_view *tgt,
                              const pkss__pose *pose, double *overlap,
                              double *rms, double *fit);

/* ------------------------------------------------------------- assess */
/* The end of a registration as assess.c reads it (register.c fills it once
 * the winner and every candidate are final). Poses in ir are pre-shape
 * (source -> template); cand holds the same candidates as delivered. */
typedef struct pkss__assess_input {
    const pkss__icp_view *sv, *tv;  /* full views: source, template */
    const pkss__icp_view *svc, *tvc; /* coarse views (may be NULL) */
    double tgt_sigma;               /* template's RMS radius ... */
    const double *tgt_centroid;     /* ... and centroid, caller units */
    const pkss__icp_result *ir;     /* per candidate */
    const pkss_candidate *cand;     /* per candidate: stage, score */
    size_t n;
    int winner;
    int refine;                     /* refinement on: near ties polished */
} pkss__assess_input;

/* The confidence model's features (docs/design.md, "Confidence"). */
enum {
    PKSS__FEAT_FIT = 0,       /* winner's fit */
    PKSS__FEAT_OVERLAP = 1,   /* winner's overlap */
    PKSS__FEAT_MARGIN = 2,    /* fit - best fit in another basin that no
                                 symmetry explains (capped) */
    PKSS__FEAT_RMS = 3,       /* RMS in template spacings (capped) */
    PKSS__FEAT_ASYMMETRY = 4, /* |f_s - f_t| */
    PKSS__FEAT_COVER_MIN = 5, /* min(f_s, f_t) */
    PKSS__FEAT_SCORE = 6,     /* the winner's search score G, radians */
    PKSS__FEAT_REFINED = 7    /* 1 if the winner was fully refined */
};

/* Alternatives, symmetry (tested by turning the winner about the target's
 * principal axes) and confidence of a finished registration. Fails only as
 * the ICP does (cancelled, out of memory). */
pkss_status pkss__assess(const pkss__assess_input *in, pkss__assessment *out);
/* The logistic model on features x[PKSS__ASSESS_FEATURES]. */
double pkss__confidence(const double *x);
/* Copies the assessment into the result's fields. */
void pkss__assess_store(const pkss__assessment *a, pkss_result *res);

/* ------------------------------------------------------------ OpenCL */
/* evaluate_cl.c; all return PKSS_ERR_UNSUPPORTED when built without it. */
pkss_status pkss__cl_prepare(pkss_context *ctx);
void pkss__cl_release(pkss_context *ctx);
pkss_status pkss__search_cl(pkss_context *ctx, const pkss__search_input *in,
                            float *scores, float *g_contour, float *g_feature);

#endif /* PKSS_INTERNAL_H */
