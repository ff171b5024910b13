/* SPDX-License-Identifier: MIT
 * options.c -- pkss-align's command line. The parameter options and their
 * --help text are generated at run time from the library's one table
 * (pkss_param_count / pkss_param_at), so the tool never restates a range,
 * default or description: every parameter NAME is `--NAME` with '_' written
 * '-', e.g. --rotation-steps 16, --drop-nonfinite off, --backend reference.
 * The few aliases below keep the option names of earlier releases working.
 *
 * Parsing follows getopt_long (bundled short options -qv, -oFILE or -o
 * FILE, --opt=value or --opt value, options and operands in any order,
 * "--" ends the options) but does not accept abbreviated long options:
 * with options generated from a table that grows, an abbreviation that
 * works today could become ambiguous in the next release.
 */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------ parameter table */

typedef struct cli_param {
    pkss_param_info info;
    char opt[64]; /* name with '_' -> '-' */
} cli_param;

static cli_param *g_params;
static size_t g_n_params;

/* Loads the library's parameter table once. @return 0 or -1. */
static int load_params(void)
{
    size_t i, n;
    if (g_params)
        return 0;
    n = pkss_param_count();
    g_params = (cli_param *)calloc(n ? n : 1, sizeof *g_params);
    if (!g_params) {
        cli_fail("PKSS_ERR_OUT_OF_MEMORY", "cannot list the parameters");
        return -1;
    }
    for (i = 0; i < n; i++) {
        cli_param *p = &g_params[g_n_params];
        size_t k;
        pkss_param_info_init(&p->info, sizeof p->info);
        if (pkss_param_at(i, &p->info) != PKSS_OK || !p->info.name ||
            strlen(p->info.name) >= sizeof p->opt)
            continue; /* an entry this tool cannot describe is left out */
        for (k = 0; p->info.name[k]; k++)
            p->opt[k] = p->info.name[k] == '_' ? '-' : p->info.name[k];
        p->opt[k] = '\0';
        if (!p->info.unit)
            p->info.unit = "";
        if (!p->info.choices)
            p->info.choices = "";
        if (!p->info.constraint)
            p->info.constraint = "";
        if (!p->info.doc)
            p->info.doc = "";
        g_n_params++;
    }
    return 0;
}

static const cli_param *param_by_opt(const char *opt)
{
    size_t i;
    for (i = 0; i < g_n_params; i++)
        if (strcmp(g_params[i].opt, opt) == 0)
            return &g_params[i];
    return NULL;
}

/* --set takes the library name or the option spelling. */
static const cli_param *param_by_name(const char *name)
{
    size_t i;
    for (i = 0; i < g_n_params; i++)
        if (strcmp(g_params[i].info.name, name) == 0)
            return &g_params[i];
    return param_by_opt(name);
}

/* Option names of earlier releases: an alias names a parameter and, for
 * the --no-* flags, the value it sets. Only names, no facts about values. */
static const struct alias {
    const char *opt, *param, *value;
} k_aliases[] = {
    {"steps", "rotation_steps", NULL},   {"offsets", "offset_steps", NULL},
    {"cells", "cell_steps", NULL},       {"rotations", "rotation_set", NULL},
    {"no-features", "use_features", "off"},
    {"no-mutual", "cull_mutual", "off"}, {"no-stat", "cull_stat", "off"},
    {"no-prealign", "pca_prealign", "off"},
};
#define N_ALIASES (sizeof k_aliases / sizeof k_aliases[0])

/* ------------------------------------------------------------- values */

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

