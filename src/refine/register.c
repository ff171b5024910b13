/* SPDX-License-Identifier: MIT
 * register.c -- PKSS-Align end to end (Algorithm 1; docs/design.md): both
 * clouds onto the pre-shape space (preshape/), the global search over
 * rotations x centre offsets (search/), the refinement stages (stages.c),
 * a wide second search, starts from local shape, a shift search (from
 * other rotations too where the winner lies astray) and a slide search
 * where the winner shows a part, the winner's last steps on the template's
 * dense points, and the winner composed back into the caller's
 * coordinates.
 */
#include "refine/ahead.h"
#include "refine/assess.h"
#include "refine/stages.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Pre-shape pose -> caller coordinates: x_t = s R x_s + t with
 * s = sigma_t s' / sigma_s and t = sigma_t t' + c_t - s R c_s. */
static void compose(const pkss_cloud *src, const pkss_cloud *tgt,
                    const pkss__pose *P, double *T16, double *s_out,
                    double *R_out, double *t_out)
{
    double s = tgt->sigma * P->s / src->sigma;
    double Rc[3];
    pkss__mat3_apply(P->R, src->centroid, Rc);
    double t[3];
    for (int d = 0; d < 3; ++d)
        t[d] = tgt->sigma * P->t[d] + tgt->centroid[d] - s * Rc[d];
    memset(T16, 0, 16 * sizeof(double));
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            T16[4 * r + c] = s * P->R[3 * r + c];
        T16[4 * r + 3] = t[r];
    }
    T16[15] = 1.0;
    if (s_out) *s_out = s;
    if (R_out) memcpy(R_out, P->R, 9 * sizeof(double));
    if (t_out) memcpy(t_out, t, 3 * sizeof(double));
}

static pkss_status check_result_arg(pkss_context *ctx, pkss_result *result)
{
    PKSS_RETURN_IF(!result, ctx, PKSS_ERR_NULL_ARGUMENT, "result is NULL");
    PKSS_RETURN_IF(result->struct_size == 0, ctx, PKSS_ERR_INVALID_ARGUMENT,
                   "result->struct_size is 0: call pkss_result_init(&result, sizeof result) first");
    PKSS_RETURN_IF(result->struct_size < PKSS_RESULT_MIN_SIZE, ctx,
                   PKSS_ERR_INVALID_ARGUMENT,
                   "result->struct_size %zu is smaller than pkss_result 1.0 (%zu): "
                   "call pkss_result_init(&result, sizeof result)",
                   result->struct_size, (size_t)PKSS_RESULT_MIN_SIZE);
    return PKSS_OK;
}

/* A registration's whole outcome, library-sized: the caller receives the
 * fields its struct_size covers, the context keeps the candidates. */
typedef struct outcome {
    pkss_result res;
    pkss_candidate cand[PKSS_MAX_CANDIDATES];
    pkss__assessment assess;
} outcome;

static void deliver(pkss_context *ctx, pkss_result *dst, const outcome *o)
{
    pkss__deliver_result(dst, &o->res);
    memcpy(ctx->candidates, o->cand, sizeof o->cand);
    ctx->n_candidates = o->res.n_candidates;
    ctx->assess = o->assess;
}

/* A failed call: no pose in the result, no candidates in the context. */
static void clear_result(pkss_context *ctx, pkss_result *result)
{
    if (ctx)
        ctx->n_candidates = 0;
    if (result && result->struct_size >= PKSS_RESULT_MIN_SIZE)
        pkss__clear_result(result);
}

static pkss_status fail_oom(pkss_context *ctx)
{
    return pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY,
                      "out of memory during the search/refinement");
}

/* A step of the search or refinement failed with st: cancelled, or out of
 * memory (their only failures). */
static pkss_status fail_step(pkss_context *ctx, pkss_status st)
{
    return st == PKSS_ERR_CANCELLED ? pkss__cancel_fail(ctx) : fail_oom(ctx);
}

/* The full and coarse views of both clouds, sharing the call's run, each
 * with a nearest-neighbour field that the runs of every candidate share
 * (without memory for one, the view's tree answers alone). */
