/* SPDX-License-Identifier: MIT
 * nn_field.c -- exact nearest neighbours by cubes of space, shared by every
 * ICP run of a registration: hard pairs refine many candidates against the
 * same clouds, and each run's fresh kd-tree queries would repeat the same
 * searches.
 *
 * Space is cut into cubes of PKSS_FIELD_CELL spacings; the second query that
 * lands in a cube builds its list (a cube asked once would not repay it), or
 * the helper thread builds it ahead while the call waits for its search
 * (pkss__nn_field_warm: the cubes of the cloud's own points, where the
 * runs' queries gather as they converge):
 * every point within d_1 + 2 rho of its centre (d_1 the centre's nearest
 * distance, rho the cube's half-diagonal), which holds the nearest point of
 * every location in the cube, sorted by distance from the centre. A query
 * reads the list in that order and stops once the rest lie farther than
 * what it needs. Cubes farther than PKSS_FIELD_FAR sides from every point
 * keep only that distance, a lower bound on every distance from them.
 *
 * Answers are checked at query time, not assumed from the geometry: the
 * nearest is reported only when it lies strictly closer than the bound on
 * every point not read, so ties and rounding fall back to the tree. Both
 * threads of a call query and build at once: a cube is claimed by an atomic
 * exchange; one another thread is still building, or one the full table or
 * pool cannot take, is left to the tree (which gives the same answers).
 */
#include "pkss_internal.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

/* The key of an empty slot, and the offsets of a cube seen once, of one
 * being built and of one the pool could not take (the tree answers there). */
#define EMPTY 0u
#define SEEN 0u
#define BUILDING (UINT32_MAX - 1)
#define NO_LIST UINT32_MAX
/* cube coordinates are packed 21 bits an axis, offset to be non-negative */
#define AXIS_BITS 21
#define AXIS_LIMIT (1 << (AXIS_BITS - 1))
/* a bound is lowered by this relative margin against rounding */
#define LOWER (1.0 - 1e-9)

/* A cube's slot: its key (EMPTY while free) and its record's offset in the
 * pool (SEEN, then BUILDING, until published). */
typedef struct slot {
    _Atomic uint64_t key;
    _Atomic uint32_t at;
} slot;

/* A list entry: a point's coordinates (the tree's own values, so distances
 * are computed as the tree computes them), its index, and its distance from
 * the cube's centre rounded down. */
typedef struct entry {
    double p[3];
    uint32_t index;
    float e;
} entry;

/* A record: the entries sorted by e, and a lower bound on the distance from
 * the centre of every point not listed (with n = 0: of every point). */
typedef struct record {
    uint32_t n;
    float bound;
    entry list[];
} record;

struct pkss__nn_field {
    const pkss__kdtree *tree;
    const double *tp;      /* the tree's points, tree order */
    const uint32_t *order; /* tree position -> index */
    double side, inv_side, rho;
    int slot_bits;
    size_t mask;           /* slots - 1 */
    slot *slots;
    atomic_size_t cells;
    entry *pool;           /* records, in units of an entry */
    size_t pool_size;
    atomic_size_t used;
};

pkss__nn_field *pkss__nn_field_new(const pkss__kdtree *tree, double spacing)
{
    return pkss__nn_field_sized(tree, spacing, PKSS_FIELD_SLOT_BITS, PKSS_FIELD_POOL_ENTRIES);
}

pkss__nn_field *pkss__nn_field_sized(const pkss__kdtree *tree, double spacing,
                                     int slot_bits, size_t pool_entries)
{
    if (!tree || !(spacing > 0.0) || pkss__kdtree_size(tree) == 0 || slot_bits < 1 ||
        slot_bits > 30 || pool_entries < 2)
        return NULL;
    pkss__nn_field *f = pkss__calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->tree = tree;
    f->tp = pkss__kdtree_points(tree);
    f->order = pkss__kdtree_order(tree);
    f->side = PKSS_FIELD_CELL * spacing;
    f->inv_side = 1.0 / f->side;
    f->rho = 0.5 * sqrt(3.0) * f->side;
    f->slot_bits = slot_bits;
    f->mask = ((size_t)1 << slot_bits) - 1;
    f->slots = pkss__calloc(f->mask + 1, sizeof *f->slots);
    f->pool_size = pool_entries;
    /* unit 0 is never a record, so that an offset of 0 means "seen" */
    atomic_init(&f->used, 1);
    atomic_init(&f->cells, 0);
    f->pool = pkss__malloc(f->pool_size * sizeof *f->pool);
    if (!f->slots || !f->pool) {
        pkss__nn_field_free(f);
        return NULL;
    }
    return f;
}

