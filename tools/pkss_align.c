/* SPDX-License-Identifier: MIT
 * pkss_align.c -- pkss-align: registers SOURCE onto TARGET with a
 * similarity transform (scale, rotation, translation), no initial guess.
 *
 * A thin client of the public API (pkss.h) and of the file readers
 * (tools/io/pkss_io.h); it doubles as an example of using the library:
 * create a context, set parameters one at a time, pkss_register(), read the
 * pkss_result. Exit codes: 0 ok, 2 usage, 3 I/O, 4 bad data,
 * 5 registration failure (see --help and tools/README.md).
 */
#include "pkss.h"
#include "pkss_io.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define TOOL "pkss-align"

enum {
    EXIT_OK = 0,
    EXIT_USAGE = 2,
    EXIT_IO = 3,
    EXIT_DATA = 4,
    EXIT_FAILURE_REG = 5
};

/* ------------------------------------------------------------ messages */

static void fail_msg(const char *status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static void fail_msg(const char *status, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, TOOL ": %s: ", status);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

/* Usage errors use the library's name for a bad argument. */
#define USAGE_STATUS "PKSS_ERR_INVALID_ARGUMENT"

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

static int exit_for_io(pkss_io_status s)
{
    switch (s) {
    case PKSS_IO_OK: return EXIT_OK;
    case PKSS_IO_ERR_OPEN: return EXIT_IO;
    case PKSS_IO_ERR_ARGUMENT: return EXIT_USAGE;
    case PKSS_IO_ERR_NOMEM: return EXIT_FAILURE_REG;
    default: return EXIT_DATA; /* FORMAT, UNSUPPORTED, EMPTY */
    }
}

static double wall_seconds(void)
{
    struct timespec ts;
    if (timespec_get(&ts, TIME_UTC) != TIME_UTC)
        return (double)clock() / CLOCKS_PER_SEC;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---------------------------------------------------------- parameters */

/* Options that map to one numeric parameter. */
typedef struct param_opt {
    const char *opt;
    const char *meta;
    pkss_param param;
    int is_double;
    const char *what;
} param_opt;

static const param_opt k_param_opts[] = {
    {"--points", "m", PKSS_PARAM_POINTS, 0,
     "resampled points per cloud (SPEC 2.4)"},
    {"--steps", "n", PKSS_PARAM_ROTATION_STEPS, 0,
     "rotation steps per Euler axis, even; step 2*pi/n (SPEC 5)"},
    {"--offsets", "N", PKSS_PARAM_OFFSET_STEPS, 0,
     "offsets per PCA axis, odd; 1 = no translation search"},
    {"--cells", "n", PKSS_PARAM_CELL_STEPS, 0,
     "azimuth bins of the cell partition, even (SPEC 3)"},
    {"--top-k", "K", PKSS_PARAM_TOP_K, 0, "candidates kept and refined"},
    {"--rotation-count", "C", PKSS_PARAM_ROTATION_COUNT, 0,
     "rotations in the uniform set"},
    {"--feature-frac", "f", PKSS_PARAM_FEATURE_FRAC, 1,
     "share of points kept as feature points"},
    {"--max-raw-points", "P", PKSS_PARAM_MAX_RAW_POINTS, 0,
     "voxel-thin inputs larger than this (SPEC 2.1)"},
    {"--min-points", "P", PKSS_PARAM_MIN_POINTS, 0,
     "fewest finite points accepted"},
    {"--seed", "S", PKSS_PARAM_SEED, 0, "seed of every random choice"},
};
#define N_PARAM_OPTS (sizeof k_param_opts / sizeof k_param_opts[0])

/* Flags that set one switch. */
typedef struct switch_opt {
    const char *opt;
    pkss_param param;
    pkss_switch value;
    const char *what;
} switch_opt;

static const switch_opt k_switch_opts[] = {
    {"--no-features", PKSS_PARAM_USE_FEATURES, PKSS_SWITCH_OFF,
     "contour representatives only (no G_f, SPEC 2.6)"},
    {"--no-refine", PKSS_PARAM_REFINE, PKSS_SWITCH_OFF,
     "return the best search candidate unrefined (SPEC 6)"},
    {"--no-mutual", PKSS_PARAM_CULL_MUTUAL, PKSS_SWITCH_OFF,
     "no mutual-kNN outlier culling (SPEC 2.2)"},
    {"--no-stat", PKSS_PARAM_CULL_STAT, PKSS_SWITCH_OFF,
     "no statistical outlier filter (SPEC 2.3)"},
    {"--no-prealign", PKSS_PARAM_PCA_PREALIGN, PKSS_SWITCH_OFF,
     "no PCA pre-alignment (SPEC 2.7)"},
    {"--drop-nonfinite", PKSS_PARAM_DROP_NONFINITE, PKSS_SWITCH_ON,
     "drop NaN/Inf points instead of failing"},
};
#define N_SWITCH_OPTS (sizeof k_switch_opts / sizeof k_switch_opts[0])

/* One setting collected from the command line, applied in order. */
typedef struct setting {
    pkss_param param;
    int kind;            /* 0 int, 1 double, 2 string */
    long long i;
    double d;
    const char *s;
    const char *opt;     /* the option and its value text, for messages */
    const char *text;
} setting;

#define MAX_SETTINGS 128
#define MAX_PARAM_ID 1000 /* ids probed with pkss_param_name() */

static int parse_ll(const char *s, long long *out)
{
    char *end;
    long long v;
    if (!s || !*s)
        return -1;
    errno = 0;
    v = strtoll(s, &end, 10);
    if (*end != '\0' || errno == ERANGE)
        return -1;
    *out = v;
    return 0;
}

static int parse_dbl(const char *s, double *out)
{
    char *end;
    double v;
    if (!s || !*s)
        return -1;
    errno = 0;
    v = strtod(s, &end);
    if (*end != '\0' || errno == ERANGE || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

static int streq_ci(const char *a, const char *b)
{
    for (; *a && *b; a++, b++) {
        char x = *a, y = *b;
        if (x >= 'A' && x <= 'Z') x = (char)(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z') y = (char)(y - 'A' + 'a');
        if (x != y)
            return 0;
    }
    return *a == *b;
}

/* Symbolic values accepted by --set, --rotations and --backend. */
static int symbolic_value(const char *v, long long *out)
{
    static const struct {
        const char *name;
        long long value;
    } k[] = {
        {"default", 0},  {"on", PKSS_SWITCH_ON},   {"off", PKSS_SWITCH_OFF},
        {"yes", 1},      {"no", 2},                {"true", 1},
        {"false", 2},    {"euler", PKSS_ROTATIONS_EULER},
        {"uniform", PKSS_ROTATIONS_UNIFORM},       {"auto", PKSS_BACKEND_AUTO},
        {"reference", PKSS_BACKEND_REFERENCE},     {"opencl", PKSS_BACKEND_OPENCL},
    };
    size_t i;
    for (i = 0; i < sizeof k / sizeof k[0]; i++)
        if (streq_ci(v, k[i].name)) {
            *out = k[i].value;
            return 0;
        }
    return -1;
}

static int param_by_name(const char *name, pkss_param *out)
{
    int id;
    for (id = 0; id < MAX_PARAM_ID; id++) {
        const char *n = pkss_param_name((pkss_param)id);
        if (n && (streq_ci(n, name))) {
            *out = (pkss_param)id;
            return 0;
        }
    }
    /* also accept dashes: rotation-steps */
    for (id = 0; id < MAX_PARAM_ID; id++) {
        const char *n = pkss_param_name((pkss_param)id);
        size_t k;
        if (!n || strlen(n) != strlen(name))
            continue;
        for (k = 0; n[k]; k++) {
            char a = n[k] == '_' ? '-' : n[k];
            char b = name[k] == '_' ? '-' : name[k];
            if (a != b)
                break;
        }
        if (n[k] == '\0') {
            *out = (pkss_param)id;
            return 0;
        }
    }
    return -1;
}

/* ------------------------------------------------------------- options */

typedef struct options {
    const char *source, *target;
    const char *out_ply, *json, *matrix;
    int ascii, quiet, verbose;
    pkss_io_format fmt_source, fmt_target;
    setting settings[MAX_SETTINGS];
    int n_settings;
    const char *device;
} options;

static void print_version(void)
{
    printf(TOOL " %d.%d.%d (built against pkss.h %d.%d.%d), runtime "
           "libpkss %s\n",
           PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR, PKSS_VERSION_PATCH,
           PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR, PKSS_VERSION_PATCH,
           pkss_version_string());
    if (pkss_version_number() / 10000 != PKSS_VERSION_MAJOR)
        printf("warning: runtime library major version differs from the "
               "header's\n");
}

static void print_range(pkss_param p, int is_double)
{
    double lo, hi, def;
    if (pkss_param_bounds(p, &lo, &hi, &def) != PKSS_OK) {
        printf("%-22s", "(unknown to library)");
        return;
    }
    if (is_double)
        printf("%-8.10g [%.10g, %.10g]", def, lo, hi);
    else
        printf("%-8.0f [%.0f, %.0f]", def, lo, hi);
}

static void print_help(void)
{
    size_t i;
    double def;
    printf(
        "Usage: " TOOL " SOURCE TARGET [options]\n"
        "Registers SOURCE onto TARGET: finds s, R, t with\n"
        "  TARGET ~= s * R * SOURCE + t   (T_target_source, no initial "
        "guess)\n"
        "and prints the 4x4 T_target_source (4 lines) and a summary line.\n"
        "\n"
        "Input files: .ply .pcd .xyz .txt .csv .pts .off .bin (KITTI) .vtk;\n"
        "'-' reads standard input (then give --source-format/--target-"
        "format).\n"
        "\n"
        "Output:\n"
        "  -o FILE              write SOURCE transformed by the result as "
        "PLY\n"
        "  --ascii              write the PLY as text (default binary "
        "little-endian double)\n"
        "  --json FILE          write the whole pkss_result (all candidates) "
        "as JSON;\n"
        "                       on a registration failure it holds the "
        "status and detail\n"
        "  --matrix FILE        write the 4x4 T_target_source only\n"
        "  -q, --quiet          print only the matrix\n"
        "  -v, --verbose        also print stage times, per-step point counts "
        "and\n"
        "                       candidates to stderr\n"
        "  --format F           format of both inputs (ply pcd xyz txt csv pts "
        "off bin vtk)\n"
        "  --source-format F, --target-format F   format of one input\n"
        "\n"
        "Device:\n"
        "  --backend B          auto | reference | opencl (default auto)\n"
        "  --device D           OpenCL device by index or name substring "
        "(default:\n"
        "                       $PKSS_DEVICE, then the first GPU, then the "
        "first CPU)\n"
        "\n"
        "Parameters (default and range from the runtime library; "
        "SPEC.md):\n");
    for (i = 0; i < N_PARAM_OPTS; i++) {
        char left[40];
        snprintf(left, sizeof left, "%s %s", k_param_opts[i].opt,
                 k_param_opts[i].meta);
        printf("  %-20s ", left);
        print_range(k_param_opts[i].param, k_param_opts[i].is_double);
        printf("\n  %-20s   %s\n", "", k_param_opts[i].what);
    }
    if (pkss_param_bounds(PKSS_PARAM_ROTATION_SET, NULL, NULL, &def) ==
        PKSS_OK)
        printf("  %-20s euler | uniform (default %s)\n", "--rotations R",
               def == PKSS_ROTATIONS_UNIFORM ? "uniform" : "euler");
    for (i = 0; i < N_SWITCH_OPTS; i++) {
        const char *d = "?";
        if (pkss_param_bounds(k_switch_opts[i].param, NULL, NULL, &def) ==
            PKSS_OK)
            d = def == PKSS_SWITCH_OFF ? "off" : "on";
        printf("  %-20s %s\n  %-20s   (%s, default %s)\n",
               k_switch_opts[i].opt, k_switch_opts[i].what, "",
               pkss_param_name(k_switch_opts[i].param)
                   ? pkss_param_name(k_switch_opts[i].param)
                   : "?",
               d);
    }
    printf("  %-20s --no-mutual and --no-stat\n", "--no-cull");
    printf("  %-20s set any parameter the library knows by name; VALUE is "
           "a number,\n"
           "  %-20s on|off|default, euler|uniform or auto|reference|opencl. "
           "Known:\n",
           "--set NAME=VALUE", "");
    {
        int id, col = 0;
        printf("   ");
        for (id = 0; id < MAX_PARAM_ID; id++) {
            const char *n = pkss_param_name((pkss_param)id);
            if (!n)
                continue;
            if (col + (int)strlen(n) + 1 > 74) {
                printf("\n   ");
                col = 0;
            }
            printf(" %s", n);
            col += (int)strlen(n) + 1;
        }
        printf("\n");
    }
    printf(
        "\n"
        "Other:\n"
        "  --version            print the tool and runtime library versions\n"
        "  -h, --help           this text\n"
        "\n"
        "Exit codes:\n"
        "  0  success\n"
        "  2  usage error (unknown option, bad or out-of-range value, "
        "unknown format)\n"
        "  3  I/O error (cannot open, read or write a file)\n"
        "  4  bad input data (malformed or empty file, NaN/Inf without\n"
        "     --drop-nonfinite, too few points, degenerate or out-of-range "
        "cloud)\n"
        "  5  registration failure (no device, OpenCL error, no consensus, "
        "out of\n"
        "     memory, internal error)\n"
        "Errors print one line on stderr: " TOOL ": STATUS_NAME: detail\n");
}

static int add_setting(options *o, pkss_param p, int kind, long long i,
                       double d, const char *s, const char *opt,
                       const char *text)
{
    setting *st;
    if (o->n_settings >= MAX_SETTINGS) {
        fail_msg(USAGE_STATUS, "too many parameter options");
        return -1;
    }
    st = &o->settings[o->n_settings++];
    st->param = p;
    st->kind = kind;
    st->i = i;
    st->d = d;
    st->s = s;
    st->opt = opt;
    st->text = text;
    return 0;
}

static int parse_format(const char *opt, const char *v, pkss_io_format *out)
{
    pkss_io_format f = pkss_io_format_from_name(v);
    if (pkss_io_format_name(f) == NULL) {
        fail_msg(USAGE_STATUS,
                 "%s: unknown format '%s' (ply pcd xyz txt csv pts off bin "
                 "kitti vtk auto)",
                 opt, v);
        return -1;
    }
    *out = f;
    return 0;
}

static int parse_set(options *o, const char *arg)
{
    char name[128];
    const char *eq = strchr(arg, '=');
    const char *v;
    pkss_param p;
    long long iv;
    double dv;
    if (!eq || eq == arg || (size_t)(eq - arg) >= sizeof name) {
        fail_msg(USAGE_STATUS, "--set expects NAME=VALUE, got '%s'", arg);
        return -1;
    }
    memcpy(name, arg, (size_t)(eq - arg));
    name[eq - arg] = '\0';
    v = eq + 1;
    if (param_by_name(name, &p) != 0) {
        fail_msg("PKSS_ERR_UNKNOWN_PARAMETER",
                 "--set: the library has no parameter '%s' (see --help)",
                 name);
        return -1;
    }
    if (pkss_param_bounds(p, NULL, NULL, NULL) != PKSS_OK) /* string */
        return add_setting(o, p, 2, 0, 0, v, "--set", arg);
    if (symbolic_value(v, &iv) == 0 || parse_ll(v, &iv) == 0)
        return add_setting(o, p, 0, iv, 0, NULL, "--set", arg);
    if (parse_dbl(v, &dv) == 0)
        return add_setting(o, p, 1, 0, dv, NULL, "--set", arg);
    fail_msg(USAGE_STATUS, "--set %s: '%s' is not a number or a known word",
             name, v);
    return -1;
}

/* @return -1 usage error, 0 run, 1 exit 0 (help/version printed). */
static int parse_args(int argc, char **argv, options *o)
{
    int i, npos = 0, only_pos = 0;
    size_t k;
    memset(o, 0, sizeof *o);
    o->fmt_source = o->fmt_target = PKSS_IO_AUTO;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *val = NULL;
        char name[64];
        const char *eq;
        int takes_value = 0;

        if (only_pos || a[0] != '-' || strcmp(a, "-") == 0) {
            if (npos == 0)
                o->source = a;
            else if (npos == 1)
                o->target = a;
            else {
                fail_msg(USAGE_STATUS,
                         "unexpected argument '%s' (give SOURCE and TARGET "
                         "only; see --help)",
                         a);
                return -1;
            }
            npos++;
            continue;
        }
        if (strcmp(a, "--") == 0) {
            only_pos = 1;
            continue;
        }
        /* split --opt=value */
        eq = strncmp(a, "--", 2) == 0 ? strchr(a, '=') : NULL;
        if (eq) {
            size_t l = (size_t)(eq - a);
            if (l >= sizeof name) {
                fail_msg(USAGE_STATUS, "unknown option '%s'", a);
                return -1;
            }
            memcpy(name, a, l);
            name[l] = '\0';
            val = eq + 1;
        } else {
            size_t l = strlen(a);
            if (l >= sizeof name) {
                fail_msg(USAGE_STATUS, "unknown option '%s'", a);
                return -1;
            }
            memcpy(name, a, l + 1);
        }

#define IS(s) (strcmp(name, (s)) == 0)
        takes_value = IS("-o") || IS("--output") || IS("--json") ||
                      IS("--matrix") || IS("--format") ||
                      IS("--source-format") || IS("--target-format") ||
                      IS("--device") || IS("--backend") ||
                      IS("--rotations") || IS("--set");
        for (k = 0; k < N_PARAM_OPTS; k++)
            if (IS(k_param_opts[k].opt))
                takes_value = 1;
        if (takes_value && !val) {
            if (i + 1 >= argc) {
                fail_msg(USAGE_STATUS, "option %s needs a value", name);
                return -1;
            }
            val = argv[++i];
        } else if (!takes_value && val) {
            fail_msg(USAGE_STATUS, "option %s takes no value", name);
            return -1;
        }

        if (IS("-h") || IS("--help")) {
            print_help();
            return 1;
        } else if (IS("--version")) {
            print_version();
            return 1;
        } else if (IS("-q") || IS("--quiet")) {
            o->quiet = 1;
        } else if (IS("-v") || IS("--verbose")) {
            o->verbose = 1;
        } else if (IS("--ascii")) {
            o->ascii = 1;
        } else if (IS("-o") || IS("--output")) {
            o->out_ply = val;
        } else if (IS("--json")) {
            o->json = val;
        } else if (IS("--matrix")) {
            o->matrix = val;
        } else if (IS("--format")) {
            if (parse_format(name, val, &o->fmt_source) != 0)
                return -1;
            o->fmt_target = o->fmt_source;
        } else if (IS("--source-format")) {
            if (parse_format(name, val, &o->fmt_source) != 0)
                return -1;
        } else if (IS("--target-format")) {
            if (parse_format(name, val, &o->fmt_target) != 0)
                return -1;
        } else if (IS("--device")) {
            o->device = val;
            if (add_setting(o, PKSS_PARAM_DEVICE, 2, 0, 0, val, "--device",
                            val) != 0)
                return -1;
        } else if (IS("--backend") || IS("--rotations")) {
            long long v;
            int ok = symbolic_value(val, &v) == 0;
            if (IS("--backend"))
                ok = ok && (streq_ci(val, "auto") ||
                            streq_ci(val, "reference") ||
                            streq_ci(val, "opencl"));
            else
                ok = ok && (streq_ci(val, "euler") ||
                            streq_ci(val, "uniform") ||
                            streq_ci(val, "default"));
            if (!ok) {
                fail_msg(USAGE_STATUS, "%s: unknown value '%s' (%s)", name,
                         val,
                         IS("--backend") ? "auto, reference or opencl"
                                         : "euler or uniform");
                return -1;
            }
            if (add_setting(o, IS("--backend") ? PKSS_PARAM_BACKEND
                                               : PKSS_PARAM_ROTATION_SET,
                            0, v, 0, NULL, IS("--backend") ? "--backend"
                                                            : "--rotations",
                            val) != 0)
                return -1;
        } else if (IS("--set")) {
            if (parse_set(o, val) != 0)
                return -1;
        } else if (IS("--no-cull")) {
            if (add_setting(o, PKSS_PARAM_CULL_MUTUAL, 0, PKSS_SWITCH_OFF, 0,
                            NULL, "--no-cull", NULL) != 0 ||
                add_setting(o, PKSS_PARAM_CULL_STAT, 0, PKSS_SWITCH_OFF, 0,
                            NULL, "--no-cull", NULL) != 0)
                return -1;
        } else {
            int found = 0;
            for (k = 0; k < N_PARAM_OPTS && !found; k++) {
                const param_opt *po = &k_param_opts[k];
                long long iv;
                double dv;
                if (!IS(po->opt))
                    continue;
                found = 1;
                if (po->is_double) {
                    if (parse_dbl(val, &dv) != 0) {
                        fail_msg(USAGE_STATUS, "%s: '%s' is not a number",
                                 name, val);
                        return -1;
                    }
                    if (add_setting(o, po->param, 1, 0, dv, NULL, po->opt,
                                    val) != 0)
                        return -1;
                } else {
                    if (parse_ll(val, &iv) != 0) {
                        fail_msg(USAGE_STATUS, "%s: '%s' is not an integer",
                                 name, val);
                        return -1;
                    }
                    if (add_setting(o, po->param, 0, iv, 0, NULL, po->opt,
                                    val) != 0)
                        return -1;
                }
            }
            for (k = 0; k < N_SWITCH_OPTS && !found; k++) {
                if (!IS(k_switch_opts[k].opt))
                    continue;
                found = 1;
                if (add_setting(o, k_switch_opts[k].param, 0,
                                k_switch_opts[k].value, 0, NULL,
                                k_switch_opts[k].opt, NULL) != 0)
                    return -1;
            }
            if (!found) {
                fail_msg(USAGE_STATUS, "unknown option '%s' (see --help)", a);
                return -1;
            }
        }
#undef IS
    }
    if (npos != 2) {
        fail_msg(USAGE_STATUS,
                 "expected SOURCE and TARGET files, got %d (usage: " TOOL
                 " SOURCE TARGET [options]; see --help)",
                 npos);
        return -1;
    }
    if (strcmp(o->source, "-") == 0 && strcmp(o->target, "-") == 0) {
        fail_msg(USAGE_STATUS, "only one input can be standard input");
        return -1;
    }
    return 0;
}

/* -------------------------------------------------------------- output */

/* Checks before the (possibly long) run that an output file can be
 * created; removes it again if it did not exist. */
static int check_output(const char *what, const char *path)
{
    FILE *f;
    int existed;
    if (!path)
        return 0;
    f = fopen(path, "rb");
    existed = f != NULL;
    if (f)
        fclose(f);
    errno = 0;
    f = fopen(path, "ab");
    if (!f) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "%s: cannot write %s: %s", path, what,
                 errno ? strerror(errno) : "unknown error");
        return -1;
    }
    fclose(f);
    if (!existed)
        remove(path);
    return 0;
}

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

static void json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.17g", v);
    else
        fputs("null", f);
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
            "\"thinned\": %llu, "
            "\"after_mutual\": %llu, \"after_stat\": %llu, \"resampled\": "
            "%llu, \"features\": %llu}",
            (unsigned long long)c->input, (unsigned long long)c->nonfinite,
            (unsigned long long)c->duplicates, (unsigned long long)c->thinned,
            (unsigned long long)c->after_mutual,
            (unsigned long long)c->after_stat,
            (unsigned long long)c->resampled,
            (unsigned long long)c->features);
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

static const char *stage_name(uint32_t stage)
{
    switch (stage) {
    case PKSS_STAGE_SEARCH: return "search";
    case PKSS_STAGE_COARSE: return "coarse";
    case PKSS_STAGE_STOPPED: return "stopped";
    case PKSS_STAGE_REFINED: return "refined";
    default: return "unknown";
    }
}

/* Rotation angle of a row-major 3x3 rotation, degrees. */
static double rotation_angle_deg(const double *R)
{
    double tr = R[0] + R[4] + R[8];
    double vx = R[7] - R[5], vy = R[2] - R[6], vz = R[3] - R[1];
    double s = 0.5 * sqrt(vx * vx + vy * vy + vz * vz);
    return atan2(s, 0.5 * (tr - 1.0)) * 180.0 / 3.14159265358979323846;
}

typedef struct run_info {
    const options *o;
    size_t n_source, n_target;
    pkss_io_format fmt_source, fmt_target;
    double load_seconds;
    double prepare_seconds;
} run_info;

static void json_input(FILE *f, const char *path, pkss_io_format fmt,
                       size_t n)
{
    fputs("{\"path\": ", f);
    json_str(f, path);
    fputs(", \"format\": ", f);
    json_str(f, pkss_io_format_name(fmt));
    fprintf(f, ", \"points\": %llu}", (unsigned long long)n);
}

static int write_json(const char *path, const run_info *ri,
                      const pkss_context *ctx, pkss_status st,
                      const pkss_result *r)
{
    FILE *f;
    uint32_t i;
    int id, first = 1;
    errno = 0;
    f = fopen(path, "w");
    if (!f) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "%s: cannot write JSON: %s", path,
                 errno ? strerror(errno) : "unknown error");
        return -1;
    }
    fprintf(f, "{\n  \"tool\": \"" TOOL "\",\n  \"tool_version\": "
               "\"%d.%d.%d\",\n  \"library_version\": ",
            PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR, PKSS_VERSION_PATCH);
    json_str(f, pkss_version_string());
    fputs(",\n  \"source\": ", f);
    json_input(f, ri->o->source, ri->fmt_source, ri->n_source);
    fputs(",\n  \"target\": ", f);
    json_input(f, ri->o->target, ri->fmt_target, ri->n_target);
    fputs(",\n  \"parameters\": {", f);
    for (id = 0; id < MAX_PARAM_ID; id++) {
        const char *n = pkss_param_name((pkss_param)id);
        double v;
        if (!n)
            continue;
        if (!first)
            fputs(", ", f);
        first = 0;
        json_str(f, n);
        fputs(": ", f);
        if (pkss_context_get_double(ctx, (pkss_param)id, &v) == PKSS_OK)
            json_num(f, v);
        else if (id == PKSS_PARAM_DEVICE && ri->o->device)
            json_str(f, ri->o->device);
        else
            fputs("null", f);
    }
    fputs("},\n  \"status\": ", f);
    json_str(f, pkss_status_name(st));
    if (st != PKSS_OK) {
        fputs(",\n  \"detail\": ", f);
        json_str(f, pkss_context_last_error(ctx));
        fputs("\n}\n", f);
    } else {
        fputs(",\n  \"T_target_source\": ", f);
        json_matrix(f, r->T_target_source, 4, 4);
        fputs(",\n  \"scale\": ", f);
        json_num(f, r->scale);
        fputs(",\n  \"rotation\": ", f);
        json_matrix(f, r->rotation, 3, 3);
        fputs(",\n  \"rotation_angle_deg\": ", f);
        json_num(f, rotation_angle_deg(r->rotation));
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
        fprintf(f, ",\n  \"winner\": %u,\n  \"n_candidates\": %u,\n"
                   "  \"candidates\": [",
                (unsigned)r->winner, (unsigned)r->n_candidates);
        for (i = 0; i < r->n_candidates && i < PKSS_MAX_CANDIDATES; i++) {
            const pkss_candidate *c = &r->candidates[i];
            fputs(i ? ",\n    {" : "\n    {", f);
            fputs("\"T_target_source\": ", f);
            json_matrix(f, c->T_target_source, 4, 4);
            fputs(", \"scale\": ", f);
            json_num(f, c->scale);
            fputs(", \"score\": ", f);
            json_num(f, c->score);
            fputs(", \"score_contour\": ", f);
            json_num(f, c->score_contour);
            fputs(", \"score_feature\": ", f);
            json_num(f, c->score_feature);
            fputs(", \"rms\": ", f);
            json_num(f, c->rms);
            fputs(", \"overlap\": ", f);
            json_num(f, c->overlap);
            fputs(", \"fit\": ", f);
            json_num(f, r->candidate_fit[i]);
            fputs(", \"stage\": ", f);
            json_str(f, stage_name(r->candidate_stage[i]));
            fprintf(f, ", \"rotation_index\": %u, \"offset_index\": %u}",
                    (unsigned)c->rotation_index, (unsigned)c->offset_index);
        }
        fprintf(f, "%s],\n  \"n_rotations\": %u,\n  \"n_offsets\": %u,\n"
                   "  \"n_evaluations\": %llu,\n  \"source_counts\": ",
                r->n_candidates ? "\n  " : "", (unsigned)r->n_rotations,
                (unsigned)r->n_offsets, (unsigned long long)r->n_evaluations);
        json_counts(f, &r->source_counts);
        fputs(",\n  \"target_counts\": ", f);
        json_counts(f, &r->target_counts);
        fputs(",\n  \"timings\": {\"load\": ", f);
        json_num(f, ri->load_seconds);
        fputs(", \"prepare\": ", f);
        json_num(f, ri->prepare_seconds);
        fputs(", \"validate\": ", f);
        json_num(f, r->timings.validate);
        fputs(", \"preprocess\": ", f);
        json_num(f, r->timings.preprocess);
        fputs(", \"search\": ", f);
        json_num(f, r->timings.search);
        fputs(", \"refine\": ", f);
        json_num(f, r->timings.refine);
        fputs(", \"total\": ", f);
        json_num(f, r->timings.total);
        fputs("},\n  \"backend\": ", f);
        json_str(f, backend_name(r->backend));
        fputs(",\n  \"device\": ", f);
        {
            char dev[PKSS_NAME_SIZE + 1];
            memcpy(dev, r->device, PKSS_NAME_SIZE);
            dev[PKSS_NAME_SIZE] = '\0';
            json_str(f, dev);
        }
        fputs("\n}\n", f);
    }
    if (ferror(f) | (fclose(f) != 0)) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "%s: write failed while writing JSON", path);
        return -1;
    }
    return 0;
}

