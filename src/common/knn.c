/* SPDX-License-Identifier: MIT
 * knn.c -- a compact static kd-tree for k-nearest-neighbour queries.
 *
 * Points are copied into tree order (so a leaf is a contiguous run, which
 * keeps queries cache friendly); splits are at the median of the widest
 * axis; leaves hold up to PKSS_KD_LEAF points. Every inner node keeps the
 * gap between its children along the split axis (largest coordinate on the
 * left, smallest on the right), and a query carries the squared distance
 * from the query to the current cell per axis, so a subtree is pruned on
 * the full box distance, not only on one plane (the scheme of nanoflann;
 * tools/bench_knn.cpp compares the two).
 *
 * Results are exact and well defined: the k nearest by (distance, index),
 * ties to the lowest index, independent of the tree's layout (equal to a
 * brute-force sort; tests/test_knn.c checks that). Pruning therefore keeps
 * subtrees whose bound equals the current k-th distance, with a relative
 * slack that absorbs the rounding of the incremental bound.
 *
 * Stacks of identical points (LiDAR no-return zeros, duplicated vertices)
 * become one leaf sorted by index, read only as far as it can still
 * contribute, so a stack of D copies costs O(k) per query, not O(D).
 *
 * docs/tuning.md (PKSS_KD_LEAF) says why this and not nanoflann (C++).
 */
#include "pkss_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


typedef struct kd_node {
    double cut_lo;    /* inner: largest coordinate of the left child on dim */
    double cut_hi;    /* inner: smallest coordinate of the right child */
    uint32_t begin;   /* first point (tree order) */
    uint32_t end;     /* one past the last point */
    uint32_t left;    /* child node indices; 0 for a leaf */
    uint32_t right;
    uint8_t dim;
    uint8_t same;     /* leaf of identical points, sorted by index */
} kd_node;

struct pkss__kdtree {
    size_t n;
    double *pts;      /* n x 3 in tree order */
    uint32_t *index;  /* tree order -> original index */
    kd_node *nodes;
    size_t n_nodes;
    double lo[3], hi[3]; /* bounding box */
};

static inline void swap_points(pkss__kdtree *t, size_t i, size_t j)
{
    double *a = t->pts + 3 * i, *b = t->pts + 3 * j;
    for (int d = 0; d < 3; ++d) {
        double x = a[d];
        a[d] = b[d];
        b[d] = x;
    }
    uint32_t x = t->index[i];
    t->index[i] = t->index[j];
    t->index[j] = x;
}

/* Moves the point of rank k (by coordinate dim) of [lo, hi) into place k,
 * smaller ones before it and larger ones after (Hoare quickselect on the
 * tree's own copy of the points, so the scans are sequential). */
