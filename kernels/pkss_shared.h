/* SPDX-License-Identifier: MIT
 * =========================================================================
 * pkss_shared.h -- the one definition of cell binning, the 3x3 SVD and the
 * shape measurement G (SPEC 3 and 4), compiled both as C11 (the reference
 * backend, src/search/search_ref.c) and as OpenCL C 1.2 (kernels/search.cl, which
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
 *
 * Lanes. The binning, the SVD and G are written once over "lanes":
 * pkss_vf / pkss_vi hold PKSS_VW floats / ints and every data-dependent
 * branch is a per-lane mask (PKSS_SEL), so that a kernel evaluates PKSS_VW
 * candidates with one SIMD instruction stream. In C (and in OpenCL with
 * PKSS_VW = 1, used on GPUs) a lane is a plain float/int, a mask is 0/1 and
 * PKSS_SEL is `?:`, so the reference runs exactly the scalar operations it
 * always ran; in OpenCL with PKSS_VW = 2..16 they are floatN/intN with
 * 0/-1 masks. Each lane performs the same float operations in the same
 * order as the scalar code, so lanes and the reference agree bit for bit
 * (a masked-off update leaves a value unchanged; a masked sum adds +0.0f,
 * which cannot change a sum that starts at +0.0f). The strided entry points
 * take the layouts the kernels use (structure-of-arrays with lanes
 * contiguous); the plain ones are the C layouts above.
 * =========================================================================
 */
#ifndef PKSS_SHARED_H
#define PKSS_SHARED_H

/* The tuning table precedes this file in the embedded OpenCL source. */
#ifndef PKSS_TUNING_H
#include "tuning.h"
#endif

/* OpenCL C: __OPENCL_C_VERSION__ (1.2+) is defined by every compiler, also
 * an offline clang -x cl without an OpenCL target, which does not define
 * __OPENCL_VERSION__. */
#if defined(__OPENCL_VERSION__) || defined(__OPENCL_C_VERSION__)
#define PKSS_OPENCL_C 1
#endif

#ifdef PKSS_OPENCL_C
#pragma OPENCL FP_CONTRACT OFF
#define PKSS_GLOBAL __global
#define PKSS_CONST __global const
#define PKSS_INLINE inline
#define PKSS_SQRT(x) sqrt(x)
#define PKSS_FABS(x) fabs(x)
#define PKSS_ACOS(x) acos(x)
#define PKSS_CEIL(x) ceil(x)
#else
/* C side: the build passes -ffp-contract=off (GCC ignores the STDC pragma). */
#include <math.h>
#define PKSS_GLOBAL
#define PKSS_CONST const
#define PKSS_INLINE static inline
#define PKSS_SQRT(x) sqrtf(x)
#define PKSS_FABS(x) fabsf(x)
#define PKSS_ACOS(x) acosf(x)
#define PKSS_CEIL(x) ceilf(x)
#endif

/* Lanes (see the banner). PKSS_VW > 1 only in OpenCL. */
#ifndef PKSS_VW
#define PKSS_VW 1
#endif
#if defined(PKSS_OPENCL_C) && PKSS_VW > 1
#define PKSS_CAT2(a, b) a##b
#define PKSS_CAT(a, b) PKSS_CAT2(a, b)
typedef PKSS_CAT(float, PKSS_VW) pkss_vf;
typedef PKSS_CAT(int, PKSS_VW) pkss_vi;
#define PKSS_SEL(m, a, b) select((b), (a), (m)) /* m ? a : b, per lane */
/* any(m) by an OR tree of vector halves: PoCL's any() extracts every lane. */
#if PKSS_VW == 16
#define PKSS_ANY(m) pkss_any16(m)
inline __attribute__((always_inline)) int pkss_any16(int16 m)
{
    int8 a = m.lo | m.hi;
    int4 b = a.lo | a.hi;
    int2 c = b.lo | b.hi;
    return (c.x | c.y) < 0;
}
#elif PKSS_VW == 8
#define PKSS_ANY(m) pkss_any8(m)
inline __attribute__((always_inline)) int pkss_any8(int8 m)
{
    int4 b = m.lo | m.hi;
    int2 c = b.lo | b.hi;
    return (c.x | c.y) < 0;
}
#else
#define PKSS_ANY(m) any(m)
#endif
#define PKSS_TO_VF(k) PKSS_CAT(convert_float, PKSS_VW)(k)
/* PKSS_VW consecutive floats p[i .. i+PKSS_VW-1] as lanes, and back */
#define PKSS_LOADV(p, i) PKSS_CAT(vload, PKSS_VW)(0, (p) + (i))
#define PKSS_STOREV(v, p) PKSS_CAT(vstore, PKSS_VW)((v), 0, (p))
#else
typedef float pkss_vf;
typedef int pkss_vi;
#define PKSS_SEL(m, a, b) ((m) ? (a) : (b))
#define PKSS_ANY(m) (m)
#define PKSS_TO_VF(k) ((float)(k))
#define PKSS_LOADV(p, i) ((p)[i])
#define PKSS_STOREV(v, p) ((p)[0] = (v))
#endif
/* Broadcasts; PKSS_TRUE is an all-lanes-on mask. */
#define PKSS_VF(x) ((pkss_vf)(x))
#define PKSS_VI(x) ((pkss_vi)(x))
#define PKSS_TRUE PKSS_VI(-1)
/* 1 where m is set, else 0 */
#define PKSS_ONE_IF(m) PKSS_SEL((m), PKSS_VI(1), PKSS_VI(0))

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

