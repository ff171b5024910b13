/* SPDX-License-Identifier: MIT
 * pkss_align.c -- pkss-align: registers SOURCE onto TARGET with a
 * similarity transform (scale, rotation, translation), no initial guess.
 *
 * A thin client of the public API (pkss.h) and of the library's file I/O
 * (pkss_io.h); it doubles as an example of using the library:
 * create a context, set parameters one at a time (here generated from
 * pkss_param_at()), install a progress callback that can cancel,
 * pkss_register(), read the pkss_result and its candidates. The parts live
 * in tools/cli/ (see cli.h); this file is the order of the run.
 *
 * Exit codes (also in --help and tools/README.md):
 *   0    success
 *   2    usage error (also: an output naming an input or another output,
 *        an output extension that cannot be written)
 *   3    I/O error: cannot read an input or write an output, stdout too
 *   4    bad input data (malformed file, NaN without --drop-nonfinite, ...)
 *   5    registration failure (library status: device, no consensus, ...)
 *   6    the confidence is below --min-confidence (outputs written)
 *   130  interrupted by SIGINT (143 SIGTERM): cancelled, no output written
 */
#define _XOPEN_SOURCE 700 /* sigaction */
#include "cli/cli.h"

#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

void cli_fail(const char *status, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, TOOL ": %s: ", status);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static int exit_for_status(pkss_status s)
{
    switch (s) {
    case PKSS_OK:
        return EXIT_OK;
    case PKSS_ERR_INVALID_ARGUMENT:
    case PKSS_ERR_UNKNOWN_PARAMETER:
    case PKSS_ERR_WRONG_PARAMETER_TYPE:
        return EXIT_USAGE;
    case PKSS_ERR_EMPTY_INPUT:
    case PKSS_ERR_TOO_FEW_POINTS:
    case PKSS_ERR_NONFINITE:
    case PKSS_ERR_DEGENERATE:
    case PKSS_ERR_OUT_OF_RANGE:
        return EXIT_DATA;
    default: /* NULL_ARGUMENT (a tool bug), memory, device, numerical */
        return EXIT_FAILURE_REG;
    }
}

static int exit_for_io(pkss_status s)
{
    switch (s) {
    case PKSS_OK: return EXIT_OK;
    case PKSS_ERR_IO: return EXIT_IO;
    case PKSS_ERR_INVALID_ARGUMENT:
    case PKSS_ERR_NULL_ARGUMENT: return EXIT_USAGE;
    case PKSS_ERR_OUT_OF_MEMORY: return EXIT_FAILURE_REG;
    default: return EXIT_DATA; /* FORMAT, UNSUPPORTED_FORMAT, EMPTY_INPUT */
    }
}

