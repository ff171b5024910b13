/* SPDX-License-Identifier: MIT
 * bench_search.c -- timings of the global search (SPEC 5) on the OpenCL
 * backend (e.g. PoCL on the CPU) and the reference backend, printed as
 * markdown tables:
 *   1. per stage -- binning, scoring, selection -- for m (points), n
 *      (rotation steps) and N (offset steps) varied one at a time around
 *      the default m = 3000, n = 12, N = 5, medians of --runs runs, and
 *      the default's second search (wide grid, trimmed measure);
 *   2. pkss_register end to end with its stage breakdown
 *      (pkss_result.timings): the bunny, and 30k-point inputs (the dragon
 *      scan against a random similarity copy; the LiDAR pair).
 * Binning and scoring of the OpenCL backend are device times from event
 * profiling; "search" is the host wall time of pkss__search_cl (uploads,
 * launches, downloads) plus the selection. The reference's binning is timed
 * by repeating its binning loops alone; its scoring is the rest of
 * pkss__search_ref.
 *
 *   bench_search [--runs R] [--data DIR] [--quick]
 *
 * Uses library internals (pkss_static), so it is a developer tool, not a
 * client of the public API. Set POCL_CACHE_DIR to a writable folder.
 */
#define _POSIX_C_SOURCE 200809L
#include "pkss_cl.h"
#include "pkss_internal.h"
#include "pkss_io.h"
#include "search_fixture.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifndef PKSS_DATA_DIR
#define PKSS_DATA_DIR "../shared/data"
#endif

static int g_runs = 5;
static const char *g_data = PKSS_DATA_DIR;

/* ------------------------------------------------------------- helpers */
static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* CPU seconds of the whole process (all threads, PoCL's workers too):
 * unlike wall time, not inflated by other processes on a shared machine. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static double rng_uniform(uint64_t *s) { return (rng_next(s) >> 11) * (1.0 / 9007199254740992.0); }

static double *load(const char *rel, size_t *n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", g_data, rel);
    double *xyz = NULL;
    char err[512];
    if (pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err) != PKSS_OK) {
        fprintf(stderr, "bench_search: cannot read %s: %s\n", path, err);
        return NULL;
    }
    return xyz;
}

/* k points drawn without replacement (partial Fisher-Yates). */
static double *subset(const double *xyz, size_t n, size_t k, uint64_t *s)
{
    if (k > n)
        k = n;
    size_t *idx = malloc(n * sizeof *idx);
    double *out = malloc(k * 3 * sizeof(double));
    for (size_t i = 0; i < n; ++i)
        idx[i] = i;
    for (size_t i = 0; i < k; ++i) {
        size_t j = i + (size_t)(rng_uniform(s) * (double)(n - i));
        size_t t = idx[i];
        idx[i] = idx[j];
        idx[j] = t;
        memcpy(out + 3 * i, xyz + 3 * idx[i], 3 * sizeof(double));
    }
    free(idx);
    return out;
}

/* In place: x <- s R x + t, R from a random unit quaternion, s in
 * [0.5, 2] log-uniform, |t| up to the cloud's extent. */
static void random_similarity(double *xyz, size_t n, uint64_t *s)
{
    double q[4], norm = 0;
    for (int i = 0; i < 4; ++i) {
        double u1 = rng_uniform(s) + 1e-12, u2 = rng_uniform(s);
        q[i] = sqrt(-2 * log(u1)) * cos(2 * 3.14159265358979323846 * u2);
        norm += q[i] * q[i];
    }
    norm = sqrt(norm);
    double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
    double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    double sc = exp(log(0.5) + rng_uniform(s) * log(4.0));
    double t[3] = {rng_uniform(s) - 0.5, rng_uniform(s) - 0.5, rng_uniform(s) - 0.5};
    for (size_t i = 0; i < n; ++i) {
        double p[3];
        pkss__mat3_apply(R, xyz + 3 * i, p);
        for (int d = 0; d < 3; ++d)
            xyz[3 * i + d] = sc * p[d] + 10 * t[d];
    }
}

static pkss_context *make_context(int backend)
{
    pkss_context *ctx = NULL;
    if (pkss_context_create(&ctx) != PKSS_OK)
        return NULL;
    pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, backend);
    double t0 = pkss__now();
    pkss_status st = pkss_context_prepare(ctx);
    if (st != PKSS_OK) {
        fprintf(stderr, "bench_search: prepare (%s): %s: %s\n",
                backend == PKSS_BACKEND_OPENCL ? "opencl" : "reference",
                pkss_status_name(st), pkss_context_last_error(ctx));
        pkss_context_destroy(ctx);
        return NULL;
    }
    if (backend == PKSS_BACKEND_OPENCL)
        printf("OpenCL device: %s; prepare (program build) %.3f s\n",
               pkss_context_device_name(ctx), pkss__now() - t0);
    return ctx;
}

