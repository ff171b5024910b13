/* SPDX-License-Identifier: MIT
 * report.c -- what pkss-align tells about a run: the JSON document
 * (schema_version 1), the matrix, the summary line and the -v report on
 * stderr. Parameters are listed from pkss_param_at() with the values in
 * force, switches and choices by name; candidates come from
 * pkss_context_candidate().
 */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Bump when a key changes meaning or goes away; adding keys does not. */
#define JSON_SCHEMA_VERSION 1

const char *cli_stage_name(uint32_t stage)
{
    switch (stage) {
    case PKSS_STAGE_SEARCH: return "search";
    case PKSS_STAGE_COARSE: return "coarse";
    case PKSS_STAGE_STOPPED: return "stopped";
    case PKSS_STAGE_REFINED: return "refined";
    default: return "unknown";
    }
}

const char *cli_progress_stage_name(int32_t stage)
{
    switch (stage) {
    case PKSS_PROGRESS_DEVICE: return "device";
    case PKSS_PROGRESS_PREPROCESS: return "preprocess";
    case PKSS_PROGRESS_SEARCH: return "search";
    case PKSS_PROGRESS_REFINE: return "refine";
    case PKSS_PROGRESS_DONE: return "done";
    default: return "unknown";
    }
}

static const char *backend_name(int b)
{
    switch (b) {
    case PKSS_BACKEND_AUTO: return "auto";
    case PKSS_BACKEND_REFERENCE: return "reference";
    case PKSS_BACKEND_OPENCL: return "opencl";
    default: return "unknown";
    }
}

double cli_rotation_angle_deg(const double *R)
{
    double tr = R[0] + R[4] + R[8];
    double vx = R[7] - R[5], vy = R[2] - R[6], vz = R[3] - R[1];
    double s = 0.5 * sqrt(vx * vx + vy * vy + vz * vz);
    return atan2(s, 0.5 * (tr - 1.0)) * 180.0 / 3.14159265358979323846;
}

/* ---------------------------------------------------------------- JSON */

static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c == '\n')
            fputs("\\n", f);
        else if (c == '\t')
            fputs("\\t", f);
        else if (c == '\r')
            fputs("\\r", f);
        else if (c < 0x20 || c == 0x7f)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f); /* UTF-8 passes through */
    }
    fputc('"', f);
}

/* A fixed char buffer from the library: never trust a terminator. */
static void json_buf(FILE *f, const char *b, size_t size)
{
    char tmp[512];
    size_t n = size < sizeof tmp - 1 ? size : sizeof tmp - 1;
    memcpy(tmp, b, n);
    tmp[n] = '\0';
    json_str(f, tmp);
}

/* The shortest text that reads back as the same double (0.1, not
 * 0.10000000000000001); JSON has no NaN/Inf, they become null. */
static void json_num(FILE *f, double v)
{
    char buf[32];
    int prec;
    if (!isfinite(v)) {
        fputs("null", f);
        return;
    }
    for (prec = 15; prec < 17; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, v);
        if (strtod(buf, NULL) == v)
            break;
    }
    if (prec == 17)
        snprintf(buf, sizeof buf, "%.17g", v);
    fputs(buf, f);
}

/* ', "key": number' : one member after the first of a JSON object. */
static void json_field(FILE *f, const char *key, double v)
{
    fprintf(f, ", \"%s\": ", key);
    json_num(f, v);
}

static void json_array(FILE *f, const double *v, int n)
{
    int i;
    fputc('[', f);
    for (i = 0; i < n; i++) {
        if (i)
            fputs(", ", f);
        json_num(f, v[i]);
    }
    fputc(']', f);
}

static void json_matrix(FILE *f, const double *m, int rows, int cols)
{
    int r;
    fputc('[', f);
    for (r = 0; r < rows; r++) {
        if (r)
            fputs(", ", f);
        json_array(f, m + r * cols, cols);
    }
    fputc(']', f);
}

static void json_counts(FILE *f, const pkss_counts *c)
{
    fprintf(f,
            "{\"input\": %llu, \"nonfinite\": %llu, \"duplicates\": %llu, "
            "\"thinned\": %llu, \"after_mutual\": %llu, \"after_stat\": "
            "%llu, \"resampled\": %llu, \"features\": %llu}",
            (unsigned long long)c->input, (unsigned long long)c->nonfinite,
            (unsigned long long)c->duplicates, (unsigned long long)c->thinned,
            (unsigned long long)c->after_mutual,
            (unsigned long long)c->after_stat,
            (unsigned long long)c->resampled,
            (unsigned long long)c->features);
}

