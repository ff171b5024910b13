/* SPDX-License-Identifier: MIT
 * pkss_info.c -- pkss-info: the library version and build, the OpenCL
 * devices as pkss sees them (the indices --device and PKSS_DEVICE take)
 * and the parameters with their defaults and ranges. A thin client of
 * pkss.h. Exits 0 whether or not a device is found (2 on a usage error).
 */
#include "pkss.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TOOL "pkss-info"
#define MAX_PARAM_ID 1000 /* ids probed with pkss_param_name() */

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

/* The API cannot tell a switch from a 0..2 integer parameter: the
 * switches of pkss.h are listed here (unknown ids print as numbers). */
static int is_switch(int id)
{
    return id == PKSS_PARAM_CULL_MUTUAL || id == PKSS_PARAM_CULL_STAT ||
           id == PKSS_PARAM_USE_FEATURES || id == PKSS_PARAM_PCA_PREALIGN ||
           id == PKSS_PARAM_REFINE || id == PKSS_PARAM_DROP_NONFINITE;
}

static void print_params(void)
{
    int id;
    printf("Parameters (name, id, default, range; 0 always means "
           "default):\n");
    for (id = 0; id < MAX_PARAM_ID; id++) {
        const char *n = pkss_param_name((pkss_param)id);
        double lo, hi, def;
        if (!n)
            continue;
        if (pkss_param_bounds((pkss_param)id, &lo, &hi, &def) != PKSS_OK)
            printf("  %-16s %4d  (string)\n", n, id);
        else if (is_switch(id))
            printf("  %-16s %4d  switch, default %s\n", n, id,
                   def == PKSS_SWITCH_OFF ? "off" : "on");
        else if (id == PKSS_PARAM_ROTATION_SET)
            printf("  %-16s %4d  default %s (1 euler, 2 uniform)\n", n, id,
                   def == PKSS_ROTATIONS_UNIFORM ? "uniform" : "euler");
        else if (id == PKSS_PARAM_BACKEND)
            printf("  %-16s %4d  default %s (0 auto, 1 reference, 2 "
                   "opencl)\n",
                   n, id,
                   def == PKSS_BACKEND_REFERENCE ? "reference"
                   : def == PKSS_BACKEND_OPENCL  ? "opencl"
                                                 : "auto");
        else
            printf("  %-16s %4d  default %-10.10g range [%.10g, %.10g]\n", n,
                   id, def, lo, hi);
    }
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
            return 0;
        }
        if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
            printf("Usage: " TOOL " [--version] [--help]\n"
                   "Prints the pkss library version and build, the OpenCL "
                   "devices pkss can use\n"
                   "(indices for pkss-align --device and PKSS_DEVICE) and "
                   "the parameters.\n"
                   "Exit codes: 0 (also when no device is found), 2 usage "
                   "error.\n");
            return 0;
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
    return 0;
}