/* ------------------------------------------------------- search stages */
typedef struct stage_times {
    double bin, score, select, search, cpu; /* medians, seconds */
    size_t pairs;
} stage_times;

/* The reference's binning loops alone (what pkss__search_ref does first). */
static void ref_binning(const pkss__search_input *in, float *tab)
{
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const size_t table = (size_t)in->n_az * (size_t)(in->n_az / 2) * 4;
    for (size_t b = 0; b < in->rot->n_binnings; ++b) {
        pkss_bin_points(in->src_pts, in->n_src, in->rot->bin_R + 9 * b, 0, 0, 0,
                        in->n_az, in->edges, tab);
        if (in->use_features)
            pkss_bin_points(in->src_feat, in->n_src_feat, in->rot->bin_R + 9 * b,
                            0, 0, 0, in->n_az, in->edges, tab + table);
    }
    for (int o = 0; o < in->n_offsets; ++o) {
        const float *c = in->offsets + 3 * o;
        pkss_bin_points(in->tgt_pts, in->n_tgt, I, c[0], c[1], c[2], in->n_az,
                        in->edges, tab);
        (void)pkss_count_occupied(tab, (int)(table / 4));
        if (in->use_features) {
            pkss_bin_points(in->tgt_feat, in->n_tgt_feat, I, c[0], c[1], c[2],
                            in->n_az, in->edges, tab + table);
            (void)pkss_count_occupied(tab + table, (int)(table / 4));
        }
    }
}

static int time_search(pkss_context *ctx, const search_fixture *f,
                       stage_times *out)
{
    const int cl = ctx->backend_in_use == PKSS_BACKEND_OPENCL;
    size_t total = f->setup.rot.n_rotations * (size_t)f->setup.n_offsets;
    float *s = malloc(3 * total * sizeof(float));
    float tab[2 * PKSS_MAX_CELLS * 4];
    double *bin = malloc((size_t)g_runs * sizeof(double));
    double *score = malloc((size_t)g_runs * sizeof(double));
    double *sel = malloc((size_t)g_runs * sizeof(double));
    double *all = malloc((size_t)g_runs * sizeof(double));
    double *cpu = malloc((size_t)g_runs * sizeof(double));
    int ok = 1;
    for (int r = -1; r < g_runs && ok; ++r) { /* r = -1: warm-up */
        double c0 = cpu_now();
        double t0 = pkss__now();
        pkss_status st = cl ? pkss__search_cl(ctx, &f->setup.in, s, s + total, s + 2 * total)
                            : pkss__search_ref(ctx, &f->setup.in, s, s + total, s + 2 * total);
        double t1 = pkss__now();
        pkss__pick picks[PKSS_MAX_CANDIDATES];
        size_t kept = pkss__select_top_k(s, s + total, f->setup.in.use_features ? s + 2 * total : NULL,
                                         &f->setup.rot, (size_t)f->setup.n_offsets,
                                         (size_t)ctx->params.top_k, picks);
        double t2 = pkss__now();
        double c2 = cpu_now();
        if (st != PKSS_OK || kept == SIZE_MAX) {
            fprintf(stderr, "bench_search: search: %s: %s\n", pkss_status_name(st),
                    pkss_context_last_error(ctx));
            ok = 0;
            break;
        }
        if (r < 0)
            continue;
        if (cl) {
            pkss__cl_stage_seconds(ctx, &bin[r], &score[r]);
        } else {
            double tb = pkss__now();
            ref_binning(&f->setup.in, tab);
            bin[r] = pkss__now() - tb;
            score[r] = (t1 - t0) - bin[r];
        }
        sel[r] = t2 - t1;
        all[r] = t2 - t0;
        cpu[r] = c2 - c0;
    }
    if (ok) {
        out->bin = median(bin, g_runs);
        out->score = median(score, g_runs);
        out->select = median(sel, g_runs);
        out->search = median(all, g_runs);
        out->cpu = median(cpu, g_runs);
        out->pairs = total;
    }
    free(s);
    free(bin);
    free(score);
    free(sel);
    free(all);
    free(cpu);
    return ok;
}