static void set_views(pkss_context *ctx, const pkss_cloud *src,
                      const pkss_cloud *tgt, pkss__views *v)
{
    pkss__icp_view_full(src, &v->sv);
    pkss__icp_view_full(tgt, &v->tv);
    pkss__icp_view_coarse(src, &v->svc);
    pkss__icp_view_coarse(tgt, &v->tvc);
    pkss__icp_view *all[4] = {&v->sv, &v->tv, &v->svc, &v->tvc};
    for (int i = 0; i < 4; ++i) {
        all[i]->run = ctx->run;
        all[i]->field = pkss__nn_field_new(all[i]->tree, all[i]->spacing);
    }
}

static void free_views(pkss__views *v)
{
    pkss__nn_field_free(v->sv.field);
    pkss__nn_field_free(v->tv.field);
    pkss__nn_field_free(v->svc.field);
    pkss__nn_field_free(v->tvc.field);
}

/* One global search (SPEC 5) over ss's rotations x offsets: its scores and
 * the best top_k candidates appended to rs (*kept of them). */
static pkss_status search_stage(pkss_context *ctx, const pkss__search_setup *ss,
                                size_t top_k, pkss__refinement *rs, size_t *kept)
{
    const size_t total = ss->rot.n_rotations * (size_t)ss->n_offsets;
    pkss_status st = PKSS_ERR_OUT_OF_MEMORY;
    float *scores = pkss__malloc(total * sizeof(float));
    float *gc = pkss__malloc(total * sizeof(float));
    float *gf = pkss__malloc(total * sizeof(float));
    *kept = 0;
    if (!scores || !gc || !gf)
        goto fail;
    if ((st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_SEARCH, 0, 1)) != PKSS_OK)
        goto fail;
    if (ctx->backend_in_use == PKSS_BACKEND_OPENCL)
        st = pkss__search_cl(ctx, &ss->in, scores, gc, gf);
    else
        st = pkss__search_ref(ctx, &ss->in, scores, gc, gf);
    if (st != PKSS_OK)
        goto done; /* the backend set its own detail */
    if ((st = pkss__checkpoint(ctx->run, PKSS_PROGRESS_SEARCH, 1, 1)) != PKSS_OK)
        goto fail;
    *kept = pkss__select_top_k(scores, gc, ctx->params.use_features ? gf : NULL,
                               &ss->rot, (size_t)ss->n_offsets, top_k,
                               rs->picks + rs->n);
    if (*kept == SIZE_MAX) {
        *kept = 0;
        st = PKSS_ERR_OUT_OF_MEMORY;
        goto fail;
    }
    rs->n += *kept;
    goto done;
fail:
    st = fail_step(ctx, st);
done:
    pkss__free(scores);
    pkss__free(gc);
    pkss__free(gf);
    return st;
}

/* The refinement of one search's candidates [base, base+kept) (SPEC 6):
 * every candidate's coarse level, full runs for the chosen, the rest
 * scored on all points. lead_in is the overlap an earlier search's winner
 * reached before its polish (0 for the first): the rigid stages are judged
 * against it, the scale stages only against this search's own leader, as a
 * part the wide grid places starts its scale stage far off. */
static pkss_status refine_stage(pkss_context *ctx, const pkss__search_setup *ss,
                                const pkss_cloud *src, const pkss_cloud *tgt,
                                pkss__refinement *rs, size_t base, size_t kept,
                                double lead_in)
{
    int scored[PKSS_MAX_CANDIDATES];
    PKSS_FORWARD(pkss__checkpoint(ctx->run, PKSS_PROGRESS_REFINE, 0, (uint32_t)kept));
    PKSS_FORWARD(pkss__stage_coarse_levels(rs, ss, src, tgt, base, kept,
                                           ctx->params.refine, scored));
    if (!ctx->params.refine)
        return PKSS_OK;
    return pkss__stage_full_runs(rs, base, kept, lead_in, scored);
}

/* One search and the refinement of its candidates, timed; a warm-up under
 * way (or NULL) ends with the search. */
static pkss_status search_pass(pkss_context *ctx, const pkss_cloud *src,
                               const pkss_cloud *tgt,
                               const pkss__search_setup *ss, size_t top_k,
                               double lead_in, pkss__refinement *rs, pkss__warmup *warm)
{
    const size_t base = rs->n;
    double t0 = pkss__now();
    size_t kept;
    pkss_status searched = search_stage(ctx, ss, top_k, rs, &kept);
    pkss__warm_end(warm);
    PKSS_FORWARD(searched);
    double t1 = pkss__now();
    rs->search_seconds += t1 - t0;
    if (kept == 0)
        return PKSS_OK;
    pkss_status st = refine_stage(ctx, ss, src, tgt, rs, base, kept, lead_in);
    if (st != PKSS_OK)
        return fail_step(ctx, st);
    rs->refine_seconds += pkss__now() - t1;
    return PKSS_OK;
}

