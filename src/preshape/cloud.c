/* SPDX-License-Identifier: MIT
 * cloud.c -- one input cloud onto the pre-shape space (SPEC 1-2, Sec. 3):
 * validation, thinning, outlier culling, resampling, pre-shape mapping
 * (Eq. 2), feature points by D_pca (Sec. 4) and the PCA frame.
 */
#include "pkss_internal.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Constants: src/tuning.h (validation, features). */

void pkss_cloud_destroy(pkss_cloud *cloud)
{
    if (!cloud)
        return;
    pkss__free(cloud->pre);
    pkss__free(cloud->feat);
    pkss__free(cloud->normal);
    pkss__kdtree_free(cloud->tree);
    pkss__kdtree_free(cloud->tree_coarse);
    pkss__free(cloud->dense);
    pkss__free(cloud->normal_dense);
    pkss__kdtree_free(cloud->tree_dense);
    pkss__free(cloud);
}

static double dist2(const double *a, const double *b)
{
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
           (a[2] - b[2]) * (a[2] - b[2]);
}

/* Mean and covariance eigen-decomposition of the points within sqrt(lim2)
 * of c, or of all n points when c is NULL; returns how many those are. */
static size_t covariance_within(const double *xyz, size_t n, const double *c,
                                double lim2, double *mean, double *w, double *V)
{
#define PKSS_IN_BALL(i) (!c || dist2(xyz + 3 * (i), c) <= lim2)
    double m[3] = {0, 0, 0};
    size_t k = 0;
    for (size_t i = 0; i < n; ++i)
        if (PKSS_IN_BALL(i)) {
            for (int d = 0; d < 3; ++d)
                m[d] += xyz[3 * i + d];
            ++k;
        }
    for (int d = 0; d < 3; ++d)
        m[d] /= (double)k;
    double C[9] = {0};
    for (size_t i = 0; i < n; ++i) {
        if (!PKSS_IN_BALL(i))
            continue;
        double x = xyz[3 * i] - m[0], y = xyz[3 * i + 1] - m[1],
               z = xyz[3 * i + 2] - m[2];
        C[0] += x * x; C[1] += x * y; C[2] += x * z;
        C[4] += y * y; C[5] += y * z; C[8] += z * z;
    }
#undef PKSS_IN_BALL
    C[3] = C[1]; C[6] = C[2]; C[7] = C[5];
    for (int i = 0; i < 9; ++i)
        C[i] /= (double)k;
    pkss__eig_sym3(C, w, V);
    if (mean)
        memcpy(mean, m, sizeof m);
    return k;
}

/* Mean and covariance eigen-decomposition of n points. */
static void covariance(const double *xyz, size_t n, double *mean, double *w,
                       double *V)
{
    covariance_within(xyz, n, NULL, 0.0, mean, w, V);
}

/* The median point (coordinate-wise) and the median distance to it, on an
 * evenly spaced sample; 0 when out of memory (the caller then judges all
 * points). */
static int median_core(const double *xyz, size_t n, double c[3], double *radius)
{
    size_t k = n < PKSS_CORE_SAMPLE ? n : PKSS_CORE_SAMPLE;
    double *v = pkss__malloc(k * sizeof(double));
    if (!v)
        return 0;
    for (int d = 0; d < 3; ++d) {
        for (size_t i = 0; i < k; ++i)
            v[i] = xyz[3 * (i * n / k) + d];
        c[d] = pkss__select_value(v, k, k / 2);
    }
    for (size_t i = 0; i < k; ++i) {
        const double *q = xyz + 3 * (i * n / k);
        v[i] = sqrt((q[0] - c[0]) * (q[0] - c[0]) + (q[1] - c[1]) * (q[1] - c[1]) +
                    (q[2] - c[2]) * (q[2] - c[2]));
    }
    *radius = pkss__select_value(v, k, k / 2);
    pkss__free(v);
    return 1;
}

/* SPEC 1: identical, collinear or coplanar "to the point that PCA or the
 * cell partition is undefined": relative variance below 1e-12 (a thickness
 * of 1e-6 of the extent). */
static pkss_status shape_verdict(pkss_context *ctx, const double w[3], size_t n,
                                 const char *which, const char *stage)
{
    PKSS_RETURN_IF(!(w[0] > 0.0), ctx, PKSS_ERR_DEGENERATE,
                   "%s cloud: all %zu points%s are identical", which, n, stage);
    PKSS_RETURN_IF(w[1] <= PKSS_FLAT_EIGEN * w[0], ctx, PKSS_ERR_DEGENERATE,
                   "%s cloud: the %zu points%s are collinear", which, n, stage);
    PKSS_RETURN_IF(w[2] <= PKSS_FLAT_EIGEN * w[0], ctx, PKSS_ERR_DEGENERATE,
                   "%s cloud: the %zu points%s are coplanar (no 3-D shape)",
                   which, n, stage);
    return PKSS_OK;
}

