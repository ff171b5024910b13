/* SPDX-License-Identifier: MIT
 * pkss_demo.c -- registers a pair of point cloud files and compares the
 * result with a known ground-truth T_target_source. Without arguments it
 * uses the bundled sample pair (tests/data/airplane_0001_{s,t}.ply): the
 * README's first command runs this. A thin client of pkss.h.
 *
 *   pkss-demo [SOURCE TARGET GROUND_TRUTH_4x4.txt]
 */
#include "pkss.h"
#include "pkss_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef PKSS_SAMPLE_DIR
#define PKSS_SAMPLE_DIR "tests/data"
#endif

static double *load(const char *path, size_t *n)
{
    double *xyz = NULL;
    char err[512];
    if (pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err) != PKSS_OK) {
        fprintf(stderr, "pkss-demo: %s\n", err);
        return NULL;
    }
    return xyz;
}

/* First 16 numbers of a text file, '#' lines skipped. */
static int read_matrix(const char *path, double T[16])
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[1024];
    int k = 0;
    while (k < 16 && fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        char *p = line, *end;
        for (double v = strtod(p, &end); end != p && k < 16; v = strtod(p, &end)) {
            T[k++] = v;
            p = end;
        }
    }
    fclose(f);
    return k == 16 ? 0 : -1;
}

int main(int argc, char **argv)
{
    const char *src_path = PKSS_SAMPLE_DIR "/airplane_0001_s.ply";
    const char *tgt_path = PKSS_SAMPLE_DIR "/airplane_0001_t.ply";
    const char *gt_path = PKSS_SAMPLE_DIR "/gt_similarity_s_to_t.txt";
    if (argc == 4) {
        src_path = argv[1];
        tgt_path = argv[2];
        gt_path = argv[3];
    } else if (argc != 1) {
        fprintf(stderr, "usage: pkss-demo [SOURCE TARGET GROUND_TRUTH_4x4.txt]\n");
        return 2;
    }
    size_t ns = 0, nt = 0;
    double *src = load(src_path, &ns), *tgt = load(tgt_path, &nt);
    double G[16];
    if (!src || !tgt || read_matrix(gt_path, G) != 0) {
        if (src && tgt)
            fprintf(stderr, "pkss-demo: cannot read a 4x4 matrix from %s\n", gt_path);
        free(src);
        free(tgt);
        return 3;
    }

    pkss_context *ctx = NULL;
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_context_create(&ctx);
    if (st == PKSS_OK)
        st = pkss_register(ctx, src, ns, tgt, nt, &res);
    if (st != PKSS_OK) {
        fprintf(stderr, "pkss-demo: %s: %s\n", pkss_status_name(st),
                pkss_context_last_error(ctx));
        pkss_context_destroy(ctx);
        free(src);
        free(tgt);
        return 5;
    }
    printf("Registered %s (%zu points) onto %s (%zu points)\n", src_path, ns, tgt_path, nt);
    printf("T_target_source:\n");
    for (int r = 0; r < 4; ++r)
        printf("  % .9f % .9f % .9f % .9f\n", res.T_target_source[4 * r],
               res.T_target_source[4 * r + 1], res.T_target_source[4 * r + 2],
               res.T_target_source[4 * r + 3]);
    /* error against the ground truth: rotation angle of R_gt^T R, scale
     * ratio, and the distance between the two images of the source centroid */
    double s_gt = cbrt(G[0] * (G[5] * G[10] - G[6] * G[9]) - G[1] * (G[4] * G[10] - G[6] * G[8]) +
                       G[2] * (G[4] * G[9] - G[5] * G[8]));
    double tr = 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            tr += (G[4 * r + c] / s_gt) * res.rotation[3 * r + c];
    double cosang = fmax(-1.0, fmin(1.0, 0.5 * (tr - 1.0)));
    double c[3] = {0, 0, 0}, lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < ns; ++i)
        for (int d = 0; d < 3; ++d)
            c[d] += src[3 * i + d] / (double)ns;
    for (size_t i = 0; i < nt; ++i)
        for (int d = 0; d < 3; ++d) {
            lo[d] = fmin(lo[d], tgt[3 * i + d]);
            hi[d] = fmax(hi[d], tgt[3 * i + d]);
        }
    double dt = 0, diam = 0;
    for (int r = 0; r < 3; ++r) {
        double a = res.T_target_source[4 * r + 3], b = G[4 * r + 3];
        for (int k = 0; k < 3; ++k) {
            a += res.T_target_source[4 * r + k] * c[k];
            b += G[4 * r + k] * c[k];
        }
        dt += (a - b) * (a - b);
        diam += (hi[r] - lo[r]) * (hi[r] - lo[r]);
    }
    printf("scale %.6f (ground truth %.6f), overlap %.3f, rms %.3g, %.3f s on %s\n", res.scale,
           s_gt, res.overlap, res.rms, res.timings.total, res.device);
    printf("error vs ground truth: rotation %.5f deg, scale %.5f %%, translation %.5f %% of "
           "the target diameter\n",
           acos(cosang) * 180.0 / 3.14159265358979323846, 100.0 * fabs(res.scale / s_gt - 1.0),
           100.0 * sqrt(dt) / sqrt(diam));
    pkss_context_destroy(ctx);
    free(src);
    free(tgt);
    return 0;
}
