/* SPDX-License-Identifier: MIT
 * resample.c -- farthest-point sampling (SPEC 2.4), accelerated.
 *
 * Exact FPS: sample 0 is the point farthest from the centroid; sample t+1
 * is the point whose distance to the nearest of samples 0..t is largest.
 * Ties go to the lowest input index, so the index sequence is exactly the
 * one of the O(n*m) textbook loop (tests/test_resample.c checks this).
 *
 * Acceleration: the points are copied into the leaf order of a small
 * bounding-volume tree (splits near the median of the widest axis, leaves
 * of up to FPS_LEAF points). Every node keeps its tight box and the largest
 * current
 * min-distance of its points (with that point's index). A new sample only
 * visits the nodes whose box could hold a point closer to it than that
 * node's largest min-distance; everything else is skipped whole. The next
 * sample is read off the root. The box bound is a valid lower bound in
 * floating point too (correctly rounded subtraction, squaring and addition
 * are monotone), so skipping never changes a value and the result is
 * bit-identical to the brute-force loop.
 *
 * Cost is about n*log(m) point updates plus the visited nodes, and
 * O(n log n) for the tree: 30k -> 3000 takes ~15 ms and 200k -> 3000 ~70 ms
 * of CPU on the 2 GHz Xeon test machine (test_resample prints both).
 * The bound and the distances use the same expression order; the build
 * uses -ffp-contract=off (no FMA), which keeps them comparable.
 */
#include "pkss_internal.h"

#include <math.h>
#include <string.h>


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
    size_t n_nodes, cap;
} fps_state;

/* (d, i) beats (bd, bi) if farther, or as far with a lower index. */
static inline int better(double d, uint32_t i, double bd, uint32_t bi)
{
    return d > bd || (d == bd && i < bi);
}

static inline void swap_points(fps_state *s, size_t i, size_t j)
{
    double *a = s->pts + 3 * i, *b = s->pts + 3 * j;
    for (int d = 0; d < 3; ++d) {
        double t = a[d];
        a[d] = b[d];
        b[d] = t;
    }
    uint32_t t = s->order[i];
    s->order[i] = s->order[j];
    s->order[j] = t;
}

/* Splits [lo, hi) by coordinate dim around the median of up to 15 evenly
 * spaced samples, in one Hoare pass over the copied coordinates (the tree
 * only needs roughly balanced halves, not exact medians). Returns mid with
 * [lo, mid) <= pivot <= [mid, hi), both sides non-empty; hi - lo >= 2. */
static size_t split_points(fps_state *s, size_t lo, size_t hi, int dim,
                           double *pivot_out)
{
    const double *v = s->pts + dim;
    size_t cnt = hi - lo;
    size_t ns = cnt < 15 ? cnt : 15;
    double smp[15];
    for (size_t a = 0; a < ns; ++a) {
        double x = v[3 * (lo + a * (cnt - 1) / (ns > 1 ? ns - 1 : 1))];
        size_t b = a;
        while (b > 0 && smp[b - 1] > x) {
            smp[b] = smp[b - 1];
            --b;
        }
        smp[b] = x;
    }
    double pivot = smp[ns / 2];
    *pivot_out = pivot;
    size_t i = lo, j = hi - 1;
    for (;;) {
        while (v[3 * i] < pivot)
            ++i;
        while (v[3 * j] > pivot)
            --j;
        if (i >= j)
            break;
        swap_points(s, i, j);
        ++i;
        --j;
    }
    if (i > j)
        return j + 1; /* [lo, j] <= pivot <= [j + 1, hi) */
    /* i == j holds the pivot: either side may take it */
    return i > lo ? i : i + 1;
}

static void tight_box(const fps_state *s, uint32_t begin, uint32_t end,
                      double lo[3], double hi[3])
{
    for (int d = 0; d < 3; ++d)
        lo[d] = hi[d] = s->pts[3 * (size_t)begin + d];
    for (uint32_t i = begin + 1; i < end; ++i) {
        const double *p = s->pts + 3 * (size_t)i;
        for (int d = 0; d < 3; ++d) { /* branch-free min/max */
            lo[d] = p[d] < lo[d] ? p[d] : lo[d];
            hi[d] = p[d] > hi[d] ? p[d] : hi[d];
        }
    }
}

