/* SPDX-License-Identifier: MIT
 * eval_partial.c -- the accuracy harness behind the SPEC 6 refinement
 * choices: objects from ../shared/data with 30-50 % cut away (the points
 * nearest a random point removed) under random similarities, and real
 * partial scan pairs with ground truth under a random similarity on top.
 * Prints failures (or every case with -v) and the strict success count
 * (rotation < 5 deg, scale < 2 %, translation < 2 % of the diameter).
 *
 *   eval_partial [all|cut|real] [-v]      BACKEND=1 for the C reference
 */
#include "support.h"
#include "pkss_io.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
static int strict_ok, strict_n; static double total_time;
static void run(const char *label, double *src, size_t ns, double *tgt, size_t nt, const double T[16], int verbose) {
  pkss_context *ctx; pkss_context_create(&ctx);
  const char *b = getenv("BACKEND"); if (b) pkss_context_set_int(ctx, PKSS_PARAM_BACKEND, atoi(b));
  pkss_result r; pkss_result_init(&r, sizeof r);
  pkss_status st = pkss_register(ctx, src, ns, tgt, nt, &r);
  double at[3]; pkss_test_centroid(src, ns, at);
  pkss_test_err e = pkss_test_pose_error(r.T_target_source, T, at);
  double d = pkss_test_diameter(tgt, nt);
  int ok = st == PKSS_OK && e.rot_deg < 5 && e.scale_rel < 0.02 && e.trans / d < 0.02;
  /* best candidate */
  double bc = 999; int bci = -1;
  for (unsigned c = 0; c < r.n_candidates; ++c) { pkss_test_err ec = pkss_test_pose_error(pkss_test_candidate(ctx, c).T_target_source, T, at); if (ec.rot_deg < bc) { bc = ec.rot_deg; bci = c; } }
  strict_ok += ok; strict_n++; total_time += r.timings.total;
  if (verbose || !ok) printf("%-40s %s rot %7.2f sc %6.2f%% tr %6.2f%% ov %.3f win %u bestcand %d (%.1f deg, ov %.3f s %.3f) %.2fs\n", label, ok ? "ok  " : "FAIL", e.rot_deg, 100*e.scale_rel, 100*e.trans/d, r.overlap, r.winner, bci, bc, bci>=0?pkss_test_candidate(ctx, bci).overlap:0, bci>=0?pkss_test_candidate(ctx, bci).scale:0, r.timings.total);
  pkss_context_destroy(ctx);
}
static int cmp_double(const void *a, const void *b) { double x=*(const double*)a, y=*(const double*)b; return (x>y)-(x<y); }
static double *cut(pkss_test_rng *rng, const double *x, size_t n, double frac, size_t *nout) {
  size_t c = pkss_test_next(rng) % n; double *d2 = malloc(n * sizeof(double));
  for (size_t i = 0; i < n; ++i) { double a=x[3*i]-x[3*c], b=x[3*i+1]-x[3*c+1], e=x[3*i+2]-x[3*c+2]; d2[i]=a*a+b*b+e*e; }
  double *s = malloc(n*sizeof(double)); memcpy(s, d2, n*sizeof(double));
  /* threshold = frac quantile */
  size_t k = (size_t)(frac * n);
  qsort(s, n, sizeof(double), cmp_double); double th = s[k];
  double *o = malloc(n*3*sizeof(double)); size_t m = 0;
  for (size_t i = 0; i < n; ++i) if (d2[i] > th) { memcpy(o+3*m, x+3*i, 24); m++; }
  free(d2); free(s); *nout = m; return o;
}
static double *loadp(const char *rel, size_t *n) { const char *p = pkss_test_data_path(rel); double *x = NULL; char err[256];
  if (!p || pkss_read_points(p, PKSS_FORMAT_AUTO, &x, n, err, sizeof err) != PKSS_OK) { printf("cannot load %s from the shared data folder\n", rel); exit(77);} return x; }
