/* SPDX-License-Identifier: MIT
 * =========================================================================
 * pkss_shared.h -- the one definition of cell binning, the 3x3 SVD and the
 * shape measurement G (SPEC 3 and 4), compiled both as C11 (the reference
 * backend, src/search_ref.c) and as OpenCL C 1.2 (kernels/search.cl, which
 * the OpenCL backend embeds and launches).
 *
 * Everything is float32 with FP contraction off on both sides, so the C
 * reference and the kernels produce the same bits for binning and agree to
 * ~1e-6 on G (only acos/sqrt implementations may differ by an ulp).
 *
 * Layouts shared with the host:
 *   points        : float[n][3]
 *   bin edges     : float[PKSS_EDGES_SIZE]  (see pkss_edges_layout below)
 *   rep table     : float[n_cells][4] = (x, y, z, r^2); r^2 < 0 means the
 *                   cell is empty. One table per binning (source rotation
 *                   or template offset), contour and feature alike.
 * =========================================================================
 */
#ifndef PKSS_SHARED_H
#define PKSS_SHARED_H

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#define PKSS_GLOBAL __global
#define PKSS_CONST __global const
#define PKSS_INLINE inline
#define PKSS_SQRT(x) sqrt(x)
#define PKSS_FABS(x) fabs(x)
#define PKSS_ACOS(x) acos(x)
#else
/* C side: the build passes -ffp-contract=off (GCC ignores the STDC pragma). */
#include <math.h>
#define PKSS_GLOBAL
#define PKSS_CONST const
#define PKSS_INLINE static inline
#define PKSS_SQRT(x) sqrtf(x)
#define PKSS_FABS(x) fabsf(x)
#define PKSS_ACOS(x) acosf(x)
#endif

#define PKSS_PI_F 3.14159265358979323846f
#define PKSS_HALF_PI_F 1.57079632679489661923f

/* Largest azimuth bin count supported (PKSS_PARAM_CELL_STEPS upper bound).
 * Elevation bins are half of it. */
#define PKSS_MAX_AZ 48
#define PKSS_MAX_CELLS (PKSS_MAX_AZ * PKSS_MAX_AZ / 2)

/* Edge table layout (filled by the host in double, rounded to float once):
 *   [0]                       n_az (as float)
 *   [1 .. n_el-1]             cos(j * 2pi/n_az), j = 1 .. n_el-1
 *                             (elevation edges; n_el = n_az / 2)
 *   [PKSS_MAX_AZ/2 + 1 + 2*(j-1)], j = 1 .. n_az/2 - 1:
 *                             cos, sin of azimuth edge j*2pi/n_az in (0, pi)
 */
#define PKSS_EDGE_AZ_BASE (PKSS_MAX_AZ / 2 + 1)
#define PKSS_EDGES_SIZE (PKSS_EDGE_AZ_BASE + PKSS_MAX_AZ)

/* Coverage guard (SPEC 4.4): fewer matched cells than this, or fewer than
 * PKSS_MIN_COVERAGE of the template's occupied cells, gives G = pi/2. */
#define PKSS_MIN_MATCHED 4
#define PKSS_MIN_COVERAGE 0.2f

