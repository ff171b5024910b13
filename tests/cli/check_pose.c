/* SPDX-License-Identifier: MIT
 * check_pose.c -- helper of the CLI tests: compares a 4x4 similarity
 * written by pkss-align (--matrix) with ground truth, and checks output
 * clouds. Uses only the file readers of the library (pkss_io.h).
 *
 *   check_pose pose EST GT SOURCE TARGET MAX_ROT_DEG MAX_SCALE MAX_TRANS
 *              [GT_SOURCE_LABEL GT_TARGET_LABEL]
 *       GT holds a 4x4 (lines starting with '#' skipped). With labels, GT
 *       is a list of "label" lines each followed by a 4x4 pose into a
 *       common frame, and the ground truth is inv(T_target) * T_source.
 *       Errors: rotation angle of R_est^T R_gt (degrees), |s/s_gt - 1|,
 *       and the distance between the source centroid mapped by both
 *       poses, as a fraction of the target's bounding-box diagonal.
 *   check_pose count CLOUD N         the cloud loads with N points
 *   check_pose same MATRIX_A MATRIX_B TOL   max |a - b| <= TOL * max |b|
 *   check_pose cloud_same CLOUD_A CLOUD_B   same points, x y z bit-identical
 *       (a written PCD or XYZ against the binary PLY of the same run)
 *
 * Exit 0 pass, 1 fail, 2 usage or unreadable input.
 */
#include "pkss_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int read_matrix(const char *path, const char *label, double T[16])
{
    FILE *f = fopen(path, "r");
    char line[4096];
    int k = 0, found = label == NULL;
    if (!f) {
        fprintf(stderr, "check_pose: cannot open %s\n", path);
        return -1;
    }
    while (k < 16 && fgets(line, sizeof line, f)) {
        char *p = line, *end;
        if (line[0] == '#')
            continue;
        if (!found) {
            line[strcspn(line, "\r\n")] = '\0';
            found = strcmp(line, label) == 0;
            continue;
        }
        for (;;) {
            double v = strtod(p, &end);
            if (end == p)
                break;
            T[k++] = v;
            if (k == 16)
                break;
            p = end;
            while (*p == ',' || *p == ' ' || *p == '\t')
                p++;
        }
    }
    fclose(f);
    if (k != 16) {
        fprintf(stderr, "check_pose: %s: no 4x4 matrix%s%s\n", path,
                label ? " after label " : "", label ? label : "");
        return -1;
    }
    return 0;
}

static double det3(const double *A)
{
    return A[0] * (A[5] * A[10] - A[6] * A[9]) -
           A[1] * (A[4] * A[10] - A[6] * A[8]) +
           A[2] * (A[4] * A[9] - A[5] * A[8]);
}

/* s and R (row-major 3x3) of a 4x4 similarity. */
static void decompose(const double *T, double *s, double R[9])
{
    int r, c;
    double d = det3(T);
    *s = cbrt(d);
    for (r = 0; r < 3; r++)
        for (c = 0; c < 3; c++)
            R[3 * r + c] = T[4 * r + c] / *s;
}

/* Inverse of a rigid or similarity 4x4. */
static void inverse(const double *T, double *Ti)
{
    double s, R[9];
    int r, c;
    decompose(T, &s, R);
    memset(Ti, 0, 16 * sizeof(double));
    for (r = 0; r < 3; r++) {
        for (c = 0; c < 3; c++)
            Ti[4 * r + c] = R[3 * c + r] / s;
        Ti[4 * r + 3] = 0;
        for (c = 0; c < 3; c++)
            Ti[4 * r + 3] -= Ti[4 * r + c] * T[4 * c + 3];
    }
    Ti[15] = 1;
}

static void mul(const double *A, const double *B, double *C)
{
    int r, c, k;
    for (r = 0; r < 4; r++)
        for (c = 0; c < 4; c++) {
            double v = 0;
            for (k = 0; k < 4; k++)
                v += A[4 * r + k] * B[4 * k + c];
            C[4 * r + c] = v;
        }
}

static void apply(const double *T, const double *p, double *q)
{
    int r;
    for (r = 0; r < 3; r++)
        q[r] = T[4 * r] * p[0] + T[4 * r + 1] * p[1] + T[4 * r + 2] * p[2] +
               T[4 * r + 3];
}

static double *load(const char *path, size_t *n)
{
    double *xyz = NULL;
    char err[1024];
    if (pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err) !=
        PKSS_OK) {
        fprintf(stderr, "check_pose: %s\n", err);
        return NULL;
    }
    return xyz;
}