static void inv4(const double T[16], double I[16]) { /* rigid or similarity inverse */ pkss_test_inverse_similarity(T, I); }
static void pair(const char *a, const char *b, const char *gtfile, const char *la, const char *lb, int seeds, int verbose) {
  /* GT: p_common = T_X * p_X ; T_target_source (B->A) = inv(T_A) T_B  -- source = B, target = A */
  size_t na, nb; double *A = loadp(a, &na), *B = loadp(b, &nb);
  double TA[16], TB[16], Ti[16], G[16];
  if (la) { pkss_test_read_matrix(pkss_test_data_path(gtfile), la, TA); pkss_test_read_matrix(pkss_test_data_path(gtfile), lb, TB); inv4(TA, Ti); pkss_test_mul4(Ti, TB, G); }
  else pkss_test_read_matrix(pkss_test_data_path(gtfile), NULL, G);
  double d = pkss_test_diameter(A, na);
  pkss_test_rng rng = {777};
  for (int s = 0; s < seeds; ++s) {
    double S[16], GG[16]; pkss_test_random_similarity(&rng, d, S);
    double *At = malloc(na*24); pkss_test_apply(S, A, na, At); pkss_test_mul4(S, G, GG);
    char label[200]; snprintf(label, sizeof label, "%s<-%s #%d", strrchr(a,'/')+1, strrchr(b,'/')+1, s);
    run(label, B, nb, At, na, GG, verbose); free(At);
  }
  free(A); free(B);
}
int main(int argc, char **argv) {
  int verbose = argc > 2; const char *which = argc > 1 ? argv[1] : "all";
  if (!strcmp(which, "all") || !strcmp(which, "cut")) {
    const char *objs[] = {"stanford_bunny/reconstruction/bun_zipper_res2.ply","stanford_dragon_stand/converted/dragonStandRight_0.ply","modelnet40_pkss/airplane_0001_t.ply","uwa_opencv/parasaurolophus_6700.ply"};
    for (int o = 0; o < 4; ++o) { size_t n; double *x = loadp(objs[o], &n); double d = pkss_test_diameter(x, n); pkss_test_rng rng = {1234 + o};
      for (int s = 0; s < 8; ++s) { double frac = 0.3 + 0.2 * pkss_test_uniform(&rng); size_t m; double *src = cut(&rng, x, n, frac, &m);
        double T[16]; pkss_test_random_similarity(&rng, d, T); double *t = malloc(n*24); pkss_test_apply(T, x, n, t);
        char label[200]; snprintf(label, sizeof label, "%s cut%.0f%% #%d", strrchr(objs[o],'/')+1, 100*frac, s);
        run(label, src, m, t, n, T, verbose); free(src); free(t); }
      free(x); }
    printf("CUT: %d/%d strict, mean time %.2f\n", strict_ok, strict_n, total_time/strict_n); strict_ok = strict_n = 0; total_time = 0;
  }
  if (!strcmp(which, "all") || !strcmp(which, "real")) {
    const char *g = "stanford_bunny/gt_poses_4x4.txt";
    pair("stanford_bunny/converted/bun000.ply","stanford_bunny/converted/bun045.ply",g,"bun000.ply","bun045.ply",2,verbose);
    pair("stanford_bunny/converted/bun000.ply","stanford_bunny/converted/bun315.ply",g,"bun000.ply","bun315.ply",2,verbose);
    pair("stanford_bunny/converted/bun045.ply","stanford_bunny/converted/bun090.ply",g,"bun045.ply","bun090.ply",2,verbose);
    pair("stanford_bunny/converted/bun270.ply","stanford_bunny/converted/bun315.ply",g,"bun270.ply","bun315.ply",2,verbose);
    pair("stanford_bunny/converted/bun000.ply","stanford_bunny/converted/chin.ply",g,"bun000.ply","chin.ply",2,verbose);
    pair("stanford_bunny/converted/bun000.ply","stanford_bunny/converted/top2.ply",g,"bun000.ply","top2.ply",2,verbose);
    const char *gd = "stanford_dragon_stand/gt_poses_4x4.txt";
    pair("stanford_dragon_stand/converted/dragonStandRight_0.ply","stanford_dragon_stand/converted/dragonStandRight_24.ply",gd,"dragonStandRight_0.ply","dragonStandRight_24.ply",2,verbose);
    pair("stanford_dragon_stand/converted/dragonStandRight_24.ply","stanford_dragon_stand/converted/dragonStandRight_48.ply",gd,"dragonStandRight_24.ply","dragonStandRight_48.ply",2,verbose);
    pair("stanford_dragon_stand/converted/dragonStandRight_48.ply","stanford_dragon_stand/converted/dragonStandRight_72.ply",gd,"dragonStandRight_48.ply","dragonStandRight_72.ply",2,verbose);
    pair("3dmatch/7-scenes-redkitchen/cloud_bin_0.ply","3dmatch/7-scenes-redkitchen/cloud_bin_4.ply","3dmatch/7-scenes-redkitchen/pair_0_4_T.txt",NULL,NULL,2,verbose);
    pair("3dmatch/geotransformer_demo/converted/ref.ply","3dmatch/geotransformer_demo/converted/src.ply","3dmatch/geotransformer_demo/gt.txt",NULL,NULL,2,verbose);
    pair("lidar_small_gicp/target.ply","lidar_small_gicp/source.ply","lidar_small_gicp/T_target_source.txt",NULL,NULL,2,verbose);
    pair("libpointmatcher/car_cloud400.csv","libpointmatcher/car_cloud401.csv","libpointmatcher/car_cloud401_to_400_T.txt",NULL,NULL,2,verbose);
    printf("REAL: %d/%d strict, mean time %.2f\n", strict_ok, strict_n, total_time/strict_n);
  }
  return 0;
}
