/* SPDX-License-Identifier: MIT
 * pkss_info.c -- pkss-info: the library version and build, the OpenCL
 * devices as pkss sees them (the indices --device and PKSS_DEVICE take)
 * and the parameters with their defaults and ranges, from the library's
 * table (pkss_param_at). A thin client of pkss.h. --params prints the
 * parameters alone, tab-separated, for scripts. Exit codes: 0 (also when
 * no device is found), 2 usage error, 3 cannot write standard output.
 */
#include "pkss.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TOOL "pkss-info"

static void print_devices(void)
{
    unsigned count = 0, i;
    pkss_status st = pkss_device_count(&count);
    if (st != PKSS_OK) {
        printf("OpenCL devices: none (%s: %s)\n", pkss_status_name(st),
               pkss_status_string(st));
        printf("  %s\n", pkss_no_device_reason());
        return;
    }
    if (count == 0) {
        printf("OpenCL devices: none\n  %s\n", pkss_no_device_reason());
        return;
    }
    printf("OpenCL devices: %u\n", count);
    for (i = 0; i < count; i++) {
        pkss_device_desc d;
        memset(&d, 0, sizeof d);
        st = pkss_device_info(i, &d);
        if (st != PKSS_OK) {
            printf("  [%u] (%s: %s)\n", i, pkss_status_name(st),
                   pkss_status_string(st));
            continue;
        }
        /* the strings are fixed buffers: never trust a terminator */
        d.name[sizeof d.name - 1] = '\0';
        d.vendor[sizeof d.vendor - 1] = '\0';
        d.platform[sizeof d.platform - 1] = '\0';
        d.version[sizeof d.version - 1] = '\0';
        printf("  [%u] %s\n", i, d.name);
        printf("      vendor:   %s\n", d.vendor);
        printf("      platform: %s\n", d.platform);
        printf("      version:  %s\n", d.version);
        printf("      type:     %s, fp64 %s, %u compute units, %.1f MiB "
               "global memory\n",
               d.is_gpu ? "GPU" : "CPU/other", d.has_fp64 ? "yes" : "no",
               d.compute_units,
               (double)d.global_mem_bytes / (1024.0 * 1024.0));
    }
}

static const char *type_name(int32_t t)
{
    switch (t) {
    case PKSS_TYPE_INT: return "int";
    case PKSS_TYPE_DOUBLE: return "double";
    case PKSS_TYPE_SWITCH: return "switch";
    case PKSS_TYPE_CHOICE: return "choice";
    case PKSS_TYPE_STRING: return "string";
    default: return "unknown";
    }
}

/* Value `v` of a '|'-separated list of names into buf; "" if none. */
static const char *choice_name(const char *choices, double v, char *buf,
                               size_t size)
{
    const char *p = choices ? choices : "";
    long k;
    size_t len;
    buf[0] = '\0';
    if (v < 0 || v != (double)(long)v)
        return buf;
    for (k = 0; k < (long)v && p; k++) {
        p = strchr(p, '|');
        if (p)
            p++;
    }
    if (!p)
        return buf;
    len = strcspn(p, "|");
    if (len >= size)
        len = size - 1;
    memcpy(buf, p, len);
    buf[len] = '\0';
    return buf;
}

/* The default as the tools spell it: a switch or choice by name. */
static const char *default_text(const pkss_param_info *in, char *buf,
                                size_t size)
{
    if (in->type == PKSS_TYPE_STRING)
        buf[0] = '\0';
    else if ((in->type == PKSS_TYPE_SWITCH || in->type == PKSS_TYPE_CHOICE) &&
             choice_name(in->choices, in->default_value, buf, size)[0])
        ;
    else
        snprintf(buf, size, "%.15g", in->default_value);
    return buf;
}

static int param_at(size_t i, pkss_param_info *in)
{
    pkss_param_info_init(in, sizeof *in);
    if (pkss_param_at(i, in) != PKSS_OK || !in->name)
        return -1;
    if (!in->unit) in->unit = "";
    if (!in->choices) in->choices = "";
    if (!in->constraint) in->constraint = "";
    if (!in->doc) in->doc = "";
    return 0;
}