static void json_input(FILE *f, const char *path, pkss_format fmt,
                       size_t n)
{
    const char *name = pkss_format_name(fmt);
    fputs("{\"path\": ", f);
    json_str(f, path);
    fputs(", \"format\": ", f);
    json_str(f, name ? name : "auto");
    fprintf(f, ", \"points\": %llu}", (unsigned long long)n);
}

/* The string a STRING parameter was given on the command line (the
 * library has no getter for strings), or NULL. */
static const char *string_setting(const cli_options *o, int32_t id)
{
    const char *s = NULL;
    int i;
    for (i = 0; i < o->n_settings; i++)
        if ((int32_t)o->settings[i].param == id)
            s = o->settings[i].s;
    return s && *s ? s : NULL;
}

static void json_parameters(FILE *f, const cli_run *run,
                            const pkss_context *ctx)
{
    size_t i, n = pkss_param_count();
    int first = 1;
    fputc('{', f);
    for (i = 0; i < n; i++) {
        pkss_param_info in;
        double v;
        char name[64];
        pkss_param_info_init(&in, sizeof in);
        if (pkss_param_at(i, &in) != PKSS_OK || !in.name)
            continue;
        fputs(first ? "\n    " : ",\n    ", f);
        first = 0;
        json_str(f, in.name);
        fputs(": ", f);
        if (in.type == PKSS_TYPE_STRING) {
            const char *s = string_setting(run->o, in.id);
            if (s)
                json_str(f, s);
            else
                fputs("null", f);
        } else if (pkss_context_get_double(ctx, (pkss_param)in.id, &v) !=
                   PKSS_OK) {
            fputs("null", f);
        } else if ((in.type == PKSS_TYPE_SWITCH ||
                    in.type == PKSS_TYPE_CHOICE) &&
                   v == floor(v) &&
                   cli_choice_name(in.choices, (long long)v, name,
                                   sizeof name)) {
            json_str(f, name);
        } else {
            json_num(f, v);
        }
    }
    fputs(first ? "}" : "\n  }", f);
}

static void json_candidates(FILE *f, const pkss_context *ctx,
                            const pkss_result *r)
{
    uint32_t i;
    fputc('[', f);
    for (i = 0; i < r->n_candidates; i++) {
        pkss_candidate c;
        pkss_candidate_init(&c, sizeof c);
        if (pkss_context_candidate(ctx, i, &c) != PKSS_OK)
            break;
        fputs(i ? ",\n    {" : "\n    {", f);
        fprintf(f, "\"index\": %u, \"T_target_source\": ", (unsigned)i);
        json_matrix(f, c.T_target_source, 4, 4);
        json_field(f, "scale", c.scale);
        json_field(f, "score", c.score);
        json_field(f, "score_contour", c.score_contour);
        json_field(f, "score_feature", c.score_feature);
        json_field(f, "rms", c.rms);
        json_field(f, "overlap", c.overlap);
        json_field(f, "fit", c.fit);
        fputs(", \"stage\": ", f);
        json_str(f, cli_stage_name(c.stage));
        fprintf(f, ", \"search\": %u, \"rotation_index\": %u, "
                   "\"offset_index\": %u}",
                (unsigned)c.search, (unsigned)c.rotation_index,
                (unsigned)c.offset_index);
    }
    fputs(r->n_candidates ? "\n  ]" : "]", f);
}

const char *cli_symmetry_name(int32_t symmetry)
{
    switch (symmetry) {
    case PKSS_SYMMETRY_NONE: return "none";
    case PKSS_SYMMETRY_DISCRETE: return "discrete";
    case PKSS_SYMMETRY_AXIAL: return "axial";
    case PKSS_SYMMETRY_SPHERICAL: return "spherical";
    default: return "unknown";
    }
}

/* The poses that fit as well (pkss_context_alternative), each with the
 * turn from the result's. */
static void json_alternatives(FILE *f, const pkss_context *ctx,
                              const pkss_result *r)
{
    uint32_t i;
    fputc('[', f);
    for (i = 0; i < r->n_alternatives; i++) {
        pkss_alternative a;
        pkss_alternative_init(&a, sizeof a);
        if (pkss_context_alternative(ctx, i, &a) != PKSS_OK)
            break;
        fputs(i ? ",\n    {" : "\n    {", f);
        fputs("\"T_target_source\": ", f);
        json_matrix(f, a.T_target_source, 4, 4);
        json_field(f, "fit", a.fit);
        json_field(f, "overlap", a.overlap);
        json_field(f, "angle_deg", a.angle_degrees);
        fputs(", \"axis\": ", f);
        json_array(f, a.axis, 3);
        fputs(", \"center\": ", f);
        json_array(f, a.center, 3);
        fprintf(f, ", \"candidate\": %d}", (int)a.candidate);
    }
    fputs(r->n_alternatives ? "\n  ]" : "]", f);
}

