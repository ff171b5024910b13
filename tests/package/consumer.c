/* SPDX-License-Identifier: MIT
 * consumer.c -- a program outside the pkss tree, built against an
 * installed pkss (CMake package or pkg-config, see README.md here): it
 * reads a PLY pair itself (nothing but libpkss is linked), registers it
 * and checks the result against a ground-truth 4x4:
 *   rotation error < 2 degrees and |s / s_gt - 1| < 1 %.
 *
 *   pkss-consumer SOURCE.ply TARGET.ply GT_4x4.txt
 * Exit 0 pass, 1 beyond the tolerances, 2 usage or unreadable input,
 * 3 registration failure.
 */
#include <pkss.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- a minimal PLY reader: the vertex element's x y z, ascii or binary
 * little-endian, every property a scalar (no lists in the vertex element);
 * elements before "vertex" are not supported (the bundled files have
 * none). */
static size_t type_size(const char *t)
{
    static const struct { const char *name; size_t size; } types[] = {
        {"char", 1}, {"uchar", 1}, {"int8", 1}, {"uint8", 1},
        {"short", 2}, {"ushort", 2}, {"int16", 2}, {"uint16", 2},
        {"int", 4}, {"uint", 4}, {"int32", 4}, {"uint32", 4},
        {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
        if (strcmp(t, types[i].name) == 0)
            return types[i].size;
    return 0;
}

/* A coordinate of `size` bytes: 4 float, 8 double (integer coordinates are
 * not needed here). Little-endian host assumed (x86, arm64). */
static double read_le(const unsigned char *p, size_t size)
{
    if (size == 4) {
        float f;
        memcpy(&f, p, 4);
        return f;
    }
    double d;
    memcpy(&d, p, 8);
    return d;
}

static double *read_ply(const char *path, size_t *n_out)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "consumer: cannot open %s\n", path);
        return NULL;
    }
    char line[512] = "";
    int binary = -1, n_props = 0, xyz[3] = {-1, -1, -1}, in_vertex = 0;
    size_t n = 0, stride = 0, offset[64], size[64];
    while (fgets(line, sizeof line, f)) {
        char a[64], b[64], c[64];
        if (strncmp(line, "format ", 7) == 0 && sscanf(line, "format %63s", a) == 1)
            binary = strcmp(a, "ascii") == 0 ? 0
                     : strcmp(a, "binary_little_endian") == 0 ? 1 : -1;
        else if (sscanf(line, "element %63s %63s", a, b) == 2) {
            in_vertex = strcmp(a, "vertex") == 0;
            if (in_vertex)
                n = strtoul(b, NULL, 10);
        } else if (in_vertex && sscanf(line, "property %63s %63s", a, b) == 2 &&
                   strcmp(a, "list") != 0 && n_props < 64) {
            size_t s = type_size(a);
            if (s == 0)
                break;
            if (sscanf(line, "property %*s %63s", c) == 1 && c[1] == '\0' &&
                c[0] >= 'x' && c[0] <= 'z') {
                if (strncmp(a, "float", 5) != 0 && strcmp(a, "double") != 0)
                    break; /* integer coordinates */
                xyz[c[0] - 'x'] = n_props;
            }
            size[n_props] = s;
            offset[n_props++] = stride;
            stride += s;
        } else if (strncmp(line, "end_header", 10) == 0) {
            break;
        }
    }
    double *pts = NULL;
    if (strncmp(line, "end_header", 10) != 0 || binary < 0 || n == 0 || xyz[0] < 0 ||
        xyz[1] < 0 || xyz[2] < 0 || !(pts = malloc(n * 3 * sizeof *pts))) {
        fprintf(stderr, "consumer: %s: unsupported or empty PLY\n", path);
        fclose(f);
        return NULL;
    }
    unsigned char rec[64 * 8];
    for (size_t i = 0; i < n; ++i) {
        int ok = 1;
        if (binary) {
            ok = fread(rec, 1, stride, f) == stride;
            for (int d = 0; ok && d < 3; ++d)
                pts[3 * i + d] = read_le(rec + offset[xyz[d]], size[xyz[d]]);
        } else {
            for (int p = 0; ok && p < n_props; ++p) {
                double v;
                ok = fscanf(f, "%lf", &v) == 1;
                for (int d = 0; d < 3; ++d)
                    if (xyz[d] == p)
                        pts[3 * i + d] = v;
            }
        }
        if (!ok) {
            fprintf(stderr, "consumer: %s: truncated at vertex %zu of %zu\n", path, i, n);
            free(pts);
            fclose(f);
            return NULL;
        }
    }
    fclose(f);
    *n_out = n;
    return pts;
}

/* First 16 numbers of a text file; '#' lines skipped. */
static int read_matrix(const char *path, double T[16])
{
    FILE *f = fopen(path, "r");
    char line[1024];
    int k = 0;
    while (f && k < 16 && fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        char *p = line, *end;
        for (double v = strtod(p, &end); end != p && k < 16; v = strtod(p, &end)) {
            T[k++] = v;
            p = end;
        }
    }
    if (f)
        fclose(f);
    return k == 16 ? 0 : -1;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: %s SOURCE.ply TARGET.ply GT_4x4.txt\n", argv[0]);
        return 2;
    }
    /* The header this was compiled against and the library loaded now. */
    printf("pkss header %d.%d.%d, library %s\n", PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR,
           PKSS_VERSION_PATCH, pkss_version_string());
    if (pkss_version_number() / 10000 != PKSS_VERSION_MAJOR) {
        fprintf(stderr, "consumer: library major version differs from the header's\n");
        return 2;
    }
    size_t ns = 0, nt = 0;
    double G[16];
    double *src = read_ply(argv[1], &ns), *tgt = read_ply(argv[2], &nt);
    if (!src || !tgt || read_matrix(argv[3], G) != 0) {
        fprintf(stderr, "consumer: cannot read the inputs\n");
        free(src);
        free(tgt);
        return 2;
    }
    pkss_context *ctx = NULL;
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_context_create(&ctx);
    if (st == PKSS_OK)
        st = pkss_register(ctx, src, ns, tgt, nt, &res);
    if (st != PKSS_OK) {
        fprintf(stderr, "consumer: %s: %s\n", pkss_status_name(st),
                ctx ? pkss_context_last_error(ctx) : "");
        pkss_context_destroy(ctx);
        free(src);
        free(tgt);
        return 3;
    }
    /* s_gt = cbrt(det(sR)); rotation error = angle of R_gt^T R */
    double s_gt = cbrt(G[0] * (G[5] * G[10] - G[6] * G[9]) - G[1] * (G[4] * G[10] - G[6] * G[8]) +
                       G[2] * (G[4] * G[9] - G[5] * G[8]));
    double tr = 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            tr += (G[4 * r + c] / s_gt) * res.rotation[3 * r + c];
    double rot_deg = acos(fmax(-1.0, fmin(1.0, 0.5 * (tr - 1.0)))) * 180.0 / 3.14159265358979323846;
    double scale_err = fabs(res.scale / s_gt - 1.0);
    printf("registered %zu onto %zu points on %s in %.3f s\n", ns, nt, res.device,
           res.timings.total);
    printf("scale %.6f (ground truth %.6f): error %.4f %%; rotation error %.4f deg\n", res.scale,
           s_gt, 100.0 * scale_err, rot_deg);
    int ok = rot_deg < 2.0 && scale_err < 0.01;
    printf("%s\n", ok ? "PASS (rotation < 2 deg, scale within 1 %)" : "FAIL");
    pkss_context_destroy(ctx);
    free(src);
    free(tgt);
    return ok ? 0 : 1;
}