static pkss_status check_shape(pkss_context *ctx, const double *xyz, size_t n,
                               const char *which, const char *stage)
{
    double w[3], V[9];
    covariance(xyz, n, NULL, w, V);
    return shape_verdict(ctx, w, n, which, stage);
}

/* The shape verdict of validation, on the points within PKSS_CORE_RADII
 * median radii of the median point (all of them if out of memory). */
static pkss_status check_core_shape(pkss_context *ctx, const double *xyz,
                                    size_t n, const char *which)
{
    double c[3], r = 0.0, w[3], V[9];
    int core = median_core(xyz, n, c, &r) && r > 0;
    double lim2 = (PKSS_CORE_RADII * r) * (PKSS_CORE_RADII * r);
    size_t k = covariance_within(xyz, n, core ? c : NULL, lim2, NULL, w, V);
    char stage[96] = "";
    if (k < n)
        snprintf(stage, sizeof stage, " (of %zu, %zu far points left out)", n, n - k);
    return shape_verdict(ctx, w, k, which, stage);
}

/* SPEC 1: validation. The finite points are *out: a copy (*owned), or the
 * caller's array itself when it is huge and all finite (*owned NULL). */
static pkss_status validate(pkss_context *ctx, const double *xyz, size_t n,
                            const char *which, const double **out,
                            double **owned, size_t *n_out, uint64_t *nonfinite)
{
    const pkss__params *p = &ctx->params;
    PKSS_RETURN_IF(!xyz, ctx, PKSS_ERR_NULL_ARGUMENT,
                   "%s points pointer is NULL", which);
    PKSS_RETURN_IF(n == 0, ctx, PKSS_ERR_EMPTY_INPUT,
                   "%s cloud is empty (n = 0)", which);
    PKSS_RETURN_IF(n > (SIZE_MAX / 3 / sizeof(double)) || n > 0x7fffffffu,
                   ctx, PKSS_ERR_INVALID_ARGUMENT,
                   "%s cloud: n = %zu points is too large", which, n);
    size_t bad = 0, first_bad = SIZE_MAX;
    double maxabs = 0.0;
    for (size_t i = 0; i < n; ++i) {
        const double *q = xyz + 3 * i;
        if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2])) {
            if (first_bad == SIZE_MAX)
                first_bad = i;
            ++bad;
            continue;
        }
        for (int d = 0; d < 3; ++d)
            if (fabs(q[d]) > maxabs)
                maxabs = fabs(q[d]);
    }
    if (bad && !p->drop_nonfinite) {
        const double *q = xyz + 3 * first_bad;
        return pkss__fail(ctx, PKSS_ERR_NONFINITE,
                          "%s point %zu has a non-finite coordinate (%g, %g, %g); "
                          "%zu such points in all (set drop_nonfinite to drop them)",
                          which, first_bad, q[0], q[1], q[2], bad);
    }
    *nonfinite = bad;
    size_t finite = n - bad;
    PKSS_RETURN_IF(finite < (size_t)p->min_points, ctx, PKSS_ERR_TOO_FEW_POINTS,
                   "%s cloud has %zu finite points; at least %d are needed "
                   "(min_points)",
                   which, finite, p->min_points);
    /* Squares of 1e150 overflow double; far below that float32 work after
     * centring and normalising is safe. */
    PKSS_RETURN_IF(maxabs > PKSS_MAX_MAGNITUDE, ctx, PKSS_ERR_OUT_OF_RANGE,
                   "%s cloud: coordinate magnitude %g is too large (limit %g)",
                   which, maxabs, PKSS_MAX_MAGNITUDE);
    PKSS_RETURN_IF(maxabs > 0 && maxabs < PKSS_MIN_MAGNITUDE, ctx, PKSS_ERR_OUT_OF_RANGE,
                   "%s cloud: coordinate magnitude %g is too small (limit %g): "
                   "rescale the input",
                   which, maxabs, PKSS_MIN_MAGNITUDE);
    /* A huge input with every point finite is read where it lies: thinning
     * (SPEC 2.1) makes its first copy, of about max_raw_points points. */
    double *pts = NULL;
    if (bad || finite <= (size_t)p->max_raw_points) {
        pts = pkss__malloc(finite * 3 * sizeof(double));
        PKSS_RETURN_IF(!pts, ctx, PKSS_ERR_OUT_OF_MEMORY,
                       "out of memory copying %zu %s points", finite, which);
        size_t k = 0;
        for (size_t i = 0; i < n; ++i) {
            const double *q = xyz + 3 * i;
            if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]))
                continue;
            memcpy(pts + 3 * k++, q, 3 * sizeof(double));
        }
    }
    const double *use = pts ? pts : xyz;
    /* Extent too small for the magnitude (e.g. georeferenced coordinates
     * with micrometre spread): the shape is lost in rounding. */
    double w[3], V[9], mean[3];
    covariance(use, finite, mean, w, V);
    double spread = sqrt(w[0] > 0 ? w[0] : 0.0);
    if (!(spread > PKSS_MIN_EXTENT * maxabs) && w[0] > 0) {
        pkss__free(pts);
        return pkss__fail(ctx, PKSS_ERR_DEGENERATE,
                          "%s cloud: extent %g is below the precision of its "
                          "coordinates (magnitude %g)",
                          which, spread, maxabs);
    }
    pkss_status st = check_core_shape(ctx, use, finite, which);
    if (st != PKSS_OK) {
        pkss__free(pts);
        return st;
    }
    *out = use;
    *owned = pts;
    *n_out = finite;
    return PKSS_OK;
}