void cli_json(FILE *f, const cli_run *run, const pkss_context *ctx,
              pkss_status st, const pkss_result *r)
{
    fprintf(f, "{\n  \"schema_version\": %d,\n  \"tool\": \"" TOOL
               "\",\n  \"tool_version\": \"%d.%d.%d\",\n"
               "  \"library_version\": ",
            JSON_SCHEMA_VERSION, PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR,
            PKSS_VERSION_PATCH);
    json_str(f, pkss_version_string());
    fputs(",\n  \"source\": ", f);
    json_input(f, run->o->source, run->fmt_source, run->n_source);
    fputs(",\n  \"target\": ", f);
    json_input(f, run->o->target, run->fmt_target, run->n_target);
    fputs(",\n  \"parameters\": ", f);
    json_parameters(f, run, ctx);
    fputs(",\n  \"status\": ", f);
    json_str(f, pkss_status_name(st));
    if (r->flags) {
        fputs(",\n  \"flags\": [", f);
        if (r->flags & PKSS_FLAG_FELL_BACK)
            fputs("\"fell_back\"", f);
        if (r->flags & ~(uint32_t)PKSS_FLAG_FELL_BACK)
            fprintf(f, "%s%u", r->flags & PKSS_FLAG_FELL_BACK ? ", " : "",
                    (unsigned)(r->flags & ~(uint32_t)PKSS_FLAG_FELL_BACK));
        fputc(']', f);
    }
    if (r->note[0]) {
        fputs(",\n  \"note\": ", f);
        json_buf(f, r->note, sizeof r->note);
    }
    if (st != PKSS_OK) {
        fputs(",\n  \"detail\": ", f);
        json_str(f, pkss_context_last_error(ctx));
        fputs("\n}\n", f);
        return;
    }
    fputs(",\n  \"T_target_source\": ", f);
    json_matrix(f, r->T_target_source, 4, 4);
    fputs(",\n  \"scale\": ", f);
    json_num(f, r->scale);
    fputs(",\n  \"rotation\": ", f);
    json_matrix(f, r->rotation, 3, 3);
    fputs(",\n  \"rotation_angle_deg\": ", f);
    json_num(f, cli_rotation_angle_deg(r->rotation));
    fputs(",\n  \"translation\": ", f);
    json_array(f, r->translation, 3);
    fputs(",\n  \"score\": ", f);
    json_num(f, r->score);
    fputs(",\n  \"rms\": ", f);
    json_num(f, r->rms);
    fputs(",\n  \"overlap\": ", f);
    json_num(f, r->overlap);
    fputs(",\n  \"fit\": ", f);
    json_num(f, r->fit);
    fputs(",\n  \"confidence\": ", f);
    json_num(f, r->confidence);
    fprintf(f, ",\n  \"ambiguous\": %s,\n  \"symmetry\": {\"kind\": ",
            r->ambiguous ? "true" : "false");
    json_str(f, cli_symmetry_name(r->symmetry));
    fprintf(f, ", \"order\": %u, \"axis\": ", (unsigned)r->symmetry_order);
    json_array(f, r->symmetry_axis, 3);
    fputs(", \"center\": ", f);
    json_array(f, r->symmetry_center, 3);
    fputs("},\n  \"alternatives\": ", f);
    json_alternatives(f, ctx, r);
    fprintf(f, ",\n  \"winner\": %u,\n  \"n_candidates\": %u,\n"
               "  \"candidates\": ",
            (unsigned)r->winner, (unsigned)r->n_candidates);
    json_candidates(f, ctx, r);
    fprintf(f, ",\n  \"n_rotations\": %u,\n  \"n_offsets\": %u,\n"
               "  \"n_evaluations\": %llu,\n  \"source_counts\": ",
            (unsigned)r->n_rotations, (unsigned)r->n_offsets,
            (unsigned long long)r->n_evaluations);
    json_counts(f, &r->source_counts);
    fputs(",\n  \"target_counts\": ", f);
    json_counts(f, &r->target_counts);
    fputs(",\n  \"timings\": {\"load\": ", f);
    json_num(f, run->load_seconds);
    json_field(f, "prepare", r->prepare_seconds);
    json_field(f, "validate", r->timings.validate);
    json_field(f, "preprocess", r->timings.preprocess);
    json_field(f, "search", r->timings.search);
    json_field(f, "refine", r->timings.refine);
    json_field(f, "total", r->timings.total);
    fputs("},\n  \"backend\": ", f);
    json_str(f, backend_name(r->backend));
    fputs(",\n  \"device\": ", f);
    json_buf(f, r->device, sizeof r->device);
    fputs("\n}\n", f);
}