static pkss_status no_consensus(pkss_context *ctx)
{
    return pkss__fail(ctx, PKSS_ERR_NO_CONSENSUS,
                      "no (rotation, offset) candidate matched enough cells "
                      "(>= %d and >= %.0f%% of the template's): the clouds "
                      "share too little shape",
                      PKSS_MIN_MATCHED, 100.0 * PKSS_MIN_COVERAGE);
}

/* The second search, on the wide offset grid (twice the step, SPEC 5
 * deviation), when winner w is a part not yet placed (pkss__part_unplaced):
 * its centroid may lie beyond the paper's grid. It
 * only adds candidates, which must beat the first search's winner, and
 * scores with the trimmed G (PKSS_WIDE_KEEP). Returns the winner after it
 * in *w and counts its evaluations. */
static pkss_status wide_search_stage(pkss_context *ctx, const pkss_cloud *src,
                                     const pkss_cloud *tgt,
                                     pkss__search_setup *ss,
                                     pkss__refinement *rs, int *w,
                                     uint64_t *evaluations, pkss__local_job *local)
{
    const uint64_t n_eval = ss->rot.n_rotations * (uint64_t)ss->n_offsets;
    const pkss__icp_result *win = &rs->ir[*w];
    size_t room = PKSS_MAX_CANDIDATES - rs->n;
    size_t k2 = (size_t)ctx->params.top_k < room ? (size_t)ctx->params.top_k : room;
    if (!(ctx->params.refine && ss->n_offsets > 1 && k2 > 0 &&
          pkss__part_unplaced(rs, *w)))
        return PKSS_OK;
    double t0 = pkss__now();
    if (pkss__search_setup_widen(&ctx->params, tgt, ss) != PKSS_OK)
        return fail_oom(ctx);
    rs->search_seconds += pkss__now() - t0;
    pkss__local_begin(pkss__run_helper(ctx->run), &rs->v, (uint64_t)ctx->params.seed, local);
    PKSS_FORWARD(search_pass(ctx, src, tgt, ss, k2, win->overlap_unpolished, rs, NULL));
    *evaluations += n_eval;
    *w = pkss__pick_winner(rs);
    return PKSS_OK;
}

/* Candidates from local shape (stages.c: pkss__stage_local) when winner w
 * is still a part not placed after both searches (pkss__part_unplaced):
 * both clouds are parts, which the searches' centroid-based cells
 * misjudge. They must beat w's fit. */
static pkss_status local_stage(pkss_context *ctx, const pkss__search_setup *ss,
                               pkss__refinement *rs, int *w, pkss__local_job *local)
{
    const pkss__icp_result *win = &rs->ir[*w];
    if (!(ctx->params.refine && rs->n < PKSS_MAX_CANDIDATES && pkss__part_unplaced(rs, *w)))
        return PKSS_OK;
    double t0 = pkss__now();
    size_t added = 0;
    pkss_status st = pkss__local_take(&rs->v, (uint64_t)ctx->params.seed, local);
    if (st == PKSS_OK)
        st = pkss__stage_local(rs, ss, local->starts, local->n, win->overlap_unpolished,
                               &added);
    if (st != PKSS_OK)
        return fail_step(ctx, st);
    if (added)
        *w = pkss__pick_winner(rs);
    rs->refine_seconds += pkss__now() - t0;
    return PKSS_OK;
}

/* A stage that appends candidates around the winner (stages.h: the shift
 * search, and the one from other rotations), then the winner again, timed. */
typedef pkss_status (*adding_stage)(pkss__refinement *rs, int w, size_t *added);

static pkss_status add_and_pick(pkss_context *ctx, pkss__refinement *rs, int *w,
                                adding_stage stage)
{
    if (!ctx->params.refine)
        return PKSS_OK;
    double t0 = pkss__now();
    size_t added = 0;
    pkss_status st = stage(rs, *w, &added);
    if (st != PKSS_OK)
        return fail_step(ctx, st);
    if (added)
        *w = pkss__pick_winner(rs);
    rs->refine_seconds += pkss__now() - t0;
    return PKSS_OK;
}