/* ---------------------------------------------------------------------- */
/* Cell index (SPEC 3): n_el = n_az/2 elevation bins x n_az azimuth bins,  */
/* index = n_az * b_theta + b_phi. Comparisons against precomputed edges   */
/* only; no acos/atan2, no sqrt. Returns -1 for r = 0.                     */
/* ---------------------------------------------------------------------- */
PKSS_INLINE int pkss_cell_index(float x, float y, float z, int n_az,
                                PKSS_CONST float *edges)
{
    float r2 = x * x + y * y + z * z;
    if (!(r2 > 0.0f))
        return -1;
    int n_el = n_az / 2;
    /* Elevation: theta >= theta_j  <=>  z <= r * cos(theta_j), decided on
     * squares so no sqrt is needed. */
    int b_el = 0;
    for (int j = 1; j < n_el; ++j) {
        float c = edges[j];
        int beyond;
        if (c > 0.0f)
            beyond = (z <= 0.0f) || (z * z <= r2 * (c * c));
        else if (c < 0.0f)
            beyond = (z < 0.0f) && (z * z >= r2 * (c * c));
        else
            beyond = (z <= 0.0f);
        b_el += beyond;
    }
    /* Azimuth: phi in [0, pi) when y > 0 or (y == 0 and x >= 0); otherwise
     * rotate by pi (negate) and add n_az/2 bins. Within the half plane,
     * phi >= phi_j  <=>  cross(e_j, v) = cos_j*y - sin_j*x >= 0. */
    int n_half = n_az / 2;
    int b_az = 0;
    float vx = x, vy = y;
    if (!(vy > 0.0f || (vy == 0.0f && vx >= 0.0f))) {
        vx = -vx;
        vy = -vy;
        b_az = n_half;
    }
    /* On the z axis the azimuth is undefined: bin 0 by convention. */
    int on_axis = (vx == 0.0f && vy == 0.0f);
    for (int j = 1; j < n_half && !on_axis; ++j) {
        float cj = edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1)];
        float sj = edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1) + 1];
        b_az += (cj * vy - sj * vx >= 0.0f);
    }
    return n_az * b_el + b_az;
}

/* Rotates (x,y,z) by the row-major 3x3 R about the origin. */
PKSS_INLINE void pkss_rotate(const float *R, float x, float y, float z,
                             float *ox, float *oy, float *oz)
{
    *ox = R[0] * x + R[1] * y + R[2] * z;
    *oy = R[3] * x + R[4] * y + R[5] * z;
    *oz = R[6] * x + R[7] * y + R[8] * z;
}

/* ---------------------------------------------------------------------- */
/* Binning (SPEC 3): representative of a cell = the point farthest from   */
/* the centre (first index wins ties). Points are rotated by R about the  */
/* origin, then taken relative to centre c. reps gets n_cells x 4 floats. */
/* ---------------------------------------------------------------------- */
PKSS_INLINE void pkss_bin_points(PKSS_CONST float *pts, int n,
                                 const float *R, float cx, float cy, float cz,
                                 int n_az, PKSS_CONST float *edges,
                                 PKSS_GLOBAL float *reps)
{
    int n_cells = n_az * (n_az / 2);
    for (int c = 0; c < n_cells; ++c) {
        reps[4 * c + 0] = 0.0f;
        reps[4 * c + 1] = 0.0f;
        reps[4 * c + 2] = 0.0f;
        reps[4 * c + 3] = -1.0f;
    }
    for (int i = 0; i < n; ++i) {
        float x, y, z;
        pkss_rotate(R, pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], &x, &y, &z);
        x -= cx;
        y -= cy;
        z -= cz;
        int c = pkss_cell_index(x, y, z, n_az, edges);
        if (c < 0)
            continue;
        float r2 = x * x + y * y + z * z;
        if (r2 > reps[4 * c + 3]) {
            reps[4 * c + 0] = x;
            reps[4 * c + 1] = y;
            reps[4 * c + 2] = z;
            reps[4 * c + 3] = r2;
        }
    }
}

/* ---------------------------------------------------------------------- */
/* 3x3 SVD (SPEC 4.2). Cyclic Jacobi on the symmetric S = H^T H gives V;   */
/* the singular values are the column norms of B = H V, which keeps small */
/* singular values accurate (sqrt of eigenvalues would lose half the      */
/* digits). Sorted descending, all >= 0.                                  */
/* ---------------------------------------------------------------------- */
PKSS_INLINE void pkss_jacobi_rotate(float *S, float *V, int p, int q)
{
    float apq = S[3 * p + q];
    if (apq == 0.0f)
        return;
    float app = S[3 * p + p], aqq = S[3 * q + q];
    float theta = (aqq - app) / (2.0f * apq);
    float t = 1.0f / (PKSS_FABS(theta) + PKSS_SQRT(theta * theta + 1.0f));
    if (theta < 0.0f)
        t = -t;
    /* theta*theta overflows for huge theta: then t ~ 1/(2 theta). */
    if (PKSS_FABS(theta) > 1.0e18f)
        t = 0.5f / theta;
    float c = 1.0f / PKSS_SQRT(t * t + 1.0f);
    float s = t * c;
    /* S <- J^T S J with J the Givens rotation in the (p, q) plane. */
    for (int k = 0; k < 3; ++k) {
        float skp = S[3 * k + p], skq = S[3 * k + q];
        S[3 * k + p] = c * skp - s * skq;
        S[3 * k + q] = s * skp + c * skq;
    }
    for (int k = 0; k < 3; ++k) {
        float spk = S[3 * p + k], sqk = S[3 * q + k];
        S[3 * p + k] = c * spk - s * sqk;
        S[3 * q + k] = s * spk + c * sqk;
    }
    for (int k = 0; k < 3; ++k) {
        float vkp = V[3 * k + p], vkq = V[3 * k + q];
        V[3 * k + p] = c * vkp - s * vkq;
        V[3 * k + q] = s * vkp + c * vkq;
    }
}