/* ------------------------------------------------------- text reports */

void cli_matrix(FILE *f, const double *T, const char *fmt)
{
    int r;
    for (r = 0; r < 4; r++)
        fprintf(f, fmt, T[4 * r], T[4 * r + 1], T[4 * r + 2], T[4 * r + 3]);
}

void cli_summary(FILE *f, const pkss_result *r)
{
    char dev[PKSS_NAME_SIZE + 1];
    memcpy(dev, r->device, PKSS_NAME_SIZE);
    dev[PKSS_NAME_SIZE] = '\0';
    fprintf(f, "scale=%.9g rotation_deg=%.6f rms=%.6g overlap=%.4f "
               "confidence=%.3f ambiguous=%s symmetry=%s "
               "time_s=%.3f device=%s\n",
            r->scale, cli_rotation_angle_deg(r->rotation), r->rms,
            r->overlap, r->confidence, r->ambiguous ? "yes" : "no",
            cli_symmetry_name(r->symmetry), r->timings.total, dev);
}

static void print_counts(const char *which, const pkss_counts *c)
{
    fprintf(stderr,
            "  %-6s input %llu, nonfinite %llu, duplicates %llu, thinned "
            "%llu, after_mutual %llu, after_stat %llu, resampled %llu, "
            "features %llu\n",
            which, (unsigned long long)c->input,
            (unsigned long long)c->nonfinite, (unsigned long long)c->duplicates,
            (unsigned long long)c->thinned,
            (unsigned long long)c->after_mutual,
            (unsigned long long)c->after_stat,
            (unsigned long long)c->resampled,
            (unsigned long long)c->features);
}

void cli_verbose(const cli_run *run, const pkss_context *ctx,
                 const pkss_result *r)
{
    uint32_t i;
    int wide = 0;
    fprintf(stderr, TOOL ": times (s): load %.3f, prepare %.3f, validate "
                    "%.3f, preprocess %.3f, search %.3f, refine %.3f, "
                    "registration total %.3f\n",
            run->load_seconds, r->prepare_seconds, r->timings.validate,
            r->timings.preprocess, r->timings.search, r->timings.refine,
            r->timings.total);
    fprintf(stderr, TOOL ": points per step:\n");
    print_counts("source", &r->source_counts);
    print_counts("target", &r->target_counts);
    for (i = 0; i < r->n_candidates; i++) {
        pkss_candidate c;
        pkss_candidate_init(&c, sizeof c);
        if (pkss_context_candidate(ctx, i, &c) == PKSS_OK && c.search == 1)
            wide = 1;
    }
    fprintf(stderr,
            TOOL ": searched %u rotations x %u offsets%s (%llu evaluations), "
                 "backend %s\n",
            (unsigned)r->n_rotations, (unsigned)r->n_offsets,
            wide ? ", then the wide offset grid" : "",
            (unsigned long long)r->n_evaluations, backend_name(r->backend));
    fprintf(stderr, TOOL ": candidates (best score first%s, * = winner):\n",
            wide ? " in each search; wide# = wide offset grid" : "");
    for (i = 0; i < r->n_candidates; i++) {
        pkss_candidate c;
        pkss_candidate_init(&c, sizeof c);
        if (pkss_context_candidate(ctx, i, &c) != PKSS_OK)
            break;
        fprintf(stderr,
                "  %c%2u score %.5f (contour %.5f, feature %.5f) scale "
                "%.6g rms %.6g overlap %.4f fit %.4f %-7s ",
                i == r->winner ? '*' : ' ', (unsigned)i, c.score,
                c.score_contour, c.score_feature, c.scale, c.rms, c.overlap,
                c.fit, cli_stage_name(c.stage));
        if (c.search == 3)
            fprintf(stderr, "local match\n");
        else
            fprintf(stderr, "rot#%u %s#%u\n", (unsigned)c.rotation_index,
                    c.search == 5   ? "rescale"
                    : c.search == 4 ? "reshift"
                    : c.search == 2 ? "shift"
                    : c.search == 1 ? "wide"
                                    : "off",
                    (unsigned)c.offset_index);
    }
}
