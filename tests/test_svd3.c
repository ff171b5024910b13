/* SPDX-License-Identifier: MIT
 * test_svd3.c -- the 3x3 SVD of kernels/pkss_shared.h (float32, shared by
 * the C reference and the OpenCL kernels) and the double SVD of
 * src/common/geometry.c against LAPACKE_dgesvd on 10^5+ random and near-degenerate
 * matrices: repeated, zero, rank-1/2 singular values and reflections;
 * the trimmed measure of the wide search on pairs with outliers; and the
 * other small dense solvers of geometry.c (the SPD solve against
 * LAPACKE_dposv, the rotation of a rotation vector).
 */
#include "support.h"

#include "pkss_internal.h"
#include "pkss_shared.h"

#include <lapacke.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *PROGRAM = "test_svd3";

/* Reference singular values by LAPACK, descending. */
static void lapack_sv(const double *H, double *s)
{
    double A[9], U[9], Vt[9], superb[2];
    memcpy(A, H, sizeof A);
    lapack_int info = LAPACKE_dgesvd(LAPACK_ROW_MAJOR, 'N', 'N', 3, 3, A, 3, s,
                                     U, 3, Vt, 3, superb);
    assert_int_equal(info, 0);
}

static double det3(const double *H)
{
    return H[0] * (H[4] * H[8] - H[5] * H[7]) - H[1] * (H[3] * H[8] - H[5] * H[6]) +
           H[2] * (H[3] * H[7] - H[4] * H[6]);
}

/* H = U diag(s) V^T with random orthogonal U, V (possibly reflections). */
static void compose_matrix(pkss_test_rng *rng, const double *s, int reflect,
                           double *H)
{
    double U[9], V[9];
    pkss_test_random_rotation(rng, U);
    pkss_test_random_rotation(rng, V);
    if (reflect)
        for (int r = 0; r < 3; ++r)
            U[3 * r + 2] = -U[3 * r + 2];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double v = 0;
            for (int k = 0; k < 3; ++k)
                v += U[3 * i + k] * s[k] * V[3 * j + k];
            H[3 * i + j] = v;
        }
}

typedef struct stats {
    long count;
    double max_err_rel;  /* max |sv - ref| / max(ref[0], tiny) */
    double max_sum_err;  /* max error of s1 + s2 + d s3 (the G argument) */
    long sign_mismatch;  /* d = sign(det) wrong where |det| is clear */
} stats;

static void check_one(const double *Hd, stats *st, double tol)
{
    float H[9];
    for (int i = 0; i < 9; ++i)
        H[i] = (float)Hd[i];
    /* the reference works on the float-rounded matrix the kernel sees */
    double Hr[9];
    for (int i = 0; i < 9; ++i)
        Hr[i] = (double)H[i];
    double ref[3];
    lapack_sv(Hr, ref);
    float sv[3];
    pkss_svd3_values(H, sv, NULL);
    double scale = ref[0] > 1e-30 ? ref[0] : 1e-30;
    double e = 0;
    for (int k = 0; k < 3; ++k) {
        assert_true(sv[k] >= 0.0f);
        double d = fabs((double)sv[k] - ref[k]) / scale;
        if (d > e)
            e = d;
    }
    assert_true(sv[0] >= sv[1] && sv[1] >= sv[2]);
    if (e > st->max_err_rel)
        st->max_err_rel = e;
    double det = det3(Hr);
    float df = pkss_det3(H) < 0.0f ? -1.0f : 1.0f;
    double dd = det < 0 ? -1.0 : 1.0;
    if (fabs(det) > 1e-4 * scale * scale * scale && df != dd)
        st->sign_mismatch++;
    double sum_ref = ref[0] + ref[1] + dd * ref[2];
    double sum_f = (double)sv[0] + sv[1] + df * sv[2];
    /* where det is ~0 the sign is arbitrary but s3 ~ 0, so the sum agrees */
    double se = fabs(sum_ref - sum_f) / scale;
    if (se > st->max_sum_err)
        st->max_sum_err = se;
    if (e > tol || se > 2 * tol)
        fail_msg("H = [%g %g %g; %g %g %g; %g %g %g]: sv (%g %g %g) vs LAPACK "
                 "(%g %g %g), rel err %g",
                 Hr[0], Hr[1], Hr[2], Hr[3], Hr[4], Hr[5], Hr[6], Hr[7], Hr[8], sv[0],
                 sv[1], sv[2], ref[0], ref[1], ref[2], e);
    st->count++;
}