/* Coverage guard (SPEC 4.4): PKSS_MIN_MATCHED and PKSS_MIN_COVERAGE of
 * src/tuning.h; `src_cover` of pkss_score_lanes is 0 in the paper's search
 * and PKSS_WIDE_SRC_COVER in the wide second search (the source table's
 * occupied count comes from its binning, as the template's does). */

/* ---------------------------------------------------------------------- */
/* Cell index (SPEC 3): n_el = n_az/2 elevation bins x n_az azimuth bins,  */
/* index = n_az * b_theta + b_phi. Comparisons against precomputed edges   */
/* only; no acos/atan2, no sqrt. Returns -1 for r = 0. Per lane.           */
/* ---------------------------------------------------------------------- */
PKSS_INLINE pkss_vi pkss_cell_index(pkss_vf x, pkss_vf y, pkss_vf z, int n_az,
                                    PKSS_CONST float *edges)
{
    pkss_vf r2 = x * x + y * y + z * z;
    int n_el = n_az / 2;
    /* Elevation: theta >= theta_j  <=>  z <= r * cos(theta_j), decided on
     * squares so no sqrt is needed. */
    pkss_vi b_el = PKSS_VI(0);
    for (int j = 1; j < n_el; ++j) {
        float c = edges[j];
        pkss_vi beyond;
        if (c > 0.0f)
            beyond = (z <= 0.0f) | (z * z <= r2 * (c * c));
        else if (c < 0.0f)
            beyond = (z < 0.0f) & (z * z >= r2 * (c * c));
        else
            beyond = (z <= 0.0f);
        b_el = b_el + PKSS_ONE_IF(beyond);
    }
    /* Azimuth: phi in [0, pi) when y > 0 or (y == 0 and x >= 0); otherwise
     * rotate by pi (negate) and add n_az/2 bins. Within the half plane,
     * phi >= phi_j  <=>  cross(e_j, v) = cos_j*y - sin_j*x >= 0. */
    int n_half = n_az / 2;
    pkss_vi flip = !((y > 0.0f) | ((y == 0.0f) & (x >= 0.0f)));
    pkss_vf vx = PKSS_SEL(flip, -x, x);
    pkss_vf vy = PKSS_SEL(flip, -y, y);
    pkss_vi b_az = PKSS_SEL(flip, PKSS_VI(n_half), PKSS_VI(0));
    /* On the z axis the azimuth is undefined: bin 0 by convention. */
    pkss_vi off_axis = !((vx == 0.0f) & (vy == 0.0f));
    for (int j = 1; j < n_half; ++j) {
        float cj = edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1)];
        float sj = edges[PKSS_EDGE_AZ_BASE + 2 * (j - 1) + 1];
        b_az = b_az + PKSS_ONE_IF((cj * vy - sj * vx >= 0.0f) & off_axis);
    }
    return PKSS_SEL(r2 > 0.0f, n_az * b_el + b_az, PKSS_VI(-1));
}

/* Rotates (x,y,z) by the row-major 3x3 R about the origin. */
PKSS_INLINE void pkss_rotate(const float *R, pkss_vf x, pkss_vf y, pkss_vf z,
                             pkss_vf *ox, pkss_vf *oy, pkss_vf *oz)
{
    *ox = R[0] * x + R[1] * y + R[2] * z;
    *oy = R[3] * x + R[4] * y + R[5] * z;
    *oz = R[6] * x + R[7] * y + R[8] * z;
}