void pkss__nn_field_free(pkss__nn_field *f)
{
    if (!f)
        return;
    pkss__free(f->slots);
    pkss__free(f->pool);
    pkss__free(f);
}

/* A float at most x (x >= 0): records keep distances as lower bounds. */
static float float_below(double x)
{
    float v = (float)x;
    return (double)v > x ? nextafterf(v, 0.0f) : v;
}

/* Builds the record of the cube with centre c into the pool; returns its
 * offset, or NO_LIST. The list holds every point within d_1 + 2 rho of c
 * (the nearest of each location in the cube) unless the cube lies beyond
 * PKSS_FIELD_FAR sides (then that distance is the bound) or the list would
 * be too long (then d_1 is). */
static uint32_t build(pkss__nn_field *f, const double c[3])
{
    /* the nearest only as far as a list is kept: beyond, its reach bounds */
    const double far = PKSS_FIELD_FAR * f->side;
    double d1sq;
    const int near = pkss__kdtree_nearest(f->tree, c, far * far, &d1sq) != UINT32_MAX;
    const double d1 = near ? sqrt(d1sq) : far;
    size_t n = 0;
    double bound = d1 * LOWER;
    uint32_t pos[PKSS_FIELD_MAX_LIST];
    double dd[PKSS_FIELD_MAX_LIST];
    if (near) {
        const double r = (d1 + 2.0 * f->rho) / LOWER;
        n = pkss__kdtree_within(f->tree, c, r * r, PKSS_FIELD_MAX_LIST, pos, dd);
        if (n > PKSS_FIELD_MAX_LIST)
            n = 0; /* too crowded for a list: keep the bound from d1 only */
        else
            bound = r * LOWER;
    }
    /* the header takes one entry's room */
    const size_t units = 1 + n;
    size_t at = atomic_fetch_add_explicit(&f->used, units, memory_order_relaxed);
    if (at + units > f->pool_size || at + units >= BUILDING)
        return NO_LIST;
    record *rec = (record *)(f->pool + at);
    for (size_t i = 0; i < n; ++i) {
        entry x;
        memcpy(x.p, f->tp + 3 * (size_t)pos[i], sizeof x.p);
        x.index = f->order[pos[i]];
        x.e = float_below(sqrt(dd[i]));
        size_t j = i;
        for (; j > 0 && rec->list[j - 1].e > x.e; --j)
            rec->list[j] = rec->list[j - 1];
        rec->list[j] = x;
    }
    rec->n = (uint32_t)n;
    rec->bound = float_below(bound);
    return (uint32_t)at;
}

/* The key of the cube q lies in (0 if beyond the packed range) and its
 * centre c. */
static uint64_t cube_of(const pkss__nn_field *f, const double q[3], double c[3])
{
    uint64_t key = 1; /* nonzero: EMPTY is 0 */
    for (int d = 0; d < 3; ++d) {
        double k = floor(q[d] * f->inv_side);
        if (!(fabs(k) < AXIS_LIMIT))
            return 0;
        c[d] = (k + 0.5) * f->side;
        key = (key << AXIS_BITS) | (uint64_t)((int64_t)k + AXIS_LIMIT);
    }
    return key;
}

/* The slot of cube key, claimed for it if it had none (*fresh set then);
 * NULL when the table is full enough or its probes are taken. */
static slot *slot_of(pkss__nn_field *f, uint64_t key, int *fresh)
{
    *fresh = 0;
    size_t h = (size_t)((key * 0x9E3779B97F4A7C15ull) >> (64 - f->slot_bits));
    for (int probe = 0; probe < PKSS_FIELD_PROBES; ++probe, h = (h + 1) & f->mask) {
        slot *s = &f->slots[h];
        uint64_t k = atomic_load_explicit(&s->key, memory_order_acquire);
        if (k == EMPTY) {
            if (atomic_load_explicit(&f->cells, memory_order_relaxed) > (f->mask + 1) / 2)
                return NULL; /* the table is full enough: no more cubes */
            uint64_t expected = EMPTY;
            if (atomic_compare_exchange_strong_explicit(&s->key, &expected, key,
                                                        memory_order_acq_rel,
                                                        memory_order_acquire)) {
                atomic_fetch_add_explicit(&f->cells, 1, memory_order_relaxed);
                *fresh = 1;
                return s;
            }
            k = expected;
        }
        if (k == key)
            return s;
    }
    return NULL;
}