static void select_kth(pkss__kdtree *t, size_t lo, size_t hi, size_t k,
                       int dim)
{
    const double *v = t->pts + dim;
    --hi; /* inclusive */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        double a = v[3 * lo], b = v[3 * mid], c = v[3 * hi];
        double pivot = (a < b) ? ((b < c) ? b : (a < c ? c : a))
                               : ((a < c) ? a : (b < c ? c : b));
        size_t i = lo, j = hi;
        for (;;) {
            while (v[3 * i] < pivot)
                ++i;
            while (v[3 * j] > pivot)
                --j;
            if (i >= j)
                break;
            swap_points(t, i, j);
            ++i;
            --j;
        }
        if (i == j) { /* the pivot itself, in its final place */
            if (k == i)
                return;
            if (k < i)
                hi = i - 1;
            else
                lo = i + 1;
        } else if (k <= j) {
            hi = j;
        } else {
            lo = j + 1;
        }
    }
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static size_t build_node(pkss__kdtree *t, size_t begin, size_t end)
{
    size_t id = t->n_nodes++;
    kd_node *node = &t->nodes[id];
    memset(node, 0, sizeof *node);
    node->begin = (uint32_t)begin;
    node->end = (uint32_t)end;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = begin; i < end; ++i) {
        const double *p = t->pts + 3 * i;
        for (int d = 0; d < 3; ++d) { /* branch-free min/max */
            lo[d] = p[d] < lo[d] ? p[d] : lo[d];
            hi[d] = p[d] > hi[d] ? p[d] : hi[d];
        }
    }
    if (id == 0) {
        memcpy(t->lo, lo, sizeof lo);
        memcpy(t->hi, hi, sizeof hi);
    }
    int dim = 0;
    for (int d = 1; d < 3; ++d)
        if (hi[d] - lo[d] > hi[dim] - lo[dim])
            dim = d;
    if (!(hi[dim] > lo[dim])) {
        /* all points identical: one leaf, by index (see knn_leaf) */
        node->same = 1;
        qsort(t->index + begin, end - begin, sizeof(uint32_t), cmp_u32);
        /* (the coordinates are all equal, so they need no reordering) */
        return id;
    }
    if (end - begin <= PKSS_KD_LEAF)
        return id;
    size_t mid = begin + (end - begin) / 2;
    select_kth(t, begin, end, mid, dim);
    double cut_hi = t->pts[3 * mid + dim];
    double cut_lo = -INFINITY;
    for (size_t i = begin; i < mid; ++i) {
        double v = t->pts[3 * i + dim];
        cut_lo = v > cut_lo ? v : cut_lo;
    }
    size_t left = build_node(t, begin, mid);
    size_t right = build_node(t, mid, end);
    node = &t->nodes[id];
    node->dim = (uint8_t)dim;
    node->cut_lo = cut_lo;
    node->cut_hi = cut_hi;
    node->left = (uint32_t)left;
    node->right = (uint32_t)right;
    return id;
}

pkss_status pkss__kdtree_build(const double *xyz, size_t n,
                               pkss__kdtree **out)
{
    if (!out)
        return PKSS_ERR_NULL_ARGUMENT;
    *out = NULL;
    if (!xyz)
        return PKSS_ERR_NULL_ARGUMENT;
    if (n == 0 || n > UINT32_MAX / 2)
        return PKSS_ERR_INVALID_ARGUMENT;
    pkss__kdtree *t = pkss__calloc(1, sizeof *t);
    if (!t)
        return PKSS_ERR_OUT_OF_MEMORY;
    t->n = n;
    t->pts = pkss__malloc(n * 3 * sizeof(double));
    t->index = pkss__malloc(n * sizeof(uint32_t));
    /* An inner node has > LEAF points and halves them, so every leaf but a
     * lone root holds >= 1 point and the tree has < 2n nodes; n + 2 is
     * enough because leaves hold >= LEAF/2 >= 2 points. */
    size_t cap = n + 2;
    t->nodes = pkss__malloc(cap * sizeof(kd_node));
    if (!t->pts || !t->index || !t->nodes) {
        pkss__kdtree_free(t);
        return PKSS_ERR_OUT_OF_MEMORY;
    }
    memcpy(t->pts, xyz, n * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i)
        t->index[i] = (uint32_t)i;
    build_node(t, 0, n);
    *out = t;
    return PKSS_OK;
}

void pkss__kdtree_free(pkss__kdtree *t)
{
    if (!t)
        return;
    pkss__free(t->pts);
    pkss__free(t->index);
    pkss__free(t->nodes);
    pkss__free(t);
}

size_t pkss__kdtree_size(const pkss__kdtree *t) { return t ? t->n : 0; }

/* (d2, i) comes before (bd, bi): nearer, or as near with a lower index. */
static inline int nearer(double d2, uint32_t i, double bd, uint32_t bi)
{
    return d2 < bd || (d2 == bd && i < bi);
}

/* One query's state. The result list is sorted by (d2, index). */
typedef struct knn_query {
    const pkss__kdtree *t;
    double q[3];
    size_t k;
    size_t skip;
    double max_d2;    /* only points at most this far (INFINITY: all) */
    uint32_t *idx;
    double *d2;
    size_t count;
} knn_query;

/* The squared distance a point must not exceed to enter the list. */
static inline double list_bound(const knn_query *s)
{
    return s->count == s->k ? s->d2[s->k - 1] : s->max_d2;
}

