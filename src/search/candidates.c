/* SPDX-License-Identifier: MIT
 * candidates.c -- the candidate sets of the global search (SPEC 5):
 * rotations {O_c} (Eq. 10: the Euler grid with duplicates removed, or a
 * near-uniform super-Fibonacci set) factorised into binning rotations and
 * azimuth shifts, and the bin-edge table of the cell partition (SPEC 3).
 */
#include "pkss_internal.h"
#include "pkss_shared.h"

#include <math.h>
#include <string.h>

void pkss__cell_edges(int n_az, float *edges)
{
    memset(edges, 0, PKSS_EDGES_SIZE * sizeof(float));
    double step = 2.0 * PKSS_PI / n_az;
    int n_el = n_az / 2;
    edges[0] = (float)n_az;
    for (int j = 1; j < n_el; ++j)
        edges[j] = (float)cos(j * step);
    for (int j = 1; j < n_az / 2; ++j) {
        edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1)] = (float)cos(j * step);
        edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1) + 1] = (float)sin(j * step);
    }
}

void pkss__rotations_free(pkss__rotation_set *rs)
{
    if (!rs)
        return;
    pkss__free(rs->R);
    pkss__free(rs->bin_R);
    pkss__free(rs->binning);
    pkss__free(rs->shift);
    memset(rs, 0, sizeof *rs);
}

static int alloc_set(pkss__rotation_set *rs, size_t n_rot, size_t n_bin)
{
    rs->R = pkss__malloc(n_rot * 9 * sizeof(double));
    rs->bin_R = pkss__malloc(n_bin * 9 * sizeof(float));
    rs->binning = pkss__malloc(n_rot * sizeof(int32_t));
    rs->shift = pkss__malloc(n_rot * sizeof(int32_t));
    return rs->R && rs->bin_R && rs->binning && rs->shift;
}

static int same_rotation(const double *A, const double *B)
{
    for (int i = 0; i < 9; ++i)
        if (fabs(A[i] - B[i]) > PKSS_SAME_ROTATION_TOL)
            return 0;
    return 1;
}

/* Eq. 10 with R = Rz(iz) Ry(iy) Rx(ix). The 12^3 triples hold 744 distinct
 * rotations (gimbal lock at beta = +-90 deg and (a,b,c) == (a+pi, pi-b,
 * c+pi)); each distinct rotation is kept once, at its first triple. When
 * the azimuth bins divide evenly into the rotation steps, Rz by iz steps is
 * a cyclic shift of iz * n_az/n azimuth bins of the binning of Ry Rx P, so
 * only n^2 binnings are needed. */
static pkss_status build_euler(int n, int n_az, pkss__rotation_set *rs)
{
    size_t total = (size_t)n * n * n;
    int factor = (n_az % n == 0);
    size_t n_bin = factor ? (size_t)n * n : total;
    if (!alloc_set(rs, total, n_bin))
        return PKSS_ERR_OUT_OF_MEMORY;
    double step = 2.0 * PKSS_PI / n;
    size_t kept = 0, bins = 0;
    int32_t *bin_of = pkss__malloc((size_t)n * n * sizeof(int32_t));
    if (!bin_of)
        return PKSS_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < (size_t)n * n; ++i)
        bin_of[i] = -1;
    for (int ix = 0; ix < n; ++ix)
        for (int iy = 0; iy < n; ++iy)
            for (int iz = 0; iz < n; ++iz) {
                double R[9];
                pkss__euler_zyx(ix * step, iy * step, iz * step, R);
                int dup = 0;
                for (size_t k = 0; k < kept && !dup; ++k)
                    dup = same_rotation(R, rs->R + 9 * k);
                if (dup)
                    continue;
                memcpy(rs->R + 9 * kept, R, sizeof R);
                if (factor) {
                    int key = ix * n + iy;
                    if (bin_of[key] < 0) {
                        double B[9];
                        pkss__euler_zyx(ix * step, iy * step, 0.0, B);
                        for (int e = 0; e < 9; ++e)
                            rs->bin_R[9 * bins + e] = (float)B[e];
                        bin_of[key] = (int32_t)bins++;
                    }
                    rs->binning[kept] = bin_of[key];
                    rs->shift[kept] = iz * (n_az / n);
                } else {
                    for (int e = 0; e < 9; ++e)
                        rs->bin_R[9 * bins + e] = (float)R[e];
                    rs->binning[kept] = (int32_t)bins++;
                    rs->shift[kept] = 0;
                }
                ++kept;
            }
    pkss__free(bin_of);
    rs->n_rotations = kept;
    rs->n_binnings = bins;
    return PKSS_OK;
}

/* Super-Fibonacci spirals (Alexa, CVPR 2022): a near-uniform set of unit
 * quaternions; every rotation is its own binning. */
static pkss_status build_uniform(int count, pkss__rotation_set *rs)
{
    if (!alloc_set(rs, (size_t)count, (size_t)count))
        return PKSS_ERR_OUT_OF_MEMORY;
    const double phi = sqrt(2.0), psi = 1.533751168755204288118041;
    for (int i = 0; i < count; ++i) {
        double s = i + 0.5;
        double r = sqrt(s / count), R_ = sqrt(1.0 - s / count);
        double alpha = 2.0 * PKSS_PI * s / phi, beta = 2.0 * PKSS_PI * s / psi;
        double x = r * sin(alpha), y = r * cos(alpha), z = R_ * sin(beta),
               w = R_ * cos(beta);
        double *M = rs->R + 9 * i;
        M[0] = 1 - 2 * (y * y + z * z); M[1] = 2 * (x * y - z * w); M[2] = 2 * (x * z + y * w);
        M[3] = 2 * (x * y + z * w); M[4] = 1 - 2 * (x * x + z * z); M[5] = 2 * (y * z - x * w);
        M[6] = 2 * (x * z - y * w); M[7] = 2 * (y * z + x * w); M[8] = 1 - 2 * (x * x + y * y);
        for (int e = 0; e < 9; ++e)
            rs->bin_R[9 * i + e] = (float)M[e];
        rs->binning[i] = i;
        rs->shift[i] = 0;
    }
    rs->n_rotations = (size_t)count;
    rs->n_binnings = (size_t)count;
    return PKSS_OK;
}

pkss_status pkss__rotations_build(const pkss__params *p,
                                  pkss__rotation_set *out)
{
    memset(out, 0, sizeof *out);
    int n_az = p->cell_steps ? p->cell_steps : p->rotation_steps;
    pkss_status st = p->rotation_set == PKSS_ROTATIONS_UNIFORM
                         ? build_uniform(p->rotation_count, out)
                         : build_euler(p->rotation_steps, n_az, out);
    if (st != PKSS_OK)
        pkss__rotations_free(out);
    return st;
}