/* Builds the list of a seen cube (slot s, centre c) if this thread claims
 * it; returns the slot's offset after that (BUILDING while another thread
 * builds it). */
static uint32_t build_claimed(pkss__nn_field *f, slot *s, const double c[3])
{
    uint32_t at = atomic_load_explicit(&s->at, memory_order_acquire);
    if (at != SEEN)
        return at;
    uint32_t seen = SEEN;
    if (!atomic_compare_exchange_strong_explicit(&s->at, &seen, BUILDING,
                                                 memory_order_acq_rel, memory_order_acquire))
        return seen; /* another thread claimed it */
    at = build(f, c);
    atomic_store_explicit(&s->at, at, memory_order_release);
    return at;
}

/* The record of the cube q lies in, and the cube's centre; NULL where the
 * tree must answer. A cube's list is built on its second query, by the
 * thread that claims it: one asked once would not repay its building
 * (unless pkss__nn_field_warm built it ahead). */
static const record *record_of(pkss__nn_field *f, const double q[3], double c[3])
{
    uint64_t key = cube_of(f, q, c);
    int fresh;
    slot *s = key ? slot_of(f, key, &fresh) : NULL;
    if (!s || fresh)
        return NULL; /* first seen, or no room */
    uint32_t at = build_claimed(f, s, c);
    return at == BUILDING || at == NO_LIST ? NULL : (const record *)(f->pool + at);
}

size_t pkss__nn_field_warm(pkss__nn_field *f, const double *pts, size_t n,
                           const atomic_int *stop)
{
    size_t built = 0;
    for (size_t i = 0; f && i < n; ++i) {
        if (atomic_load_explicit(stop, memory_order_relaxed))
            break;
        double c[3];
        uint64_t key = cube_of(f, pts + 3 * i, c);
        int fresh;
        slot *s = key ? slot_of(f, key, &fresh) : NULL;
        if (s && atomic_load_explicit(&s->at, memory_order_acquire) == SEEN) {
            uint32_t at = build_claimed(f, s, c);
            built += at != BUILDING && at != NO_LIST;
        }
    }
    return built;
}

/* (d2, i) comes before (bd, bi): nearer, or as near with a lower index. */
static inline int nearer(double d2, uint32_t i, double bd, uint32_t bi)
{
    return d2 < bd || (d2 == bd && i < bi);
}

int pkss__nn_field_near(pkss__nn_field *f, const double q[3], int keep, uint32_t *idx,
                        double *d2, double *lb)
{
    if (!f || keep < 1 || keep >= PKSS_FIELD_MAX_KEEP)
        return -1;
    double c[3];
    const record *rec = record_of(f, q, c);
    if (!rec)
        return -1;
    const double delta = sqrt(pkss__dist2(q, c)) / LOWER;
    /* the keep + 1 nearest read so far, by (d2, index) */
    uint32_t bi[PKSS_FIELD_MAX_KEEP];
    double bd[PKSS_FIELD_MAX_KEEP];
    int got = 0;
    double rest = (double)rec->bound - delta; /* every point not listed */
    for (uint32_t j = 0; j < rec->n; ++j) {
        const entry *x = &rec->list[j];
        const double low = (double)x->e - delta;
        if (got == keep + 1 && low > 0.0 && low * low > bd[keep]) {
            /* this entry and all after it lie beyond the last one kept */
            rest = low < rest ? low : rest;
            break;
        }
        const double dd = pkss__dist2(x->p, q);
        if (got == keep + 1 && !nearer(dd, x->index, bd[keep], bi[keep]))
            continue;
        int at = got < keep + 1 ? got++ : keep;
        while (at > 0 && nearer(dd, x->index, bd[at - 1], bi[at - 1])) {
            bd[at] = bd[at - 1];
            bi[at] = bi[at - 1];
            --at;
        }
        bd[at] = dd;
        bi[at] = x->index;
    }
    double bound = rest > 0.0 ? rest : 0.0;
    if (got == keep + 1) {
        double last = sqrt(bd[keep]) * LOWER;
        bound = last < bound ? last : bound;
        got = keep;
    }
    /* only those strictly inside the bound are known to be the nearest; with
     * none of them, the nearest is not known unless nothing lies inside */
    int known = 0;
    while (known < got && bd[known] < bound * bound)
        ++known;
    if (got > 0 && known == 0)
        return -1;
    got = known;
    for (int i = 0; i < got; ++i) {
        idx[i] = bi[i];
        d2[i] = bd[i];
    }
    *lb = bound;
    return got;
}