static void print_matrix(FILE *f, const double *T, const char *fmt)
{
    int r;
    for (r = 0; r < 4; r++)
        fprintf(f, fmt, T[4 * r], T[4 * r + 1], T[4 * r + 2], T[4 * r + 3]);
}

static int write_matrix(const char *path, const double *T)
{
    FILE *f;
    errno = 0;
    f = fopen(path, "w");
    if (!f) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "%s: cannot write the matrix: %s", path,
                 errno ? strerror(errno) : "unknown error");
        return -1;
    }
    print_matrix(f, T, "%.17g %.17g %.17g %.17g\n");
    if (ferror(f) | (fclose(f) != 0)) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "%s: write failed while writing the matrix", path);
        return -1;
    }
    return 0;
}

static int write_aligned(const char *path, const double *xyz, size_t n,
                         const double *T, int ascii)
{
    double *out;
    size_t i;
    char err[1024];
    pkss_io_status st;
    out = (double *)malloc((n ? n : 1) * 3 * sizeof(double));
    if (!out) {
        fail_msg(pkss_status_name(PKSS_ERR_OUT_OF_MEMORY), "cannot transform %llu points",
                 (unsigned long long)n);
        return EXIT_FAILURE_REG;
    }
    for (i = 0; i < n; i++) {
        const double *p = xyz + 3 * i;
        int k;
        for (k = 0; k < 3; k++)
            out[3 * i + k] = T[4 * k] * p[0] + T[4 * k + 1] * p[1] +
                             T[4 * k + 2] * p[2] + T[4 * k + 3];
    }
    st = pkss_io_write_ply(path, out, n, ascii, err, sizeof err);
    free(out);
    if (st != PKSS_IO_OK) {
        fail_msg(pkss_io_status_name(st), "%s", err);
        return exit_for_io(st);
    }
    return EXIT_OK;
}