/* float32 singular values within 2e-6 of sigma_1 (a few float ulps). */
#define SV_TOL 2e-6

static void test_random_matrices(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 1)};
    stats st = {0};
    for (int n = 0; n < 60000; ++n) {
        double H[9];
        double mag = pow(10.0, -3.0 + 6.0 * pkss_test_uniform(&rng));
        for (int i = 0; i < 9; ++i)
            H[i] = mag * pkss_test_normal(&rng);
        check_one(H, &st, SV_TOL);
    }
    printf("  random: %ld matrices, max rel sv error %.3g, max rel G-sum error %.3g, "
           "sign mismatches %ld\n",
           st.count, st.max_err_rel, st.max_sum_err, st.sign_mismatch);
    assert_int_equal(st.sign_mismatch, 0);
}

static void test_near_degenerate_matrices(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 2)};
    stats st = {0};
    const double tiny[] = {0.0, 1e-12, 1e-7, 1e-4};
    for (int n = 0; n < 50000; ++n) {
        double s[3];
        int kind = n % 8;
        double a = pkss_test_uniform(&rng) + 0.01;
        double t = tiny[(n / 8) % 4];
        switch (kind) {
        case 0: s[0] = s[1] = s[2] = a; break;                   /* all repeated */
        case 1: s[0] = s[1] = a; s[2] = 0.3 * a; break;            /* top pair */
        case 2: s[0] = a; s[1] = s[2] = 0.4 * a; break;            /* bottom pair */
        case 3: s[0] = a; s[1] = s[2] = t * a; break;              /* rank 1 */
        case 4: s[0] = a; s[1] = 0.5 * a; s[2] = t * a; break;     /* rank 2 */
        case 5: s[0] = s[1] = a; s[2] = t * a; break;              /* rank 2, repeated */
        case 6: s[0] = a; s[1] = a * (1 + 1e-7); s[2] = a * (1 - 1e-7); break; /* clustered */
        default: s[0] = a; s[1] = 0.7 * a; s[2] = 0.2 * a; break;
        }
        /* sort descending for the composed matrix */
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2 - i; ++j)
                if (s[j] < s[j + 1]) {
                    double x = s[j]; s[j] = s[j + 1]; s[j + 1] = x;
                }
        double H[9];
        compose_matrix(&rng, s, n % 2, H);
        check_one(H, &st, SV_TOL);
    }
    /* exact special matrices */
    double Z[9] = {0};
    check_one(Z, &st, SV_TOL);
    double Id[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    check_one(Id, &st, SV_TOL);
    double Rf[9] = {1, 0, 0, 0, 1, 0, 0, 0, -1};
    check_one(Rf, &st, SV_TOL);
    double R1[9] = {1, 2, 3, 2, 4, 6, 3, 6, 9};
    check_one(R1, &st, SV_TOL);
    double D[9] = {3, 0, 0, 0, 0, 0, 0, 0, 2};
    check_one(D, &st, SV_TOL);
    printf("  near-degenerate: %ld matrices, max rel sv error %.3g, max rel G-sum error %.3g, "
           "sign mismatches %ld\n",
           st.count, st.max_err_rel, st.max_sum_err, st.sign_mismatch);
    assert_int_equal(st.sign_mismatch, 0);
    /* a pure reflection: s = (1,1,1), d = -1, so the G argument is 1 */
    float Rff[9] = {1, 0, 0, 0, 1, 0, 0, 0, -1};
    assert_float_equal(pkss_measure_from_H(Rff), acosf(1.0f), 1e-6);
}

