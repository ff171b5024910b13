/* SPDX-License-Identifier: MIT
 * pose_probe.c -- whose miss is it? Scores a known pose (the ground truth)
 * and, optionally, pkss's answer with pkss's own measures (overlap, fit,
 * RMS of the mutual pairs: refine/icp.h), then lets the refinement start
 * from the truth: the point-to-plane polish alone, a whole full run, and
 * rigid runs at fixed scales around the truth's. When those leave the
 * truth for a pose that scores better, the objective prefers the miss:
 * the data cannot tell it from the truth, and no search will fix it.
 * A developer tool (it links pkss_static for the ICP engine).
 *   ./tools/pose_probe SOURCE TARGET TRUTH.txt [FOUND.txt] [--seed N]
 * TRUTH.txt / FOUND.txt: a 4x4 T_target_source (16 numbers, row-major),
 * e.g. pkss-align --matrix FOUND.txt.
 */
#define _POSIX_C_SOURCE 200809L
#include "pkss_internal.h"
#include "pkss_io.h"
#include "refine/icp_parts.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int read_matrix(const char *path, double T[16])
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    int ok = 1;
    for (int i = 0; i < 16 && ok; ++i)
        ok = fscanf(f, "%lf", &T[i]) == 1;
    fclose(f);
    return ok;
}

/* A caller-units similarity as a pose between the two pre-shapes (the
 * inverse of register.c:compose). */
static void to_pose(const pkss_cloud *s, const pkss_cloud *t, const double T[16],
                    pkss__pose *P)
{
    double A[9];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            A[3 * r + c] = T[4 * r + c];
    double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
                 A[2] * (A[3] * A[7] - A[4] * A[6]);
    double sc = cbrt(det), Rc[3];
    for (int i = 0; i < 9; ++i)
        P->R[i] = A[i] / sc;
    P->s = sc * s->sigma / t->sigma;
    pkss__mat3_apply(P->R, s->centroid, Rc);
    for (int d = 0; d < 3; ++d)
        P->t[d] = (T[4 * d + 3] + sc * Rc[d] - t->centroid[d]) / t->sigma;
}

static void show(const char *name, const pkss__icp_view *sv, const pkss__icp_view *tv,
                 const pkss__pose *P, const pkss__pose *truth)
{
    double ov = 0.0, rms = 0.0, fit = 0.0;
    pkss__icp_overlap(sv, tv, P, &ov, &rms, &fit);
    double deg = pkss__rotation_angle(P->R, truth->R) * 180.0 / PKSS_PI;
    printf("| %s | %+.2f | %.2f | %.4f | %.4f | %.5f |\n", name,
           100.0 * (P->s / truth->s - 1.0), deg, ov, fit, rms);
}

static void run_from(const char *name, const pkss__icp_view *sv, const pkss__icp_view *tv,
                     const pkss__icp_schedule *sched, const pkss__pose *start,
                     const pkss__pose *truth)
{
    pkss__icp_result r;
    memset(&r, 0, sizeof r);
    if (pkss__icp_run(sv, tv, sched, NULL, start, &r) == PKSS_OK)
        show(name, sv, tv, &r.pose, truth);
}

int main(int argc, char **argv)
{
    const char *path[4] = {NULL, NULL, NULL, NULL};
    int np = 0, seed = 0;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--seed") && i + 1 < argc)
            seed = atoi(argv[++i]);
        else if (np < 4)
            path[np++] = argv[i];
    }
    if (np < 3) {
        fprintf(stderr, "usage: pose_probe SOURCE TARGET TRUTH.txt [FOUND.txt] [--seed N]\n");
        return 2;
    }
    double *xs = NULL, *xt = NULL, Tg[16], Tf[16];
    size_t ns = 0, nt = 0;
    char err[512];
    if (pkss_read_points(path[0], PKSS_FORMAT_AUTO, &xs, &ns, err, sizeof err) != PKSS_OK ||
        pkss_read_points(path[1], PKSS_FORMAT_AUTO, &xt, &nt, err, sizeof err) != PKSS_OK) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    if (!read_matrix(path[2], Tg) || (path[3] && !read_matrix(path[3], Tf))) {
        fprintf(stderr, "cannot read a 4x4 matrix\n");
        return 1;
    }
    pkss_context *ctx = NULL;
    pkss_cloud *cs = NULL, *ct = NULL;
    if (pkss_context_create(&ctx) != PKSS_OK ||
        pkss_context_set_int(ctx, PKSS_PARAM_SEED, seed) != PKSS_OK ||
        pkss_cloud_create(ctx, xs, ns, &cs) != PKSS_OK ||
        pkss_cloud_create(ctx, xt, nt, &ct) != PKSS_OK) {
        fprintf(stderr, "%s\n", pkss_context_last_error(ctx));
        return 1;
    }
    pkss__icp_view sv, tv;
    pkss__icp_view_full(cs, &sv);
    pkss__icp_view_full(ct, &tv);
    pkss__pose G, F;
    to_pose(cs, ct, Tg, &G);
    printf("| pose | scale vs truth %% | rotation vs truth deg | overlap | fit | RMS (pre-shape) |\n"
           "|---|---:|---:|---:|---:|---:|\n");
    show("truth", &sv, &tv, &G, &G);
    if (path[3]) {
        to_pose(cs, ct, Tf, &F);
        show("found", &sv, &tv, &F, &G);
    }
    pkss__icp_work w;
    if (!pkss__work_alloc(&w, sv.m, tv.m, 1))
        return 1;
    pkss__pose P = G;
    double ov0;
    pkss__plane_stage(&sv, &tv, pkss__schedule_full.plane_iters, &w, &P, &ov0);
    pkss__work_free(&w);
    show("truth, then the polish", &sv, &tv, &P, &G);
    run_from("truth, then a full run", &sv, &tv, &pkss__schedule_full, &G, &G);
    pkss__icp_schedule rigid = pkss__schedule_full;
    rigid.free_scale = 0;
    rigid.plane_iters = 0;
    for (int k = -4; k <= 4; ++k) {
        pkss__pose Q = G;
        Q.s = G.s * (1.0 + 0.01 * k);
        char name[64];
        snprintf(name, sizeof name, "rigid run at truth scale %+d %%", k);
        run_from(name, &sv, &tv, &rigid, &Q, &G);
    }
    pkss_cloud_destroy(cs);
    pkss_cloud_destroy(ct);
    pkss_context_destroy(ctx);
    pkss_points_free(xs);
    pkss_points_free(xt);
    return 0;
}