/* Compacts pts by keep[], returning the new count. */
static size_t compact(double *pts, size_t n, const unsigned char *keep)
{
    size_t k = 0;
    for (size_t i = 0; i < n; ++i)
        if (keep[i]) {
            if (k != i)
                memmove(pts + 3 * k, pts + 3 * i, 3 * sizeof(double));
            ++k;
        }
    return k;
}

/* The nf points of largest d (ties to the lower index), in index order,
 * into feat; scratch holds m doubles. */
static void top_by_value(const double *d, size_t m, size_t nf, double *scratch,
                         uint32_t *feat)
{
    memcpy(scratch, d, m * sizeof(double));
    double cut = pkss__select_value(scratch, m, m - nf);
    size_t above = 0;
    for (size_t i = 0; i < m; ++i)
        above += d[i] > cut;
    size_t at_cut = nf - above, k = 0;
    for (size_t i = 0; i < m; ++i) {
        if (d[i] > cut) {
            feat[k++] = (uint32_t)i;
        } else if (d[i] == cut && at_cut > 0) {
            feat[k++] = (uint32_t)i;
            --at_cut;
        }
    }
}

/* The least-squares plane of point p's k neighbours (row: their indices
 * into pts, self excluded): its unit normal and p's distance to it (ds, or
 * NULL). */
static void point_plane(const double *pts, const uint32_t *row, size_t k, const double *p,
                        double *normal, double *ds)
{
    double nb[3 * PKSS_KNN_K];
    for (size_t j = 0; j < k; ++j)
        memcpy(nb + 3 * j, pts + 3 * row[j], 3 * sizeof(double));
    double w[3], V[9], mean[3];
    covariance(nb, k, mean, w, V);
    /* normal = eigenvector of the smallest eigenvalue (column 2) */
    if (ds)
        *ds = fabs((p[0] - mean[0]) * V[2] + (p[1] - mean[1]) * V[5] +
                   (p[2] - mean[2]) * V[8]);
    for (int d = 0; d < 3; ++d)
        normal[d] = V[3 * d + 2];
}

/* The planes of every point (point_plane; idx: m x k neighbours). */
static pkss_status neighbour_planes(const double *pts, size_t m, const uint32_t *idx,
                                    size_t k, double *normal, double *ds, pkss__run *run)
{
    for (size_t i = 0; i < m; ++i) {
        if (i % 1024 == 0 && pkss__tick(run) != PKSS_OK)
            return PKSS_ERR_CANCELLED;
        point_plane(pts, idx + k * i, k, pts + 3 * i, normal + 3 * i, ds ? ds + i : NULL);
    }
    return PKSS_OK;
}

/* The PKSS_KNN_K nearest neighbours of each of the m points the tree was
 * built from, their planes (neighbour_planes) and each point's
 * nearest-neighbour distance (nn). */
static pkss_status local_planes(const pkss__kdtree *tree, const double *pts, size_t m,
                                double *normal, double *ds, double *nn, pkss__run *run)
{
    size_t k = m - 1 < PKSS_KNN_K ? m - 1 : PKSS_KNN_K;
    uint32_t *idx = pkss__malloc(m * k * sizeof(uint32_t));
    double *d2 = pkss__malloc(m * k * sizeof(double));
    pkss_status st = idx && d2 ? pkss__knn_all(tree, pts, m, k, idx, d2)
                               : PKSS_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; st == PKSS_OK && i < m; ++i)
        nn[i] = sqrt(d2[k * i]);
    if (st == PKSS_OK)
        st = neighbour_planes(pts, m, idx, k, normal, ds, run);
    pkss__free(idx);
    pkss__free(d2);
    return st;
}