/* The double SVD used for O_r and the ICP: reconstruction, orthogonality
 * and a proper Procrustes rotation, including rank-deficient H. */
static void test_double_svd_and_procrustes(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 3)};
    double worst_rec = 0, worst_orth = 0;
    for (int n = 0; n < 20000; ++n) {
        double s[3] = {1.0, 0.5 + 0.5 * pkss_test_uniform(&rng), 0.0};
        int kind = n % 4;
        s[2] = kind == 0 ? 0.0 : (kind == 1 ? 1e-9 : 0.2 * pkss_test_uniform(&rng));
        if (kind == 3) s[1] = s[0];
        double H[9], U[9], S[3], V[9];
        compose_matrix(&rng, s, n % 2, H);
        pkss__svd3(H, U, S, V);
        double ref[3];
        lapack_sv(H, ref);
        for (int k = 0; k < 3; ++k)
            assert_float_equal(S[k], ref[k], 1e-9);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                double v = 0, uu = 0, vv = 0;
                for (int k = 0; k < 3; ++k) {
                    v += U[3 * i + k] * S[k] * V[3 * j + k];
                    uu += U[3 * k + i] * U[3 * k + j];
                    vv += V[3 * k + i] * V[3 * k + j];
                }
                double e = fabs(v - H[3 * i + j]);
                if (e > worst_rec) worst_rec = e;
                double o = fabs(uu - (i == j)) + fabs(vv - (i == j));
                if (o > worst_orth) worst_orth = o;
            }
        double R[9];
        pkss__procrustes_rotation(H, R);
        assert_float_equal(det3(R), 1.0, 1e-9);
    }
    printf("  double SVD: max reconstruction error %.3g, max orthogonality error %.3g\n",
           worst_rec, worst_orth);
    assert_true(worst_rec < 1e-8);
    assert_true(worst_orth < 1e-8);
    /* Procrustes recovers a known rotation from exact correspondences */
    double Rg[9];
    pkss_test_random_rotation(&rng, Rg);
    double H[9] = {0};
    for (int p = 0; p < 20; ++p) {
        double x[3] = {pkss_test_normal(&rng), pkss_test_normal(&rng), pkss_test_normal(&rng)};
        double y[3];
        pkss__mat3_apply(Rg, x, y);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                H[3 * r + c] += x[r] * y[c];
    }
    double R[9];
    pkss__procrustes_rotation(H, R);
    for (int i = 0; i < 9; ++i)
        assert_float_equal(R[i], Rg[i], 1e-9);
}

/* Rep tables for the measure (n_az = 12: 72 cells, every cell occupied):
 * template representatives y_c at random, source x_c = s Q y_c + t, and
 * `outliers` source cells moved far off. */
#define TRIM_AZ 12
#define TRIM_CELLS (TRIM_AZ * TRIM_AZ / 2)
static void trim_tables(pkss_test_rng *rng, int outliers, float *src, float *tgt)
{
    double Q[9];
    pkss_test_random_rotation(rng, Q);
    for (int c = 0; c < TRIM_CELLS; ++c) {
        double y[3] = {pkss_test_normal(rng), pkss_test_normal(rng), pkss_test_normal(rng)};
        double x[3];
        pkss__mat3_apply(Q, y, x);
        for (int d = 0; d < 3; ++d) {
            tgt[4 * c + d] = (float)y[d];
            src[4 * c + d] = (float)(1.7 * x[d] + 0.3 * d);
        }
        tgt[4 * c + 3] = src[4 * c + 3] = 1.0f;
    }
    /* spread over the table: every 6th cell from a random start */
    int start = (int)(pkss_test_uniform(rng) * 6);
    for (int i = 0; i < outliers; ++i) {
        int c = (start + 6 * i) % TRIM_CELLS;
        for (int d = 0; d < 3; ++d)
            src[4 * c + d] += (float)(1.5 * pkss_test_normal(rng));
    }
}

