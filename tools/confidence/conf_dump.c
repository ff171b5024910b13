/* SPDX-License-Identifier: MIT
 * conf_dump.c -- registers every pair of a manifest (tools/confidence/
 * pairs.py writes it: id, pkss seed, source file, target file, raw
 * little-endian float64 xyz) and prints one JSON line per pair: the pose,
 * the confidence, the ambiguity report and the model's features, which are
 * internal (a developer tool: it links pkss_static for them).
 *   conf_dump DIR [reference|opencl] > runs.jsonl */
#include "pkss_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double *load(const char *dir, const char *name, size_t *n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    double *xyz = malloc(bytes > 0 ? (size_t)bytes : 1);
    *n = (size_t)bytes / (3 * sizeof(double));
    if (!xyz || fread(xyz, sizeof(double), 3 * *n, f) != 3 * *n) {
        free(xyz);
        xyz = NULL;
    }
    fclose(f);
    return xyz;
}

static void print_array(const double *x, int n)
{
    putchar('[');
    for (int i = 0; i < n; ++i)
        printf("%s%.17g", i ? "," : "", x[i]);
    putchar(']');
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: conf_dump DIR [reference|opencl]\n");
        return 2;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/manifest.txt", argv[1]);
    FILE *man = fopen(path, "r");
    if (!man) {
        fprintf(stderr, "conf_dump: cannot open %s\n", path);
        return 2;
    }
    int backend = argc > 2 && strcmp(argv[2], "opencl") == 0 ? PKSS_BACKEND_OPENCL
                                                             : PKSS_BACKEND_REFERENCE;
    pkss_context *ctx = NULL;
    if (pkss_context_create(&ctx) != PKSS_OK)
        return 1;
    char id[512], sname[256], tname[256];
    long seed;
    while (fscanf(man, "%511s %ld %255s %255s", id, &seed, sname, tname) == 4) {
        size_t ns = 0, nt = 0;
        double *s = load(argv[1], sname, &ns), *t = load(argv[1], tname, &nt);
        pkss_context_reset(ctx, PKSS_RESET_PARAMS);
        pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend);
        pkss_context_set_int(ctx, PKSS_PARAM_SEED, seed);
        pkss_result res;
        pkss_result_init(&res, sizeof res);
        pkss_status st = s && t ? pkss_register(ctx, s, ns, t, nt, &res)
                                : PKSS_ERR_NULL_ARGUMENT;
        printf("{\"id\":\"%s\",\"status\":\"%s\"", id, pkss_status_name(st));
        if (st == PKSS_OK) {
            printf(",\"T\":");
            print_array(res.T_target_source, 16);
            printf(",\"confidence\":%.17g,\"ambiguous\":%u,\"symmetry\":%d,"
                   "\"order\":%u,\"axis\":",
                   res.confidence, res.ambiguous, res.symmetry, res.symmetry_order);
            print_array(res.symmetry_axis, 3);
            printf(",\"time\":%.6g,\"assess_time\":%.6g,\"features\":",
                   res.timings.total, ctx->assess.seconds);
            print_array(ctx->assess.features, PKSS__ASSESS_FEATURES);
            printf(",\"alternatives\":[");
            for (uint32_t i = 0; i < res.n_alternatives; ++i) {
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
        fflush(stdout);
        free(s);
        free(t);
    }
    fclose(man);
    pkss_context_destroy(ctx);
    return 0;
}
