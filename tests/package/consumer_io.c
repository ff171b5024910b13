/* SPDX-License-Identifier: MIT
 * consumer_io.c -- a program outside the pkss tree using the installed file
 * I/O (pkss_io.h): reads the pair with pkss_read_points, writes the source
 * as .npy and .pcd with pkss_write_points, checks both read back
 * bit-identically, then registers the pair and prints the scale.
 *
 *   pkss-consumer-io SOURCE TARGET WORK_DIR
 * Exit 0 pass, 1 a mismatch, 2 unreadable or unwritable file, 3 failure.
 */
#include <pkss.h>
#include <pkss_io.h>

#include <stdio.h>
#include <string.h>

static int load(const char *path, double **xyz, size_t *n)
{
    char err[512];
    pkss_status st = pkss_read_points(path, PKSS_FORMAT_AUTO, xyz, n, err, sizeof err);
    if (st != PKSS_OK)
        fprintf(stderr, "consumer-io: %s: %s\n", pkss_status_name(st), err);
    return st == PKSS_OK ? 0 : -1;
}

int main(int argc, char **argv)
{
    double *src = NULL, *tgt = NULL, *back = NULL;
    size_t ns = 0, nt = 0, nb = 0;
    char path[4096], err[512];
    static const char *const ext[] = {"npy", "pcd"};
    if (argc != 4) {
        fprintf(stderr, "usage: pkss-consumer-io SOURCE TARGET WORK_DIR\n");
        return 2;
    }
    if (load(argv[1], &src, &ns) != 0 || load(argv[2], &tgt, &nt) != 0)
        return 2;
    for (int k = 0; k < 2; ++k) {
        snprintf(path, sizeof path, "%s/source.%s", argv[3], ext[k]);
        pkss_status st = pkss_write_points(path, PKSS_FORMAT_AUTO, src, ns, 0, err, sizeof err);
        if (st != PKSS_OK) {
            fprintf(stderr, "consumer-io: %s: %s\n", pkss_status_name(st), err);
            return 2;
        }
        if (load(path, &back, &nb) != 0)
            return 2;
        if (nb != ns || memcmp(back, src, ns * 3 * sizeof(double)) != 0) {
            fprintf(stderr, "consumer-io: %s does not read back bit-identically\n", path);
            return 1;
        }
        pkss_points_free(back);
        printf("%s: %zu points written and read back bit-identically\n", path, ns);
    }
    pkss_context *ctx = NULL;
    pkss_result res;
    pkss_result_init(&res, sizeof res);
    pkss_status st = pkss_context_create(&ctx);
    if (st == PKSS_OK)
        st = pkss_register(ctx, src, ns, tgt, nt, &res);
    pkss_points_free(src);
    pkss_points_free(tgt);
    if (st != PKSS_OK) {
        fprintf(stderr, "consumer-io: %s\n", pkss_status_name(st));
        pkss_context_destroy(ctx);
        return 3;
    }
    printf("registered: scale %.4f\n", res.scale);
    pkss_context_destroy(ctx);
    return 0;
}
