/* SPDX-License-Identifier: MIT */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "pkss_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define PI 3.14159265358979323846

const char *pkss_test_data_path(const char *relative)
{
    static char buf[4096];
    const char *root = getenv("PKSS_DATA_DIR");
    if (!root || !root[0])
        root = PKSS_DATA_DIR;
    snprintf(buf, sizeof buf, "%s/%s", root, relative);
    struct stat st;
    if (stat(buf, &st) != 0)
        return NULL;
    return buf;
}

double *pkss_test_load(const char *relative, size_t *n)
{
    const char *path = pkss_test_data_path(relative);
    if (!path) {
        print_message("SKIP: %s not found under the shared data folder "
                      "(../shared/data or $PKSS_DATA_DIR)\n", relative);
        skip();
        return NULL;
    }
    double *xyz = NULL;
    char err[512];
    pkss_status st = pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err);
    if (st != PKSS_OK) {
        print_error("cannot load %s: %s\n", path, err);
        return NULL;
    }
    return xyz;
}

double *pkss_test_load_bundled(const char *name, size_t *n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", PKSS_TEST_DATA_DIR, name);
    double *xyz = NULL;
    char err[512];
    if (pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err) != PKSS_OK) {
        print_error("cannot load %s: %s\n", path, err);
        return NULL;
    }
    return xyz;
}

int pkss_test_read_matrix(const char *path, const char *label, double T[16])
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    char line[4096];
    int found = label == NULL, k = 0;
    while (k < 16 && fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        if (!found) {
            line[strcspn(line, "\r\n")] = 0;
            found = strcmp(line, label) == 0;
            continue;
        }
        char *p = line, *end;
        for (;;) {
            double v = strtod(p, &end);
            if (end == p)
                break;
            if (k < 16)
                T[k++] = v;
            p = end;
            while (*p == ',' || *p == ' ' || *p == '\t')
                ++p;
        }
    }
    fclose(f);
    return k == 16 ? 0 : -1;
}

uint64_t pkss_test_seed(const char *program, uint64_t fallback)
{
    const char *e = getenv("PKSS_TEST_SEED");
    uint64_t s = (e && e[0]) ? strtoull(e, NULL, 0) : fallback;
    printf("[%s] seed %llu (set PKSS_TEST_SEED to replay)\n", program,
           (unsigned long long)s);
    fflush(stdout);
    return s;
}

uint64_t pkss_test_next(pkss_test_rng *r)
{
    uint64_t z = (r->s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

double pkss_test_uniform(pkss_test_rng *r)
{
    return (double)(pkss_test_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

double pkss_test_normal(pkss_test_rng *r)
{
    double u = pkss_test_uniform(r), v = pkss_test_uniform(r);
    if (u < 1e-300)
        u = 1e-300;
    return sqrt(-2.0 * log(u)) * cos(2.0 * PI * v);
}

void pkss_test_random_rotation(pkss_test_rng *r, double R[9])
{
    double q[4], n = 0;
    for (int i = 0; i < 4; ++i) {
        q[i] = pkss_test_normal(r);
        n += q[i] * q[i];
    }
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - z * w); R[2] = 2 * (x * z + y * w);
    R[3] = 2 * (x * y + z * w); R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - x * w);
    R[6] = 2 * (x * z - y * w); R[7] = 2 * (y * z + x * w); R[8] = 1 - 2 * (x * x + y * y);
}

void pkss_test_random_similarity(pkss_test_rng *r, double max_t, double T[16])
{
    double R[9];
    pkss_test_random_rotation(r, R);
    double s = exp(log(0.5) + pkss_test_uniform(r) * (log(2.0) - log(0.5)));
    memset(T, 0, 16 * sizeof(double));
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            T[4 * i + j] = s * R[3 * i + j];
        T[4 * i + 3] = max_t * (2.0 * pkss_test_uniform(r) - 1.0);
    }
    T[15] = 1;
}

void pkss_test_apply(const double T[16], const double *in, size_t n, double *out)
{
    for (size_t i = 0; i < n; ++i) {
        double x = in[3 * i], y = in[3 * i + 1], z = in[3 * i + 2];
        for (int r = 0; r < 3; ++r)
            out[3 * i + r] = T[4 * r] * x + T[4 * r + 1] * y + T[4 * r + 2] * z + T[4 * r + 3];
    }
}

void pkss_test_mul4(const double A[16], const double B[16], double C[16])
{
    double T[16];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double s = 0;
            for (int k = 0; k < 4; ++k)
                s += A[4 * i + k] * B[4 * k + j];
            T[4 * i + j] = s;
        }
    memcpy(C, T, sizeof T);
}

void pkss_test_decompose(const double T[16], double *s, double R[9])
{
    double det = T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8]) +
                 T[2] * (T[4] * T[9] - T[5] * T[8]);
    double sc = cbrt(det);
    *s = sc;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            R[3 * i + j] = T[4 * i + j] / sc;
}

void pkss_test_inverse_similarity(const double T[16], double Ti[16])
{
    double s, R[9];
    pkss_test_decompose(T, &s, R);
    memset(Ti, 0, 16 * sizeof(double));
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            Ti[4 * i + j] = R[3 * j + i] / s;
    for (int i = 0; i < 3; ++i)
        Ti[4 * i + 3] = -(Ti[4 * i] * T[3] + Ti[4 * i + 1] * T[7] + Ti[4 * i + 2] * T[11]);
    Ti[15] = 1;
}

