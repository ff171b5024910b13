/* SPDX-License-Identifier: MIT
 * dedupe.c -- removes exact duplicate points right after validation (a huge
 * input is voxel-thinned first, which keeps one point per voxel anyway).
 *
 * Scanners write stacks of identical records (e.g. the small_gicp LiDAR
 * scans hold ~5000 "no return" points at exactly (0,0,0), 7 % of the file)
 * and merged scans repeat points. Duplicates carry no shape: they make the
 * k nearest neighbours of a stack all coincide, which defeats the
 * neighbourhood statistics of the outlier filters (SPEC 2.2-2.3) and skews
 * the centroid. The first occurrence of each position is kept. O(n) with an
 * open-addressing hash set of point indices.
 */
#include "pkss_internal.h"

#include <string.h>

static uint64_t mix(uint64_t h, double v)
{
    uint64_t b;
    v += 0.0; /* -0.0 and +0.0 are the same position */
    memcpy(&b, &v, sizeof b);
    h ^= b + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    h ^= h >> 31;
    h *= 0xbf58476d1ce4e5b9ULL;
    return h ^ (h >> 29);
}

static int same(const double *a, const double *b)
{
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

pkss_status pkss__dedupe(const double *xyz, size_t n, unsigned char *keep,
                         size_t *n_unique)
{
    size_t cap = 16;
    while (cap < 2 * n)
        cap <<= 1;
    uint32_t *slot = pkss__malloc(cap * sizeof(uint32_t));
    if (!slot)
        return PKSS_ERR_OUT_OF_MEMORY;
    memset(slot, 0xff, cap * sizeof(uint32_t));
    size_t unique = 0;
    for (size_t i = 0; i < n; ++i) {
        const double *p = xyz + 3 * i;
        uint64_t h = mix(mix(mix(0, p[0]), p[1]), p[2]);
        size_t s = (size_t)h & (cap - 1);
        keep[i] = 1;
        while (slot[s] != UINT32_MAX) {
            if (same(xyz + 3 * (size_t)slot[s], p)) {
                keep[i] = 0;
                break;
            }
            s = (s + 1) & (cap - 1);
        }
        if (keep[i]) {
            slot[s] = (uint32_t)i;
            ++unique;
        }
    }
    pkss__free(slot);
    *n_unique = unique;
    return PKSS_OK;
}