/* Sec. 4: D_pca(p) = distance of p to the least-squares plane of its 12
 * nearest neighbours (self excluded); P' = the top feature_frac by D_pca.
 * Also keeps that plane's normal at every point (the refinement's
 * point-to-plane stage, icp.c) and the median nearest-neighbour spacing. */
static pkss_status features_and_spacing(pkss_cloud *c, double frac,
                                        pkss__run *run)
{
    size_t m = c->m;
    double *ds = pkss__malloc(m * sizeof(double));
    double *nn = pkss__malloc(m * sizeof(double));
    c->normal = pkss__malloc(3 * m * sizeof(double));
    pkss_status st = ds && nn && c->normal
                         ? local_planes(c->tree, c->pre, m, c->normal, ds, nn, run)
                         : PKSS_ERR_OUT_OF_MEMORY;
    if (st != PKSS_OK) {
        pkss__free(ds); pkss__free(nn);
        return st;
    }
    c->spacing = pkss__select_value(nn, m, m / 2);
    size_t nf = (size_t)ceil(frac * (double)m);
    /* G_f needs PKSS_MIN_MATCHED matched cells (Eq. 7_3), so as many feature
     * points at least: fewer would void every candidate. */
    if (nf < PKSS_MIN_MATCHED) nf = PKSS_MIN_MATCHED;
    if (nf > m) nf = m;
    c->feat = pkss__malloc(nf * sizeof(uint32_t));
    if (!c->feat) {
        pkss__free(ds); pkss__free(nn);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    /* in point index order: deterministic and cache friendly */
    top_by_value(ds, m, nf, nn, c->feat);
    c->n_feat = nf;
    pkss__free(ds); pkss__free(nn);
    return PKSS_OK;
}

/* The coarse refinement level: the first quarter of the FPS-ordered points
 * (all of them for small clouds), its kd-tree and NN spacing. */
static pkss_status coarse_level(pkss_cloud *c)
{
    c->m_coarse = c->m >= PKSS_COARSE_MIN_M ? c->m / PKSS_COARSE_DIV : c->m;
    pkss_status st = pkss__kdtree_build(c->pre, c->m_coarse, &c->tree_coarse);
    if (st != PKSS_OK)
        return st;
    double *nn = pkss__malloc(c->m_coarse * sizeof(double));
    if (!nn)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < c->m_coarse; ++i) {
        uint32_t j;
        double d2 = 0.0;
        pkss__kdtree_knn(c->tree_coarse, c->pre + 3 * i, 1, i, &j, &d2);
        nn[i] = sqrt(d2);
    }
    c->spacing_coarse = pkss__select_value(nn, c->m_coarse, c->m_coarse / 2);
    pkss__free(nn);
    return PKSS_OK;
}

/* PCA frame of the pre-shape cloud (SPEC 2.7, Eq. 11): axes by decreasing
 * variance; the first two signs chosen so that more points lie on the
 * positive side, the third = u x v (right-handed). Half-extents per axis. */
static void pca_frame(pkss_cloud *c)
{
    double w[3], V[9];
    covariance(c->pre, c->m, NULL, w, V);
    for (int a = 0; a < 2; ++a) {
        long long balance = 0;
        for (size_t i = 0; i < c->m; ++i) {
            const double *p = c->pre + 3 * i;
            double proj = p[0] * V[a] + p[1] * V[3 + a] + p[2] * V[6 + a];
            balance += proj > 0 ? 1 : (proj < 0 ? -1 : 0);
        }
        if (balance < 0)
            for (int r = 0; r < 3; ++r)
                V[3 * r + a] = -V[3 * r + a];
    }
    V[2] = V[3] * V[7] - V[6] * V[4];
    V[5] = V[6] * V[1] - V[0] * V[7];
    V[8] = V[0] * V[4] - V[3] * V[1];
    memcpy(c->axes, V, sizeof V);
    for (int a = 0; a < 3; ++a) {
        double lo = DBL_MAX, hi = -DBL_MAX;
        for (size_t i = 0; i < c->m; ++i) {
            const double *p = c->pre + 3 * i;
            double proj = p[0] * V[a] + p[1] * V[3 + a] + p[2] * V[6 + a];
            if (proj < lo) lo = proj;
            if (proj > hi) hi = proj;
        }
        c->half_extent[a] = 0.5 * (hi - lo);
    }
}

/* One cloud in the making: the working copy of its points and the
 * buffers the stages below share. */
