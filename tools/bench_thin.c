/* SPDX-License-Identifier: MIT
 * bench_thin.c -- voxel thinning (SPEC 2.1) of huge clouds of several
 * kinds to max_raw_points: the count it lands on and the best of --runs
 * CPU-bound runs. A developer tool (it links pkss_static for
 * pkss__thin_voxel); the kinds are seeded and need no data:
 *   surface  1M points on a sphere
 *   volume   1M points filling a cube
 *   rod      1M points in a thin bar (nearly a line)
 *   rings    1M points of a LiDAR-like sweep: 64 rings, dense near the centre
 *   rings2M  the same, 2M points
 *   FILE     any file pkss_io reads, given with --file
 *   ./tools/bench_thin [--runs 3] [--file scan.ply]
 */
#define _POSIX_C_SOURCE 200809L
#include "pkss_internal.h"
#include "pkss_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TARGET 200000

static double uniform(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) * 0x1.0p-53;
}

/* n points of the kind, malloc'd. */
static double *make(const char *kind, size_t n)
{
    double *x = malloc(n * 3 * sizeof *x);
    uint64_t s = 42;
    for (size_t i = 0; x && i < n; ++i) {
        double a = uniform(&s), b = uniform(&s), c = uniform(&s), *p = x + 3 * i;
        if (!strcmp(kind, "surface")) {
            double z = 2.0 * a - 1.0, r = sqrt(1.0 - z * z), t = 2.0 * PKSS_PI * b;
            p[0] = r * cos(t), p[1] = r * sin(t), p[2] = z;
        } else if (!strcmp(kind, "volume")) {
            p[0] = a, p[1] = b, p[2] = c;
        } else if (!strcmp(kind, "rod")) {
            p[0] = 10.0 * a, p[1] = 0.01 * b, p[2] = 0.01 * c;
        } else { /* rings: range ~ Rayleigh, so dense near the sensor */
            double r = 30.0 * sqrt(-2.0 * log(a + 1e-12)), t = 2.0 * PKSS_PI * b;
            p[0] = r * cos(t), p[1] = r * sin(t), p[2] = 0.2 * c + 0.05 * (double)(i % 64);
        }
    }
    return x;
}

static void bench(const char *name, const double *x, size_t n, int runs)
{
    double best = HUGE_VAL;
    size_t m = 0;
    for (int r = 0; r < runs; ++r) {
        double *out = NULL, t0 = pkss__now();
        if (pkss__thin_voxel(x, n, TARGET, 0, &out, &m) != PKSS_OK) {
            printf("%-8s thinning failed\n", name);
            return;
        }
        double t = pkss__now() - t0;
        best = t < best ? t : best;
        free(out);
    }
    printf("| %s | %zu | %zu | %.4f |\n", name, n, m, best);
}

int main(int argc, char **argv)
{
    int runs = 3;
    const char *file = NULL;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--file") && i + 1 < argc)
            file = argv[++i];
        else {
            fprintf(stderr, "usage: bench_thin [--runs N] [--file CLOUD]\n");
            return 2;
        }
    }
    printf("| cloud | points | thinned (target %d) | best of %d, s |\n|---|---:|---:|---:|\n",
           TARGET, runs);
    const char *kinds[] = {"surface", "volume", "rod", "rings"};
    for (size_t k = 0; k < sizeof kinds / sizeof *kinds; ++k) {
        double *x = make(kinds[k], 1000000);
        if (!x)
            return 1;
        bench(kinds[k], x, 1000000, runs);
        free(x);
    }
    double *x = make("rings", 2000000);
    if (x)
        bench("rings2M", x, 2000000, runs);
    free(x);
    if (file) {
        char err[512];
        size_t n = 0;
        if (pkss_read_points(file, PKSS_FORMAT_AUTO, &x, &n, err, sizeof err) != PKSS_OK) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        bench(file, x, n, runs);
        pkss_points_free(x);
    }
    return 0;
}