static void print_counts(const char *which, const pkss_counts *c)
{
    fprintf(stderr,
            "  %-6s input %llu, nonfinite %llu, duplicates %llu, thinned %llu, "
            "after_mutual %llu, after_stat %llu, resampled %llu, features %llu\n",
            which, (unsigned long long)c->input,
            (unsigned long long)c->nonfinite, (unsigned long long)c->duplicates,
            (unsigned long long)c->thinned,
            (unsigned long long)c->after_mutual,
            (unsigned long long)c->after_stat,
            (unsigned long long)c->resampled,
            (unsigned long long)c->features);
}

static void print_verbose(const run_info *ri, const pkss_result *r)
{
    uint32_t i;
    fprintf(stderr, TOOL ": times (s): load %.3f, prepare %.3f, validate "
                    "%.3f, preprocess %.3f, search %.3f, refine %.3f, "
                    "registration total %.3f\n",
            ri->load_seconds, ri->prepare_seconds, r->timings.validate,
            r->timings.preprocess,
            r->timings.search, r->timings.refine, r->timings.total);
    fprintf(stderr, TOOL ": points per step:\n");
    print_counts("source", &r->source_counts);
    print_counts("target", &r->target_counts);
    int wide = r->n_evaluations > (uint64_t)r->n_rotations * r->n_offsets;
    fprintf(stderr,
            TOOL ": searched %u rotations x %u offsets%s (%llu evaluations), "
                 "backend %s\n",
            (unsigned)r->n_rotations, (unsigned)r->n_offsets,
            wide ? ", twice (then on the wide offset grid)" : "",
            (unsigned long long)r->n_evaluations, backend_name(r->backend));
    fprintf(stderr, TOOL ": candidates (best score first%s, * = winner):\n",
            wide ? " in each search; wide# = wide offset grid" : "");
    for (i = 0; i < r->n_candidates && i < PKSS_MAX_CANDIDATES; i++) {
        const pkss_candidate *c = &r->candidates[i];
        int on_wide = c->offset_index >= r->n_offsets;
        fprintf(stderr,
                "  %c%2u score %.5f (contour %.5f, feature %.5f) scale "
                "%.6g rms %.6g overlap %.4f fit %.4f %-7s rot#%u %s#%u\n",
                i == r->winner ? '*' : ' ', (unsigned)i, c->score,
                c->score_contour, c->score_feature, c->scale, c->rms,
                c->overlap, r->candidate_fit[i],
                stage_name(r->candidate_stage[i]), (unsigned)c->rotation_index,
                on_wide ? "wide" : "off",
                (unsigned)(c->offset_index - (on_wide ? r->n_offsets : 0)));
    }
}

