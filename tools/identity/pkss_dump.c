/* SPDX-License-Identifier: MIT
 * pkss_dump.c -- registers every pair of an export_pairs.py manifest and
 * prints each transform's 16 doubles in hex (%a), so that two builds of the
 * library can be compared bit for bit (tools/identity/README.md). Builds
 * against the 0.1 header as well as 1.x, to compare across the ABI change.
 *   pkss_dump DIR [reference|opencl] > transforms.txt */
#include "pkss.h"

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

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: pkss_dump DIR [reference|opencl]\n");
        return 2;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/manifest.txt", argv[1]);
    FILE *man = fopen(path, "r");
    if (!man) {
        fprintf(stderr, "pkss_dump: cannot open %s\n", path);
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
#if PKSS_VERSION_MAJOR >= 1
        pkss_result_init(&res, sizeof res);
#else
        pkss_result_init(&res);
#endif
        pkss_status st = s && t ? pkss_register(ctx, s, ns, t, nt, &res)
                                : PKSS_ERR_NULL_ARGUMENT;
        printf("%s %s", id, pkss_status_name(st));
        for (int k = 0; k < 16; ++k)
            printf(" %a", st == PKSS_OK ? res.T_target_source[k] : 0.0);
        printf(" %.4f\n", st == PKSS_OK ? res.timings.total : 0.0);
        fflush(stdout);
        free(s);
        free(t);
    }
    fclose(man);
    pkss_context_destroy(ctx);
    return 0;
}
