/* SPDX-License-Identifier: MIT
 * conf_dump.c -- registers every pair of a manifest (tools/confidence/
 * pairs.py writes it: id, pkss seed, source file, target file, raw
 * little-endian float64 xyz) and prints one JSON line per pair: the pose,
 * the confidence, the ambiguity report and the model's features, which are
 * internal (a developer tool: it links pkss_static for them).
 *   conf_dump DIR [reference|opencl] > runs.jsonl */
#include "pkss_internal.h"
#include "../identity/pairs.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void print_array(const double *x, int n)
{
    putchar('[');
    for (int i = 0; i < n; ++i)
        printf("%s%.17g", i ? "," : "", x[i]);
    putchar(']');
}

static void report(const char *id, pkss_status st, const pkss_result *res,
                   pkss_context *ctx)
{
    printf("{\"id\":\"%s\",\"status\":\"%s\"", id, pkss_status_name(st));
    if (st == PKSS_OK) {
        printf(",\"T\":");
        print_array(res->T_target_source, 16);
        printf(",\"confidence\":%.17g,\"ambiguous\":%u,\"symmetry\":%d,"
               "\"order\":%u,\"axis\":",
               res->confidence, res->ambiguous, res->symmetry, res->symmetry_order);
        print_array(res->symmetry_axis, 3);
        printf(",\"time\":%.6g,\"assess_time\":%.6g,\"features\":",
               res->timings.total, ctx->assess.seconds);
        print_array(ctx->assess.features, PKSS__ASSESS_FEATURES);
        printf(",\"alternatives\":[");
        for (uint32_t i = 0; i < res->n_alternatives; ++i) {
            pkss_alternative a;
            pkss_alternative_init(&a, sizeof a);
            pkss_context_alternative(ctx, i, &a);
            printf("%s{\"angle\":%.6g,\"axis\":", i ? "," : "", a.angle_degrees);
            print_array(a.axis, 3);
            printf(",\"fit\":%.6g,\"candidate\":%d,\"T\":", a.fit, a.candidate);
            print_array(a.T_target_source, 16);
            putchar('}');
        }
        putchar(']');
    }
    printf("}\n");
}

int main(int argc, char **argv)
{
    return pairs_run(argc, argv, "conf_dump", report);
}