/* Inserts (dd, ix) if it belongs to the k best; returns 0 if it does not. */
static inline int list_insert(knn_query *s, double dd, uint32_t ix)
{
    size_t k = s->k, c = s->count;
    if (c == k) {
        if (!nearer(dd, ix, s->d2[k - 1], s->idx[k - 1]))
            return 0;
        c = k - 1;
    } else {
        ++s->count;
    }
    size_t j = c;
    while (j > 0 && nearer(dd, ix, s->d2[j - 1], s->idx[j - 1])) {
        s->d2[j] = s->d2[j - 1];
        s->idx[j] = s->idx[j - 1];
        --j;
    }
    s->d2[j] = dd;
    s->idx[j] = ix;
    return 1;
}

/* True if a cell at squared box distance md cannot improve the list. */
static inline int prune(const knn_query *s, double md)
{
    return md * PKSS_KD_SLACK > list_bound(s);
}

static void knn_leaf(knn_query *s, const kd_node *node)
{
    const pkss__kdtree *t = s->t;
    if (node->same) {
        /* identical points in index order: stop at the first that fails */
        double dd = pkss__dist2(t->pts + 3 * (size_t)node->begin, s->q);
        if (dd > s->max_d2)
            return;
        for (uint32_t i = node->begin; i < node->end; ++i) {
            uint32_t ix = t->index[i];
            if (ix == s->skip)
                continue;
            if (!list_insert(s, dd, ix))
                break;
        }
        return;
    }
    /* the leaf's distances first, in a loop without branches that the
     * compiler vectorises; then a point farther than a full list's last (or
     * the bound) cannot enter it, whatever its index: most points of a leaf
     * stop at this one comparison */
    double dist[PKSS_KD_LEAF];
    const uint32_t b = node->begin, n = node->end - b;
    const double *p = t->pts + 3 * (size_t)b;
    for (uint32_t i = 0; i < n; ++i)
        dist[i] = pkss__dist2(p + 3 * (size_t)i, s->q);
    double worst = list_bound(s);
    for (uint32_t i = 0; i < n; ++i) {
        double dd = dist[i];
        if (dd > worst)
            continue;
        uint32_t ix = t->index[b + i];
        if (ix == s->skip || !list_insert(s, dd, ix))
            continue;
        if (s->count == s->k)
            worst = s->d2[s->k - 1];
    }
}

/* The child of inner node on q's side (*near) and the other (*far), and the
 * squared distance from q to the far child's side of the split gap. */
static inline double split_children(const pkss__kdtree *t, const kd_node *node,
                                    const double *q, const kd_node **near,
                                    const kd_node **far)
{
    const int dim = node->dim;
    const double diff1 = q[dim] - node->cut_lo;
    const double diff2 = q[dim] - node->cut_hi;
    if (diff1 + diff2 < 0.0) {
        *near = &t->nodes[node->left];
        *far = &t->nodes[node->right];
        return diff2 * diff2;
    }
    *near = &t->nodes[node->right];
    *far = &t->nodes[node->left];
    return diff1 * diff1;
}

/* mindist: squared distance from q to the cell of node, as the sum of the
 * per-axis parts in dists[]. */
static void knn_search(knn_query *s, const kd_node *node, double mindist,
                       double dists[3])
{
    if (!node->left) {
        knn_leaf(s, node);
        return;
    }
    const int dim = node->dim;
    const kd_node *best, *other;
    const double cut = split_children(s->t, node, s->q, &best, &other);
    knn_search(s, best, mindist, dists);
    double saved = dists[dim];
    double md = mindist + cut - saved;
    if (!prune(s, md)) {
        dists[dim] = cut;
        knn_search(s, other, md, dists);
        dists[dim] = saved;
    }
}

/* Squared distance from q to the tree's box, per axis and total. */
static double root_dist(const pkss__kdtree *t, const double q[3],
                        double dists[3])
{
    double md = 0.0;
    for (int d = 0; d < 3; ++d) {
        double g = 0.0;
        if (q[d] < t->lo[d])
            g = t->lo[d] - q[d];
        else if (q[d] > t->hi[d])
            g = q[d] - t->hi[d];
        dists[d] = g * g;
        md += dists[d];
    }
    return md;
}

