/* SPDX-License-Identifier: MIT
 * basin.c -- the one "same minimum" test, with its two tolerance sets, and
 * the table of minima that runs reach (pkss__basins).
 */
#include "refine/icp_parts.h"

#include <math.h>

const pkss__basin_tol pkss__start_basin = {
    PKSS_START_BASIN_DEG, PKSS_START_BASIN_SCALE, PKSS_START_BASIN_H};
const pkss__basin_tol pkss__run_basin = {
    PKSS_RUN_BASIN_DEG, PKSS_RUN_BASIN_SCALE, PKSS_RUN_BASIN_H};

int pkss__same_basin(const pkss__pose *a, const pkss__pose *b, double h,
                     const pkss__basin_tol *tol)
{
    double reach = tol->spacings * h;
    return pkss__rotation_angle(a->R, b->R) < tol->degrees * PKSS_PI / 180.0 &&
           pkss__dist2(a->t, b->t) < reach * reach &&
           fabs(a->s / b->s - 1.0) < tol->scale;
}

int pkss__basins_find(const pkss__basins *b, const pkss__pose *T, double h,
                      int not_owner, double bar)
{
    for (int k = 0; k < b->n; ++k)
        if (b->owner[k] != not_owner && (!b->abandoned[k] || bar >= b->bar[k]) &&
            pkss__same_basin(T, &b->pose[k], h, &pkss__run_basin))
            return b->owner[k];
    return -1;
}

void pkss__basins_add(pkss__basins *b, const pkss__pose *T, int id, double bar)
{
    if (!b || b->n >= (int)(sizeof b->owner / sizeof *b->owner))
        return;
    b->pose[b->n] = *T;
    b->owner[b->n] = id;
    b->bar[b->n] = bar;
    b->abandoned[b->n++] = 0;
}

void pkss__basins_abandon(pkss__basins *b, int id)
{
    for (int k = 0; b && k < b->n; ++k)
        if (b->owner[k] == id)
            b->abandoned[k] = 1;
}
