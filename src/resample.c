/* SPDX-License-Identifier: MIT
 * resample.c -- farthest-point sampling (SPEC 2.4), accelerated.
 *
 * Exact FPS: sample 0 is the point farthest from the centroid; sample t+1
 * is the point whose distance to the nearest of samples 0..t is largest.
 * Ties go to the lowest input index, so the index sequence is exactly the
 * one of the O(n*m) textbook loop (tests/test_resample.c checks this).
 *
 * Acceleration: the points are copied into the leaf order of a small
 * bounding-volume tree (median splits of the widest axis, leaves of up to
 * FPS_LEAF points). Every node keeps its tight box and the largest current
 * min-distance of its points (with that point's index). A new sample only
 * visits the nodes whose box could hold a point closer to it than that
 * node's largest min-distance; everything else is skipped whole. The next
 * sample is read off the root. The box bound is a valid lower bound in
 * floating point too (correctly rounded subtraction, squaring and addition
 * are monotone), so skipping never changes a value and the result is
 * bit-identical to the brute-force loop.
 *
 * Cost is about n*log(m) point updates plus the visited nodes: 200k -> 3000
 * takes a few tens of milliseconds.
 */
#include "pkss_internal.h"

#include <math.h>
#include <string.h>

#define FPS_LEAF 32

typedef struct fps_node {
    double lo[3], hi[3];  /* tight box of the node's points */
    double best_d2;       /* largest min-distance^2 in the node (-1: none) */
    uint32_t best;        /* its input index (lowest on ties) */
    uint32_t begin, end;  /* points [begin, end) in leaf order */
    uint32_t left, right; /* children; left == 0 for a leaf */
    uint32_t parent;      /* UINT32_MAX for the root */
} fps_node;

typedef struct fps_state {
    double *pts;      /* n x 3 in leaf order */
    double *mind;     /* n, leaf order: current min distance^2, -1 taken */
    uint32_t *order;  /* leaf order -> input index */
    uint32_t *where;  /* input index -> leaf-order position */
    uint32_t *leaf;   /* leaf-order position -> leaf node */
    fps_node *nodes;
    size_t n_nodes;
} fps_state;

/* (d, i) beats (bd, bi) if farther, or as far with a lower index. */
static inline int better(double d, uint32_t i, double bd, uint32_t bi)
{
    return d > bd || (d == bd && i < bi);
}

/* Moves the element of rank k (by coordinate dim) of order[lo, hi) into
 * place k; smaller ones before it, larger ones after. */
static void select_rank(const double *xyz, uint32_t *order, size_t lo,
                        size_t hi, size_t k, int dim)
{
    --hi; /* inclusive */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        double a = xyz[3 * order[lo] + dim], b = xyz[3 * order[mid] + dim],
               c = xyz[3 * order[hi] + dim];
        double pivot = (a < b) ? ((b < c) ? b : (a < c ? c : a))
                               : ((a < c) ? a : (b < c ? c : b));
        size_t i = lo, j = hi;
        for (;;) {
            while (xyz[3 * order[i] + dim] < pivot)
                ++i;
            while (xyz[3 * order[j] + dim] > pivot)
                --j;
            if (i >= j)
                break;
            uint32_t t = order[i];
            order[i] = order[j];
            order[j] = t;
            ++i;
            --j;
        }
        /* now [lo, j] <= pivot <= [j+1, hi] (Hoare) when i >= j */
        if (i == j) {
            /* order[i] == pivot exactly and sits between both parts */
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

static uint32_t build(fps_state *s, const double *xyz, uint32_t begin,
                      uint32_t end, uint32_t parent)
{
    uint32_t id = (uint32_t)s->n_nodes++;
    fps_node *nd = &s->nodes[id];
    nd->begin = begin;
    nd->end = end;
    nd->left = nd->right = 0;
    nd->parent = parent;
    nd->best_d2 = -1.0;
    nd->best = UINT32_MAX;
    double lo[3], hi[3];
    for (int d = 0; d < 3; ++d)
        lo[d] = hi[d] = xyz[3 * s->order[begin] + d];
    for (uint32_t i = begin + 1; i < end; ++i) {
        const double *p = xyz + 3 * s->order[i];
        for (int d = 0; d < 3; ++d) {
            if (p[d] < lo[d])
                lo[d] = p[d];
            if (p[d] > hi[d])
                hi[d] = p[d];
        }
    }
    memcpy(nd->lo, lo, sizeof lo);
    memcpy(nd->hi, hi, sizeof hi);
    int dim = 0;
    for (int d = 1; d < 3; ++d)
        if (hi[d] - lo[d] > hi[dim] - lo[dim])
            dim = d;
    if (end - begin <= FPS_LEAF || !(hi[dim] > lo[dim])) {
        for (uint32_t i = begin; i < end; ++i)
            s->leaf[i] = id;
        return id;
    }
    uint32_t mid = begin + (end - begin) / 2;
    select_rank(xyz, s->order, begin, end, mid, dim);
    uint32_t l = build(s, xyz, begin, mid, id);
    uint32_t r = build(s, xyz, mid, end, id);
    s->nodes[id].left = l;
    s->nodes[id].right = r;
    return id;
}

static void leaf_best(fps_state *s, fps_node *nd)
{
    double bd = -1.0;
    uint32_t bi = UINT32_MAX;
    for (uint32_t i = nd->begin; i < nd->end; ++i)
        if (better(s->mind[i], s->order[i], bd, bi)) {
            bd = s->mind[i];
            bi = s->order[i];
        }
    nd->best_d2 = bd;
    nd->best = bi;
}

static void inner_best(fps_state *s, fps_node *nd)
{
    const fps_node *a = &s->nodes[nd->left], *b = &s->nodes[nd->right];
    if (better(b->best_d2, b->best, a->best_d2, a->best)) {
        nd->best_d2 = b->best_d2;
        nd->best = b->best;
    } else {
        nd->best_d2 = a->best_d2;
        nd->best = a->best;
    }
}

/* Lowers min-distances with the new sample q; returns nothing, keeps the
 * node maxima current. */
static void update(fps_state *s, uint32_t id, const double q[3])
{
    fps_node *nd = &s->nodes[id];
    double lb = 0.0;
    for (int d = 0; d < 3; ++d) {
        double g = 0.0;
        if (q[d] < nd->lo[d])
            g = nd->lo[d] - q[d];
        else if (q[d] > nd->hi[d])
            g = q[d] - nd->hi[d];
        lb += g * g;
    }
    if (lb >= nd->best_d2)
        return; /* no point of this node gets closer than its own min */
    if (!nd->left) {
        int changed = 0;
        for (uint32_t i = nd->begin; i < nd->end; ++i) {
            const double *p = s->pts + 3 * (size_t)i;
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < s->mind[i]) {
                s->mind[i] = d2;
                changed = 1;
            }
        }
        if (changed)
            leaf_best(s, nd);
        return;
    }
    update(s, nd->left, q);
    update(s, nd->right, q);
    inner_best(s, &s->nodes[id]);
}

/* Marks input point `ix` as taken and repairs the maxima on its path. */
static void take(fps_state *s, uint32_t ix)
{
    uint32_t pos = s->where[ix];
    s->mind[pos] = -1.0;
    uint32_t id = s->leaf[pos];
    leaf_best(s, &s->nodes[id]);
    while (s->nodes[id].parent != UINT32_MAX) {
        id = s->nodes[id].parent;
        inner_best(s, &s->nodes[id]);
    }
}

static void state_free(fps_state *s)
{
    pkss__free(s->pts);
    pkss__free(s->mind);
    pkss__free(s->order);
    pkss__free(s->where);
    pkss__free(s->leaf);
    pkss__free(s->nodes);
}

/* Index of the point farthest from the centroid (lowest index on ties). */
static uint32_t farthest_from_centroid(const double *xyz, size_t n)
{
    double c[3] = {0.0, 0.0, 0.0};
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d)
            c[d] += xyz[3 * i + d];
    for (int d = 0; d < 3; ++d)
        c[d] /= (double)n;
    double bd = -1.0;
    uint32_t bi = 0;
    for (size_t i = 0; i < n; ++i) {
        double dx = xyz[3 * i] - c[0], dy = xyz[3 * i + 1] - c[1],
               dz = xyz[3 * i + 2] - c[2];
        double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 > bd) {
            bd = d2;
            bi = (uint32_t)i;
        }
    }
    return bi;
}

