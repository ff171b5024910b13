/* SPDX-License-Identifier: MIT
 * pkss_count.c -- pkss_dump with the work of each registration: prints
 * pkss_dump's line per pair (score_dump.py reads it) on stdout, and the
 * counts of the ICP's nearest-neighbour lookups (refine/work_counts.h) on
 * stderr. Built (linked statically) when CMake runs with -DPKSS_COUNT_WORK=ON
 * (tools/README.md).
 *   pkss_count DIR [reference|opencl] > transforms.txt 2> counts.txt */
#include "pairs.h"
#include "work_counts.h"

static void report(const char *id, pkss_status st, const pkss_result *res,
                   pkss_context *ctx)
{
    (void)ctx;
    unsigned long n[PKSS_WORK_COUNTS];
    pkss__work_counts(n);
    pairs_print(id, st, res);
    fprintf(stderr, "%s lookups %lu single %lu first %lu moved %lu\n", id,
            n[PKSS_WORK_LOOKUPS], n[PKSS_WORK_SINGLE], n[PKSS_WORK_FIRST],
            n[PKSS_WORK_MOVED]);
}

int main(int argc, char **argv)
{
    return pairs_run(argc, argv, "pkss_count", report);
}
