/* SPDX-License-Identifier: MIT
 * cl_loader.c -- dlopen()s the OpenCL ICD loader at first use and resolves
 * the entry points of cl_loader.h. Without it (no ocl-icd-libopencl1 on
 * the machine) libpkss still loads: the device listing is empty and says
 * why, and PKSS_BACKEND_AUTO runs the reference backend.
 *
 * $PKSS_OPENCL_LIBRARY, when set and non-empty, is the only library tried
 * (a path or a soname; a nonexistent path simulates a machine without the
 * loader). Otherwise libOpenCL.so.1 (the ABI soname every ICD loader has),
 * then libOpenCL.so (development symlink, some non-Debian layouts).
 */
#define _POSIX_C_SOURCE 200809L
#define PKSS_CL_LOADER_IMPL
#include "pkss_cl.h"

#ifdef PKSS_WITH_OPENCL

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

pkss__cl_api pkss__cl;

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static int load_ok;
static char load_error[1024];

#define PKSS_LOADER_HINT                                                       \
    "install ocl-icd-libopencl1 and pocl-opencl-icd (apt-get install "        \
    "ocl-icd-libopencl1 pocl-opencl-icd) or a GPU vendor's OpenCL driver, or " \
    "set PKSS_OPENCL_LIBRARY to the loader's path; meanwhile "                 \
    "PKSS_BACKEND_REFERENCE (plain C) works"

static void load(void)
{
    const char *env = getenv("PKSS_OPENCL_LIBRARY");
    void *lib = NULL;
    const char *tried = NULL;
    char err[512] = "";
    if (env && env[0]) {
        tried = env;
        lib = dlopen(env, RTLD_NOW | RTLD_LOCAL);
        if (!lib) {
            const char *e = dlerror();
            snprintf(err, sizeof err, "%s", e ? e : "unknown dlopen error");
        }
    } else {
        static const char *const names[] = {"libOpenCL.so.1", "libOpenCL.so"};
        for (size_t i = 0; i < sizeof names / sizeof names[0] && !lib; ++i) {
            tried = names[i];
            lib = dlopen(names[i], RTLD_NOW | RTLD_LOCAL);
            if (!lib && i == 0) {
                /* keep the first error: it names the soname that matters */
                const char *e = dlerror();
                snprintf(err, sizeof err, "%s", e ? e : "unknown dlopen error");
            }
        }
    }
    if (!lib) {
        if (env && env[0])
            /* dlerror() already names the path */
            snprintf(load_error, sizeof load_error,
                     "the OpenCL ICD loader (libOpenCL.so.1) could not be "
                     "loaded: %s (PKSS_OPENCL_LIBRARY is set); "
                     PKSS_LOADER_HINT ".",
                     err);
        else
            snprintf(load_error, sizeof load_error,
                     "the OpenCL ICD loader (libOpenCL.so.1) could not be "
                     "loaded: %s; " PKSS_LOADER_HINT ".",
                     err);
        return;
    }
    pkss__cl_api api;
    memset(&api, 0, sizeof api);
    /* dlsym returns void *; ISO C has no object-to-function pointer
     * conversion, POSIX guarantees it works through memcpy. */
#define PKSS_CL_RESOLVE(ret, name, args)                                       \
    {                                                                          \
        void *sym = dlsym(lib, "cl" #name);                                    \
        if (!sym) {                                                            \
            const char *e = dlerror();                                         \
            snprintf(load_error, sizeof load_error,                            \
                     "the OpenCL ICD loader %s lacks cl" #name ": %s; "        \
                     PKSS_LOADER_HINT ".",                                     \
                     tried, e ? e : "symbol not found");                       \
            return; /* the library stays loaded: harmless, never used */       \
        }                                                                      \
        memcpy(&api.name, &sym, sizeof sym);                                   \
    }
    PKSS_CL_FUNCTIONS(PKSS_CL_RESOLVE)
#undef PKSS_CL_RESOLVE
    pkss__cl = api;
    load_ok = 1;
}

int pkss__cl_load(void)
{
    pthread_once(&load_once, load);
    return load_ok;
}

const char *pkss__cl_load_error(void) { return load_error; }

#else
/* ISO C forbids an empty translation unit. */
typedef int pkss__cl_loader_unused;
#endif /* PKSS_WITH_OPENCL */