/* ---------------------------------------------------------------- main */

static int load(const char *what, const char *path, pkss_io_format fmt,
                double **xyz, size_t *n, pkss_io_format *used)
{
    char err[1024];
    pkss_io_status st;
    if (fmt == PKSS_IO_AUTO && strcmp(path, "-") == 0) {
        fail_msg(USAGE_STATUS,
                 "%s is standard input: give its format with --%s-format",
                 what, what);
        return EXIT_USAGE;
    }
    *used = fmt != PKSS_IO_AUTO ? fmt : pkss_io_format_from_path(path);
    st = pkss_io_read(path, fmt, xyz, n, err, sizeof err);
    if (st != PKSS_IO_OK) {
        fail_msg(pkss_io_status_name(st), "%s", err);
        return exit_for_io(st);
    }
    return EXIT_OK;
}

int main(int argc, char **argv)
{
    options o;
    run_info ri;
    double *src = NULL, *tgt = NULL, t0;
    size_t ns = 0, nt = 0;
    pkss_context *ctx = NULL;
    pkss_result res;
    pkss_status st;
    int rc, i;

    rc = parse_args(argc, argv, &o);
    if (rc != 0)
        return rc < 0 ? EXIT_USAGE : EXIT_OK;

    if (check_output("the aligned cloud", o.out_ply) != 0 ||
        check_output("JSON", o.json) != 0 ||
        check_output("the matrix", o.matrix) != 0)
        return EXIT_IO;

    memset(&ri, 0, sizeof ri);
    ri.o = &o;
    st = pkss_context_create(&ctx);
    if (st != PKSS_OK) {
        fail_msg(pkss_status_name(st), "cannot create a context: %s",
                 pkss_status_string(st));
        rc = exit_for_status(st);
        goto done;
    }
    for (i = 0; i < o.n_settings; i++) {
        const setting *s = &o.settings[i];
        if (s->kind == 0)
            st = pkss_context_set_int(ctx, s->param, s->i);
        else if (s->kind == 1)
            st = pkss_context_set_double(ctx, s->param, s->d);
        else
            st = pkss_context_set_string(ctx, s->param, s->s);
        if (st != PKSS_OK) {
            const char *detail = pkss_context_last_error(ctx);
            fail_msg(pkss_status_name(st), "%s%s%s: %s", s->opt,
                     s->text ? " " : "", s->text ? s->text : "",
                     detail[0] ? detail : pkss_status_string(st));
            rc = EXIT_USAGE;
            goto done;
        }
    }

    /* Parameters are checked above, before the (possibly slow) loading. */
    t0 = wall_seconds();
    rc = load("source", o.source, o.fmt_source, &src, &ns, &ri.fmt_source);
    if (rc == EXIT_OK)
        rc = load("target", o.target, o.fmt_target, &tgt, &nt,
                  &ri.fmt_target);
    if (rc != EXIT_OK)
        goto done;
    ri.n_source = ns;
    ri.n_target = nt;
    ri.load_seconds = wall_seconds() - t0;
    if (o.verbose)
        fprintf(stderr,
                TOOL ": source %s: %llu points; target %s: %llu points "
                     "(loaded in %.3f s)\n",
                o.source, (unsigned long long)ns, o.target,
                (unsigned long long)nt, ri.load_seconds);

    /* Optional (registration prepares lazily), but it times the device
     * set-up and kernel build apart from the stages of pkss_timings. */
    pkss_result_init(&res);
    t0 = wall_seconds();
    st = pkss_context_prepare(ctx);
    ri.prepare_seconds = wall_seconds() - t0;
    if (st != PKSS_OK) {
        const char *detail = pkss_context_last_error(ctx);
        if (o.json)
            write_json(o.json, &ri, ctx, st, &res);
        fail_msg(pkss_status_name(st), "%s", detail[0] ? detail
                                                        : pkss_status_string(st));
        rc = exit_for_status(st);
        goto done;
    }
    if (o.verbose)
        fprintf(stderr, TOOL ": device %s prepared in %.3f s\n",
                pkss_context_device_name(ctx), ri.prepare_seconds);

    st = pkss_register(ctx, src, ns, tgt, nt, &res);
    if (o.json && write_json(o.json, &ri, ctx, st, &res) != 0 &&
        st == PKSS_OK) {
        rc = EXIT_IO;
        goto done;
    }
    if (st != PKSS_OK) {
        const char *detail = pkss_context_last_error(ctx);
        fail_msg(pkss_status_name(st), "%s", detail[0] ? detail
                                                        : pkss_status_string(st));
        rc = exit_for_status(st);
        goto done;
    }

    print_matrix(stdout, res.T_target_source, "%.9g %.9g %.9g %.9g\n");
    if (!o.quiet) {
        char dev[PKSS_NAME_SIZE + 1];
        memcpy(dev, res.device, PKSS_NAME_SIZE);
        dev[PKSS_NAME_SIZE] = '\0';
        printf("scale=%.9g rotation_deg=%.6f rms=%.6g overlap=%.4f "
               "time_s=%.3f device=%s\n",
               res.scale, rotation_angle_deg(res.rotation), res.rms,
               res.overlap, res.timings.total, dev);
    }
    fflush(stdout);
    if (o.verbose)
        print_verbose(&ri, &res);

    rc = EXIT_OK;
    if (o.matrix && write_matrix(o.matrix, res.T_target_source) != 0)
        rc = EXIT_IO;
    if (rc == EXIT_OK && o.out_ply)
        rc = write_aligned(o.out_ply, src, ns, res.T_target_source, o.ascii);
done:
    pkss_context_destroy(ctx);
    pkss_io_free(src);
    pkss_io_free(tgt);
    if (fflush(stdout) != 0 && rc == EXIT_OK) {
        fail_msg(pkss_io_status_name(PKSS_IO_ERR_OPEN),
                 "cannot write to standard output");
        rc = EXIT_IO;
    }
    return rc;
}