/* The slide search on the winner, timed. */
static pkss_status slide_stage(pkss_context *ctx, pkss__refinement *rs, int w)
{
    if (!ctx->params.refine)
        return PKSS_OK;
    double t0 = pkss__now();
    pkss_status st = pkss__stage_slide(rs, w);
    if (st != PKSS_OK)
        return fail_step(ctx, st);
    rs->refine_seconds += pkss__now() - t0;
    return PKSS_OK;
}

/* The winner's last steps on the dense points (fine.c): a sample of the
 * source's as large as its resampled view, all of the template's; its
 * scores taken again where they end; timed. */
static pkss_status fine_stage(pkss_context *ctx, const pkss_cloud *src,
                              const pkss_cloud *tgt, pkss__refinement *rs, int w)
{
    if (!ctx->params.refine)
        return PKSS_OK;
    double t0 = pkss__now();
    pkss__icp_view sd, td;
    pkss__icp_view_dense(src, src->m, &sd);
    pkss__icp_view_dense(tgt, tgt->m_dense, &td);
    sd.run = td.run = ctx->run;
    pkss_status st = pkss__icp_fine(&rs->v.sv, &rs->v.tv, &sd, &td, &rs->ir[w]);
    if (st != PKSS_OK)
        return fail_step(ctx, st);
    rs->refine_seconds += pkss__now() - t0;
    return PKSS_OK;
}

/* Candidate counts after each stage that adds some: which search a
 * candidate came from (pkss_candidate.search). */
typedef struct stage_ends {
    size_t first, searched, local, shifted, reshifted;
} stage_ends;

static uint32_t search_of(const stage_ends *e, size_t c)
{
    return c < e->first       ? 0u
           : c < e->searched  ? 1u
           : c < e->local     ? 3u
           : c < e->shifted   ? 2u
           : c < e->reshifted ? 4u
                              : 5u;
}

/* The candidates and the winner in caller coordinates (pkss_result). */
static void report(const pkss_cloud *src, const pkss_cloud *tgt,
                   const pkss__refinement *rs, const stage_ends *ends, int best,
                   outcome *out)
{
    pkss_result *res = &out->res;
    for (size_t c = 0; c < rs->n; ++c) {
        const pkss__pick *pk = &rs->picks[c];
        pkss_candidate *cand = &out->cand[c];
        cand->struct_size = sizeof *cand;
        compose(src, tgt, &rs->ir[c].pose, cand->T_target_source,
                &cand->scale, NULL, NULL);
        cand->score = pk->score;
        cand->score_contour = pk->g_contour;
        cand->score_feature = pk->g_feature;
        cand->rms = rs->ir[c].rms * tgt->sigma;
        cand->overlap = rs->ir[c].overlap;
        cand->fit = rs->ir[c].fit;
        cand->stage = rs->stage[c];
        cand->rotation_index = pk->rotation;
        cand->offset_index = pk->offset;
        cand->search = search_of(ends, c);
    }
    compose(src, tgt, &rs->ir[best].pose, res->T_target_source, &res->scale,
            res->rotation, res->translation);
    res->n_candidates = (uint32_t)rs->n;
    res->winner = (uint32_t)best;
    res->score = out->cand[best].score;
    res->rms = out->cand[best].rms;
    res->overlap = out->cand[best].overlap;
    res->fit = out->cand[best].fit;
    res->timings.search = rs->search_seconds;
    res->timings.refine = rs->refine_seconds;
}

/* Algorithm 1 after pre-processing: the search set-up, the first search
 * and its refinement, the wide second search, the local-feature starts,
 * the shift searches (the winner's, from other rotations, at other
 * scales), the slide search, the winner's last steps, and the report. */