/* Builds the subtree of [begin, end). `box` (lo then hi) is a box known to
 * contain the points (the parent's, cut at the split): it picks the split
 * axis, so that only the leaves read their points to get a tight box;
 * inner boxes are the union of their children's. */
static uint32_t build(fps_state *s, uint32_t begin, uint32_t end,
                      uint32_t parent, const double box[6])
{
    if (s->n_nodes == s->cap) {
        fps_node *grown =
            pkss__realloc(s->nodes, 2 * s->cap * sizeof(fps_node));
        if (!grown)
            return UINT32_MAX;
        s->nodes = grown;
        s->cap *= 2;
    }
    uint32_t id = (uint32_t)s->n_nodes++;
    fps_node *nd = &s->nodes[id];
    nd->begin = begin;
    nd->end = end;
    nd->left = nd->right = 0;
    nd->parent = parent;
    nd->best_d2 = -1.0;
    nd->best = UINT32_MAX;
    int dim = 0;
    for (int d = 1; d < 3; ++d)
        if (box[3 + d] - box[d] > box[3 + dim] - box[dim])
            dim = d;
    if (end - begin <= FPS_LEAF || !(box[3 + dim] > box[dim])) {
        tight_box(s, begin, end, nd->lo, nd->hi);
        for (uint32_t i = begin; i < end; ++i)
            s->leaf[i] = id;
        return id;
    }
    double pivot;
    uint32_t mid = (uint32_t)split_points(s, begin, end, dim, &pivot);
    double sub[6];
    memcpy(sub, box, sizeof sub);
    sub[3 + dim] = pivot;
    uint32_t l = build(s, begin, mid, id, sub);
    if (l == UINT32_MAX)
        return UINT32_MAX;
    memcpy(sub, box, sizeof sub);
    sub[dim] = pivot;
    uint32_t r = build(s, mid, end, id, sub);
    if (r == UINT32_MAX)
        return UINT32_MAX;
    nd = &s->nodes[id];
    nd->left = l;
    nd->right = r;
    const fps_node *a = &s->nodes[l], *c = &s->nodes[r];
    for (int d = 0; d < 3; ++d) {
        nd->lo[d] = a->lo[d] < c->lo[d] ? a->lo[d] : c->lo[d];
        nd->hi[d] = a->hi[d] > c->hi[d] ? a->hi[d] : c->hi[d];
    }
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
        /* lower the min-distances and find the new leaf maximum in one
         * pass (min/max written branch-free) */
        double bd = -1.0;
        uint32_t bi = UINT32_MAX;
        for (uint32_t i = nd->begin; i < nd->end; ++i) {
            const double *p = s->pts + 3 * (size_t)i;
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            double d2 = dx * dx + dy * dy + dz * dz;
            double m = s->mind[i];
            m = d2 < m ? d2 : m;
            s->mind[i] = m;
            if (m >= bd) {
                uint32_t ix = s->order[i];
                if (m > bd || ix < bi) {
                    bd = m;
                    bi = ix;
                }
            }
        }
        nd->best_d2 = bd;
        nd->best = bi;
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
    /* Roughly balanced splits: about 2n / (FPS_LEAF / 2) nodes; the array
     * grows if the splits are lopsided. */
    s.cap = 4 * (n / FPS_LEAF) + 16;
    s.nodes = pkss__malloc(s.cap * sizeof(fps_node));
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    if (!s.pts || !s.mind || !s.order || !s.where || !s.leaf || !s.nodes)
        goto cleanup;

    memcpy(s.pts, xyz, n * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i)
        s.order[i] = (uint32_t)i;
    double box[6];
    tight_box(&s, 0, (uint32_t)n, box, box + 3);
    if (build(&s, 0, (uint32_t)n, UINT32_MAX, box) == UINT32_MAX)
        goto cleanup; /* out of memory growing the node array */
    for (size_t i = 0; i < n; ++i) {
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
    st = PKSS_OK;

cleanup:
    state_free(&s);
    return st;
}