/* ---------------------------------------------------------------------- */
/* Binning (SPEC 3): representative of a cell = the point farthest from   */
/* the centre (first index wins ties). Points are rotated by R about the  */
/* origin, then taken relative to centre c.                               */
/* Strided layouts: coordinate d of point i is pts[d*dstride + i*istride]; */
/* component k of cell c is reps[(4*c + k) * rstride]. With PKSS_VW > 1   */
/* the lanes are PKSS_VW consecutive points (istride must be 1 and pts    */
/* readable up to n rounded up to PKSS_VW); the cells are then updated    */
/* lane after lane, in point order, as the scalar loop does.              */
/* ---------------------------------------------------------------------- */
PKSS_INLINE void pkss_bin_points_strided(PKSS_CONST float *pts, int dstride,
                                         int istride, int n, const float *R,
                                         float cx, float cy, float cz,
                                         int n_az, PKSS_CONST float *edges,
                                         PKSS_GLOBAL float *reps, int rstride)
{
    int n_cells = n_az * (n_az / 2);
    for (int c = 0; c < n_cells; ++c) {
        reps[(4 * c + 0) * rstride] = 0.0f;
        reps[(4 * c + 1) * rstride] = 0.0f;
        reps[(4 * c + 2) * rstride] = 0.0f;
        reps[(4 * c + 3) * rstride] = -1.0f;
    }
    for (int i0 = 0; i0 < n; i0 += PKSS_VW) {
        pkss_vf x, y, z;
        pkss_rotate(R, PKSS_LOADV(pts, i0 * istride),
                    PKSS_LOADV(pts, dstride + i0 * istride),
                    PKSS_LOADV(pts, 2 * dstride + i0 * istride), &x, &y, &z);
        x = x - cx;
        y = y - cy;
        z = z - cz;
        pkss_vi cell = pkss_cell_index(x, y, z, n_az, edges);
        pkss_vf r2 = x * x + y * y + z * z;
        float xa[PKSS_VW], ya[PKSS_VW], za[PKSS_VW], ra[PKSS_VW];
        int ca[PKSS_VW];
        PKSS_STOREV(x, xa);
        PKSS_STOREV(y, ya);
        PKSS_STOREV(z, za);
        PKSS_STOREV(r2, ra);
        PKSS_STOREV(cell, ca);
        int lanes = n - i0 < PKSS_VW ? n - i0 : PKSS_VW;
        for (int l = 0; l < lanes; ++l) {
            int c = ca[l];
            if (c < 0)
                continue;
            if (ra[l] > reps[(4 * c + 3) * rstride]) {
                reps[(4 * c + 0) * rstride] = xa[l];
                reps[(4 * c + 1) * rstride] = ya[l];
                reps[(4 * c + 2) * rstride] = za[l];
                reps[(4 * c + 3) * rstride] = ra[l];
            }
        }
    }
}

/* Occupied cells of a (strided) rep table. */
PKSS_INLINE int pkss_count_occupied_strided(PKSS_CONST float *reps,
                                            int n_cells, int rstride)
{
    int k = 0;
    for (int c = 0; c < n_cells; ++c)
        k += reps[(4 * c + 3) * rstride] > 0.0f;
    return k;
}

/* ---------------------------------------------------------------------- */
/* 3x3 SVD (SPEC 4.2). Cyclic Jacobi on the symmetric S = H^T H gives V;   */
/* the singular values are the column norms of B = H V, which keeps small */
/* singular values accurate (sqrt of eigenvalues would lose half the      */
/* digits). Sorted descending, all >= 0. Lanes where `active` is off are  */
/* left as they are (a converged lane stops, as the scalar loop breaks).  */
/* ---------------------------------------------------------------------- */
PKSS_INLINE void pkss_jacobi_rotate_masked(pkss_vf *S, pkss_vf *V, int p,
                                           int q, pkss_vi active)
{
    pkss_vf apq = S[3 * p + q];
    pkss_vi act = active & (apq != 0.0f);
    if (!PKSS_ANY(act))
        return;
    pkss_vf app = S[3 * p + p], aqq = S[3 * q + q];
    pkss_vf theta = (aqq - app) / (2.0f * apq);
    pkss_vf t = 1.0f / (PKSS_FABS(theta) + PKSS_SQRT(theta * theta + 1.0f));
    t = PKSS_SEL(theta < 0.0f, -t, t);
    /* theta*theta overflows for huge theta: then t ~ 1/(2 theta). */
    t = PKSS_SEL(PKSS_FABS(theta) > 1.0e18f, 0.5f / theta, t);
    pkss_vf c = 1.0f / PKSS_SQRT(t * t + 1.0f);
    pkss_vf s = t * c;
    /* S <- J^T S J with J the Givens rotation in the (p, q) plane. */
    for (int k = 0; k < 3; ++k) {
        pkss_vf skp = S[3 * k + p], skq = S[3 * k + q];
        S[3 * k + p] = PKSS_SEL(act, c * skp - s * skq, skp);
        S[3 * k + q] = PKSS_SEL(act, s * skp + c * skq, skq);
    }
    for (int k = 0; k < 3; ++k) {
        pkss_vf spk = S[3 * p + k], sqk = S[3 * q + k];
        S[3 * p + k] = PKSS_SEL(act, c * spk - s * sqk, spk);
        S[3 * q + k] = PKSS_SEL(act, s * spk + c * sqk, sqk);
    }
    for (int k = 0; k < 3; ++k) {
        pkss_vf vkp = V[3 * k + p], vkq = V[3 * k + q];
        V[3 * k + p] = PKSS_SEL(act, c * vkp - s * vkq, vkp);
        V[3 * k + q] = PKSS_SEL(act, s * vkp + c * vkq, vkq);
    }
}

PKSS_INLINE void pkss_jacobi_rotate(pkss_vf *S, pkss_vf *V, int p, int q)
{
    pkss_jacobi_rotate_masked(S, V, p, q, PKSS_TRUE);
}

