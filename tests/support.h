/* SPDX-License-Identifier: MIT
 * support.h -- helpers shared by the cmocka test programs: the shared data
 * folder, file loading, the OpenCL device check, a seeded RNG (seed
 * printed; PKSS_TEST_SEED overrides), random similarity transforms and
 * pose error metrics. */
#ifndef PKSS_TEST_SUPPORT_H
#define PKSS_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "pkss.h"

/* Full path of a file under ../shared/data (PKSS_DATA_DIR), or NULL when
 * the file is absent. The returned string is static (overwritten by the
 * next call). */
const char *pkss_test_data_path(const char *relative);

/* Skips the calling test, with the reason, when no OpenCL device is
 * listed. */
void pkss_test_need_device(void);

/* Loads a data file (any format pkss_io reads) into a malloc'd n x 3 array;
 * calls cmocka skip() with a clear message when the file is absent, and
 * returns NULL with the reader's message printed when it cannot be read
 * (the caller asserts on the result). */
double *pkss_test_load(const char *relative, size_t *n);
/* The same for a file of the repository's tests/data (always present). */
double *pkss_test_load_bundled(const char *name, size_t *n);

/* Reads the first 16 numbers of a text file (comment lines starting with
 * '#' skipped) as a row-major 4x4; after the line equal to `label` when
 * label is not NULL. Returns 0 on success. */
int pkss_test_read_matrix(const char *path, const char *label, double T[16]);

/* Seed for this test program: PKSS_TEST_SEED or `fallback`; printed. */
uint64_t pkss_test_seed(const char *program, uint64_t fallback);

typedef struct pkss_test_rng { uint64_t s; } pkss_test_rng;
uint64_t pkss_test_next(pkss_test_rng *r);
double pkss_test_uniform(pkss_test_rng *r);            /* [0, 1) */
double pkss_test_normal(pkss_test_rng *r);
void pkss_test_random_rotation(pkss_test_rng *r, double R[9]); /* Haar */

/* Random similarity of SPEC 7: rotation uniform on SO(3), scale
 * log-uniform in [0.5, 2], translation up to `max_t` in each direction. */
void pkss_test_random_similarity(pkss_test_rng *r, double max_t, double T[16]);

/* out = T * [in; 1] for n points (out may equal in). */
void pkss_test_apply(const double T[16], const double *in, size_t n, double *out);
/* C = A * B (4x4) and the inverse of a similarity. */
void pkss_test_mul4(const double A[16], const double B[16], double C[16]);
void pkss_test_inverse_similarity(const double T[16], double Ti[16]);

/* Decomposes a similarity into s, R. */
void pkss_test_decompose(const double T[16], double *s, double R[9]);
/* Pose errors of an estimate against ground truth: rotation (degrees),
 * scale (relative, |s/s_gt - 1|), translation (norm, in target units,
 * evaluated as the error of the mapped source centroid `at`). */
typedef struct pkss_test_err { double rot_deg, scale_rel, trans; } pkss_test_err;
pkss_test_err pkss_test_pose_error(const double T_est[16], const double T_gt[16],
                                   const double at[3]);

/* Diameter (max extent of the bounding box diagonal) and centroid. */
double pkss_test_diameter(const double *xyz, size_t n);
void pkss_test_centroid(const double *xyz, size_t n, double c[3]);

/* Shuffles the rows of an n x 3 array. */
void pkss_test_shuffle(pkss_test_rng *r, double *xyz, size_t n);

/* Two independent resamplings of one cloud (each point kept with
 * probability p, source first), the target mapped by a random similarity
 * T (pkss_test_random_similarity with the cloud's diameter): target =
 * T * source up to the sampling. Malloc'd arrays; NULL when out of memory. */
void pkss_test_similar_pair(pkss_test_rng *r, const double *xyz, size_t n, double p,
                            double **src, size_t *ns, double **tgt, size_t *nt,
                            double T[16]);

/* Index of the point with the largest coordinate `axis` (the smallest with
 * from_min; the first of ties). */
size_t pkss_test_extreme(const double *xyz, size_t n, int axis, int from_min);
/* A part of a cloud: `share` of its n points, those nearest point `centre`,
 * cut away; the rest, nearest first, in a malloc'd array of *n_part rows
 * (NULL when out of memory). */
double *pkss_test_cut_near(const double *xyz, size_t n, size_t centre, double share,
                           size_t *n_part);

/* Candidate `index` of ctx's last registration (pkss_context_candidate);
 * an all-zero pose if there is none. */
pkss_candidate pkss_test_candidate(const pkss_context *ctx, size_t index);

#endif
