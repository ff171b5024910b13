/* SPDX-License-Identifier: MIT
 * cli.h -- the parts of pkss-align (tools/pkss_align.c), one job per file:
 *   options.c     the command line; parameter options and --help are
 *                 generated from pkss_param_at() at run time
 *   outfile.c     outputs that never lose or corrupt a file: temporary
 *                 file in the target's folder, fsync, rename; streams
 *   cloud_write.c the aligned cloud as PLY, PCD, XYZ or NPY (pkss_io.h)
 *   report.c      JSON, the matrix and the -v report
 * Private to the tool; only pkss.h and pkss_io.h are public.
 */
#ifndef PKSS_CLI_H
#define PKSS_CLI_H

#include "pkss.h"
#include "pkss_io.h"

#include <stdio.h>
#include <sys/types.h>

#define TOOL "pkss-align"

/* Exit codes (documented in --help, tools/README.md and pkss_align.c). */
enum {
    EXIT_OK = 0,
    EXIT_USAGE = 2,
    EXIT_IO = 3,          /* cannot read or write a file (stdout too) */
    EXIT_DATA = 4,        /* bad input data */
    EXIT_FAILURE_REG = 5, /* the registration failed (library status) */
    EXIT_LOW_CONFIDENCE = 6, /* below --min-confidence (outputs written) */
    EXIT_INTERRUPTED = 130
};

/* Usage errors use the library's name for a bad argument, I/O errors its
 * name for a file that cannot be read or written. */
#define USAGE_STATUS "PKSS_ERR_INVALID_ARGUMENT"
#define IO_STATUS "PKSS_ERR_IO"
/* A result below --min-confidence is the tool's verdict, not a library
 * status: it has a name of its own (tools/README.md). */
#define LOW_CONFIDENCE_STATUS "PKSS_LOW_CONFIDENCE"

void cli_fail(const char *status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* ------------------------------------------------------------ options.c */

/* One parameter setting from the command line, applied in order. */
typedef struct cli_setting {
    pkss_param param;
    int type;          /* pkss_param_type of the parameter */
    long long i;       /* INT, SWITCH, CHOICE */
    double d;          /* DOUBLE */
    const char *s;     /* STRING */
    char opt[80];      /* the option as given, for messages */
    const char *text;  /* its value text */
} cli_setting;

#define CLI_MAX_SETTINGS 128

typedef struct cli_options {
    const char *source, *target;
    const char *out_cloud, *json, *matrix;
    pkss_format out_format; /* from --output-format, else extension (AUTO) */
    int ascii, quiet, verbose;
    double min_confidence;       /* --min-confidence, or -1 when not given */
    pkss_format fmt_source, fmt_target;
    cli_setting settings[CLI_MAX_SETTINGS];
    int n_settings;
} cli_options;

/* @return -1 usage error (message printed), 0 run, 1 exit 0 (--help or
 *         --version printed). */
int cli_parse_args(int argc, char **argv, cli_options *o);

/* The value names of a switch or choice ("default|on|off"): writes name
 * number `v` into buf; @return buf, or NULL if there is none. */
const char *cli_choice_name(const char *choices, long long v, char *buf,
                            size_t size);

/* ------------------------------------------------------------ outfile.c */

typedef enum cli_out_kind {
    CLI_OUT_FILE = 0, /* regular file or none yet: temp + fsync + rename */
    CLI_OUT_STDOUT,   /* "-" */
    CLI_OUT_STREAM    /* FIFO, character device, socket: written directly */
} cli_out_kind;

typedef struct cli_out {
    const char *what;  /* "the aligned cloud", "JSON", "the matrix" */
    const char *path;  /* as given, NULL if not requested */
    cli_out_kind kind;
    char *final;       /* FILE: the resolved path renamed onto */
    char *tmp;         /* FILE: the temporary file while it exists */
    FILE *f;           /* while writing */
    mode_t mode;       /* FILE: permissions of the result */
    int registered;    /* slot in the signal handler's list */
} cli_out;

/* @return 0, or EXIT_USAGE after naming both paths when two of `paths`
 *         (inputs first, then outputs; NULL entries skipped) are the same
 *         file. Uses stat() and realpath() only: never opens a path. */
int cli_check_distinct(const char *const *paths, const char *const *roles,
                       size_t n, size_t first_output);

/* Classifies an output and checks, without creating it, that it can be
 * written (folder exists and is writable, not a directory).
 * @return EXIT_OK or EXIT_IO (message printed). */
int cli_out_plan(cli_out *o, const char *what, const char *path);

/* Opens the output for writing: a new temporary file beside the final
 * path, stdout, or the stream itself. @return the FILE or NULL (printed). */
FILE *cli_out_open(cli_out *o);

/* Flushes, checks, fsyncs and closes what cli_out_open gave.
 * @return 0 or -1 (message printed; the temporary file is removed). */
int cli_out_close(cli_out *o);

/* Renames the temporary file over the final path. @return 0 or -1. */
int cli_out_commit(cli_out *o);

/* Removes the temporary file, if any. Safe to call twice. */
void cli_out_discard(cli_out *o);

/* Called from a signal handler: unlinks every temporary file still open
 * (async-signal-safe). */
void cli_out_unlink_all_from_signal(void);

/* -------------------------------------------------------- cloud_write.c */

/* The format of an output path by its extension (.ply .pcd .xyz .npy) or
 * of a name; PKSS_FORMAT_AUTO for one the library cannot write. */
pkss_format cli_cloud_format_from_path(const char *path);
pkss_format cli_cloud_format_from_name(const char *name);

/* Writes n points (row-major x y z) to the output.
 * @return EXIT_OK or EXIT_IO (printed). */
int cli_write_cloud(cli_out *o, pkss_format fmt, const double *xyz,
                    size_t n, int ascii);

/* -------------------------------------------------------------- report.c */

typedef struct cli_run {
    const cli_options *o;
    size_t n_source, n_target;
    pkss_format fmt_source, fmt_target;
    double load_seconds;
} cli_run;

void cli_json(FILE *f, const cli_run *run, const pkss_context *ctx,
              pkss_status st, const pkss_result *r);
void cli_matrix(FILE *f, const double *T, const char *fmt);
void cli_summary(FILE *f, const pkss_result *r);
void cli_verbose(const cli_run *run, const pkss_context *ctx,
                 const pkss_result *r);
const char *cli_stage_name(uint32_t stage);
const char *cli_symmetry_name(int32_t symmetry);
const char *cli_progress_stage_name(int32_t stage);
double cli_rotation_angle_deg(const double *R);

#endif