struct pkss__prep {
    pkss_context *ctx;
    const pkss__params *p;
    const char *which;
    pkss_cloud *c;
    const double *in; /* the caller's points, when validation left them */
    double *pts;      /* the working copy, else */
    size_t np;
    unsigned char *keep;
    uint32_t *sel;
    pkss__knn_graph graph; /* culling's kNN graph of the kept points, if any */
    uint32_t *dense_order; /* the dense view's point i is kept point dense_order[i] */
    double t_stages;       /* when the stages began (validation done) */
};
typedef struct pkss__prep prep;

/* Each stage returns PKSS_OK, PKSS_ERR_OUT_OF_MEMORY (reported by the
 * driver with the stage's point count) or a failure it has described. */
typedef pkss_status (*prep_stage)(prep *w);

/* SPEC 2.1: a huge input that validation left where it lies is thinned
 * from there (one cloud's copy is then ~max_raw_points, not n). Each voxel
 * keeps one point, so exact duplicates go with the thinning. */
static pkss_status thin_in_place(prep *w)
{
    if (w->pts)
        return PKSS_OK;
    return pkss__thin_voxel(w->in, w->np, (size_t)w->p->max_raw_points,
                            (uint64_t)w->p->seed, &w->pts, &w->np);
}

/* Exact duplicates carry no shape and defeat the kNN statistics of the
 * outlier filters (dedupe.c). */
static pkss_status drop_duplicates(prep *w)
{
    w->keep = pkss__malloc(w->np ? w->np : 1);
    if (!w->keep)
        return PKSS_ERR_OUT_OF_MEMORY;
    size_t n_unique = w->np;
    PKSS_FORWARD(pkss__dedupe(w->pts, w->np, w->keep, &n_unique));
    if (n_unique < w->np) {
        w->c->counts.duplicates = w->np - n_unique;
        w->np = compact(w->pts, w->np, w->keep);
    }
    PKSS_RETURN_IF(w->np < (size_t)w->p->min_points, w->ctx, PKSS_ERR_TOO_FEW_POINTS,
                   "%s cloud has %zu distinct points (%llu exact duplicates "
                   "dropped); at least %d are needed (min_points)",
                   w->which, w->np, (unsigned long long)w->c->counts.duplicates,
                   w->p->min_points);
    return PKSS_OK;
}

/* SPEC 2.1: a huge input copied by validation (it had non-finite points to
 * drop) is thinned here, after its duplicates went. */
static pkss_status thin_copy(prep *w)
{
    if (w->np > (size_t)w->p->max_raw_points) {
        double *thin = NULL;
        size_t nt = 0;
        PKSS_FORWARD(pkss__thin_voxel(w->pts, w->np, (size_t)w->p->max_raw_points,
                                      (uint64_t)w->p->seed, &thin, &nt));
        pkss__free(w->pts);
        w->pts = thin;
        w->np = nt;
    }
    return PKSS_OK;
}

/* The subset's draws: a splitmix64 stream of the seed apart from thin.c's. */
#define CULL_SUBSET_STREAM 0x5ca1ab1e5eedULL

/* Larger clouds are culled on a seeded uniform subset of PKSS_CULL_SUBSET m
 * points (selection sampling into the keep mask, then compact: order kept):
 * the filters' statistics are density-relative, so outliers keep their
 * share, and FPS takes only m. */
static pkss_status subset_for_culling(prep *w)
{
    size_t want = PKSS_CULL_SUBSET * (size_t)w->p->points;
    if (w->np > want) {
        uint64_t rng = (uint64_t)w->p->seed ^ CULL_SUBSET_STREAM;
        size_t kept = 0;
        for (size_t i = 0; i < w->np; ++i) {
            /* keep point i with odds (want - kept) / (np - i) */
            w->keep[i] = kept < want && pkss__splitmix64_unit(&rng) * (double)(w->np - i) <
                                            (double)(want - kept);
            kept += w->keep[i];
        }
        w->np = compact(w->pts, w->np, w->keep);
    }
    w->c->counts.thinned = w->np;
    return PKSS_OK;
}

/* SPEC 2.2-2.3: outliers go before resampling (FPS would promote them).
 * Both filters use the PKSS_KNN_K-NN graph: the statistical filter takes
 * mutual culling's, carried over to the survivors. */