size_t pkss__kdtree_knn_within(const pkss__kdtree *t, const double q[3], size_t k,
                               size_t skip, double max_d2, uint32_t *idx, double *d2)
{
    if (!t || !q || !idx || !d2 || k == 0)
        return 0;
    knn_query s;
    s.t = t;
    memcpy(s.q, q, sizeof s.q);
    s.k = k;
    s.skip = skip;
    s.max_d2 = max_d2;
    s.idx = idx;
    s.d2 = d2;
    s.count = 0;
    double dists[3];
    double md = root_dist(t, q, dists);
    if (!prune(&s, md))
        knn_search(&s, &t->nodes[0], md, dists);
    return s.count;
}

size_t pkss__kdtree_knn(const pkss__kdtree *t, const double q[3], size_t k,
                        size_t skip, uint32_t *idx, double *d2)
{
    return pkss__kdtree_knn_within(t, q, k, skip, INFINITY, idx, d2);
}

/* Nearest neighbour: the k = 1 search with a starting radius. */
typedef struct nn_query {
    const pkss__kdtree *t;
    double q[3];
    double best_d2;   /* current bound (max_d2 until something is found) */
    uint32_t best;
} nn_query;

static inline int nn_prune(const nn_query *s, double md)
{
    /* Before anything is found, the bound max_d2 is exclusive. */
    if (s->best == UINT32_MAX)
        return md * PKSS_KD_SLACK >= s->best_d2;
    return md * PKSS_KD_SLACK > s->best_d2;
}

static void nn_search(nn_query *s, const kd_node *node, double mindist,
                      double dists[3])
{
    const pkss__kdtree *t = s->t;
    if (!node->left) {
        uint32_t end = node->same ? node->begin + 1 : node->end;
        for (uint32_t i = node->begin; i < end; ++i) {
            double dd = pkss__dist2(t->pts + 3 * (size_t)i, s->q);
            uint32_t ix = t->index[i];
            if (dd < s->best_d2 ||
                (dd == s->best_d2 && s->best != UINT32_MAX && ix < s->best)) {
                s->best_d2 = dd;
                s->best = ix;
            }
        }
        return;
    }
    const int dim = node->dim;
    const kd_node *best, *other;
    const double cut = split_children(t, node, s->q, &best, &other);
    nn_search(s, best, mindist, dists);
    double saved = dists[dim];
    double md = mindist + cut - saved;
    if (!nn_prune(s, md)) {
        dists[dim] = cut;
        nn_search(s, other, md, dists);
        dists[dim] = saved;
    }
}

/* Ties go to the lowest index here too; a point exactly at sqrt(max_d2) is
 * not "within" it. */
uint32_t pkss__kdtree_nearest(const pkss__kdtree *t, const double q[3],
                              double max_d2, double *out_d2)
{
    nn_query s;
    s.t = t;
    s.best_d2 = max_d2;
    s.best = UINT32_MAX;
    if (t && q) {
        memcpy(s.q, q, sizeof s.q);
        double dists[3];
        double md = root_dist(t, q, dists);
        if (!nn_prune(&s, md))
            nn_search(&s, &t->nodes[0], md, dists);
    }
    if (out_d2)
        *out_d2 = s.best_d2;
    return s.best;
}

/* Whether any point lies within sqrt(max_d2) of q: the nearest-neighbour
 * search of pkss__kdtree_nearest, with the bound held at max_d2 and ended
 * at the first point inside it, so the answer is that of nearest != none. */
typedef struct any_query {
    const pkss__kdtree *t;
    double q[3];
    double max_d2;
} any_query;

static int any_search(const any_query *s, const kd_node *node, double mindist,
                      double dists[3])
{
    const pkss__kdtree *t = s->t;
    if (!node->left) {
        uint32_t end = node->same ? node->begin + 1 : node->end;
        for (uint32_t i = node->begin; i < end; ++i)
            if (pkss__dist2(t->pts + 3 * (size_t)i, s->q) < s->max_d2)
                return 1;
        return 0;
    }
    const int dim = node->dim;
    const kd_node *best, *other;
    const double cut = split_children(t, node, s->q, &best, &other);
    if (any_search(s, best, mindist, dists))
        return 1;
    double saved = dists[dim];
    double md = mindist + cut - saved;
    if (md * PKSS_KD_SLACK >= s->max_d2)
        return 0;
    dists[dim] = cut;
    int found = any_search(s, other, md, dists);
    dists[dim] = saved;
    return found;
}