/* The paper's G of two full rep tables in double (SPEC 4): both sets
 * centred and scaled to unit Frobenius norm, arccos(s1 + s2 + sign(det H) s3). */
static double reference_G(const float *src, const float *tgt, int n)
{
    double mx[3] = {0, 0, 0}, my[3] = {0, 0, 0}, H[9] = {0}, nx = 0, ny = 0;
    for (int c = 0; c < n; ++c)
        for (int d = 0; d < 3; ++d) {
            mx[d] += src[4 * c + d] / (double)n;
            my[d] += tgt[4 * c + d] / (double)n;
        }
    for (int c = 0; c < n; ++c)
        for (int i = 0; i < 3; ++i) {
            double xi = src[4 * c + i] - mx[i];
            nx += xi * xi;
            ny += (tgt[4 * c + i] - my[i]) * (tgt[4 * c + i] - my[i]);
            for (int j = 0; j < 3; ++j)
                H[3 * i + j] += xi * (tgt[4 * c + j] - my[j]);
        }
    for (int i = 0; i < 9; ++i)
        H[i] /= sqrt(nx * ny);
    double U[9], S[3], V[9];
    pkss__svd3(H, U, S, V);
    double tr = S[0] + S[1] + (det3(H) < 0 ? -S[2] : S[2]);
    return acos(fmin(1.0, fmax(-1.0, tr)));
}

/* The one-pass moments (pkss_pair_moments: raw sums, centred after) give
 * the paper's G of a centred double computation: on noisy pairs whose
 * matched cells lie on one side (a partial match, its means far from the
 * pre-shape's centre: up to the reps' own spread) and on clean ones. */
static void test_one_pass_moments(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 9)};
    float src[4 * TRIM_CELLS], tgt[4 * TRIM_CELLS], ms[4 * TRIM_CELLS], mt[4 * TRIM_CELLS];
    double worst = 0.0;
    for (int n = 0; n < 200; ++n) {
        trim_tables(&rng, 0, src, tgt);
        double noise = 0.02 * (n % 10), side = pkss_test_normal(&rng);
        int k = 0;
        for (int c = 0; c < TRIM_CELLS; ++c) {
            for (int d = 0; d < 3; ++d)
                src[4 * c + d] += (float)(noise * pkss_test_normal(&rng));
            /* half the pairs: only cells with y_0 beyond a random level */
            int keep = n % 2 == 0 || tgt[4 * c] > side;
            if (!keep)
                src[4 * c + 3] = -1.0f;
            else {
                memcpy(ms + 4 * k, src + 4 * c, 4 * sizeof(float));
                memcpy(mt + 4 * k, tgt + 4 * c, 4 * sizeof(float));
                ++k;
            }
        }
        if (k < PKSS_MIN_MATCHED)
            continue;
        float g = pkss_score_pair(src, 0, tgt, k, TRIM_AZ, 1.0f, 0.0f, k);
        double e = fabs(g - reference_G(ms, mt, k));
        if (g >= 2e-3f) /* below, float's acos near 1 bounds the precision */
            worst = fmax(worst, e);
        assert_true(e < (g >= 2e-3f ? 1e-4 : 2e-3));
    }
    printf("  one-pass moments: |G - G_double| <= %.3g where G >= 2e-3\n", worst);
}

/* The trimmed G (keep < 1) recovers the shape shared by 80 % of the pairs
 * when the others are outliers, where the paper's G (keep = 1) does not;
 * with no outliers both are ~0; keep = 1 is the paper's G. */
