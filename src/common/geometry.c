/* SPDX-License-Identifier: MIT
 * geometry.c -- small double-precision 3x3 linear algebra for the host side:
 * rotations, the symmetric eigen-decomposition used by PCA and D_pca, the
 * full SVD used for O_r (Eq. 7) and the Umeyama/Kabsch updates of the ICP.
 * (The float32 singular values of the search live in kernels/pkss_shared.h.)
 */
#include "pkss_internal.h"

#include <math.h>
#include <string.h>

void pkss__mat3_mul(const double *A, const double *B, double *C)
{
    double T[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            T[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] +
                           A[3 * i + 2] * B[6 + j];
    memcpy(C, T, sizeof T);
}

void pkss__mat3_transpose(const double *A, double *T)
{
    double U[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            U[3 * j + i] = A[3 * i + j];
    memcpy(T, U, sizeof U);
}

void pkss__mat3_identity(double *A)
{
    memset(A, 0, 9 * sizeof(double));
    A[0] = A[4] = A[8] = 1.0;
}

void pkss__euler_zyx(double a, double b, double c, double *R)
{
    double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b), cc = cos(c),
           sc = sin(c);
    double Rx[9] = {1, 0, 0, 0, ca, -sa, 0, sa, ca};
    double Ry[9] = {cb, 0, sb, 0, 1, 0, -sb, 0, cb};
    double Rz[9] = {cc, -sc, 0, sc, cc, 0, 0, 0, 1};
    double T[9];
    pkss__mat3_mul(Ry, Rx, T);
    pkss__mat3_mul(Rz, T, R);
}

double pkss__rotation_angle(const double *R1, const double *R2)
{
    /* angle of R1^T R2: trace = sum_ij R1_ij R2_ij */
    double tr = 0.0;
    for (int i = 0; i < 9; ++i)
        tr += R1[i] * R2[i];
    double c = 0.5 * (tr - 1.0);
    if (c > 1.0) c = 1.0;
    if (c < -1.0) c = -1.0;
    return acos(c);
}

void pkss__eig_sym3(const double *Sin, double *w, double *V)
{
    double S[9];
    memcpy(S, Sin, sizeof S);
    pkss__mat3_identity(V);
    for (int sweep = 0; sweep < 50; ++sweep) {
        double off = fabs(S[1]) + fabs(S[2]) + fabs(S[5]);
        double scale = fabs(S[0]) + fabs(S[4]) + fabs(S[8]);
        if (off == 0.0 || off <= 1e-15 * scale)
            break;
        static const int P[3] = {0, 0, 1}, Q[3] = {1, 2, 2};
        for (int r = 0; r < 3; ++r) {
            int p = P[r], q = Q[r];
            double apq = S[3 * p + q];
            if (apq == 0.0)
                continue;
            double theta = (S[3 * q + q] - S[3 * p + p]) / (2.0 * apq);
            double t = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0));
            if (theta < 0.0)
                t = -t;
            double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
            for (int k = 0; k < 3; ++k) {
                double skp = S[3 * k + p], skq = S[3 * k + q];
                S[3 * k + p] = c * skp - s * skq;
                S[3 * k + q] = s * skp + c * skq;
            }
            for (int k = 0; k < 3; ++k) {
                double spk = S[3 * p + k], sqk = S[3 * q + k];
                S[3 * p + k] = c * spk - s * sqk;
                S[3 * q + k] = s * spk + c * sqk;
            }
            for (int k = 0; k < 3; ++k) {
                double vkp = V[3 * k + p], vkq = V[3 * k + q];
                V[3 * k + p] = c * vkp - s * vkq;
                V[3 * k + q] = s * vkp + c * vkq;
            }
        }
    }
    double d[3] = {S[0], S[4], S[8]};
    int o[3] = {0, 1, 2};
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2 - i; ++j)
            if (d[o[j]] < d[o[j + 1]]) {
                int t = o[j];
                o[j] = o[j + 1];
                o[j + 1] = t;
            }
    double Vs[9];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            Vs[3 * r + c] = V[3 * r + o[c]];
    for (int i = 0; i < 3; ++i)
        w[i] = d[o[i]];
    memcpy(V, Vs, sizeof Vs);
}

static void normalize3(double *v)
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0) {
        v[0] /= n;
        v[1] /= n;
        v[2] /= n;
    }
}