static pkss_status cull_outliers(prep *w)
{
    const pkss__params *p = w->p;
    pkss__knn_graph graph = {0, 0, NULL, NULL};
    pkss_status st = PKSS_OK;
    if (p->cull_mutual && w->np > PKSS_KNN_K + 1) {
        st = pkss__cull_mutual(w->pts, w->np, PKSS_KNN_K, w->keep, &graph);
        size_t before = w->np;
        if (st == PKSS_OK)
            w->np = compact(w->pts, w->np, w->keep);
        if (st == PKSS_OK && w->np != before)
            st = pkss__knn_graph_compact(&graph, w->keep, w->pts, w->np);
        if (st != PKSS_OK) {
            pkss__knn_graph_free(&graph);
            return st;
        }
    }
    w->c->counts.after_mutual = w->np;
    if (p->cull_stat && w->np > PKSS_KNN_K + 1) {
        st = pkss__cull_stat(w->pts, w->np, w->keep, &graph);
        size_t before = w->np;
        if (st == PKSS_OK)
            w->np = compact(w->pts, w->np, w->keep);
        if (st == PKSS_OK && w->np != before)
            st = pkss__knn_graph_compact(&graph, w->keep, w->pts, w->np);
    }
    if (st != PKSS_OK)
        pkss__knn_graph_free(&graph);
    w->graph = graph; /* the dense view's planes (pkss__prep_planes) */
    PKSS_FORWARD(st);
    w->c->counts.after_stat = w->np;
    PKSS_RETURN_IF(w->np < (size_t)p->min_points, w->ctx, PKSS_ERR_TOO_FEW_POINTS,
                   "%s cloud: only %zu points survive outlier culling; at "
                   "least %d are needed (min_points; or disable cull_mutual/cull_stat)",
                   w->which, w->np, p->min_points);
    return PKSS_OK;
}

/* SPEC 2.4: farthest-point resampling to m points, shape checked again. */
static pkss_status resample(prep *w)
{
    size_t m = 0, cap = (size_t)w->p->points < w->np ? (size_t)w->p->points : w->np;
    w->sel = pkss__malloc(cap * sizeof(uint32_t));
    if (!w->sel)
        return PKSS_ERR_OUT_OF_MEMORY;
    PKSS_FORWARD(pkss__fps(w->pts, w->np, (size_t)w->p->points, w->sel, &m));
    pkss_cloud *c = w->c;
    c->m = m;
    c->pre = pkss__malloc(m * 3 * sizeof(double));
    if (!c->pre)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < m; ++i)
        memcpy(c->pre + 3 * i, w->pts + 3 * (size_t)w->sel[i], 3 * sizeof(double));
    c->counts.resampled = m;
    return check_shape(w->ctx, c->pre, m, w->which, " after resampling");
}

/* SPEC 2.5, Eq. 2: centre and divide by the RMS radius
 * sigma = sqrt(sum |x - mean|^2 / m). */
static pkss_status map_to_preshape(prep *w)
{
    pkss_cloud *c = w->c;
    const size_t m = c->m;
    double mean[3] = {0, 0, 0}, ss = 0.0;
    for (size_t i = 0; i < m; ++i)
        for (int d = 0; d < 3; ++d)
            mean[d] += c->pre[3 * i + d];
    for (int d = 0; d < 3; ++d)
        mean[d] /= (double)m;
    for (size_t i = 0; i < m; ++i)
        for (int d = 0; d < 3; ++d) {
            double v = c->pre[3 * i + d] - mean[d];
            ss += v * v;
        }
    c->sigma = sqrt(ss / (double)m);
    memcpy(c->centroid, mean, sizeof mean);
    for (size_t i = 0; i < m; ++i)
        for (int d = 0; d < 3; ++d)
            c->pre[3 * i + d] = (c->pre[3 * i + d] - mean[d]) / c->sigma;
    return PKSS_OK;
}

static pkss_status build_tree(prep *w)
{
    return pkss__kdtree_build(w->c->pre, w->c->m, &w->c->tree);
}

/* Sec. 4: feature points by D_pca, normals, spacing. */
static pkss_status features(prep *w)
{
    pkss_status st = features_and_spacing(w->c, w->p->feature_frac, w->ctx->run);
    if (st == PKSS_ERR_CANCELLED)
        return pkss__cancel_fail(w->ctx);
    w->c->counts.features = w->p->use_features ? w->c->n_feat : 0;
    return st;
}

#define DENSE_ORDER_STREAM 0xde45e0dde4ULL

/* The kNN graph of the kept points: culling's, else queried (culling off). */
static pkss_status kept_graph(prep *w)
{
    size_t k = w->np - 1 < PKSS_KNN_K ? w->np - 1 : PKSS_KNN_K;
    return pkss__knn_graph_of(w->pts, w->np, k, &w->graph);
}

/* The dense view's points: those culling kept, mapped by the resampled
 * points' mean and sigma (Eq. 2), seeded-shuffled (a prefix is a uniform
 * sample; FPS favours points noise pushed outward), and their median
 * spacing. Their planes and tree: pkss__prep_planes. */