/* Singular values of the row-major 3x3 H into sv[0] >= sv[1] >= sv[2] >= 0;
 * if V is not NULL it receives the matching right singular vectors as
 * columns (row-major 3x3). */
PKSS_INLINE void pkss_svd3_values(const float *H, float *sv, float *Vout)
{
    float S[9], V[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            S[3 * i + j] = H[i] * H[j] + H[3 + i] * H[3 + j] +
                           H[6 + i] * H[6 + j];
            V[3 * i + j] = (i == j) ? 1.0f : 0.0f;
        }
    for (int sweep = 0; sweep < 10; ++sweep) {
        float off = PKSS_FABS(S[1]) + PKSS_FABS(S[2]) + PKSS_FABS(S[5]);
        float diag = PKSS_FABS(S[0]) + PKSS_FABS(S[4]) + PKSS_FABS(S[8]);
        if (off <= 1.0e-9f * diag || off == 0.0f)
            break;
        pkss_jacobi_rotate(S, V, 0, 1);
        pkss_jacobi_rotate(S, V, 0, 2);
        pkss_jacobi_rotate(S, V, 1, 2);
    }
    /* B = H V; singular value i = |B column i|. */
    float s[3];
    for (int k = 0; k < 3; ++k) {
        float b0 = H[0] * V[k] + H[1] * V[3 + k] + H[2] * V[6 + k];
        float b1 = H[3] * V[k] + H[4] * V[3 + k] + H[5] * V[6 + k];
        float b2 = H[6] * V[k] + H[7] * V[3 + k] + H[8] * V[6 + k];
        s[k] = PKSS_SQRT(b0 * b0 + b1 * b1 + b2 * b2);
    }
    int o0 = 0, o1 = 1, o2 = 2, tmp;
    if (s[o0] < s[o1]) { tmp = o0; o0 = o1; o1 = tmp; }
    if (s[o1] < s[o2]) { tmp = o1; o1 = o2; o2 = tmp; }
    if (s[o0] < s[o1]) { tmp = o0; o0 = o1; o1 = tmp; }
    sv[0] = s[o0];
    sv[1] = s[o1];
    sv[2] = s[o2];
    if (Vout) {
        for (int r = 0; r < 3; ++r) {
            Vout[3 * r + 0] = V[3 * r + o0];
            Vout[3 * r + 1] = V[3 * r + o1];
            Vout[3 * r + 2] = V[3 * r + o2];
        }
    }
}

PKSS_INLINE float pkss_det3(const float *H)
{
    return H[0] * (H[4] * H[8] - H[5] * H[7]) -
           H[1] * (H[3] * H[8] - H[5] * H[6]) +
           H[2] * (H[3] * H[7] - H[4] * H[6]);
}

/* G = arccos(clamp(s1 + s2 + d*s3, -1, 1)), d = sign(det H)  (Eq. 6, 7_0;
 * SPEC 4.3). H must already be normalised (both sets unit Frobenius). */