/* Swaps a and b where m is set. */
#define PKSS_SWAP_IF(m, a, b)                                                  \
    do {                                                                       \
        pkss_vf pkss_sw_ = (a);                                                \
        (a) = PKSS_SEL((m), (b), (a));                                         \
        (b) = PKSS_SEL((m), pkss_sw_, (b));                                    \
    } while (0)

/* Singular values of the row-major 3x3 H into sv[0] >= sv[1] >= sv[2] >= 0;
 * if V is not NULL it receives the matching right singular vectors as
 * columns (row-major 3x3). Lanes where `active` is off are not computed. */
PKSS_INLINE void pkss_svd3_values_masked(const pkss_vf *H, pkss_vf *sv,
                                         pkss_vf *Vout, pkss_vi active)
{
    pkss_vf S[9], V[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            S[3 * i + j] = H[i] * H[j] + H[3 + i] * H[3 + j] +
                           H[6 + i] * H[6 + j];
            V[3 * i + j] = PKSS_VF((i == j) ? 1.0f : 0.0f);
        }
    for (int sweep = 0; sweep < 10; ++sweep) {
        pkss_vf off = PKSS_FABS(S[1]) + PKSS_FABS(S[2]) + PKSS_FABS(S[5]);
        pkss_vf diag = PKSS_FABS(S[0]) + PKSS_FABS(S[4]) + PKSS_FABS(S[8]);
        active = active & !((off <= 1.0e-9f * diag) | (off == 0.0f));
        if (!PKSS_ANY(active))
            break;
        pkss_jacobi_rotate_masked(S, V, 0, 1, active);
        pkss_jacobi_rotate_masked(S, V, 0, 2, active);
        pkss_jacobi_rotate_masked(S, V, 1, 2, active);
    }
    /* B = H V; singular value i = |B column i|. */
    pkss_vf s[3];
    for (int k = 0; k < 3; ++k) {
        pkss_vf b0 = H[0] * V[k] + H[1] * V[3 + k] + H[2] * V[6 + k];
        pkss_vf b1 = H[3] * V[k] + H[4] * V[3 + k] + H[5] * V[6 + k];
        pkss_vf b2 = H[6] * V[k] + H[7] * V[3 + k] + H[8] * V[6 + k];
        s[k] = PKSS_SQRT(b0 * b0 + b1 * b1 + b2 * b2);
    }
    /* Sort descending by three compare-and-swaps (values and, if wanted,
     * the columns of V with them). */
    pkss_vi m01 = s[0] < s[1];
    PKSS_SWAP_IF(m01, s[0], s[1]);
    pkss_vi m12 = s[1] < s[2];
    PKSS_SWAP_IF(m12, s[1], s[2]);
    pkss_vi m01b = s[0] < s[1];
    PKSS_SWAP_IF(m01b, s[0], s[1]);
    sv[0] = s[0];
    sv[1] = s[1];
    sv[2] = s[2];
    if (Vout) {
        for (int r = 0; r < 3; ++r) {
            pkss_vf c0 = V[3 * r + 0], c1 = V[3 * r + 1], c2 = V[3 * r + 2];
            PKSS_SWAP_IF(m01, c0, c1);
            PKSS_SWAP_IF(m12, c1, c2);
            PKSS_SWAP_IF(m01b, c0, c1);
            Vout[3 * r + 0] = c0;
            Vout[3 * r + 1] = c1;
            Vout[3 * r + 2] = c2;
        }
    }
}

PKSS_INLINE void pkss_svd3_values(const pkss_vf *H, pkss_vf *sv, pkss_vf *Vout)
{
    pkss_svd3_values_masked(H, sv, Vout, PKSS_TRUE);
}

PKSS_INLINE pkss_vf pkss_det3(const pkss_vf *H)
{
    return H[0] * (H[4] * H[8] - H[5] * H[7]) -
           H[1] * (H[3] * H[8] - H[5] * H[6]) +
           H[2] * (H[3] * H[7] - H[4] * H[6]);
}

/* G = arccos(clamp(s1 + s2 + d*s3, -1, 1)), d = sign(det H)  (Eq. 6, 7_0;
 * SPEC 4.3). H must already be normalised (both sets unit Frobenius). sv
 * receives the singular values and, if not NULL, V the right singular
 * vectors (pkss_svd3_values_masked), for a caller that also needs the fit. */
PKSS_INLINE pkss_vf pkss_measure_from_H_svd(const pkss_vf *H, pkss_vi active,
                                            pkss_vf *sv, pkss_vf *V)
{
    pkss_svd3_values_masked(H, sv, V, active);
    pkss_vf d = PKSS_SEL(pkss_det3(H) < 0.0f, PKSS_VF(-1.0f), PKSS_VF(1.0f));
    pkss_vf tr = sv[0] + sv[1] + d * sv[2];
    tr = PKSS_SEL(tr > 1.0f, PKSS_VF(1.0f), tr);
    tr = PKSS_SEL(tr < -1.0f, PKSS_VF(-1.0f), tr);
    return PKSS_ACOS(tr);
}