static pkss_status dense_points(prep *w)
{
    pkss_cloud *c = w->c;
    const size_t n = w->np;
    PKSS_FORWARD(kept_graph(w));
    c->dense = pkss__malloc(3 * n * sizeof(double));
    w->dense_order = pkss__malloc(n * sizeof(uint32_t));
    double *nn = pkss__malloc(n * sizeof(double));
    pkss_status st = c->dense && w->dense_order && nn ? PKSS_OK : PKSS_ERR_OUT_OF_MEMORY;
    if (st == PKSS_OK) {
        for (size_t i = 0; i < n; ++i)
            nn[i] = sqrt(w->graph.d2[w->graph.k * i]);
        c->spacing_dense = pkss__select_value(nn, n, n / 2) / c->sigma;
        uint32_t *order = w->dense_order;
        for (size_t i = 0; i < n; ++i)
            order[i] = (uint32_t)i;
        uint64_t rng = (uint64_t)w->p->seed ^ DENSE_ORDER_STREAM;
        for (size_t i = n; i > 1; --i) { /* Fisher-Yates */
            size_t j = (size_t)(pkss__splitmix64(&rng) % i);
            uint32_t t = order[i - 1];
            order[i - 1] = order[j];
            order[j] = t;
        }
        for (size_t i = 0; i < n; ++i)
            for (int d = 0; d < 3; ++d)
                c->dense[3 * i + d] =
                    (w->pts[3 * (size_t)order[i] + d] - c->centroid[d]) / c->sigma;
        c->m_dense = n;
    }
    pkss__free(nn);
    return st;
}

/* The dense view's planes, claimed PKSS_PLANES_CHUNK points at a time by
 * both threads of the call; the helper's part first builds the view's
 * kd-tree (it needs the points alone). Each point's plane is its own, so
 * which thread computes it never changes it. */
typedef struct planes_job {
    prep *w;
    atomic_size_t next;
} planes_job;

typedef struct planes_part {
    planes_job *job;
    int builds_tree;
    pkss_status st;
} planes_part;

static void planes_worker(void *arg)
{
    planes_part *part = arg;
    prep *w = part->job->w;
    pkss_cloud *c = w->c;
    const pkss__knn_graph *g = &w->graph;
    part->st = part->builds_tree ? pkss__kdtree_build(c->dense, c->m_dense, &c->tree_dense)
                                 : PKSS_OK;
    while (part->st == PKSS_OK) {
        size_t a = atomic_fetch_add_explicit(&part->job->next, PKSS_PLANES_CHUNK,
                                             memory_order_relaxed);
        if (a >= c->m_dense)
            break;
        if (pkss__tick(w->ctx->run) != PKSS_OK) {
            part->st = PKSS_ERR_CANCELLED;
            break;
        }
        size_t b = a + PKSS_PLANES_CHUNK < c->m_dense ? a + PKSS_PLANES_CHUNK : c->m_dense;
        for (size_t i = a; i < b; ++i) {
            size_t o = w->dense_order[i];
            point_plane(w->pts, g->idx + g->k * o, g->k, w->pts + 3 * o,
                        c->normal_dense + 3 * i, NULL);
        }
    }
}

/* The coarse view and the PCA frame (Eq. 11). */
static pkss_status coarse_and_frame(prep *w)
{
    PKSS_FORWARD(coarse_level(w->c));
    pca_frame(w->c);
    return PKSS_OK;
}

/* The stages in order, with the progress step (of 6) each begins after. */
static const struct {
    int step;
    prep_stage run;
} PREP_STAGES[] = {
    {0, thin_in_place}, {0, drop_duplicates}, {1, thin_copy},
    {1, subset_for_culling}, {2, cull_outliers}, {3, resample}, {3, map_to_preshape},
    {4, build_tree},    {5, features},        {5, dense_points},
    {5, coarse_and_frame},
};

/* A stage's failure to allocate (status st) for n points, described. */
static pkss_status prep_oom(prep *w, pkss_status st, size_t n)
{
    return pkss__fail(w->ctx, st, "out of memory pre-processing the %s cloud (%zu points)",
                      w->which, n);
}

static pkss_status run_stages(prep *w)
{
    int step = -1;
    for (size_t k = 0; k < sizeof PREP_STAGES / sizeof *PREP_STAGES; ++k) {
        if (PREP_STAGES[k].step != step) {
            step = PREP_STAGES[k].step;
            if (pkss__checkpoint(w->ctx->run, PKSS_PROGRESS_PREPROCESS, (uint32_t)step, 6))
                return pkss__cancel_fail(w->ctx);
        }
        pkss_status st = PREP_STAGES[k].run(w);
        if (st == PKSS_ERR_OUT_OF_MEMORY)
            return prep_oom(w, st, w->np);
        if (st != PKSS_OK)
            return st;
    }
    return PKSS_OK;
}