static void test_trimmed_measure(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 4)};
    float src[4 * TRIM_CELLS], tgt[4 * TRIM_CELLS];
    double worst_clean = 0, worst_ratio = 0, worst_trim = 0;
    for (int n = 0; n < 200; ++n) {
        trim_tables(&rng, 0, src, tgt);
        float g_full = pkss_score_pair(src, 0, tgt, TRIM_CELLS, TRIM_AZ, 1.0f, 0.0f, TRIM_CELLS);
        float g_trim = pkss_score_pair(src, 0, tgt, TRIM_CELLS, TRIM_AZ, 0.8f, 0.0f, TRIM_CELLS);
        worst_clean = fmax(worst_clean, fmax(g_full, g_trim));
        /* 10 of 72 cells (14 %) are outliers */
        trim_tables(&rng, 10, src, tgt);
        g_full = pkss_score_pair(src, 0, tgt, TRIM_CELLS, TRIM_AZ, 1.0f, 0.0f, TRIM_CELLS);
        g_trim = pkss_score_pair(src, 0, tgt, TRIM_CELLS, TRIM_AZ, 0.8f, 0.0f, TRIM_CELLS);
        assert_float_equal(g_full, reference_G(src, tgt, TRIM_CELLS), 1e-4);
        worst_trim = fmax(worst_trim, g_trim);
        worst_ratio = fmax(worst_ratio, g_trim / g_full);
    }
    /* One trimming step from the fit to all pairs: an outlier moved little
     * can stay in the kept set, so the trimmed G is small, not 0. */
    printf("  trimmed measure: clean pairs G <= %.3g; 14 %% outliers: trimmed G <= %.3g, "
           "<= %.3g x the full G\n", worst_clean, worst_trim, worst_ratio);
    assert_true(worst_clean < 2e-3);
    assert_true(worst_trim < 0.05);
    assert_true(worst_ratio < 0.2);
    /* the coverage guard does not depend on keep: 3 matched pairs */
    for (int c = 3; c < TRIM_CELLS; ++c)
        src[4 * c + 3] = -1.0f;
    assert_float_equal(pkss_score_pair(src, 0, tgt, TRIM_CELLS, TRIM_AZ, 0.8f, 0.0f, TRIM_CELLS),
                       PKSS_HALF_PI_F, 0.0);
}

/* The trimmed G's residual cache (pkss_cache_residuals) changes no value:
 * counts, means and moments of the pairs a filter keeps equal those that
 * recompute each residual, bit for bit, at thresholds from none kept to
 * all, with empty cells and outliers; and it is only used where the
 * partition fits it. */
static void test_trim_cache_equals_recomputing(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 8)};
    float src[4 * TRIM_CELLS], tgt[4 * TRIM_CELLS];
    for (int n = 0; n < 100; ++n) {
        trim_tables(&rng, 10, src, tgt);
        for (int c = n % 7; c < TRIM_CELLS; c += 7) /* empty cells on either side */
            (c % 2 ? src : tgt)[4 * c + 3] = -1.0f;
        int shift = n % TRIM_AZ;
        pkss_trim plain, cached;
        plain.on = 1;
        plain.cached = 0;
        for (int i = 0; i < 9; ++i) /* a rotation near the identity */
            plain.R[i] = (i % 4 == 0 ? 1.0f : 0.0f) + 0.05f * (float)pkss_test_normal(&rng);
        for (int d = 0; d < 3; ++d) {
            plain.mx[d] = 0.1f * (float)pkss_test_normal(&rng);
            plain.my[d] = 0.1f * (float)pkss_test_normal(&rng);
        }
        plain.sx = 0.3f;
        plain.sy = 0.35f;
        cached = plain;
        pkss_cache_residuals(src, shift, tgt, 1, TRIM_AZ, &cached);
        assert_true(cached.cached);
        for (int t = 0; t <= 40; ++t) {
            plain.tau = cached.tau = 0.002f * (float)(t * t);
            assert_int_equal(pkss_count_kept(src, shift, tgt, 1, TRIM_AZ, &plain),
                             pkss_count_kept(src, shift, tgt, 1, TRIM_AZ, &cached));
            float ma[3], mb[3], ya[3], yb[3], Ha[9], Hb[9], nxa, nxb, nya, nyb;
            assert_int_equal(
                pkss_pair_moments(src, shift, tgt, 1, TRIM_AZ, &plain, ma, ya, Ha, &nxa, &nya),
                pkss_pair_moments(src, shift, tgt, 1, TRIM_AZ, &cached, mb, yb, Hb, &nxb, &nyb));
            assert_memory_equal(ma, mb, sizeof ma);
            assert_memory_equal(ya, yb, sizeof ya);
            assert_memory_equal(Ha, Hb, sizeof Ha);
            assert_true(nxa == nxb && nya == nyb);
        }
    }
    /* a finer partition than the cache holds recomputes */
    pkss_trim big;
    big.on = 1;
    pkss_cache_residuals(src, 0, tgt, 1, 2 * TRIM_AZ, &big);
    assert_false(big.cached);
}