pkss_test_err pkss_test_pose_error(const double T_est[16], const double T_gt[16],
                                   const double at[3])
{
    pkss_test_err e;
    double se, Re[9], sg, Rg[9];
    pkss_test_decompose(T_est, &se, Re);
    pkss_test_decompose(T_gt, &sg, Rg);
    double tr = 0;
    for (int i = 0; i < 9; ++i)
        tr += Re[i] * Rg[i];
    double c = 0.5 * (tr - 1.0);
    c = c > 1 ? 1 : (c < -1 ? -1 : c);
    e.rot_deg = acos(c) * 180.0 / PI;
    e.scale_rel = fabs(se / sg - 1.0);
    double a[3], b[3];
    pkss_test_apply(T_est, at, 1, a);
    pkss_test_apply(T_gt, at, 1, b);
    e.trans = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
    return e;
}

double pkss_test_diameter(const double *xyz, size_t n)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d) {
            if (xyz[3 * i + d] < lo[d]) lo[d] = xyz[3 * i + d];
            if (xyz[3 * i + d] > hi[d]) hi[d] = xyz[3 * i + d];
        }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

void pkss_test_centroid(const double *xyz, size_t n, double c[3])
{
    c[0] = c[1] = c[2] = 0;
    for (size_t i = 0; i < n; ++i)
        for (int d = 0; d < 3; ++d)
            c[d] += xyz[3 * i + d];
    for (int d = 0; d < 3; ++d)
        c[d] /= (double)n;
}

void pkss_test_shuffle(pkss_test_rng *r, double *xyz, size_t n)
{
    for (size_t i = n; i > 1; --i) {
        size_t j = (size_t)(pkss_test_next(r) % i);
        for (int d = 0; d < 3; ++d) {
            double t = xyz[3 * (i - 1) + d];
            xyz[3 * (i - 1) + d] = xyz[3 * j + d];
            xyz[3 * j + d] = t;
        }
    }
}

size_t pkss_test_extreme(const double *xyz, size_t n, int axis, int from_min)
{
    const double sign = from_min ? -1.0 : 1.0;
    size_t top = 0;
    for (size_t i = 1; i < n; ++i)
        if (sign * xyz[3 * i + axis] > sign * xyz[3 * top + axis])
            top = i;
    return top;
}

static double cut_centre[3]; /* for by_distance_to_cut (qsort has no context) */

static int by_distance_to_cut(const void *a, const void *b)
{
    const double *x = a, *y = b;
    double da = 0.0, db = 0.0;
    for (int k = 0; k < 3; ++k) {
        da += (x[k] - cut_centre[k]) * (x[k] - cut_centre[k]);
        db += (y[k] - cut_centre[k]) * (y[k] - cut_centre[k]);
    }
    return (da > db) - (da < db);
}

double *pkss_test_cut_near(const double *xyz, size_t n, size_t centre, double share,
                           size_t *n_part)
{
    double *part = malloc(3 * n * sizeof(double));
    if (!part)
        return NULL;
    memcpy(part, xyz, 3 * n * sizeof(double));
    for (int k = 0; k < 3; ++k)
        cut_centre[k] = xyz[3 * centre + k];
    qsort(part, n, 3 * sizeof(double), by_distance_to_cut);
    size_t cut = (size_t)(share * (double)n);
    *n_part = n - cut;
    memmove(part, part + 3 * cut, 3 * *n_part * sizeof(double));
    return part;
}

/* Keeps each point with probability p (NULL when out of memory). */
static double *random_subset(pkss_test_rng *r, const double *xyz, size_t n, double p,
                             size_t *n_out)
{
    double *out = malloc((n ? n : 1) * 3 * sizeof(double));
    size_t k = 0;
    for (size_t i = 0; out && i < n; ++i)
        if (pkss_test_uniform(r) < p) {
            memcpy(out + 3 * k, xyz + 3 * i, 3 * sizeof(double));
            ++k;
        }
    *n_out = k;
    return out;
}

void pkss_test_similar_pair(pkss_test_rng *r, const double *xyz, size_t n, double p,
                            double **src, size_t *ns, double **tgt, size_t *nt,
                            double T[16])
{
    *src = random_subset(r, xyz, n, p, ns);
    *tgt = random_subset(r, xyz, n, p, nt);
    pkss_test_random_similarity(r, pkss_test_diameter(xyz, n), T);
    if (*tgt)
        pkss_test_apply(T, *tgt, *nt, *tgt);
}

pkss_candidate pkss_test_candidate(const pkss_context *ctx, size_t index)
{
    pkss_candidate c;
    pkss_candidate_init(&c, sizeof c);
    if (pkss_context_candidate(ctx, index, &c) != PKSS_OK)
        memset(c.T_target_source, 0, sizeof c.T_target_source);
    return c;
}

void pkss_test_need_device(void)
{
    unsigned count = 0;
    pkss_status st = pkss_device_count(&count);
    if (st != PKSS_OK || count == 0) {
        print_message("SKIP: no OpenCL device (%s): %s\n", pkss_status_name(st),
                      pkss_no_device_reason());
        skip();
    }
}