static pkss_status run(pkss_context *ctx, const pkss_cloud *src,
                       const pkss_cloud *tgt, outcome *out)
{
    pkss_status st = PKSS_OK;
    double t0 = pkss__now();
    pkss__warmup warm = {.ticket = 0};
    pkss__local_job local = {.ticket = 0, .ready = 0};
    pkss__search_setup *ss = pkss__calloc(1, sizeof *ss);
    pkss__refinement *rs = pkss__calloc(1, sizeof *rs);
    if (!ss || !rs) {
        st = pkss__fail(ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
        goto done;
    }
    if (pkss__search_setup_build(&ctx->params, src, tgt, ss) != PKSS_OK) {
        st = fail_oom(ctx);
        goto done;
    }
    rs->search_seconds = pkss__now() - t0;
    set_views(ctx, src, tgt, &rs->v);
    pkss__warm_begin(pkss__run_helper(ctx->run), &rs->v, &warm);
    out->res.n_evaluations = ss->rot.n_rotations * (uint64_t)ss->n_offsets;
    if ((st = search_pass(ctx, src, tgt, ss, (size_t)ctx->params.top_k, 0.0, rs, &warm)) !=
        PKSS_OK)
        goto done;
    if (rs->n == 0) {
        st = no_consensus(ctx);
        goto done;
    }
    const size_t n_first = rs->n;
    int best = pkss__pick_winner(rs);
    if ((st = wide_search_stage(ctx, src, tgt, ss, rs, &best,
                                &out->res.n_evaluations, &local)) != PKSS_OK)
        goto done;
    const size_t n_searched = rs->n;
    if ((st = local_stage(ctx, ss, rs, &best, &local)) != PKSS_OK)
        goto done;
    const size_t n_local = rs->n;
    if ((st = add_and_pick(ctx, rs, &best, pkss__stage_shift)) != PKSS_OK)
        goto done;
    const size_t n_shifted = rs->n;
    if ((st = add_and_pick(ctx, rs, &best, pkss__stage_reshift)) != PKSS_OK)
        goto done;
    const size_t n_reshifted = rs->n;
    if ((st = add_and_pick(ctx, rs, &best, pkss__stage_rescale)) != PKSS_OK)
        goto done;
    if ((st = slide_stage(ctx, rs, best)) != PKSS_OK)
        goto done;
    if ((st = fine_stage(ctx, src, tgt, rs, best)) != PKSS_OK)
        goto done;
    out->res.n_rotations = (uint32_t)ss->rot.n_rotations;
    out->res.n_offsets = (uint32_t)ss->n_offsets;
    const stage_ends ends = {n_first, n_searched, n_local, n_shifted, n_reshifted};
    report(src, tgt, rs, &ends, best, out);
    /* How far to trust it: alternatives, symmetry, confidence (assess.c). */
    pkss__assess_input ai = {&rs->v.sv, &rs->v.tv, &rs->v.svc, &rs->v.tvc, tgt->sigma,
                             tgt->centroid, rs->ir, out->cand, rs->n, best,
                             ctx->params.refine};
    if ((st = pkss__assess(&ai, &out->assess)) != PKSS_OK) {
        st = fail_step(ctx, st);
        goto done;
    }
    pkss__assess_store(&out->assess, &out->res);
done:
    pkss__warm_end(&warm);
    pkss__local_wait(&local);
    pkss__search_setup_free(ss);
    pkss__free(ss);
    if (rs)
        free_views(&rs->v);
    pkss__free(rs);
    return st;
}

/* Entering PKSS_PROGRESS_DEVICE, when the device is not prepared yet. */
static pkss_status device_checkpoint(pkss_context *ctx)
{
    if (ctx->prepared)
        return PKSS_OK;
    return pkss__checkpoint(ctx->run, PKSS_PROGRESS_DEVICE, 0, 1) == PKSS_OK
               ? PKSS_OK : pkss__cancel_fail(ctx);
}

/* The device, if not prepared yet, timed (after device_checkpoint). */
static pkss_status prepare_device(pkss_context *ctx, outcome *out)
{
    if (ctx->prepared)
        return PKSS_OK;
    double t0 = pkss__now();
    pkss_status st = pkss_context_prepare(ctx);
    out->res.prepare_seconds += pkss__now() - t0;
    return st;
}

/* The device once the clouds are built (their build overlapped the
 * driver's start-up). A device failure is reported before an input
 * failure, as when the device was opened first. */
static pkss_status prepare_after_build(pkss_context *ctx, outcome *out,
                                       pkss_status built)
{
    char detail[PKSS_DETAIL_SIZE];
    memcpy(detail, ctx->detail, sizeof detail);
    pkss_status st = prepare_device(ctx, out);
    if (st != PKSS_OK || built == PKSS_OK)
        return st;
    memcpy(ctx->detail, detail, sizeof detail);
    return built;
}

/* Runs the search and refinement into a library-sized result; the caller
 * delivers it. */
static pkss_status register_into(pkss_context *ctx, const pkss_cloud *source,
                                 const pkss_cloud *target, outcome *out)
{
    double t0 = pkss__now();
    pkss_status st = device_checkpoint(ctx);
    if (st == PKSS_OK)
        st = prepare_device(ctx, out);
    if (st != PKSS_OK)
        return st;
    pkss_result *res = &out->res;
    res->struct_size = sizeof *res;
    res->source_counts = source->counts;
    res->target_counts = target->counts;
    res->backend = ctx->backend_in_use;
    snprintf(res->device, sizeof res->device, "%s", ctx->device_name);
    if (ctx->backend_in_use == PKSS_BACKEND_REFERENCE && ctx->fallback_note[0]) {
        res->flags |= PKSS_FLAG_FELL_BACK;
        snprintf(res->note, sizeof res->note, "%s", ctx->fallback_note);
    }
    st = run(ctx, source, target, out);
    res->timings.total = pkss__now() - t0;
    return st;
}

/* The checks every registration entry point starts with; a failed call
 * leaves no pose in the result and no candidates in the context. */
static pkss_status begin_call(pkss_context *ctx, pkss_result *result)
{
    if (!ctx) {
        clear_result(NULL, result);
        return PKSS_ERR_NULL_ARGUMENT;
    }
    pkss__clear_error(ctx);
    clear_result(ctx, result);
    return check_result_arg(ctx, result);
}

pkss_status pkss_register_clouds(pkss_context *ctx, const pkss_cloud *source,
                                 const pkss_cloud *target, pkss_result *result)
{
    PKSS_FORWARD(begin_call(ctx, result));
    PKSS_RETURN_IF(!source, ctx, PKSS_ERR_NULL_ARGUMENT, "source cloud is NULL");
    PKSS_RETURN_IF(!target, ctx, PKSS_ERR_NULL_ARGUMENT, "target cloud is NULL");
    outcome *out = pkss__calloc(1, sizeof *out);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    pkss__run run_state;
    pkss__run_begin(ctx, &run_state);
    pkss_status st = register_into(ctx, source, target, out);
    if (st == PKSS_OK)
        deliver(ctx, result, out);
    pkss__checkpoint(ctx->run, PKSS_PROGRESS_DONE, 1, 1);
    pkss__run_end(ctx);
    pkss__free(out);
    return st;
}

pkss_status pkss_register(pkss_context *ctx, const double *source,
                          size_t n_source, const double *target,
                          size_t n_target, pkss_result *result)
{
    PKSS_FORWARD(begin_call(ctx, result));
    double t0 = pkss__now();
    pkss_cloud *src = NULL, *tgt = NULL;
    outcome *out = pkss__calloc(1, sizeof *out);
    PKSS_RETURN_IF(!out, ctx, PKSS_ERR_OUT_OF_MEMORY, "out of memory");
    pkss__run run_state;
    pkss__run_begin(ctx, &run_state);
    /* the driver starts up while the clouds are built (pkss__cl_warmup) */
    pkss_status st = device_checkpoint(ctx);
    pkss__cl_warmup warm = {.started = 0};
    if (st == PKSS_OK)
        pkss__cl_warmup_begin(ctx, &warm);
    double tb = pkss__now();
    if (st == PKSS_OK)
        st = pkss__cloud_build_pair(ctx, source, n_source, target, n_target, &src, &tgt);
    double tw = pkss__now(), build_wall = tw - tb;
    if (warm.started) {
        pkss__cl_warmup_end(&warm);
        out->res.prepare_seconds += pkss__now() - tw;
    }
    if (st != PKSS_ERR_CANCELLED)
        st = prepare_after_build(ctx, out, st);
    if (st == PKSS_OK)
        st = register_into(ctx, src, tgt, out);
    if (st == PKSS_OK) {
        /* the two clouds ran concurrently: report wall-clock shares */
        pkss_result *res = &out->res;
        double v = src->validate_seconds > tgt->validate_seconds
                       ? src->validate_seconds : tgt->validate_seconds;
        res->timings.validate = v;
        res->timings.preprocess = build_wall - v;
        res->timings.total = pkss__now() - t0;
        deliver(ctx, result, out);
    }
    pkss__checkpoint(ctx->run, PKSS_PROGRESS_DONE, 1, 1);
    pkss__run_end(ctx);
    pkss__free(out);
    pkss_cloud_destroy(src);
    pkss_cloud_destroy(tgt);
    return st;
}