/* The source-side coverage guard of the wide search (src_cover,
 * PKSS_WIDE_SRC_COVER): a pairing that matches fewer than that share of
 * the source's occupied cells gets pi/2 even where it passes the
 * template's guard (20 % of the template's occupied cells) and its few
 * pairs fit perfectly; at or above the share, the guard changes nothing. */
static void test_source_coverage_guard(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 7)};
    float src[4 * TRIM_CELLS], tgt[4 * TRIM_CELLS];
    const float share = PKSS_WIDE_SRC_COVER;
    for (int n = 0; n < 50; ++n) {
        trim_tables(&rng, 0, src, tgt);
        /* the template occupies only its first `below` cells (the source
         * all 72): `below` pairs, every template cell matched */
        int below = (int)ceilf(share * TRIM_CELLS) - 1, at = below + 1;
        for (int c = below; c < TRIM_CELLS; ++c)
            tgt[4 * c + 3] = -1.0f;
        float unguarded = pkss_score_pair(src, 0, tgt, below, TRIM_AZ, 1.0f, 0.0f, TRIM_CELLS);
        assert_true(unguarded < 1e-3f); /* the pairs fit: only the guard refuses */
        assert_float_equal(pkss_score_pair(src, 0, tgt, below, TRIM_AZ, 1.0f, share,
                                           pkss_count_occupied(src, TRIM_CELLS)),
                           PKSS_HALF_PI_F, 0.0);
        assert_float_equal(pkss_score_pair(src, 0, tgt, below, TRIM_AZ, PKSS_WIDE_KEEP, share,
                                           pkss_count_occupied(src, TRIM_CELLS)),
                           PKSS_HALF_PI_F, 0.0);
        tgt[4 * below + 3] = 1.0f; /* one more: the share is reached */
        assert_float_equal(pkss_score_pair(src, 0, tgt, at, TRIM_AZ, 1.0f, share,
                                           pkss_count_occupied(src, TRIM_CELLS)),
                           pkss_score_pair(src, 0, tgt, at, TRIM_AZ, 1.0f, 0.0f, TRIM_CELLS), 0.0);
        /* the share counts the source's occupied cells: a source that
         * occupies only the matched cells passes with as few pairs */
        tgt[4 * below + 3] = -1.0f;
        for (int c = below; c < TRIM_CELLS; ++c)
            src[4 * c + 3] = -1.0f;
        assert_true(pkss_score_pair(src, 0, tgt, below, TRIM_AZ, 1.0f, share,
                                    pkss_count_occupied(src, TRIM_CELLS)) < 1e-3f);
    }
}

/* pkss__solve_spd (the point-to-plane stage's 7 x 7 normal equations)
 * against LAPACKE_dposv on random SPD systems, conditioned from 1 to 1e10;
 * a matrix with a zero or negative pivot is refused. */