static void prep_free(prep *w)
{
    pkss__free(w->pts);
    pkss__free(w->keep);
    pkss__free(w->sel);
    pkss__free(w->dense_order);
    pkss__knn_graph_free(&w->graph);
    pkss__free(w);
}

pkss_status pkss__prep_open(pkss_context *ctx, const double *xyz, size_t n,
                            const char *which, prep **out)
{
    *out = NULL;
    double t0 = pkss__now();
    prep *w = pkss__calloc(1, sizeof *w);
    pkss_cloud *c = pkss__calloc(1, sizeof(pkss_cloud));
    if (!w || !c) {
        pkss__free(w);
        pkss__free(c);
        return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    }
    *w = (prep){.ctx = ctx, .p = &ctx->params, .which = which, .c = c};
    c->counts.input = n;
    c->prep = ctx->params; /* what the cloud was prepared under (cloud_bytes.c) */
    pkss_status st = validate(ctx, xyz, n, which, &w->in, &w->pts, &w->np,
                              &c->counts.nonfinite);
    w->t_stages = pkss__now();
    c->validate_seconds = w->t_stages - t0;
    if (st == PKSS_OK)
        st = run_stages(w);
    if (st != PKSS_OK) {
        pkss__prep_close(w, NULL);
        return st;
    }
    *out = w;
    return PKSS_OK;
}

pkss_status pkss__prep_planes(prep *w, pkss__helper *helper)
{
    pkss_cloud *c = w->c;
    c->normal_dense = pkss__malloc(3 * c->m_dense * sizeof(double));
    if (!c->normal_dense)
        return prep_oom(w, PKSS_ERR_OUT_OF_MEMORY, c->m_dense);
    planes_job job = {.w = w};
    atomic_init(&job.next, 0);
    planes_part parts[2] = {{&job, 0, PKSS_OK}, {&job, 1, PKSS_OK}};
    pkss__helper_both(helper, planes_worker, &parts[0], &parts[1]);
    for (int i = 0; i < 2; ++i) {
        if (parts[i].st == PKSS_ERR_CANCELLED)
            return pkss__cancel_fail(w->ctx);
        if (parts[i].st != PKSS_OK)
            return prep_oom(w, parts[i].st, c->m_dense); /* the tree's */
    }
    return PKSS_OK;
}

void pkss__prep_close(prep *w, pkss_cloud **out)
{
    if (!w)
        return;
    pkss_cloud *c = w->c;
    c->prep_seconds = pkss__now() - w->t_stages;
    prep_free(w);
    if (out)
        *out = c;
    else
        pkss_cloud_destroy(c);
}

pkss_status pkss__cloud_build(pkss_context *ctx, const double *xyz, size_t n,
                              const char *which, pkss_cloud **out)
{
    *out = NULL;
    prep *w = NULL;
    PKSS_FORWARD(pkss__prep_open(ctx, xyz, n, which, &w));
    pkss_status st = pkss__prep_planes(w, pkss__run_helper(ctx->run));
    pkss__prep_close(w, st == PKSS_OK ? out : NULL);
    return st;
}

/* ------------------------------------------------------------ public */
pkss_status pkss_cloud_create(pkss_context *ctx, const double *xyz, size_t n,
                              pkss_cloud **out)
{
    if (out)
        *out = NULL;
    PKSS_RETURN_IF(!ctx, NULL, PKSS_ERR_NULL_ARGUMENT, "ctx is NULL");
    pkss__clear_error(ctx);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_NULL_ARGUMENT, "out is NULL");
    pkss__run run_state;
    pkss__run_begin(ctx, &run_state);
    pkss_status st = pkss__cloud_build(ctx, xyz, n, "input", out);
    pkss__checkpoint(ctx->run, PKSS_PROGRESS_DONE, 1, 1);
    pkss__run_end(ctx);
    return st;
}

pkss_status pkss_cloud_counts(const pkss_cloud *cloud, pkss_counts *out)
{
    if (!cloud || !out)
        return PKSS_ERR_NULL_ARGUMENT;
    *out = cloud->counts;
    return PKSS_OK;
}

size_t pkss_cloud_size(const pkss_cloud *cloud) { return cloud ? cloud->m : 0; }

pkss_status pkss_cloud_points(const pkss_cloud *cloud, double *xyz,
                              size_t capacity)
{
    if (!cloud || !xyz)
        return PKSS_ERR_NULL_ARGUMENT;
    if (capacity < cloud->m)
        return PKSS_ERR_INVALID_ARGUMENT;
    for (size_t i = 0; i < cloud->m; ++i)
        for (int d = 0; d < 3; ++d)
            xyz[3 * i + d] = cloud->pre[3 * i + d] * cloud->sigma + cloud->centroid[d];
    return PKSS_OK;
}