static int lower_eq(const char *a, const char *b, size_t bn)
{
    size_t k;
    for (k = 0; k < bn; k++) {
        char x = a[k], y = b[k];
        if (x >= 'A' && x <= 'Z')
            x = (char)(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z')
            y = (char)(y - 'A' + 'a');
        if (x != y || x == '\0')
            return 0;
    }
    return a[bn] == '\0';
}

const char *cli_choice_name(const char *choices, long long v, char *buf,
                            size_t size)
{
    const char *p = choices;
    long long k = 0;
    if (!choices || !*choices || v < 0 || size == 0)
        return NULL;
    while (k < v) {
        p = strchr(p, '|');
        if (!p)
            return NULL;
        p++;
        k++;
    }
    {
        size_t len = strcspn(p, "|");
        if (len == 0 || len >= size)
            return NULL;
        memcpy(buf, p, len);
        buf[len] = '\0';
    }
    return buf;
}

/* The number of the value called `word` in a '|'-list, or -1. */
static long long choice_value(const char *choices, const char *word)
{
    const char *p = choices;
    long long k = 0;
    while (p && *p) {
        size_t len = strcspn(p, "|");
        if (lower_eq(word, p, len))
            return k;
        p += len;
        if (*p == '|')
            p++;
        k++;
    }
    return -1;
}

/* Switch values: the table's names, their usual synonyms, or a number. */
static int switch_value(const cli_param *p, const char *v, long long *out)
{
    static const struct {
        const char *word;
        long long value;
    } k_syn[] = {{"yes", PKSS_SWITCH_ON},   {"true", PKSS_SWITCH_ON},
                 {"no", PKSS_SWITCH_OFF},   {"false", PKSS_SWITCH_OFF}};
    size_t i;
    long long c = choice_value(p->info.choices, v);
    if (c >= 0) {
        *out = c;
        return 0;
    }
    for (i = 0; i < sizeof k_syn / sizeof k_syn[0]; i++)
        if (lower_eq(v, k_syn[i].word, strlen(k_syn[i].word))) {
            *out = k_syn[i].value;
            return 0;
        }
    return parse_ll(v, out); /* the library checks the range */
}

/* Human list of a '|'-list: "auto, reference or opencl". */
static void print_choices(FILE *f, const char *choices, int skip_default)
{
    char buf[64];
    long long k, n = 0;
    while (cli_choice_name(choices, n, buf, sizeof buf))
        n++;
    for (k = skip_default; k < n; k++) {
        cli_choice_name(choices, k, buf, sizeof buf);
        fprintf(f, "%s%s", k == skip_default ? "" : k == n - 1 ? " or " : ", ",
                buf);
    }
}

static int add_setting(cli_options *o, const cli_param *p, const char *opt,
                       const char *val)
{
    cli_setting *st;
    if (o->n_settings >= CLI_MAX_SETTINGS) {
        cli_fail(USAGE_STATUS, "too many parameter options");
        return -1;
    }
    st = &o->settings[o->n_settings];
    memset(st, 0, sizeof *st);
    st->param = (pkss_param)p->info.id;
    st->type = p->info.type;
    snprintf(st->opt, sizeof st->opt, "%s", opt);
    st->text = val;
    /* "default" is 0, which every parameter takes as its default */
    if (lower_eq(val, "default", 7) && p->info.type == PKSS_TYPE_DOUBLE) {
        o->n_settings++;
        return 0;
    }
    switch (p->info.type) {
    case PKSS_TYPE_INT:
        if (lower_eq(val, "default", 7))
            break;
        if (parse_ll(val, &st->i) != 0) {
            cli_fail(USAGE_STATUS, "%s: '%s' is not an integer", opt, val);
            return -1;
        }
        break;
    case PKSS_TYPE_DOUBLE:
        if (parse_dbl(val, &st->d) != 0) {
            cli_fail(USAGE_STATUS, "%s: '%s' is not a number", opt, val);
            return -1;
        }
        break;
    case PKSS_TYPE_SWITCH:
        if (switch_value(p, val, &st->i) != 0) {
            cli_fail(USAGE_STATUS, "%s: unknown value '%s' (on, off or "
                     "default)", opt, val);
            return -1;
        }
        break;
    case PKSS_TYPE_CHOICE:
        st->i = choice_value(p->info.choices, val);
        if (st->i < 0 && parse_ll(val, &st->i) != 0) {
            fprintf(stderr, TOOL ": " USAGE_STATUS ": %s: unknown value '%s' (",
                    opt, val);
            print_choices(stderr, p->info.choices,
                          strncmp(p->info.choices, "default|", 8) == 0);
            fputs(")\n", stderr);
            return -1;
        }
        break;
    case PKSS_TYPE_STRING:
        st->s = val;
        break;
    default:
        cli_fail(USAGE_STATUS, "%s: parameter type %d unknown to this tool",
                 opt, (int)p->info.type);
        return -1;
    }
    o->n_settings++;
    return 0;
}

static int is_switch_word(const char *v)
{
    static const char *const k[] = {"on",  "off", "default", "yes", "no",
                                    "true", "false", "0",    "1",   "2"};
    size_t i;
    for (i = 0; i < sizeof k / sizeof k[0]; i++)
        if (lower_eq(v, k[i], strlen(k[i])))
            return 1;
    return 0;
}

/* ---------------------------------------------------------------- help */

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

static void print_aliases(const cli_param *p)
{
    size_t k;
    int first = 1;
    if (p->info.type == PKSS_TYPE_SWITCH) {
        printf("; --no-%s", p->opt);
        first = 0;
    }
    for (k = 0; k < N_ALIASES; k++)
        if (strcmp(k_aliases[k].param, p->info.name) == 0) {
            printf("%s--%s", first ? "; also " : ", ", k_aliases[k].opt);
            first = 0;
        }
}

static void print_param_help(const cli_param *p)
{
    char left[96], def[64];
    const pkss_param_info *in = &p->info;
    switch (in->type) {
    case PKSS_TYPE_SWITCH:
        snprintf(left, sizeof left, "--%s[=on|off]", p->opt);
        break;
    case PKSS_TYPE_CHOICE: {
        const char *c = in->choices;
        if (strncmp(c, "default|", 8) == 0)
            c += 8;
        snprintf(left, sizeof left, "--%s %s", p->opt, c);
        break;
    }
    case PKSS_TYPE_STRING:
        snprintf(left, sizeof left, "--%s S", p->opt);
        break;
    case PKSS_TYPE_DOUBLE:
        snprintf(left, sizeof left, "--%s X", p->opt);
        break;
    default:
        snprintf(left, sizeof left, "--%s N", p->opt);
        break;
    }
    printf("  %-24s", left);
    if (strlen(left) > 24)
        printf("\n  %-24s", "");
    if (in->type == PKSS_TYPE_SWITCH || in->type == PKSS_TYPE_CHOICE) {
        if (!cli_choice_name(in->choices, (long long)in->default_value, def,
                             sizeof def))
            snprintf(def, sizeof def, "%.15g", in->default_value);
        printf(" default %s", def);
    } else if (in->type == PKSS_TYPE_STRING) {
        printf(" string");
    } else {
        printf(" default %.15g, %s in [%.15g, %.15g]", in->default_value,
               in->type == PKSS_TYPE_DOUBLE ? "real" : "integer", in->lower,
               in->upper);
        if (in->unit[0])
            printf(" %s", in->unit);
        if (in->constraint[0])
            printf(", %s", in->constraint);
    }
    print_aliases(p);
    printf("\n  %-24s %s\n", "", in->doc);
}

static void print_help(void)
{
    size_t i;
    printf(
        "Usage: " TOOL " SOURCE TARGET [options]\n"
        "Registers SOURCE onto TARGET: finds s, R, t with\n"
        "  TARGET ~= s * R * SOURCE + t   (T_target_source, no initial "
        "guess)\n"
        "and prints the 4x4 T_target_source (4 lines) and a summary line.\n"
        "\n"
        "Input files: .ply .pcd .xyz .txt .csv .pts .off .bin (KITTI) .vtk.\n"
        "'-' reads standard input: PLY, PCD, OFF and VTK are recognised "
        "from the\n"
        "content, other formats need --source-format/--target-format.\n"
        "\n"
        "Output (every FILE may be '-' for standard output; a file is "
        "written to a\n"
        "temporary file beside it and renamed over it when complete, so "
        "an\n"
        "interrupted run never leaves a partial file; FIFOs and devices "
        "are written\n"
        "directly; an output naming an input or another output is "
        "refused):\n"
        "  -o, --output FILE       SOURCE transformed by the result; the "
        "format follows\n"
        "                          the extension: .ply .pcd .xyz .npy\n"
        "  --output-format F       ply, pcd, xyz or npy (needed for '-' and "
        "names without\n"
        "                          one of those extensions)\n"
        "  --ascii                 write PLY as text (default binary "
        "little-endian\n"
        "                          double; PCD and XYZ are text, %%.17g, "
        "exact)\n"
        "  --json FILE             the whole result (all candidates, "
        "schema_version 1)\n"
        "                          as JSON; on a registration failure the "
        "status and detail\n"
        "  --matrix FILE           the 4x4 T_target_source only (%%.17g)\n"
        "  -q, --quiet             print only the matrix\n"
        "  --min-confidence X      exit 6 when the result's confidence (the "
        "estimated\n"
        "                          probability that the pose is right) is "
        "below X in\n"
        "                          [0, 1]; the outputs are written all the "
        "same\n"
        "  -v, --verbose           progress as it happens, stage times, "
        "point counts and\n"
        "                          candidates on stderr\n"
        "  --format F              format of both inputs (ply pcd xyz txt "
        "csv pts off bin\n"
        "                          vtk)\n"
        "  --source-format F, --target-format F   format of one input\n"
        "When an output goes to standard output, the matrix and summary "
        "are not printed.\n"
        "\n"
        "Parameters (from the runtime library's table, pkss_param_at(); "
        "the value 0 or\n"
        "'default' means the library default; switches alone mean on):\n");
    for (i = 0; i < g_n_params; i++)
        print_param_help(&g_params[i]);
    printf("  %-24s --no-cull-mutual and --no-cull-stat\n", "--no-cull");
    printf("  %-24s any parameter above by name (NAME as in pkss.h, e.g.\n"
           "  %-24s rotation_steps=16, or its option spelling)\n",
           "--set NAME=VALUE", "");
    printf(
        "\n"
        "Other:\n"
        "  --version               print the tool and runtime library "
        "versions\n"
        "  -h, --help              this text\n"
        "\n"
        "Exit codes:\n"
        "  0    success\n"
        "  2    usage error (unknown option, bad or out-of-range value, "
        "unknown format\n"
        "       or output extension, an output naming an input or another "
        "output)\n"
        "  3    I/O error (cannot open, read or write a file, standard "
        "output included)\n"
        "  4    bad input data (malformed or empty file, NaN/Inf without\n"
        "       --drop-nonfinite, too few points, degenerate or "
        "out-of-range cloud)\n"
        "  5    registration failure (no device, OpenCL error, no "
        "consensus, out of\n"
        "       memory, internal error)\n"
        "  6    the result's confidence is below --min-confidence (the "
        "outputs were\n"
        "       written)\n"
        "  130  interrupted (SIGINT; 143 for SIGTERM): the run is "
        "cancelled, no output\n"
        "       file is written or changed\n"
        "Errors print one line on stderr: " TOOL ": STATUS_NAME: detail\n");
}

/* ------------------------------------------------------------- parsing */

static int parse_format(const char *opt, const char *v, pkss_format *out)
{
    pkss_format f = pkss_format_from_name(v);
    if (pkss_format_name(f) == NULL) {
        cli_fail(USAGE_STATUS,
                 "%s: unknown format '%s' (ply pcd xyz txt csv pts off bin "
                 "kitti vtk auto)",
                 opt, v);
        return -1;
    }
    *out = f;
    return 0;
}

static int parse_set(cli_options *o, const char *arg)
{
    char name[80];
    const char *eq = strchr(arg, '=');
    const cli_param *p;
    if (!eq || eq == arg || (size_t)(eq - arg) >= sizeof name) {
        cli_fail(USAGE_STATUS, "--set expects NAME=VALUE, got '%s'", arg);
        return -1;
    }
    memcpy(name, arg, (size_t)(eq - arg));
    name[eq - arg] = '\0';
    p = param_by_name(name);
    if (!p) {
        cli_fail("PKSS_ERR_UNKNOWN_PARAMETER",
                 "--set: the library has no parameter '%s' (see --help)",
                 name);
        return -1;
    }
    {
        char opt[96];
        snprintf(opt, sizeof opt, "--set %s", name);
        return add_setting(o, p, opt, eq + 1);
    }
}

enum { ARG_NONE, ARG_REQUIRED };

/* The tool's own long options (the parameters come from the table). */
static const struct tool_opt {
    const char *name;
    int arg;
    int id;
} k_tool_opts[] = {
    {"help", ARG_NONE, 'h'},          {"version", ARG_NONE, 'V'},
    {"quiet", ARG_NONE, 'q'},         {"verbose", ARG_NONE, 'v'},
    {"ascii", ARG_NONE, 'a'},         {"output", ARG_REQUIRED, 'o'},
    {"json", ARG_REQUIRED, 'j'},      {"matrix", ARG_REQUIRED, 'm'},
    {"format", ARG_REQUIRED, 'f'},    {"source-format", ARG_REQUIRED, 's'},
    {"target-format", ARG_REQUIRED, 't'},
    {"output-format", ARG_REQUIRED, 'O'},
    {"set", ARG_REQUIRED, 'S'},       {"no-cull", ARG_NONE, 'C'},
    {"min-confidence", ARG_REQUIRED, 'c'},
};
#define N_TOOL_OPTS (sizeof k_tool_opts / sizeof k_tool_opts[0])

/* Applies one tool option. @return -1 usage error, 0 go on, 1 exit 0. */
static int tool_option(cli_options *o, int id, const char *opt,
                       const char *val)
{
    const cli_param *p;
    switch (id) {
    case 'h': print_help(); return 1;
    case 'V': print_version(); return 1;
    case 'q': o->quiet = 1; return 0;
    case 'v': o->verbose = 1; return 0;
    case 'a': o->ascii = 1; return 0;
    case 'o': o->out_cloud = val; return 0;
    case 'j': o->json = val; return 0;
    case 'm': o->matrix = val; return 0;
    case 'f':
        if (parse_format(opt, val, &o->fmt_source) != 0)
            return -1;
        o->fmt_target = o->fmt_source;
        return 0;
    case 's': return parse_format(opt, val, &o->fmt_source);
    case 't': return parse_format(opt, val, &o->fmt_target);
    case 'O':
        o->out_format = cli_cloud_format_from_name(val);
        if (o->out_format == PKSS_FORMAT_AUTO) {
            cli_fail(USAGE_STATUS, "%s: cannot write '%s' (ply, pcd, xyz or npy)",
                     opt, val);
            return -1;
        }
        return 0;
    case 'S': return parse_set(o, val);
    case 'c':
        if (parse_dbl(val, &o->min_confidence) != 0 || o->min_confidence < 0.0 ||
            o->min_confidence > 1.0) {
            cli_fail(USAGE_STATUS, "%s: '%s' is not a number in [0, 1]", opt,
                     val ? val : "");
            return -1;
        }
        return 0;
    case 'C':
        if ((p = param_by_name("cull_mutual")) != NULL &&
            add_setting(o, p, opt, "off") != 0)
            return -1;
        if ((p = param_by_name("cull_stat")) != NULL &&
            add_setting(o, p, opt, "off") != 0)
            return -1;
        return 0;
    default: return -1;
    }
}

/* One long option "--name[=value]" at argv[*i]. */
static int long_option(cli_options *o, int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    const char *body = a + 2, *eq = strchr(body, '='), *val = eq ? eq + 1 : NULL;
    char name[80];
    size_t len = eq ? (size_t)(eq - body) : strlen(body), k;
    const cli_param *p;
    const char *forced = NULL;
    if (len >= sizeof name) {
        cli_fail(USAGE_STATUS, "unknown option '%s' (see --help)", a);
        return -1;
    }
    memcpy(name, body, len);
    name[len] = '\0';

    for (k = 0; k < N_TOOL_OPTS; k++) {
        const struct tool_opt *t = &k_tool_opts[k];
        char opt[96];
        if (strcmp(t->name, name) != 0)
            continue;
        snprintf(opt, sizeof opt, "--%s", name);
        if (t->arg == ARG_NONE && val) {
            cli_fail(USAGE_STATUS, "option %s takes no value", opt);
            return -1;
        }
        if (t->arg == ARG_REQUIRED && !val) {
            if (*i + 1 >= argc) {
                cli_fail(USAGE_STATUS, "option %s needs a value", opt);
                return -1;
            }
            val = argv[++*i];
        }
        return tool_option(o, t->id, opt, val);
    }

    p = param_by_opt(name);
    for (k = 0; !p && k < N_ALIASES; k++)
        if (strcmp(k_aliases[k].opt, name) == 0) {
            p = param_by_name(k_aliases[k].param);
            forced = k_aliases[k].value;
        }
    if (!p && strncmp(name, "no-", 3) == 0) {
        p = param_by_opt(name + 3);
        if (p && p->info.type != PKSS_TYPE_SWITCH)
            p = NULL;
        forced = "off";
    }
    if (!p) {
        cli_fail(USAGE_STATUS, "unknown option '%s' (see --help)", a);
        return -1;
    }
    {
        char opt[96];
        snprintf(opt, sizeof opt, "--%s", name);
        if (forced) {
            if (val) {
                cli_fail(USAGE_STATUS, "option %s takes no value", opt);
                return -1;
            }
            return add_setting(o, p, opt, forced);
        }
        if (p->info.type == PKSS_TYPE_SWITCH && !val) {
            /* a switch alone means on; a following on/off/... is its value */
            if (*i + 1 < argc && is_switch_word(argv[*i + 1]))
                val = argv[++*i];
            else
                val = "on";
            return add_setting(o, p, opt, val);
        }
        if (!val) {
            if (*i + 1 >= argc) {
                cli_fail(USAGE_STATUS, "option %s needs a value", opt);
                return -1;
            }
            val = argv[++*i];
        }
        return add_setting(o, p, opt, val);
    }
}

/* A bundle of short options: -qv, -o FILE, -oFILE, -vo FILE. */
static int short_options(cli_options *o, int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    size_t j;
    for (j = 1; a[j]; j++) {
        int rc;
        char opt[3] = {'-', a[j], '\0'};
        switch (a[j]) {
        case 'h': return tool_option(o, 'h', opt, NULL);
        case 'q': rc = tool_option(o, 'q', opt, NULL); break;
        case 'v': rc = tool_option(o, 'v', opt, NULL); break;
        case 'o': {
            const char *val = a[j + 1] ? a + j + 1 : NULL;
            if (!val) {
                if (*i + 1 >= argc) {
                    cli_fail(USAGE_STATUS, "option -o needs a value");
                    return -1;
                }
                val = argv[++*i];
            }
            return tool_option(o, 'o', opt, val);
        }
        default:
            cli_fail(USAGE_STATUS, "unknown option '-%c' in '%s' (see --help)",
                     a[j], a);
            return -1;
        }
        if (rc != 0)
            return rc;
    }
    return 0;
}

int cli_parse_args(int argc, char **argv, cli_options *o)
{
    int i, npos = 0, only_pos = 0;
    memset(o, 0, sizeof *o);
    o->fmt_source = o->fmt_target = PKSS_FORMAT_AUTO;
    o->min_confidence = -1.0;
    if (load_params() != 0)
        return -1;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        int rc;
        if (only_pos || a[0] != '-' || strcmp(a, "-") == 0) {
            if (npos == 0)
                o->source = a;
            else if (npos == 1)
                o->target = a;
            else {
                cli_fail(USAGE_STATUS,
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
        rc = a[1] == '-' ? long_option(o, argc, argv, &i)
                         : short_options(o, argc, argv, &i);
        if (rc != 0)
            return rc;
    }
    if (npos != 2) {
        cli_fail(USAGE_STATUS,
                 "expected SOURCE and TARGET files, got %d (usage: " TOOL
                 " SOURCE TARGET [options]; see --help)",
                 npos);
        return -1;
    }
    if (strcmp(o->source, "-") == 0 && strcmp(o->target, "-") == 0) {
        cli_fail(USAGE_STATUS, "only one input can be standard input");
        return -1;
    }
    return 0;
}