static void bench_stages(pkss_context *cl, pkss_context *ref, const double *cloud,
                         size_t n, int quick)
{
    static const int configs[][3] = {
        /* m, n, N: the default, then one varied at a time */
        {3000, 12, 5}, {1000, 12, 5}, {5000, 12, 5}, {3000, 8, 5},
        {3000, 16, 5}, {3000, 12, 1}, {3000, 12, 3},
    };
    size_t n_cfg = quick ? 1 : sizeof configs / sizeof configs[0];
    uint64_t seed = 42;
    double *a = subset(cloud, n, n * 7 / 10, &seed);
    double *b = subset(cloud, n, n * 7 / 10, &seed);
    size_t na = n * 7 / 10, nb = n * 7 / 10;
    random_similarity(b, nb, &seed);

    printf("\n### Search stages (medians of %d runs; bunny reconstruction, 70 %% subsets)\n\n",
           g_runs);
    printf("| backend | m | n | N | pairs | binning s | scoring s | selection s | "
           "search s (bin+score+select, wall) | CPU s (all threads) |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t c = 0; c < n_cfg; ++c) {
        for (int k = 0; k < 2; ++k) {
            pkss_context *ctx = k == 0 ? cl : ref;
            if (!ctx)
                continue;
            pkss_context_set_int(ctx, PKSS_PARAM_POINTS, configs[c][0]);
            pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_STEPS, configs[c][1]);
            pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, configs[c][2]);
            search_fixture f;
            if (search_fixture_build(ctx, a, na, b, nb, &f) != PKSS_OK) {
                fprintf(stderr, "bench_search: %s\n", pkss_context_last_error(ctx));
                continue;
            }
            stage_times t;
            if (time_search(ctx, &f, &t))
                printf("| %s | %d | %d | %d | %zu | %.4f | %.4f | %.4f | %.4f | %.4f |\n",
                       k == 0 ? "OpenCL" : "reference", configs[c][0], configs[c][1],
                       configs[c][2], t.pairs, t.bin, t.score, t.select, t.search, t.cpu);
            /* the default's second search: wide grid, trimmed measure */
            if (c == 0 && pkss__search_setup_widen(&ctx->params, f.tgt, &f.setup) == PKSS_OK &&
                time_search(ctx, &f, &t))
                printf("| %s | %d | %d | %d wide, keep %.1f | %zu | %.4f | %.4f | %.4f | %.4f | %.4f |\n",
                       k == 0 ? "OpenCL" : "reference", configs[c][0], configs[c][1],
                       configs[c][2], (double)f.setup.in.keep, t.pairs, t.bin, t.score,
                       t.select, t.search, t.cpu);
            fflush(stdout);
            search_fixture_free(&f);
        }
    }
    for (int k = 0; k < 2; ++k) {
        pkss_context *ctx = k == 0 ? cl : ref;
        if (!ctx)
            continue;
        pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 0); /* defaults */
        pkss_context_set_int(ctx, PKSS_PARAM_ROTATION_STEPS, 0);
        pkss_context_set_int(ctx, PKSS_PARAM_OFFSET_STEPS, 0);
    }
    free(a);
    free(b);
}

/* ---------------------------------------------------------- end to end */
static void bench_register(pkss_context *ctx, const char *label, const double *src,
                           size_t ns, const double *tgt, size_t nt)
{
    double *v[5], *tot;
    for (int i = 0; i < 5; ++i)
        v[i] = malloc((size_t)g_runs * sizeof(double));
    tot = malloc((size_t)g_runs * sizeof(double));
    pkss_result res;
    for (int r = -1; r < g_runs; ++r) { /* r = -1: warm-up */
        pkss_result_init(&res, sizeof res);
        pkss_status st = pkss_register(ctx, src, ns, tgt, nt, &res);
        if (st != PKSS_OK) {
            fprintf(stderr, "bench_search: register %s: %s: %s\n", label,
                    pkss_status_name(st), pkss_context_last_error(ctx));
            goto done;
        }
        if (r < 0)
            continue;
        v[0][r] = res.timings.validate;
        v[1][r] = res.timings.preprocess;
        v[2][r] = res.timings.search;
        v[3][r] = res.timings.refine;
        tot[r] = res.timings.total;
        v[4][r] = res.timings.total - (res.timings.validate + res.timings.preprocess +
                                       res.timings.search + res.timings.refine);
    }
    double mv = median(v[0], g_runs), mp = median(v[1], g_runs), ms = median(v[2], g_runs);
    double mr = median(v[3], g_runs), mo = median(v[4], g_runs), mt = median(tot, g_runs);
    printf("| %s | %s | %zu / %zu | %.4f | %.4f (%.0f %%) | %.4f (%.0f %%) | %.4f (%.0f %%) "
           "| %.4f | **%.4f** |\n",
           label, res.backend == PKSS_BACKEND_OPENCL ? "OpenCL" : "reference", ns, nt, mv,
           mp, 100 * mp / mt, ms, 100 * ms / mt, mr, 100 * mr / mt, mo, mt);
    fflush(stdout);
done:
    for (int i = 0; i < 5; ++i)
        free(v[i]);
    free(tot);
}

