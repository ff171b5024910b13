/* SPDX-License-Identifier: MIT
 * pkss_dump.c -- registers every pair of an export_pairs.py manifest and
 * prints each transform's 16 doubles in hex (%a), so that two builds of the
 * library can be compared bit for bit (tools/README.md), or scored with
 * score_dump.py. Builds against the 0.1 header as well as 1.x, to compare
 * across the ABI change.
 *   pkss_dump DIR [reference|opencl] > transforms.txt */
#include "pairs.h"

static void report(const char *id, pkss_status st, const pkss_result *res,
                   pkss_context *ctx)
{
    (void)ctx;
    pairs_print(id, st, res);
}

int main(int argc, char **argv)
{
    return pairs_run(argc, argv, "pkss_dump", report);
}