PKSS_INLINE pkss_vf pkss_measure_from_H(const pkss_vf *H)
{
    pkss_vf sv[3];
    return pkss_measure_from_H_svd(H, PKSS_TRUE, sv, 0);
}

/* ---------------------------------------------------------------------- */
/* Trimmed measure (the wide second search of register.c; a deviation     */
/* from SPEC 4). Where one cloud shows only a part of the other, the cells */
/* that look into the missing part match the whole's far contour with the */
/* part's cut rim, and those few pairs decide G: a parasaurolophus with   */
/* 40 % cut away scored 0.63 at the true rotation and centre, 210th of    */
/* 744 rotations, against 0.29 at a wrong one. Keeping only the share     */
/* `keep` of the matched pairs that the best rotation of all of them fits */
/* best (a trimmed Procrustes fit, one trimming step) lets the shared     */
/* surface decide.                                                        */
/* ---------------------------------------------------------------------- */
/* Bisection steps for the trimming threshold: PKSS_TRIM_STEPS (tuning.h). */

/* The rotation R (row-major, y ~ R x) that best fits the pairs of the     */
/* normalised H = sum x y^T, from its singular values sv and right        */
/* singular vectors V (pkss_measure_from_H_svd): R = V D U^T (Kabsch),    */
/* with U from B = H V = U Sigma and its third column u1 x u2.            */
/* sum_out = the pairs' residual sum |R x - y|^2 = 2 - 2 tr(D Sigma).     */
/* Lanes whose second singular value vanishes (the pairs lie on a line)   */
/* are cleared from *ok.                                                  */
PKSS_INLINE void pkss_fit_rotation(const pkss_vf *H, const pkss_vf *sv,
                                   const pkss_vf *V, pkss_vf *R,
                                   pkss_vf *sum_out, pkss_vi *ok)
{
    pkss_vf U[9];
    *ok = *ok & (sv[1] > 1.0e-6f * (sv[0] + 1.0e-30f));
    for (int c = 0; c < 2; ++c) {
        pkss_vf inv = 1.0f / PKSS_SEL(*ok, sv[c], PKSS_VF(1.0f));
        for (int r = 0; r < 3; ++r)
            U[3 * r + c] = (H[3 * r] * V[c] + H[3 * r + 1] * V[3 + c] +
                            H[3 * r + 2] * V[6 + c]) * inv;
    }
    U[2] = U[3] * U[7] - U[6] * U[4];
    U[5] = U[6] * U[1] - U[0] * U[7];
    U[8] = U[0] * U[4] - U[3] * U[1];
    /* U is proper by construction, V may not be (Jacobi with column swaps):
     * the best proper R = V diag(1, 1, det V) U^T; its fit is
     * tr(R H) = s1 + s2 + sign(det H) s3, as in G. */
    pkss_vf dv = PKSS_SEL(pkss_det3(V) < 0.0f, PKSS_VF(-1.0f), PKSS_VF(1.0f));
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            R[3 * i + j] = V[3 * i] * U[3 * j] + V[3 * i + 1] * U[3 * j + 1] +
                           dv * V[3 * i + 2] * U[3 * j + 2];
    pkss_vf d = PKSS_SEL(pkss_det3(H) < 0.0f, PKSS_VF(-1.0f), PKSS_VF(1.0f));
    pkss_vf sum = 2.0f - 2.0f * (sv[0] + sv[1] + d * sv[2]);
    *sum_out = PKSS_SEL(sum > 0.0f, sum, PKSS_VF(0.0f));
}

/* |R (x - mx) sx - (y - my) sy|^2 for one pair. */
PKSS_INLINE pkss_vf pkss_pair_residual(const pkss_vf *R, const pkss_vf *x,
                                       const pkss_vf *y, const pkss_vf *mx,
                                       const pkss_vf *my, pkss_vf sx,
                                       pkss_vf sy)
{
    pkss_vf u0 = (x[0] - mx[0]) * sx, u1 = (x[1] - mx[1]) * sx,
            u2 = (x[2] - mx[2]) * sx;
    /* written out, as in pkss_pair_moments */
    pkss_vf e0 = R[0] * u0 + R[1] * u1 + R[2] * u2 - (y[0] - my[0]) * sy;
    pkss_vf e1 = R[3] * u0 + R[4] * u1 + R[5] * u2 - (y[1] - my[1]) * sy;
    pkss_vf e2 = R[6] * u0 + R[7] * u1 + R[8] * u2 - (y[2] - my[2]) * sy;
    pkss_vf r = PKSS_VF(0.0f);
    r = r + e0 * e0;
    r = r + e1 * e1;
    r = r + e2 * e2;
    return r;
}