int main(int argc, char **argv)
{
    int quick = 0;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--runs") == 0 && i + 1 < argc)
            g_runs = atoi(argv[++i]);
        else if (strcmp(argv[i], "--data") == 0 && i + 1 < argc)
            g_data = argv[++i];
        else if (strcmp(argv[i], "--quick") == 0)
            quick = 1;
        else {
            fprintf(stderr, "usage: bench_search [--runs R] [--data DIR] [--quick]\n");
            return 2;
        }
    }
    if (g_runs < 1)
        g_runs = 1;
    printf("%s\n", pkss_build_info());
    double la_v[3] = {0, 0, 0};
    FILE *la = fopen("/proc/loadavg", "r");
    if (la) {
        if (fscanf(la, "%lf %lf %lf", &la_v[0], &la_v[1], &la_v[2]) != 3)
            la_v[0] = la_v[1] = la_v[2] = 0;
        fclose(la);
    }
    printf("load average at start: %.2f %.2f %.2f (wall times grow with it; CPU "
           "times much less)\n", la_v[0], la_v[1], la_v[2]);
    pkss_context *cl = make_context(PKSS_BACKEND_OPENCL);
    pkss_context *ref = make_context(PKSS_BACKEND_REFERENCE);
    if (!ref)
        return 1;

    size_t n_bunny = 0, n_dragon = 0, n_ls = 0, n_lt = 0;
    double *bunny = load("stanford_bunny/reconstruction/bun_zipper_res2.ply", &n_bunny);
    if (!bunny)
        return 1;
    bench_stages(cl, ref, bunny, n_bunny, quick);

    printf("\n### pkss_register end to end (defaults; medians of %d runs after a warm-up; "
           "share of total in parentheses)\n\n", g_runs);
    printf("| input | backend | points src / tgt | validate s | preprocess s | search s | "
           "refine s | other s | total s |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
    uint64_t seed = 7;
    double *bs = subset(bunny, n_bunny, n_bunny * 7 / 10, &seed);
    double *bt = subset(bunny, n_bunny, n_bunny * 7 / 10, &seed);
    random_similarity(bt, n_bunny * 7 / 10, &seed);
    for (int k = 0; k < 2; ++k)
        if (k == 0 ? cl != NULL : 1)
            bench_register(k == 0 ? cl : ref, "bunny 70 % vs similarity copy", bs,
                           n_bunny * 7 / 10, bt, n_bunny * 7 / 10);
    double *dragon = quick ? NULL : load("stanford_dragon_stand/converted/dragonStandRight_0.ply", &n_dragon);
    if (dragon) {
        double *ds = subset(dragon, n_dragon, 30000, &seed);
        double *dt = subset(dragon, n_dragon, 30000, &seed);
        random_similarity(dt, 30000, &seed);
        for (int k = 0; k < 2; ++k)
            if (k == 0 ? cl != NULL : 1)
                bench_register(k == 0 ? cl : ref, "dragon scan 30k vs similarity copy 30k",
                               ds, 30000, dt, 30000);
        free(ds);
        free(dt);
    }
    double *ls = quick ? NULL : load("lidar_small_gicp/source.ply", &n_ls);
    double *lt = quick ? NULL : load("lidar_small_gicp/target.ply", &n_lt);
    if (ls && lt) {
        double *s30 = subset(ls, n_ls, 30000, &seed);
        double *t30 = subset(lt, n_lt, 30000, &seed);
        for (int k = 0; k < 2; ++k)
            if (k == 0 ? cl != NULL : 1)
                bench_register(k == 0 ? cl : ref, "LiDAR source 30k vs target 30k", s30,
                               30000, t30, 30000);
        free(s30);
        free(t30);
    }
    free(bs);
    free(bt);
    pkss_points_free(bunny);
    pkss_points_free(dragon);
    pkss_points_free(ls);
    pkss_points_free(lt);
    pkss_context_destroy(cl);
    pkss_context_destroy(ref);
    return 0;
}