static double wall_seconds(void)
{
    struct timespec ts;
    if (timespec_get(&ts, TIME_UTC) != TIME_UTC)
        return (double)clock() / CLOCKS_PER_SEC;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ------------------------------------------------- signals and progress */

static volatile sig_atomic_t g_signal;

/* The first SIGINT/SIGTERM asks the run to stop (the progress callback
 * cancels it, outputs are discarded); a second one leaves at once,
 * removing the temporary files first. */
static void on_signal(int sig)
{
    if (g_signal) {
        cli_out_unlink_all_from_signal();
        _exit(128 + sig);
    }
    g_signal = sig;
}

static void install_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0; /* no SA_RESTART: a read blocked on stdin returns */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

typedef struct progress_state {
    int verbose;
    int32_t stage;
    double last_print;
} progress_state;

/* Prints each stage as it starts (and its steps about once a second) with
 * -v; returns non-zero, which cancels the run, once a signal came. */
static int on_progress(void *user, const pkss_progress *p)
{
    progress_state *ps = (progress_state *)user;
    if (ps->verbose && !g_signal &&
        (p->stage != ps->stage || p->elapsed - ps->last_print >= 1.0)) {
        fprintf(stderr, TOOL ": [%8.3f s] %s", p->elapsed,
                cli_progress_stage_name(p->stage));
        if (p->steps)
            fprintf(stderr, " %u/%u", (unsigned)p->step, (unsigned)p->steps);
        fputc('\n', stderr);
        ps->stage = p->stage;
        ps->last_print = p->elapsed;
    }
    return g_signal != 0;
}

/* ---------------------------------------------------------------- main */

static int load(const char *what, const char *path, pkss_format fmt,
                double **xyz, size_t *n, pkss_format *used)
{
    char err[1024];
    pkss_status st;
    int is_stdin = strcmp(path, "-") == 0;
    *used = fmt != PKSS_FORMAT_AUTO ? fmt : pkss_format_from_path(path);
    st = pkss_read_points(path, fmt, xyz, n, err, sizeof err);
    if (st != PKSS_OK) {
        if (g_signal)
            return EXIT_INTERRUPTED;
        if (is_stdin && fmt == PKSS_FORMAT_AUTO && st == PKSS_ERR_INVALID_ARGUMENT)
            cli_fail(USAGE_STATUS,
                     "%s is standard input and its content is not PLY, PCD, "
                     "OFF, VTK, NPY or NPZ: give its format with --%s-format",
                     what, what);
        else
            cli_fail(pkss_status_name(st), "%s", err);
        return exit_for_io(st);
    }
    return EXIT_OK;
}

/* The transformed source, or NULL (printed). */
static double *transform(const double *xyz, size_t n, const double *T)
{
    size_t i;
    double *out = (double *)malloc((n ? n : 1) * 3 * sizeof(double));
    if (!out) {
        cli_fail(pkss_status_name(PKSS_ERR_OUT_OF_MEMORY),
                 "cannot transform %llu points", (unsigned long long)n);
        return NULL;
    }
    for (i = 0; i < n; i++) {
        const double *p = xyz + 3 * i;
        int k;
        for (k = 0; k < 3; k++)
            out[3 * i + k] = T[4 * k] * p[0] + T[4 * k + 1] * p[1] +
                             T[4 * k + 2] * p[2] + T[4 * k + 3];
    }
    return out;
}

enum { OUT_JSON, OUT_MATRIX, OUT_CLOUD, N_OUTS };

/* Writes every requested output (temporary files), then renames them all
 * only if each one succeeded and no signal came: a failed or interrupted
 * run changes no file. */
static int write_outputs(cli_out *outs, const cli_run *run,
                         const pkss_context *ctx, pkss_status st,
                         const pkss_result *r, const double *src, size_t ns,
                         pkss_format cloud_fmt)
{
    int rc = EXIT_OK, k;
    FILE *f;
    if (outs[OUT_JSON].path) {
        if ((f = cli_out_open(&outs[OUT_JSON])) == NULL)
            rc = EXIT_IO;
        else {
            cli_json(f, run, ctx, st, r);
            if (cli_out_close(&outs[OUT_JSON]) != 0)
                rc = EXIT_IO;
        }
    }
    if (st == PKSS_OK && rc == EXIT_OK && outs[OUT_MATRIX].path) {
        if ((f = cli_out_open(&outs[OUT_MATRIX])) == NULL)
            rc = EXIT_IO;
        else {
            cli_matrix(f, r->T_target_source, "%.17g %.17g %.17g %.17g\n");
            if (cli_out_close(&outs[OUT_MATRIX]) != 0)
                rc = EXIT_IO;
        }
    }
    if (st == PKSS_OK && rc == EXIT_OK && outs[OUT_CLOUD].path) {
        double *out = transform(src, ns, r->T_target_source);
        if (!out)
            rc = EXIT_FAILURE_REG;
        else {
            rc = cli_write_cloud(&outs[OUT_CLOUD], cloud_fmt, out, ns,
                                 run->o->ascii);
            free(out);
        }
    }
    if (rc == EXIT_OK && g_signal)
        rc = EXIT_INTERRUPTED;
    for (k = 0; k < N_OUTS; k++) {
        if (rc == EXIT_OK && cli_out_commit(&outs[k]) != 0)
            rc = EXIT_IO; /* earlier renames stand; the rest are dropped */
        cli_out_discard(&outs[k]);
    }
    return rc;
}

int main(int argc, char **argv)
{
    cli_options o;
    cli_run run;
    cli_out outs[N_OUTS];
    pkss_format cloud_fmt = PKSS_FORMAT_AUTO;
    progress_state ps;
    double *src = NULL, *tgt = NULL, t0;
    size_t ns = 0, nt = 0;
    pkss_context *ctx = NULL;
    pkss_result res;
    pkss_status st;
    int rc, i, to_stdout = 0;

    memset(outs, 0, sizeof outs);
    rc = cli_parse_args(argc, argv, &o);
    if (rc != 0) {
        rc = rc < 0 ? EXIT_USAGE : EXIT_OK;
        goto done;
    }

    /* Everything about the outputs is checked before the (possibly long)
     * loading and registration: format, aliasing, writability. */
    if (o.out_cloud) {
        cloud_fmt = o.out_format ? o.out_format
                                 : cli_cloud_format_from_path(o.out_cloud);
        if (cloud_fmt == PKSS_FORMAT_AUTO) {
            cli_fail(USAGE_STATUS,
                     "-o %s: cannot tell the output format from the name "
                     "(write .ply, .pcd, .xyz or .npy, or give --output-format)",
                     o.out_cloud);
            rc = EXIT_USAGE;
            goto done;
        }
    }
    {
        const char *paths[] = {o.source, o.target, o.out_cloud, o.json,
                               o.matrix};
        const char *roles[] = {"SOURCE", "TARGET", "output -o",
                               "output --json", "output --matrix"};
        rc = cli_check_distinct(paths, roles, 5, 2);
        if (rc != 0)
            goto done;
    }
    if ((rc = cli_out_plan(&outs[OUT_JSON], "JSON", o.json)) != 0 ||
        (rc = cli_out_plan(&outs[OUT_MATRIX], "the matrix", o.matrix)) != 0 ||
        (rc = cli_out_plan(&outs[OUT_CLOUD], "the aligned cloud",
                           o.out_cloud)) != 0)
        goto done;
    for (i = 0; i < N_OUTS; i++)
        if (outs[i].path && outs[i].kind == CLI_OUT_STDOUT)
            to_stdout = 1;
    install_signals();

    memset(&run, 0, sizeof run);
    run.o = &o;
    st = pkss_context_create(&ctx);
    if (st != PKSS_OK) {
        cli_fail(pkss_status_name(st), "cannot create a context: %s",
                 pkss_status_string(st));
        rc = exit_for_status(st);
        goto done;
    }
    for (i = 0; i < o.n_settings; i++) {
        const cli_setting *s = &o.settings[i];
        if (s->type == PKSS_TYPE_DOUBLE)
            st = pkss_context_set_double(ctx, s->param, s->d);
        else if (s->type == PKSS_TYPE_STRING)
            st = pkss_context_set_string(ctx, s->param, s->s);
        else
            st = pkss_context_set_int(ctx, s->param, s->i);
        if (st != PKSS_OK) {
            const char *detail = pkss_context_last_error(ctx);
            cli_fail(pkss_status_name(st), "%s %s: %s", s->opt,
                     s->text ? s->text : "",
                     detail[0] ? detail : pkss_status_string(st));
            rc = EXIT_USAGE;
            goto done;
        }
    }
    memset(&ps, 0, sizeof ps);
    ps.verbose = o.verbose;
    pkss_context_set_progress(ctx, on_progress, &ps);

    /* Parameters are checked above, before the (possibly slow) loading. */
    t0 = wall_seconds();
    rc = load("source", o.source, o.fmt_source, &src, &ns, &run.fmt_source);
    if (rc == EXIT_OK)
        rc = load("target", o.target, o.fmt_target, &tgt, &nt,
                  &run.fmt_target);
    if (rc == EXIT_OK && g_signal)
        rc = EXIT_INTERRUPTED;
    if (rc != EXIT_OK)
        goto done;
    run.n_source = ns;
    run.n_target = nt;
    run.load_seconds = wall_seconds() - t0;
    if (o.verbose)
        fprintf(stderr,
                TOOL ": source %s: %llu points; target %s: %llu points "
                     "(loaded in %.3f s)\n",
                o.source, (unsigned long long)ns, o.target,
                (unsigned long long)nt, run.load_seconds);

    pkss_result_init(&res, sizeof res);
    st = pkss_register(ctx, src, ns, tgt, nt, &res);
    if (g_signal) { /* cancelled, or finished as the signal came */
        rc = EXIT_INTERRUPTED;
        goto done;
    }
    if (res.flags & PKSS_FLAG_FELL_BACK && !o.quiet) {
        char note[PKSS_NOTE_SIZE + 1];
        memcpy(note, res.note, PKSS_NOTE_SIZE);
        note[PKSS_NOTE_SIZE] = '\0';
        fprintf(stderr, TOOL ": warning: %s\n",
                note[0] ? note : "no usable OpenCL device: ran on the "
                                 "reference backend");
    }
    if (st != PKSS_OK) {
        const char *detail = pkss_context_last_error(ctx);
        /* the JSON records the failure; its own failure is reported too */
        (void)write_outputs(outs, &run, ctx, st, &res, src, ns, cloud_fmt);
        cli_fail(pkss_status_name(st), "%s",
                 detail[0] ? detail : pkss_status_string(st));
        rc = exit_for_status(st);
        goto done;
    }

    if (!to_stdout) { /* an output on stdout keeps it machine-readable */
        cli_matrix(stdout, res.T_target_source, "%.9g %.9g %.9g %.9g\n");
        if (!o.quiet)
            cli_summary(stdout, &res);
    }
    fflush(stdout);
    if (o.verbose)
        cli_verbose(&run, ctx, &res);
    rc = write_outputs(outs, &run, ctx, st, &res, src, ns, cloud_fmt);
    if (rc == EXIT_OK && o.min_confidence >= 0.0 &&
        res.confidence < o.min_confidence) {
        cli_fail(LOW_CONFIDENCE_STATUS,
                 "confidence %.3f is below --min-confidence %g: the pose may "
                 "be wrong%s (the outputs were written)",
                 res.confidence, o.min_confidence,
                 res.ambiguous ? "; other poses fit as well (ambiguous)" : "");
        rc = EXIT_LOW_CONFIDENCE;
    }

done:
    for (i = 0; i < N_OUTS; i++)
        cli_out_discard(&outs[i]);
    pkss_context_destroy(ctx);
    pkss_points_free(src);
    pkss_points_free(tgt);
    if (rc == EXIT_INTERRUPTED && g_signal) {
        rc = 128 + g_signal;
        fprintf(stderr, TOOL ": PKSS_ERR_CANCELLED: interrupted by signal %d; "
                "no output written\n", (int)g_signal);
    }
    /* Every write is checked, standard output's too (> /dev/full). */
    if ((fflush(stdout) != 0 || ferror(stdout)) &&
        rc != EXIT_INTERRUPTED && rc < 128) {
        int e = errno; /* from the failed write or this flush */
        cli_fail(IO_STATUS, "cannot write to standard output%s%s",
                 e ? ": " : "", e ? strerror(e) : "");
        if (rc == EXIT_OK)
            rc = EXIT_IO;
    }
    return rc;
}