/* ---------------------------------------------------------------------- */
/* Score of (source binning + azimuth shift, template binning) pairs       */
/* (SPEC 4). Template cell (e, a) is matched with source cell              */
/* (e, (a - shift) mod n_az): rotating the source by a whole azimuth step  */
/* about z moves its cells by one azimuth index. Both matched sets are     */
/* centred on their own means and scaled to unit Frobenius norm (Eq. 2 on  */
/* the representatives), H = X^T Y. tgt_occupied = occupied template cells.*/
/* One source table (float[n_cells][4]) against PKSS_VW template tables:   */
/* component k of cell c of lane l is tgt[(4*c + k) * tgt_stride + l].     */
/* ---------------------------------------------------------------------- */

/* The pair of template cell ct = n_az * e + a: its source representative */
/* x and template representatives y; the mask says in which lanes both    */
/* cells are occupied (all clear when the source cell is empty).          */
PKSS_INLINE pkss_vi pkss_load_pair(PKSS_CONST float *src, int shift,
                                   PKSS_CONST float *tgt, int tgt_stride,
                                   int n_az, int e, int a, pkss_vf *x,
                                   pkss_vf *y)
{
    int ct = n_az * e + a;
    int as = a - shift;
    if (as < 0)
        as += n_az;
    int cs = n_az * e + as;
    if (!(src[4 * cs + 3] > 0.0f))
        return PKSS_VI(0);
    x[0] = PKSS_VF(src[4 * cs]);
    x[1] = PKSS_VF(src[4 * cs + 1]);
    x[2] = PKSS_VF(src[4 * cs + 2]);
    y[0] = PKSS_LOADV(tgt, (4 * ct) * tgt_stride);
    y[1] = PKSS_LOADV(tgt, (4 * ct + 1) * tgt_stride);
    y[2] = PKSS_LOADV(tgt, (4 * ct + 2) * tgt_stride);
    return PKSS_LOADV(tgt, (4 * ct + 3) * tgt_stride) > 0.0f;
}

/* A residual filter on the pairs: with `on`, only pairs whose residual    */
/* under (R, mx, my, sx, sy) is at most tau take part. With `cached`, the  */
/* residuals are read from res[cell], computed once (pkss_cache_residuals) */
/* for the bisection's passes instead of again in each: the same values.  */
typedef struct pkss_trim {
    int on, cached;
    pkss_vf R[9], mx[3], my[3], sx, sy, tau;
    pkss_vf res[PKSS_TRIM_CACHE_CELLS];
} pkss_trim;

PKSS_INLINE pkss_vi pkss_trim_keeps(const pkss_trim *f, int cell,
                                    const pkss_vf *x, const pkss_vf *y)
{
    if (!f->on)
        return PKSS_TRUE;
    if (f->cached)
        return f->res[cell] <= f->tau;
    return pkss_pair_residual(f->R, x, y, f->mx, f->my, f->sx, f->sy) <= f->tau;
}

/* The matched pairs that pass filter f, in one pass: their count k, means
 * mx, my and, centred on them, H = sum x y^T (not normalised) with the
 * squared norms nx, ny, from the raw sums (H = S_xy - k mx my^T). Both
 * pre-shapes are centred (Eq. 2), so the means are small against the
 * reps and the subtraction loses little. */
