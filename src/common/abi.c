/* SPDX-License-Identifier: MIT
 * abi.c -- the growth rule of the public structs (docs/compatibility.md):
 * the library fills only the whole fields that the caller's struct_size
 * covers, so a caller built against an older 1.x header is never written
 * past, and never receives half a field. */
#include "pkss_internal.h"

#include <string.h>

typedef struct field {
    size_t offset, size;
} field;

#define F(type, name) {offsetof(type, name), sizeof(((type *)0)->name)}

static const field RESULT_FIELDS[] = {
    F(pkss_result, T_target_source), F(pkss_result, scale),
    F(pkss_result, rotation),        F(pkss_result, translation),
    F(pkss_result, score),           F(pkss_result, rms),
    F(pkss_result, overlap),         F(pkss_result, fit),
    F(pkss_result, winner),          F(pkss_result, n_candidates),
    F(pkss_result, n_rotations),     F(pkss_result, n_offsets),
    F(pkss_result, n_evaluations),   F(pkss_result, source_counts),
    F(pkss_result, target_counts),   F(pkss_result, timings),
    F(pkss_result, backend),         F(pkss_result, flags),
    F(pkss_result, device),          F(pkss_result, note),
    F(pkss_result, prepare_seconds), F(pkss_result, confidence),
    F(pkss_result, ambiguous),       F(pkss_result, n_alternatives),
    F(pkss_result, symmetry),        F(pkss_result, symmetry_order),
    F(pkss_result, symmetry_axis),   F(pkss_result, symmetry_center),
};

static const field ALTERNATIVE_FIELDS[] = {
    F(pkss_alternative, T_target_source), F(pkss_alternative, fit),
    F(pkss_alternative, overlap),         F(pkss_alternative, angle_degrees),
    F(pkss_alternative, axis),            F(pkss_alternative, center),
    F(pkss_alternative, candidate),
};

static const field CANDIDATE_FIELDS[] = {
    F(pkss_candidate, T_target_source), F(pkss_candidate, scale),
    F(pkss_candidate, score),           F(pkss_candidate, score_contour),
    F(pkss_candidate, score_feature),   F(pkss_candidate, rms),
    F(pkss_candidate, overlap),         F(pkss_candidate, fit),
    F(pkss_candidate, stage),           F(pkss_candidate, rotation_index),
    F(pkss_candidate, offset_index),    F(pkss_candidate, search),
};

static const field PARAM_INFO_FIELDS[] = {
    F(pkss_param_info, id),          F(pkss_param_info, type),
    F(pkss_param_info, name),        F(pkss_param_info, lower),
    F(pkss_param_info, upper),       F(pkss_param_info, default_value),
    F(pkss_param_info, unit),        F(pkss_param_info, choices),
    F(pkss_param_info, constraint),  F(pkss_param_info, doc),
};
#undef F

#define N_OF(a) (sizeof(a) / sizeof((a)[0]))

/* Copies the fields of src that end within dst's struct_size; the caller's
 * struct_size itself is left as the caller set it. */
static void copy_fields(void *dst, const void *src, const field *f, size_t n)
{
    size_t have = *(const size_t *)dst;
    for (size_t i = 0; i < n; ++i)
        if (f[i].offset + f[i].size <= have)
            memcpy((char *)dst + f[i].offset, (const char *)src + f[i].offset,
                   f[i].size);
}

void pkss__struct_init(void *p, size_t struct_size)
{
    if (struct_size < sizeof(size_t))
        return;
    memset(p, 0, struct_size);
    *(size_t *)p = struct_size;
}

void pkss__deliver_result(pkss_result *dst, const pkss_result *src)
{
    copy_fields(dst, src, RESULT_FIELDS, N_OF(RESULT_FIELDS));
}

/* Zeroes the fields of a result that its struct_size covers (no pose). */
void pkss__clear_result(pkss_result *dst)
{
    static const pkss_result zero;
    copy_fields(dst, &zero, RESULT_FIELDS, N_OF(RESULT_FIELDS));
}

void pkss__deliver_candidate(pkss_candidate *dst, const pkss_candidate *src)
{
    copy_fields(dst, src, CANDIDATE_FIELDS, N_OF(CANDIDATE_FIELDS));
}

void pkss__deliver_alternative(pkss_alternative *dst,
                               const pkss_alternative *src)
{
    copy_fields(dst, src, ALTERNATIVE_FIELDS, N_OF(ALTERNATIVE_FIELDS));
}

void pkss__deliver_param_info(pkss_param_info *dst, const pkss_param_info *src)
{
    copy_fields(dst, src, PARAM_INFO_FIELDS, N_OF(PARAM_INFO_FIELDS));
}

void pkss_result_init(pkss_result *result, size_t struct_size)
{
    if (result)
        pkss__struct_init(result, struct_size);
}

void pkss_candidate_init(pkss_candidate *candidate, size_t struct_size)
{
    if (candidate)
        pkss__struct_init(candidate, struct_size);
}

void pkss_alternative_init(pkss_alternative *alternative, size_t struct_size)
{
    if (alternative)
        pkss__struct_init(alternative, struct_size);
}

/* Each table lists every field of its struct: gaps between fields are no
 * wider than alignment padding (a test checks this, so a field appended to
 * a struct but not to its table is caught). */
static int complete(const field *f, size_t n, size_t struct_bytes)
{
    size_t end = sizeof(size_t); /* struct_size comes first */
    for (size_t i = 0; i < n; ++i) {
        if (f[i].offset < end || f[i].offset - end >= sizeof(double))
            return 0;
        end = f[i].offset + f[i].size;
    }
    return struct_bytes - end < sizeof(double);
}

int pkss__abi_tables_complete(void)
{
    return complete(RESULT_FIELDS, N_OF(RESULT_FIELDS), sizeof(pkss_result)) &&
           complete(CANDIDATE_FIELDS, N_OF(CANDIDATE_FIELDS), sizeof(pkss_candidate)) &&
           complete(ALTERNATIVE_FIELDS, N_OF(ALTERNATIVE_FIELDS), sizeof(pkss_alternative)) &&
           complete(PARAM_INFO_FIELDS, N_OF(PARAM_INFO_FIELDS), sizeof(pkss_param_info));
}