static void test_spd_solve(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 5)};
    double worst = 0.0;
    for (int trial = 0; trial < 2000; ++trial) {
        int n = 1 + trial % 7;
        double B[49], A[49], A2[49], b[7], x[7];
        for (int i = 0; i < n * n; ++i)
            B[i] = pkss_test_normal(&rng);
        /* A = B B^T + eps I, eps from 1 down to 1e-10 */
        double eps = pow(10.0, -10.0 * pkss_test_uniform(&rng));
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                double v = i == j ? eps : 0.0;
                for (int k = 0; k < n; ++k)
                    v += B[n * i + k] * B[n * j + k];
                A[n * i + j] = A2[n * i + j] = v;
            }
        for (int i = 0; i < n; ++i)
            b[i] = x[i] = pkss_test_normal(&rng);
        assert_int_equal(pkss__solve_spd(A, x, n), 1);
        assert_int_equal(LAPACKE_dposv(LAPACK_ROW_MAJOR, 'L', n, 1, A2, n, b, 1), 0);
        double nx = 0.0, dx = 0.0;
        for (int i = 0; i < n; ++i) {
            nx = fmax(nx, fabs(b[i]));
            dx = fmax(dx, fabs(x[i] - b[i]));
        }
        /* both are backward stable: the difference grows with cond(A) */
        worst = fmax(worst, dx / nx * eps);
    }
    printf("  SPD solve: max |x - x_lapack| / |x| times eps (cond(A) ~ 1 / eps) = %.3g\n", worst);
    assert_true(worst < 1e-11);
    double indefinite[4] = {1, 2, 2, 1}, zero[4] = {0, 0, 0, 1}, r[2] = {1, 1};
    assert_int_equal(pkss__solve_spd(indefinite, r, 2), 0);
    assert_int_equal(pkss__solve_spd(zero, r, 2), 0);
}

/* pkss__rotation_exp: a rotation (orthonormal, det +1) that keeps its axis
 * and turns by |w|, down to |w| = 1e-9 (the series branch) and up to pi. */
static void test_rotation_exp(void **state)
{
    (void)state;
    pkss_test_rng rng = {pkss_test_seed(PROGRAM, 6)};
    for (int trial = 0; trial < 1000; ++trial) {
        double w[3], R[9], Rw[3], Id[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        double th = trial < 100 ? pow(10.0, -9.0 + 8.0 * pkss_test_uniform(&rng))
                                : 3.14159265358979 * pkss_test_uniform(&rng);
        double nv = 0.0;
        for (int d = 0; d < 3; ++d) {
            w[d] = pkss_test_normal(&rng);
            nv += w[d] * w[d];
        }
        for (int d = 0; d < 3; ++d)
            w[d] *= th / sqrt(nv);
        pkss__rotation_exp(w, R);
        double RtR[9], Rt[9];
        pkss__mat3_transpose(R, Rt);
        pkss__mat3_mul(Rt, R, RtR);
        for (int i = 0; i < 9; ++i)
            assert_float_equal(RtR[i], Id[i], 1e-12);
        assert_float_equal(det3(R), 1.0, 1e-12);
        pkss__mat3_apply(R, w, Rw);
        for (int d = 0; d < 3; ++d)
            assert_float_equal(Rw[d], w[d], 1e-12);
        assert_float_equal(pkss__rotation_angle(R, Id), th, 1e-7);
        if (th < 1e-3) {
            /* first order: R x = x + w x x, to within th^2 */
            double x[3] = {1, 0, 0}, Rx[3];
            pkss__mat3_apply(R, x, Rx);
            assert_float_equal(Rx[1], w[2], th * th + 1e-15);
            assert_float_equal(Rx[2], -w[1], th * th + 1e-15);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_matrices),
        cmocka_unit_test(test_near_degenerate_matrices),
        cmocka_unit_test(test_double_svd_and_procrustes),
        cmocka_unit_test(test_one_pass_moments),
        cmocka_unit_test(test_trimmed_measure),
        cmocka_unit_test(test_trim_cache_equals_recomputing),
        cmocka_unit_test(test_source_coverage_guard),
        cmocka_unit_test(test_spd_solve),
        cmocka_unit_test(test_rotation_exp),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