PKSS_INLINE pkss_vi pkss_pair_moments(PKSS_CONST float *src, int shift,
                                      PKSS_CONST float *tgt, int tgt_stride,
                                      int n_az, const pkss_trim *f, pkss_vf *mx,
                                      pkss_vf *my, pkss_vf *H, pkss_vf *nx_out,
                                      pkss_vf *ny_out)
{
    const pkss_vf zero = PKSS_VF(0.0f);
    pkss_vi k = PKSS_VI(0);
    pkss_vf x[3], y[3], sx[3], sy[3], nx = zero, ny = zero;
    pkss_vf s0 = zero, s1 = zero, s2 = zero, t0 = zero, t1 = zero, t2 = zero;
    pkss_vf h0 = zero, h1 = zero, h2 = zero, h3 = zero, h4 = zero, h5 = zero, h6 = zero,
            h7 = zero, h8 = zero;
    for (int e = 0; e < n_az / 2; ++e)
        for (int a = 0; a < n_az; ++a) {
            pkss_vi m = pkss_load_pair(src, shift, tgt, tgt_stride, n_az, e, a, x, y);
            if (!PKSS_ANY(m))
                continue;
            m = m & pkss_trim_keeps(f, n_az * e + a, x, y);
            k = k + PKSS_ONE_IF(m);
            /* written out, not looped: a loop over an array makes the
             * kernel compiler keep the array on the stack */
            pkss_vf x0 = PKSS_SEL(m, x[0], zero), x1 = PKSS_SEL(m, x[1], zero),
                    x2 = PKSS_SEL(m, x[2], zero);
            pkss_vf y0 = PKSS_SEL(m, y[0], zero), y1 = PKSS_SEL(m, y[1], zero),
                    y2 = PKSS_SEL(m, y[2], zero);
            s0 = s0 + x0;
            s1 = s1 + x1;
            s2 = s2 + x2;
            t0 = t0 + y0;
            t1 = t1 + y1;
            t2 = t2 + y2;
            h0 = h0 + x0 * y0;
            h1 = h1 + x0 * y1;
            h2 = h2 + x0 * y2;
            h3 = h3 + x1 * y0;
            h4 = h4 + x1 * y1;
            h5 = h5 + x1 * y2;
            h6 = h6 + x2 * y0;
            h7 = h7 + x2 * y1;
            h8 = h8 + x2 * y2;
            nx = nx + (x0 * x0 + x1 * x1 + x2 * x2);
            ny = ny + (y0 * y0 + y1 * y1 + y2 * y2);
        }
    /* no array initialised from h0..h8 here: a program built so crashed
     * LeakSanitizer's scan of the test process when PoCL loaded it from
     * its binary (docs/tuning.md, "OpenCL lanes and groups") */
    H[0] = h0;
    H[1] = h1;
    H[2] = h2;
    H[3] = h3;
    H[4] = h4;
    H[5] = h5;
    H[6] = h6;
    H[7] = h7;
    H[8] = h8;
    sx[0] = s0;
    sx[1] = s1;
    sx[2] = s2;
    sy[0] = t0;
    sy[1] = t1;
    sy[2] = t2;
    pkss_vf inv_k = 1.0f / PKSS_TO_VF(PKSS_SEL(k > 0, k, PKSS_VI(1)));
    for (int d = 0; d < 3; ++d) {
        mx[d] = sx[d] * inv_k;
        my[d] = sy[d] * inv_k;
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            H[3 * i + j] = H[3 * i + j] - sx[i] * my[j];
    nx = nx - (sx[0] * mx[0] + sx[1] * mx[1] + sx[2] * mx[2]);
    ny = ny - (sy[0] * my[0] + sy[1] * my[1] + sy[2] * my[2]);
    *nx_out = PKSS_SEL(nx > 0.0f, nx, zero);
    *ny_out = PKSS_SEL(ny > 0.0f, ny, zero);
    return k;
}

/* Fills f->res with every template cell's residual under f (a value no  */
/* tau reaches where the cell has no pair in a lane) and sets f->cached,  */
/* when the partition has at most PKSS_TRIM_CACHE_CELLS cells.            */
PKSS_INLINE void pkss_cache_residuals(PKSS_CONST float *src, int shift,
                                      PKSS_CONST float *tgt, int tgt_stride,
                                      int n_az, pkss_trim *f)
{
    f->cached = 0;
    if (n_az * (n_az / 2) > PKSS_TRIM_CACHE_CELLS)
        return;
    const pkss_vf none = PKSS_VF(3.0e38f);
    pkss_vf x[3], y[3];
    for (int e = 0; e < n_az / 2; ++e)
        for (int a = 0; a < n_az; ++a) {
            pkss_vi m = pkss_load_pair(src, shift, tgt, tgt_stride, n_az, e, a, x, y);
            f->res[n_az * e + a] =
                PKSS_ANY(m) ? PKSS_SEL(m, pkss_pair_residual(f->R, x, y, f->mx, f->my,
                                                             f->sx, f->sy), none)
                            : none;
        }
    f->cached = 1;
}

/* How many matched pairs pass filter f. */
PKSS_INLINE pkss_vi pkss_count_kept(PKSS_CONST float *src, int shift,
                                    PKSS_CONST float *tgt, int tgt_stride,
                                    int n_az, const pkss_trim *f)
{
    pkss_vi k = PKSS_VI(0);
    if (f->cached) { /* a cell without a pair holds a residual no tau reaches */
        for (int c = 0; c < n_az * (n_az / 2); ++c)
            k = k + PKSS_ONE_IF(f->res[c] <= f->tau);
        return k;
    }
    pkss_vf x[3], y[3];
    for (int e = 0; e < n_az / 2; ++e)
        for (int a = 0; a < n_az; ++a) {
            pkss_vi m = pkss_load_pair(src, shift, tgt, tgt_stride, n_az, e, a, x, y);
            if (PKSS_ANY(m))
                k = k + PKSS_ONE_IF(m & pkss_trim_keeps(f, n_az * e + a, x, y));
        }
    return k;
}

/* G of normalised moments, pi/2 where not valid (also nx or ny = 0); H is
 * left normalised, with its singular values in sv and, if V is not NULL,
 * its right singular vectors in V. */
PKSS_INLINE pkss_vf pkss_measure_moments(pkss_vf *H, pkss_vf nx, pkss_vf ny,
                                         pkss_vi *valid, pkss_vf *sv,
                                         pkss_vf *V)
{
    *valid = *valid & (nx > 0.0f) & (ny > 0.0f);
    if (!PKSS_ANY(*valid))
        return PKSS_VF(PKSS_HALF_PI_F);
    pkss_vf inv = 1.0f / (PKSS_SQRT(nx) * PKSS_SQRT(ny));
    for (int i = 0; i < 9; ++i)
        H[i] = H[i] * inv;
    pkss_vf g = pkss_measure_from_H_svd(H, *valid, sv, V);
    return PKSS_SEL(*valid, g, PKSS_VF(PKSS_HALF_PI_F));
}

/* keep = 1: the paper's G (SPEC 4). keep < 1: the trimmed G (see above)  */
/* of the ceil(keep * k) pairs that the rotation fitted to all k pairs    */
/* fits best, up to the bisection's tolerance; a lane whose trimmed set   */
/* cannot be measured keeps the untrimmed G. The coverage guard counts    */
/* all k matched pairs either way. src_cover: the share of the source    */
/* table's src_occupied occupied cells (counted where it was binned) the  */
/* pairs must match (0: no such guard).                                   */
PKSS_INLINE pkss_vf pkss_score_lanes(PKSS_CONST float *src, int shift,
                                     PKSS_CONST float *tgt, int tgt_stride,
                                     pkss_vi tgt_occupied, int n_az, float keep,
                                     float src_cover, int src_occupied)
{
    pkss_trim f;
    f.on = 0;
    f.cached = 0;
    pkss_vf mx[3], my[3], H[9], nx, ny, sv[3], V[9];
    pkss_vi k = pkss_pair_moments(src, shift, tgt, tgt_stride, n_az, &f, mx, my, H,
                                  &nx, &ny);
    pkss_vi valid = (k >= PKSS_MIN_MATCHED) &
                    !(PKSS_TO_VF(k) < PKSS_MIN_COVERAGE * PKSS_TO_VF(tgt_occupied)) &
                    !(PKSS_TO_VF(k) < PKSS_VF(src_cover * (float)src_occupied));
    if (!PKSS_ANY(valid))
        return PKSS_VF(PKSS_HALF_PI_F);
    int trim = keep < 1.0f;
    /* the trimmed G needs V as well: one SVD serves both */
    pkss_vf g = pkss_measure_moments(H, nx, ny, &valid, sv, trim ? V : 0);
    if (!trim || !PKSS_ANY(valid))
        return g;

    pkss_vi ok = valid;
    pkss_vf sum;
    pkss_fit_rotation(H, sv, V, f.R, &sum, &ok);
    for (int d = 0; d < 3; ++d) {
        f.mx[d] = mx[d];
        f.my[d] = my[d];
    }
    f.sx = 1.0f / PKSS_SQRT(PKSS_SEL(ok, nx, PKSS_VF(1.0f)));
    f.sy = 1.0f / PKSS_SQRT(PKSS_SEL(ok, ny, PKSS_VF(1.0f)));
    f.on = 1;
    pkss_cache_residuals(src, shift, tgt, tgt_stride, n_az, &f);
    /* Bisection for the smallest tau (to tolerance) that keeps `need`
     * pairs. It starts from the mean residual / (1 - keep): by Markov's
     * inequality fewer than (1 - keep) k residuals exceed it, so it keeps
     * at least `need` (the margin covers the rounding of sum, ~1 ulp of 2). */
    pkss_vf need = PKSS_CEIL(keep * PKSS_TO_VF(k));
    pkss_vf lo = PKSS_VF(0.0f);
    pkss_vf hi = sum / (PKSS_TO_VF(k) * (1.0f - keep)) * 1.001f + 1.0e-6f;
    for (int it = 0; it < PKSS_TRIM_STEPS; ++it) {
        f.tau = 0.5f * (lo + hi);
        pkss_vi enough = PKSS_TO_VF(pkss_count_kept(src, shift, tgt, tgt_stride,
                                                    n_az, &f)) >= need;
        hi = PKSS_SEL(enough, f.tau, hi);
        lo = PKSS_SEL(enough, lo, f.tau);
    }
    f.tau = hi;
    pkss_vi k2 = pkss_pair_moments(src, shift, tgt, tgt_stride, n_az, &f, mx, my, H,
                                   &nx, &ny);
    ok = ok & (k2 >= PKSS_MIN_MATCHED);
    pkss_vf g2 = pkss_measure_moments(H, nx, ny, &ok, sv, 0);
    return PKSS_SEL(ok, g2, g);
}

#if PKSS_VW == 1
/* The C layouts of the banner (one lane). */
PKSS_INLINE void pkss_bin_points(PKSS_CONST float *pts, int n, const float *R,
                                 float cx, float cy, float cz, int n_az,
                                 PKSS_CONST float *edges, PKSS_GLOBAL float *reps)
{
    pkss_bin_points_strided(pts, 1, 3, n, R, cx, cy, cz, n_az, edges, reps, 1);
}

PKSS_INLINE float pkss_score_pair(PKSS_CONST float *src, int shift,
                                  PKSS_CONST float *tgt, int tgt_occupied,
                                  int n_az, float keep, float src_cover,
                                  int src_occupied)
{
    return pkss_score_lanes(src, shift, tgt, 1, tgt_occupied, n_az, keep,
                            src_cover, src_occupied);
}

PKSS_INLINE int pkss_count_occupied(PKSS_CONST float *reps, int n_cells)
{
    return pkss_count_occupied_strided(reps, n_cells, 1);
}
#endif

#endif /* PKSS_SHARED_H */
