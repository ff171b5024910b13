/* SPDX-License-Identifier: MIT
 * assess.h -- how far to trust a finished registration (assess.c):
 * alternatives, symmetry, confidence (docs/confidence.md).
 */
#ifndef PKSS_REFINE_ASSESS_H
#define PKSS_REFINE_ASSESS_H

#include "refine/icp.h"

/* The end of a registration as assess.c reads it (register.c fills it once
 * the winner and every candidate are final). Poses in ir are pre-shape
 * (source -> template); cand holds the same candidates as delivered. */
typedef struct pkss__assess_input {
    const pkss__icp_view *sv, *tv;  /* full views: source, template */
    const pkss__icp_view *svc, *tvc; /* coarse views (may be NULL) */
    double tgt_sigma;               /* template's RMS radius ... */
    const double *tgt_centroid;     /* ... and centroid, caller units */
    const pkss__icp_result *ir;     /* per candidate */
    const pkss_candidate *cand;     /* per candidate: stage, score */
    size_t n;
    int winner;
    int refine;                     /* refinement on: near ties polished */
} pkss__assess_input;

/* The confidence model's features (docs/design.md, "Confidence"). */
enum {
    PKSS__FEAT_FIT = 0,       /* winner's fit */
    PKSS__FEAT_OVERLAP = 1,   /* winner's overlap */
    PKSS__FEAT_MARGIN = 2,    /* fit - best fit in another basin that no
                                 symmetry explains (capped) */
    PKSS__FEAT_RMS = 3,       /* RMS in template spacings (capped) */
    PKSS__FEAT_ASYMMETRY = 4, /* |f_s - f_t| */
    PKSS__FEAT_COVER_MIN = 5, /* min(f_s, f_t) */
    PKSS__FEAT_SCORE = 6,     /* the winner's search score G, radians */
    PKSS__FEAT_REFINED = 7    /* 1 if the winner was fully refined */
};

/* Alternatives, symmetry (tested by turning the winner about the target's
 * principal axes) and confidence of a finished registration. Fails only as
 * the ICP does (cancelled, out of memory). */
pkss_status pkss__assess(const pkss__assess_input *in, pkss__assessment *out);
/* The logistic model on features x[PKSS__ASSESS_FEATURES]. */
double pkss__confidence(const double *x);
/* Copies the assessment into the result's fields. */
void pkss__assess_store(const pkss__assessment *a, pkss_result *res);

#endif
