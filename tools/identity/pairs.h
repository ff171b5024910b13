/* SPDX-License-Identifier: MIT
 * pairs.h -- the loop shared by the pair dumpers (pkss_dump.c here,
 * tools/confidence/conf_dump.c): read an export_pairs.py / pairs.py
 * manifest (id, pkss seed, source file, target file: raw little-endian
 * float64 xyz), register each pair with that seed on the chosen backend,
 * and hand the outcome to the tool's report function. Builds against the
 * 0.1 header as well as 1.x. */
#ifndef PKSS_TOOLS_PAIRS_H
#define PKSS_TOOLS_PAIRS_H

#include "pkss.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void (*pairs_report_fn)(const char *id, pkss_status st,
                                const pkss_result *res, pkss_context *ctx);

static double *pairs_load(const char *dir, const char *name, size_t *n)
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

/* pkss_dump's line: the pair's id, status, the 16 doubles of its transform
 * in hex (%a) and its registration time (score_dump.py reads it). */
static inline void pairs_print(const char *id, pkss_status st, const pkss_result *res)
{
    printf("%s %s", id, pkss_status_name(st));
    for (int k = 0; k < 16; ++k)
        printf(" %a", st == PKSS_OK ? res->T_target_source[k] : 0.0);
    printf(" %.4f\n", st == PKSS_OK ? res->timings.total : 0.0);
}

/* main() of a dumper: TOOL DIR [reference|opencl]. */
static int pairs_run(int argc, char **argv, const char *tool, pairs_report_fn report)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s DIR [reference|opencl]\n", tool);
        return 2;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/manifest.txt", argv[1]);
    FILE *man = fopen(path, "r");
    if (!man) {
        fprintf(stderr, "%s: cannot open %s\n", tool, path);
        return 2;
    }
    int backend = argc > 2 && strcmp(argv[2], "opencl") == 0 ? PKSS_BACKEND_OPENCL
                                                             : PKSS_BACKEND_REFERENCE;
    pkss_context *ctx = NULL;
    if (pkss_context_create(&ctx) != PKSS_OK) {
        fclose(man);
        return 1;
    }
    char id[512], sname[256], tname[256];
    long seed;
    while (fscanf(man, "%511s %ld %255s %255s", id, &seed, sname, tname) == 4) {
        size_t ns = 0, nt = 0;
        double *s = pairs_load(argv[1], sname, &ns), *t = pairs_load(argv[1], tname, &nt);
        pkss_context_reset(ctx, PKSS_RESET_PARAMS);
        pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend);
        pkss_context_set_int(ctx, PKSS_PARAM_SEED, seed);
        pkss_result res;
#if PKSS_VERSION_MAJOR >= 1
        pkss_result_init(&res, sizeof res);
#else
        pkss_result_init(&res);
#endif
        pkss_status st = s && t ? pkss_register(ctx, s, ns, t, nt, &res)
                                : PKSS_ERR_NULL_ARGUMENT;
        report(id, st, &res, ctx);
        fflush(stdout);
        free(s);
        free(t);
    }
    fclose(man);
    pkss_context_destroy(ctx);
    return 0;
}

#endif