PKSS_INLINE float pkss_measure_from_H(const float *H)
{
    float sv[3];
    pkss_svd3_values(H, sv, 0);
    float d = pkss_det3(H) < 0.0f ? -1.0f : 1.0f;
    float tr = sv[0] + sv[1] + d * sv[2];
    if (tr > 1.0f)
        tr = 1.0f;
    if (tr < -1.0f)
        tr = -1.0f;
    return PKSS_ACOS(tr);
}

/* ---------------------------------------------------------------------- */
/* Score of one (source binning + azimuth shift, template binning) pair     */
/* (SPEC 4). Template cell (e, a) is matched with source cell               */
/* (e, (a - shift) mod n_az): rotating the source by a whole azimuth step   */
/* about z moves its cells by one azimuth index. Both matched sets are      */
/* centred on their own means and scaled to unit Frobenius norm (Eq. 2 on   */
/* the representatives), H = X^T Y. tgt_occupied = occupied template cells. */
/* ---------------------------------------------------------------------- */
PKSS_INLINE float pkss_score_pair(PKSS_CONST float *src, int shift,
                                  PKSS_CONST float *tgt, int tgt_occupied,
                                  int n_az)
{
    int n_el = n_az / 2;
    int k = 0;
    float mx0 = 0.0f, mx1 = 0.0f, mx2 = 0.0f;
    float my0 = 0.0f, my1 = 0.0f, my2 = 0.0f;
    for (int e = 0; e < n_el; ++e) {
        for (int a = 0; a < n_az; ++a) {
            int ct = n_az * e + a;
            int as = a - shift;
            if (as < 0)
                as += n_az;
            int cs = n_az * e + as;
            if (tgt[4 * ct + 3] > 0.0f && src[4 * cs + 3] > 0.0f) {
                ++k;
                mx0 += src[4 * cs];
                mx1 += src[4 * cs + 1];
                mx2 += src[4 * cs + 2];
                my0 += tgt[4 * ct];
                my1 += tgt[4 * ct + 1];
                my2 += tgt[4 * ct + 2];
            }
        }
    }
    if (k < PKSS_MIN_MATCHED || (float)k < PKSS_MIN_COVERAGE * (float)tgt_occupied)
        return PKSS_HALF_PI_F;
    float inv_k = 1.0f / (float)k;
    mx0 *= inv_k; mx1 *= inv_k; mx2 *= inv_k;
    my0 *= inv_k; my1 *= inv_k; my2 *= inv_k;
    float H[9] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    float nx = 0.0f, ny = 0.0f;
    for (int e = 0; e < n_el; ++e) {
        for (int a = 0; a < n_az; ++a) {
            int ct = n_az * e + a;
            int as = a - shift;
            if (as < 0)
                as += n_az;
            int cs = n_az * e + as;
            if (tgt[4 * ct + 3] > 0.0f && src[4 * cs + 3] > 0.0f) {
                float x0 = src[4 * cs] - mx0, x1 = src[4 * cs + 1] - mx1,
                      x2 = src[4 * cs + 2] - mx2;
                float y0 = tgt[4 * ct] - my0, y1 = tgt[4 * ct + 1] - my1,
                      y2 = tgt[4 * ct + 2] - my2;
                H[0] += x0 * y0; H[1] += x0 * y1; H[2] += x0 * y2;
                H[3] += x1 * y0; H[4] += x1 * y1; H[5] += x1 * y2;
                H[6] += x2 * y0; H[7] += x2 * y1; H[8] += x2 * y2;
                nx += x0 * x0 + x1 * x1 + x2 * x2;
                ny += y0 * y0 + y1 * y1 + y2 * y2;
            }
        }
    }
    if (!(nx > 0.0f) || !(ny > 0.0f))
        return PKSS_HALF_PI_F;
    float inv = 1.0f / (PKSS_SQRT(nx) * PKSS_SQRT(ny));
    for (int i = 0; i < 9; ++i)
        H[i] *= inv;
    return pkss_measure_from_H(H);
}

/* Occupied cells of a rep table. */
PKSS_INLINE int pkss_count_occupied(PKSS_CONST float *reps, int n_cells)
{
    int k = 0;
    for (int c = 0; c < n_cells; ++c)
        k += reps[4 * c + 3] > 0.0f;
    return k;
}

#endif /* PKSS_SHARED_H */