static int cmd_pose(int argc, char **argv)
{
    double E[16], G[16], Gs[16], Gt[16], Gti[16], se, sg, Re[9], Rg[9];
    double c[3] = {0, 0, 0}, lo[3], hi[3], pe[3], pg[3], tr = 0, diam, terr;
    double max_rot, max_scale, max_trans, rot_err, scale_err;
    double *src, *tgt;
    size_t ns, nt, i, nc = 0;
    int k, ok;

    if (argc != 9 && argc != 11) {
        fprintf(stderr, "check_pose pose: wrong arguments\n");
        return 2;
    }
    max_rot = atof(argv[6]);
    max_scale = atof(argv[7]);
    max_trans = atof(argv[8]);
    if (read_matrix(argv[2], NULL, E) != 0)
        return 2;
    if (argc == 11) {
        if (read_matrix(argv[3], argv[9], Gs) != 0 ||
            read_matrix(argv[3], argv[10], Gt) != 0)
            return 2;
        inverse(Gt, Gti);
        mul(Gti, Gs, G);
    } else if (read_matrix(argv[3], NULL, G) != 0) {
        return 2;
    }
    src = load(argv[4], &ns);
    tgt = load(argv[5], &nt);
    if (!src || !tgt) {
        free(src);
        free(tgt);
        return 2;
    }
    for (i = 0; i < ns; i++)
        if (isfinite(src[3 * i]) && isfinite(src[3 * i + 1]) &&
            isfinite(src[3 * i + 2])) {
            for (k = 0; k < 3; k++)
                c[k] += src[3 * i + k];
            nc++;
        }
    for (k = 0; k < 3; k++) {
        c[k] /= nc ? (double)nc : 1.0;
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (i = 0; i < nt; i++)
        for (k = 0; k < 3; k++)
            if (isfinite(tgt[3 * i + k])) {
                if (tgt[3 * i + k] < lo[k]) lo[k] = tgt[3 * i + k];
                if (tgt[3 * i + k] > hi[k]) hi[k] = tgt[3 * i + k];
            }
    diam = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) +
                (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
    free(src);
    free(tgt);

    decompose(E, &se, Re);
    decompose(G, &sg, Rg);
    for (k = 0; k < 3; k++) /* trace of Re^T Rg */
        tr += Re[k] * Rg[k] + Re[3 + k] * Rg[3 + k] + Re[6 + k] * Rg[6 + k];
    {
        double cosang = 0.5 * (tr - 1.0);
        if (cosang > 1) cosang = 1;
        if (cosang < -1) cosang = -1;
        rot_err = acos(cosang) * 180.0 / 3.14159265358979323846;
    }
    scale_err = fabs(se / sg - 1.0);
    apply(E, c, pe);
    apply(G, c, pg);
    terr = sqrt((pe[0] - pg[0]) * (pe[0] - pg[0]) +
                (pe[1] - pg[1]) * (pe[1] - pg[1]) +
                (pe[2] - pg[2]) * (pe[2] - pg[2]));
    ok = isfinite(se) && se > 0 && rot_err <= max_rot &&
         scale_err <= max_scale && terr <= max_trans * diam;
    printf("rotation error %.4f deg (bar %g), scale error %.5f%% (bar %g%%), "
           "translation error %.6g = %.4f%% of diameter %.6g (bar %g%%): %s\n",
           rot_err, max_rot, 100 * scale_err, 100 * max_scale, terr,
           diam > 0 ? 100 * terr / diam : 0.0, diam, 100 * max_trans,
           ok ? "PASS" : "FAIL");
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && strcmp(argv[1], "pose") == 0)
        return cmd_pose(argc, argv);
    if (argc == 4 && strcmp(argv[1], "count") == 0) {
        size_t n = 0;
        double *xyz = load(argv[2], &n);
        if (!xyz)
            return 2;
        free(xyz);
        if (n != (size_t)strtoull(argv[3], NULL, 10)) {
            printf("%s: %lu points, expected %s: FAIL\n", argv[2],
                   (unsigned long)n, argv[3]);
            return 1;
        }
        printf("%s: %lu points: PASS\n", argv[2], (unsigned long)n);
        return 0;
    }
    if (argc == 5 && strcmp(argv[1], "same") == 0) {
        double A[16], B[16], m = 0, d = 0, tol = atof(argv[4]);
        int k;
        if (read_matrix(argv[2], NULL, A) != 0 ||
            read_matrix(argv[3], NULL, B) != 0)
            return 2;
        for (k = 0; k < 16; k++) {
            if (fabs(B[k]) > m) m = fabs(B[k]);
            if (fabs(A[k] - B[k]) > d) d = fabs(A[k] - B[k]);
        }
        printf("max difference %.3g (tolerance %.3g): %s\n", d, tol * m,
               d <= tol * m ? "PASS" : "FAIL");
        return d <= tol * m ? 0 : 1;
    }
    if (argc == 4 && strcmp(argv[1], "cloud_same") == 0) {
        size_t na = 0, nb = 0, i;
        double *a = load(argv[2], &na), *b = a ? load(argv[3], &nb) : NULL;
        int ok;
        if (!a || !b) {
            free(a);
            return 2;
        }
        ok = na == nb;
        for (i = 0; ok && i < 3 * na; i++)
            if (memcmp(&a[i], &b[i], sizeof a[i]) != 0) {
                printf("point %lu coordinate %lu: %.17g vs %.17g\n",
                       (unsigned long)(i / 3), (unsigned long)(i % 3), a[i],
                       b[i]);
                ok = 0;
            }
        printf("%s: %lu points, %s: %lu points, bit-identical: %s\n",
               argv[2], (unsigned long)na, argv[3], (unsigned long)nb,
               ok ? "PASS" : "FAIL");
        free(a);
        free(b);
        return ok ? 0 : 1;
    }
    fprintf(stderr, "usage: check_pose pose|count|same|cloud_same ... (see the source)\n");
    return 2;
}