pkss_status pkss__fps(const double *xyz, size_t n, size_t m, uint32_t *idx,
                      size_t *m_out)
{
    if (m_out)
        *m_out = 0;
    if (!xyz || !idx || !m_out)
        return PKSS_ERR_NULL_ARGUMENT;
    if (n >= UINT32_MAX)
        return PKSS_ERR_INVALID_ARGUMENT;
    if (m > n)
        m = n;
    if (m == 0)
        return PKSS_OK;

    fps_state s;
    memset(&s, 0, sizeof s);
    s.pts = pkss__malloc(n * 3 * sizeof(double));
    s.mind = pkss__malloc(n * sizeof(double));
    s.order = pkss__malloc(n * sizeof(uint32_t));
    s.where = pkss__malloc(n * sizeof(uint32_t));
    s.leaf = pkss__malloc(n * sizeof(uint32_t));
    /* Inner nodes have > FPS_LEAF points and split them in halves, so a
     * leaf holds >= FPS_LEAF/2 points (or is the root): at most
     * n/(FPS_LEAF/2) leaves and twice that many nodes. */
    size_t cap = 2 * (n / (FPS_LEAF / 2)) + 3;
    if (cap > 2 * n + 1)
        cap = 2 * n + 1;
    s.nodes = pkss__malloc(cap * sizeof(fps_node));
    if (!s.pts || !s.mind || !s.order || !s.where || !s.leaf || !s.nodes) {
        state_free(&s);
        return PKSS_ERR_OUT_OF_MEMORY;
    }

    for (size_t i = 0; i < n; ++i)
        s.order[i] = (uint32_t)i;
    build(&s, xyz, 0, (uint32_t)n, UINT32_MAX);
    for (size_t i = 0; i < n; ++i) {
        memcpy(s.pts + 3 * i, xyz + 3 * (size_t)s.order[i], 3 * sizeof(double));
        s.where[s.order[i]] = (uint32_t)i;
        s.mind[i] = INFINITY;
    }
    for (size_t id = s.n_nodes; id-- > 0;) {
        fps_node *nd = &s.nodes[id];
        if (nd->left)
            inner_best(&s, nd);
        else
            leaf_best(&s, nd);
    }

    uint32_t next = farthest_from_centroid(xyz, n);
    for (size_t t = 0; t < m; ++t) {
        idx[t] = next;
        take(&s, next);
        update(&s, 0, xyz + 3 * (size_t)next);
        next = s.nodes[0].best;
    }
    *m_out = m;
    state_free(&s);
    return PKSS_OK;
}