/* Human-readable, from the library's table (pkss_param_at). */
static void print_params(void)
{
    size_t i, n = pkss_param_count();
    printf("Parameters (name, id, type, default, range; 0 always means "
           "default):\n");
    for (i = 0; i < n; i++) {
        pkss_param_info in;
        char def[64];
        if (param_at(i, &in) != 0)
            continue;
        default_text(&in, def, sizeof def);
        if (in.type == PKSS_TYPE_STRING)
            printf("  %-16s %4d  string\n", in.name, (int)in.id);
        else if (in.type == PKSS_TYPE_SWITCH || in.type == PKSS_TYPE_CHOICE)
            printf("  %-16s %4d  %-6s default %-10s (%s)\n", in.name,
                   (int)in.id, type_name(in.type), def, in.choices);
        else
            printf("  %-16s %4d  %-6s default %-10s range [%.15g, %.15g]%s%s"
                   "\n",
                   in.name, (int)in.id, type_name(in.type), def, in.lower,
                   in.upper, in.constraint[0] ? " " : "", in.constraint);
    }
}

/* Machine-readable (--params): a header line, then one tab-separated line
 * per parameter; the CLI test, the Python binding and the README checks
 * read it. Tabs and newlines cannot occur in the table's strings. */
static void print_params_tsv(void)
{
    size_t i, n = pkss_param_count();
    printf("name\tid\ttype\tdefault\tlower\tupper\tunit\tchoices\t"
           "constraint\toption\tdoc\n");
    for (i = 0; i < n; i++) {
        pkss_param_info in;
        char def[64], opt[64];
        size_t k;
        if (param_at(i, &in) != 0)
            continue;
        for (k = 0; in.name[k] && k + 1 < sizeof opt; k++)
            opt[k] = in.name[k] == '_' ? '-' : in.name[k];
        opt[k] = '\0';
        printf("%s\t%d\t%s\t%s\t%.15g\t%.15g\t%s\t%s\t%s\t--%s\t%s\n",
               in.name, (int)in.id, type_name(in.type),
               default_text(&in, def, sizeof def), in.lower, in.upper,
               in.unit, in.choices, in.constraint, opt, in.doc);
    }
}

/* Every write is checked: a full disk or closed pipe is exit 3. */
static int finish(int rc)
{
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, TOOL ": PKSS_ERR_IO: cannot write to standard "
                        "output\n");
        return rc ? rc : 3;
    }
    return rc;
}

int main(int argc, char **argv)
{
    int i;
    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--version") == 0) {
            printf(TOOL " %d.%d.%d (built against pkss.h), runtime libpkss "
                        "%s\n",
                   PKSS_VERSION_MAJOR, PKSS_VERSION_MINOR, PKSS_VERSION_PATCH,
                   pkss_version_string());
            return finish(0);
        }
        if (strcmp(argv[i], "--params") == 0) {
            print_params_tsv();
            return finish(0);
        }
        if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
            printf("Usage: " TOOL " [--version] [--params] [--help]\n"
                   "Prints the pkss library version and build, the OpenCL "
                   "devices pkss can use\n"
                   "(indices for pkss-align --device and PKSS_DEVICE) and "
                   "the parameters.\n"
                   "  --params   only the parameters, one tab-separated "
                   "line each after a\n"
                   "             header line: name id type default lower "
                   "upper unit choices\n"
                   "             constraint option doc\n"
                   "Exit codes: 0 (also when no device is found), 2 usage "
                   "error, 3 cannot\n"
                   "write standard output.\n");
            return finish(0);
        }
        fprintf(stderr,
                TOOL ": PKSS_ERR_INVALID_ARGUMENT: unknown argument '%s' "
                     "(see --help)\n",
                argv[i]);
        return 2;
    }
    printf("pkss library: %s (version number %u; this tool built against "
           "%d.%d.%d)\n",
           pkss_version_string(), pkss_version_number(), PKSS_VERSION_MAJOR,
           PKSS_VERSION_MINOR, PKSS_VERSION_PATCH);
    printf("build: %s\n", pkss_build_info());
    printf("max candidates: %u\n", pkss_max_candidates());
    print_devices();
    {
        const char *env = getenv("PKSS_DEVICE");
        printf("PKSS_DEVICE: %s\n", env && *env ? env : "(not set)");
    }
    print_params();
    return finish(0);
}