void pkss__cross3(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Any unit vector orthogonal to a (unit). */
static void orthogonal3(const double *a, double *b)
{
    double e[3] = {0, 0, 0};
    int i = fabs(a[0]) <= fabs(a[1]) ? (fabs(a[0]) <= fabs(a[2]) ? 0 : 2)
                                     : (fabs(a[1]) <= fabs(a[2]) ? 1 : 2);
    e[i] = 1.0;
    pkss__cross3(a, e, b);
    normalize3(b);
}

void pkss__svd3(const double *H, double *U, double *s, double *V)
{
    /* V and s^2 from the eigen-decomposition of H^T H; U from H V, columns
     * re-orthonormalised so rank-deficient H still yields a rotation or
     * reflection basis. */
    double S[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            S[3 * i + j] = H[i] * H[j] + H[3 + i] * H[3 + j] + H[6 + i] * H[6 + j];
    double w[3];
    pkss__eig_sym3(S, w, V);
    double B[9];
    pkss__mat3_mul(H, V, B);
    double u[3][3];
    for (int k = 0; k < 3; ++k) {
        u[k][0] = B[k];
        u[k][1] = B[3 + k];
        u[k][2] = B[6 + k];
        s[k] = sqrt(u[k][0] * u[k][0] + u[k][1] * u[k][1] + u[k][2] * u[k][2]);
    }
    double tol = 1e-12 * (s[0] > 0 ? s[0] : 1.0);
    if (s[0] > tol)
        normalize3(u[0]);
    else {
        u[0][0] = 1; u[0][1] = 0; u[0][2] = 0;
    }
    /* Gram-Schmidt for u1, u2; replace tiny columns by orthogonal ones. */
    double d01 = u[1][0] * u[0][0] + u[1][1] * u[0][1] + u[1][2] * u[0][2];
    for (int i = 0; i < 3; ++i)
        u[1][i] -= d01 * u[0][i];
    if (s[1] > tol && sqrt(u[1][0] * u[1][0] + u[1][1] * u[1][1] + u[1][2] * u[1][2]) > tol)
        normalize3(u[1]);
    else
        orthogonal3(u[0], u[1]);
    double c[3];
    pkss__cross3(u[0], u[1], c);
    if (s[2] > tol) {
        /* keep u2's orientation from H v2 (may be a reflection) */
        double dot = c[0] * u[2][0] + c[1] * u[2][1] + c[2] * u[2][2];
        if (dot < 0) {
            c[0] = -c[0]; c[1] = -c[1]; c[2] = -c[2];
        }
    }
    u[2][0] = c[0]; u[2][1] = c[1]; u[2][2] = c[2];
    for (int k = 0; k < 3; ++k) {
        U[k] = u[k][0];
        U[3 + k] = u[k][1];
        U[6 + k] = u[k][2];
    }
}

static double det3d(const double *A)
{
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
           A[2] * (A[3] * A[7] - A[4] * A[6]);
}

void pkss__procrustes_rotation(const double *H, double *R)
{
    double U[9], s[3], V[9];
    pkss__svd3(H, U, s, V);
    /* R = V diag(1, 1, d) U^T with d = sign(det(V U^T)) (reflection-safe). */
    double Ut[9], VUt[9];
    pkss__mat3_transpose(U, Ut);
    pkss__mat3_mul(V, Ut, VUt);
    double d = det3d(VUt) < 0 ? -1.0 : 1.0;
    double D[9] = {1, 0, 0, 0, 1, 0, 0, 0, d};
    double VD[9];
    pkss__mat3_mul(V, D, VD);
    pkss__mat3_mul(VD, Ut, R);
}

void pkss__rotation_exp(const double *w, double *R)
{
    double th = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    /* R = I + a [w]x + b [w]x^2, with the series of a and b near 0 */
    double a = th > 1e-6 ? sin(th) / th : 1.0 - th * th / 6.0;
    double b = th > 1e-6 ? (1.0 - cos(th)) / (th * th) : 0.5 - th * th / 24.0;
    double K[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0}, K2[9];
    pkss__mat3_mul(K, K, K2);
    for (int i = 0; i < 9; ++i)
        R[i] = (i % 4 == 0 ? 1.0 : 0.0) + a * K[i] + b * K2[i];
}

int pkss__solve_spd(double *A, double *b, int n)
{
    /* Cholesky A = L L^T in place (lower triangle), then two substitutions */
    for (int j = 0; j < n; ++j) {
        double d = A[n * j + j];
        for (int k = 0; k < j; ++k)
            d -= A[n * j + k] * A[n * j + k];
        if (!(d > 0.0))
            return 0;
        d = sqrt(d);
        A[n * j + j] = d;
        for (int i = j + 1; i < n; ++i) {
            double v = A[n * i + j];
            for (int k = 0; k < j; ++k)
                v -= A[n * i + k] * A[n * j + k];
            A[n * i + j] = v / d;
        }
    }
    for (int i = 0; i < n; ++i) {
        for (int k = 0; k < i; ++k)
            b[i] -= A[n * i + k] * b[k];
        b[i] /= A[n * i + i];
    }
    for (int i = n - 1; i >= 0; --i) {
        for (int k = i + 1; k < n; ++k)
            b[i] -= A[n * k + i] * b[k];
        b[i] /= A[n * i + i];
    }
    return 1;
}

double pkss__dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

uint64_t pkss__splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double pkss__splitmix64_unit(uint64_t *state)
{
    return (double)(pkss__splitmix64(state) >> 11) * 0x1.0p-53;
}