int pkss__kdtree_any_within(const pkss__kdtree *t, const double q[3], double max_d2)
{
    if (!t || !q || t->n == 0)
        return 0;
    any_query s = {t, {q[0], q[1], q[2]}, max_d2};
    double dists[3];
    double md = root_dist(t, q, dists);
    return md * PKSS_KD_SLACK < max_d2 && any_search(&s, &t->nodes[0], md, dists);
}

/* Every point within sqrt(max_d2) of q (inclusive), as tree positions: the
 * search of pkss__kdtree_any_within, collecting instead of stopping. */
typedef struct within_query {
    const pkss__kdtree *t;
    double q[3];
    double max_d2;
    size_t cap, count;
    uint32_t *pos;
    double *d2;
} within_query;

static void within_search(within_query *s, const kd_node *node, double mindist,
                          double dists[3])
{
    const pkss__kdtree *t = s->t;
    if (!node->left) {
        for (uint32_t i = node->begin; i < node->end; ++i) {
            double dd = pkss__dist2(t->pts + 3 * (size_t)i, s->q);
            if (dd > s->max_d2)
                continue;
            if (s->count < s->cap) {
                s->pos[s->count] = i;
                s->d2[s->count] = dd;
            }
            ++s->count;
        }
        return;
    }
    const int dim = node->dim;
    const kd_node *best, *other;
    const double cut = split_children(t, node, s->q, &best, &other);
    within_search(s, best, mindist, dists);
    double saved = dists[dim];
    double md = mindist + cut - saved;
    if (md * PKSS_KD_SLACK > s->max_d2)
        return;
    dists[dim] = cut;
    within_search(s, other, md, dists);
    dists[dim] = saved;
}

size_t pkss__kdtree_within(const pkss__kdtree *t, const double q[3], double max_d2,
                           size_t cap, uint32_t *pos, double *d2)
{
    if (!t || !q || t->n == 0)
        return 0;
    within_query s = {t, {q[0], q[1], q[2]}, max_d2, cap, 0, pos, d2};
    double dists[3];
    double md = root_dist(t, q, dists);
    if (!(md * PKSS_KD_SLACK > max_d2))
        within_search(&s, &t->nodes[0], md, dists);
    return s.count;
}

const double *pkss__kdtree_points(const pkss__kdtree *t) { return t ? t->pts : NULL; }

const uint32_t *pkss__kdtree_order(const pkss__kdtree *t) { return t ? t->index : NULL; }

/* Queries run in tree order (neighbouring queries touch the same nodes and
 * leaves, which keeps them in cache); results land in input order. xyz
 * must be the array the tree was built from (only checked for NULL; the
 * tree's own copy is read). */
pkss_status pkss__knn_all(const pkss__kdtree *t, const double *xyz, size_t n,
                          size_t k, uint32_t *idx, double *d2)
{
    if (!t || !xyz || !idx || !d2)
        return PKSS_ERR_NULL_ARGUMENT;
    if (n != t->n || k == 0)
        return PKSS_ERR_INVALID_ARGUMENT;
    for (size_t pos = 0; pos < n; ++pos) {
        size_t i = t->index[pos];
        uint32_t *ri = idx + k * i;
        double *rd = d2 + k * i;
        /* the tree's copy of point i: same values, read sequentially */
        size_t got = pkss__kdtree_knn(t, t->pts + 3 * pos, k, i, ri, rd);
        /* Fewer points than k: repeat the last neighbour so every row is
         * full (callers only need n > k, which validation guarantees). */
        for (size_t j = got; j < k; ++j) {
            ri[j] = got ? ri[got - 1] : (uint32_t)i;
            rd[j] = got ? rd[got - 1] : 0.0;
        }
    }
    return PKSS_OK;
}
