/* SPDX-License-Identifier: MIT
 * device.c -- OpenCL devices as pkss sees them (STYLE 11): listing across
 * all platforms (pkss_device_count / pkss_device_info), the reason when
 * there is none, the OpenCL error names, and the deterministic device
 * selection of a context. The listing is re-read on every call (the ICD
 * loader caches platforms itself) under one mutex, so it is thread-safe.
 * The ICD loader itself is loaded at the first listing (cl_loader.c); when
 * it is absent the listing is empty and the reason says so.
 */
#define _POSIX_C_SOURCE 200809L /* access */
#include "pkss_cl.h"

#ifdef PKSS_WITH_OPENCL

#include <ctype.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef CL_PLATFORM_NOT_FOUND_KHR
#define CL_PLATFORM_NOT_FOUND_KHR -1001
#endif

/* ------------------------------------------------------------ errors */
const char *pkss__cl_error_name(cl_int err)
{
    switch (err) {
#define E(x) case x: return #x;
    E(CL_SUCCESS) E(CL_DEVICE_NOT_FOUND) E(CL_DEVICE_NOT_AVAILABLE)
    E(CL_COMPILER_NOT_AVAILABLE) E(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    E(CL_OUT_OF_RESOURCES) E(CL_OUT_OF_HOST_MEMORY)
    E(CL_PROFILING_INFO_NOT_AVAILABLE) E(CL_MEM_COPY_OVERLAP)
    E(CL_IMAGE_FORMAT_MISMATCH) E(CL_IMAGE_FORMAT_NOT_SUPPORTED)
    E(CL_BUILD_PROGRAM_FAILURE) E(CL_MAP_FAILURE)
    E(CL_MISALIGNED_SUB_BUFFER_OFFSET)
    E(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
    E(CL_COMPILE_PROGRAM_FAILURE) E(CL_LINKER_NOT_AVAILABLE)
    E(CL_LINK_PROGRAM_FAILURE) E(CL_DEVICE_PARTITION_FAILED)
    E(CL_KERNEL_ARG_INFO_NOT_AVAILABLE)
    E(CL_INVALID_VALUE) E(CL_INVALID_DEVICE_TYPE) E(CL_INVALID_PLATFORM)
    E(CL_INVALID_DEVICE) E(CL_INVALID_CONTEXT) E(CL_INVALID_QUEUE_PROPERTIES)
    E(CL_INVALID_COMMAND_QUEUE) E(CL_INVALID_HOST_PTR) E(CL_INVALID_MEM_OBJECT)
    E(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR) E(CL_INVALID_IMAGE_SIZE)
    E(CL_INVALID_SAMPLER) E(CL_INVALID_BINARY) E(CL_INVALID_BUILD_OPTIONS)
    E(CL_INVALID_PROGRAM) E(CL_INVALID_PROGRAM_EXECUTABLE)
    E(CL_INVALID_KERNEL_NAME) E(CL_INVALID_KERNEL_DEFINITION)
    E(CL_INVALID_KERNEL) E(CL_INVALID_ARG_INDEX) E(CL_INVALID_ARG_VALUE)
    E(CL_INVALID_ARG_SIZE) E(CL_INVALID_KERNEL_ARGS)
    E(CL_INVALID_WORK_DIMENSION) E(CL_INVALID_WORK_GROUP_SIZE)
    E(CL_INVALID_WORK_ITEM_SIZE) E(CL_INVALID_GLOBAL_OFFSET)
    E(CL_INVALID_EVENT_WAIT_LIST) E(CL_INVALID_EVENT) E(CL_INVALID_OPERATION)
    E(CL_INVALID_GL_OBJECT) E(CL_INVALID_BUFFER_SIZE) E(CL_INVALID_MIP_LEVEL)
    E(CL_INVALID_GLOBAL_WORK_SIZE) E(CL_INVALID_PROPERTY)
    E(CL_INVALID_IMAGE_DESCRIPTOR) E(CL_INVALID_COMPILER_OPTIONS)
    E(CL_INVALID_LINKER_OPTIONS) E(CL_INVALID_DEVICE_PARTITION_COUNT)
#undef E
    case CL_PLATFORM_NOT_FOUND_KHR:
        return "CL_PLATFORM_NOT_FOUND_KHR";
    default:
        return "CL_UNKNOWN_ERROR";
    }
}

pkss_status pkss__cl_fail(pkss_context *ctx, cl_int err, const char *what)
{
    int len = (int)strcspn(what, "(");
    while (len > 0 && what[len - 1] == ' ')
        --len;
    return pkss__fail(ctx, PKSS_ERR_DEVICE, "%.*s: %s (%d)", len, what,
                      pkss__cl_error_name(err), (int)err);
}

/* ------------------------------------------------------------ listing */
typedef struct device_list {
    unsigned count;
    int loader_ok;            /* libOpenCL could be loaded (cl_loader.c) */
    cl_int platform_err;      /* clGetPlatformIDs result */
    unsigned n_platforms;
    cl_platform_id platform[PKSS_CL_MAX_DEVICES];
    cl_device_id device[PKSS_CL_MAX_DEVICES];
} device_list;

/* Serialises the enumeration: some ICD loaders initialise lazily and not
 * every one of them does so under a lock. */
static pthread_mutex_t list_lock = PTHREAD_MUTEX_INITIALIZER;
static int listed_once; /* under list_lock: the driver has started up */

/* Every device of every platform, platform then device order. */
static void list_devices(device_list *out)
{
    memset(out, 0, sizeof *out);
    out->loader_ok = pkss__cl_load();
    if (!out->loader_ok) {
        out->platform_err = CL_PLATFORM_NOT_FOUND_KHR;
        return;
    }
    pthread_mutex_lock(&list_lock);
    cl_platform_id plats[16];
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(16, plats, &np);
    out->platform_err = err;
    listed_once = 1;
    if (err == CL_SUCCESS) {
        if (np > 16)
            np = 16;
        out->n_platforms = np;
        for (cl_uint p = 0; p < np && out->count < PKSS_CL_MAX_DEVICES; ++p) {
            cl_device_id devs[PKSS_CL_MAX_DEVICES];
            cl_uint nd = 0;
            if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL,
                               PKSS_CL_MAX_DEVICES, devs, &nd) != CL_SUCCESS)
                continue;
            if (nd > PKSS_CL_MAX_DEVICES)
                nd = PKSS_CL_MAX_DEVICES;
            for (cl_uint d = 0; d < nd && out->count < PKSS_CL_MAX_DEVICES; ++d) {
                out->platform[out->count] = plats[p];
                out->device[out->count] = devs[d];
                out->count++;
            }
        }
    }
    pthread_mutex_unlock(&list_lock);
}

/* ------------------------------------------------------------ warm-up */
static void *warmup_main(void *arg)
{
    (void)arg;
    device_list list;
    list_devices(&list);
    return NULL;
}

void pkss__cl_warmup_begin(const pkss_context *ctx, pkss__cl_warmup *w)
{
    w->started = 0;
    if (ctx->prepared || ctx->params.backend == PKSS_BACKEND_REFERENCE)
        return;
    pthread_mutex_lock(&list_lock);
    int done = listed_once;
    pthread_mutex_unlock(&list_lock);
    if (!done)
        w->started = pthread_create(&w->thread, NULL, warmup_main, NULL) == 0;
}

void pkss__cl_warmup_end(pkss__cl_warmup *w)
{
    if (w->started)
        pthread_join(w->thread, NULL);
    w->started = 0;
}

static void device_string(cl_device_id d, cl_device_info what, char *buf,
                          size_t size)
{
    buf[0] = '\0';
    if (clGetDeviceInfo(d, what, size, buf, NULL) != CL_SUCCESS)
        buf[0] = '\0';
    buf[size - 1] = '\0';
}

static void platform_string(cl_platform_id p, cl_platform_info what,
                            char *buf, size_t size)
{
    buf[0] = '\0';
    if (clGetPlatformInfo(p, what, size, buf, NULL) != CL_SUCCESS)
        buf[0] = '\0';
    buf[size - 1] = '\0';
}

static cl_device_type device_type(cl_device_id d)
{
    cl_device_type t = 0;
    if (clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof t, &t, NULL) != CL_SUCCESS)
        return 0;
    return t;
}

static void describe(cl_platform_id p, cl_device_id d, pkss_device_desc *out)
{
    memset(out, 0, sizeof *out);
    device_string(d, CL_DEVICE_NAME, out->name, sizeof out->name);
    device_string(d, CL_DEVICE_VENDOR, out->vendor, sizeof out->vendor);
    device_string(d, CL_DEVICE_VERSION, out->version, sizeof out->version);
    platform_string(p, CL_PLATFORM_NAME, out->platform, sizeof out->platform);
    out->is_gpu = (device_type(d) & CL_DEVICE_TYPE_GPU) != 0;
    cl_device_fp_config fp64 = 0;
    if (clGetDeviceInfo(d, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp64, &fp64,
                        NULL) != CL_SUCCESS)
        fp64 = 0;
    out->has_fp64 = fp64 != 0;
    cl_uint cu = 0;
    if (clGetDeviceInfo(d, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof cu, &cu,
                        NULL) == CL_SUCCESS)
        out->compute_units = cu;
    cl_ulong mem = 0;
    if (clGetDeviceInfo(d, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof mem, &mem,
                        NULL) == CL_SUCCESS)
        out->global_mem_bytes = mem;
}

pkss_status pkss_device_count(unsigned *count)
{
    if (!count)
        return PKSS_ERR_NULL_ARGUMENT;
    device_list list;
    list_devices(&list);
    *count = list.count;
    return PKSS_OK;
}

pkss_status pkss_device_info(unsigned index, pkss_device_desc *out)
{
    if (!out)
        return PKSS_ERR_NULL_ARGUMENT;
    device_list list;
    list_devices(&list);
    if (index >= list.count)
        return PKSS_ERR_INVALID_ARGUMENT;
    describe(list.platform[index], list.device[index], out);
    return PKSS_OK;
}

#define PKSS_INSTALL_HINT                                                      \
    "On Debian/Ubuntu install PoCL, which runs the kernels on the CPU: "      \
    "apt-get install pocl-opencl-icd ocl-icd-libopencl1 (or a GPU vendor's "  \
    "OpenCL driver); meanwhile PKSS_BACKEND_REFERENCE (plain C) works."

/* PoCL hides its devices when its cache folder cannot be written. Tried
 * for real (permission bits do not bind root): a probe file in the folder,
 * or creating the folder; whatever the probe made is removed. Runs only
 * when no device is listed. */
static int pocl_cache_unwritable(void)
{
    const char *dir = getenv("POCL_CACHE_DIR");
    char probe[4096];
    if (!dir || !dir[0] || strlen(dir) > sizeof probe - 16)
        return 0;
    if (mkdir(dir, 0700) == 0) {
        rmdir(dir);
        return 0;
    }
    snprintf(probe, sizeof probe, "%s/.pkssXXXXXX", dir);
    int fd = mkstemp(probe);
    if (fd < 0)
        return 1;
    close(fd);
    unlink(probe);
    return 0;
}

const char *pkss_no_device_reason(void)
{
    device_list list;
    list_devices(&list);
    if (!list.loader_ok)
        return pkss__cl_load_error();
    if (list.platform_err != CL_SUCCESS || list.n_platforms == 0)
        return "No OpenCL platform is installed: the ICD loader found no "
               "vendor driver (/etc/OpenCL/vendors/*.icd, or OCL_ICD_VENDORS). "
               PKSS_INSTALL_HINT;
    if (list.count == 0 && pocl_cache_unwritable())
        return "OpenCL platforms are installed but none lists a device, and "
               "POCL_CACHE_DIR names a folder that cannot be written (PoCL "
               "lists no device without a writable cache): point "
               "POCL_CACHE_DIR at a writable folder, or unset it; meanwhile "
               "PKSS_BACKEND_REFERENCE (plain C) works.";
    if (list.count == 0)
        return "OpenCL platforms are installed but none lists a device. "
               PKSS_INSTALL_HINT;
    return "OpenCL devices are available (see pkss_device_count); none is "
           "missing.";
}

/* ---------------------------------------------------------- selection */
static int contains_nocase(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    if (n == 0)
        return 0;
    for (; *hay; ++hay) {
        size_t i = 0;
        while (i < n && hay[i] &&
               tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            ++i;
        if (i == n)
            return 1;
    }
    return 0;
}

static const char *type_word(cl_device_type t)
{
    if (t & CL_DEVICE_TYPE_GPU)
        return "GPU";
    if (t & CL_DEVICE_TYPE_CPU)
        return "CPU";
    if (t & CL_DEVICE_TYPE_ACCELERATOR)
        return "accelerator";
    return "other";
}

/* Appends "0: name (platform, CPU); 1: ..." to buf. */
static void list_text(const device_list *list, char *buf, size_t size)
{
    size_t used = strlen(buf);
    if (list->count == 0) {
        snprintf(buf + used, size - used, "no OpenCL device is listed (%s)",
                 pkss_no_device_reason());
        return;
    }
    for (unsigned i = 0; i < list->count && used + 1 < size; ++i) {
        pkss_device_desc d;
        describe(list->platform[i], list->device[i], &d);
        int w = snprintf(buf + used, size - used, "%s%u: %s (%s, %s)",
                         i ? "; " : "", i, d.name, d.platform,
                         type_word(device_type(list->device[i])));
        if (w < 0)
            break;
        used += (size_t)w < size - used ? (size_t)w : size - used - 1;
    }
}

/* Index of the device matching `req` (decimal index, or name substring,
 * then platform/vendor/type substring), or -1. */
static int match_request(const device_list *list, const char *req)
{
    const char *p = req;
    while (*p == ' ')
        ++p;
    if (*p && strspn(p, "0123456789") == strlen(p)) {
        char *end = NULL;
        unsigned long idx = strtoul(p, &end, 10);
        return idx < list->count ? (int)idx : -1;
    }
    for (unsigned i = 0; i < list->count; ++i) {
        char name[PKSS_NAME_SIZE];
        device_string(list->device[i], CL_DEVICE_NAME, name, sizeof name);
        if (contains_nocase(name, p))
            return (int)i;
    }
    for (unsigned i = 0; i < list->count; ++i) {
        pkss_device_desc d;
        describe(list->platform[i], list->device[i], &d);
        if (contains_nocase(d.vendor, p) || contains_nocase(d.platform, p) ||
            contains_nocase(type_word(device_type(list->device[i])), p))
            return (int)i;
    }
    return -1;
}

pkss_status pkss__cl_select(pkss_context *ctx, cl_platform_id *platform,
                            cl_device_id *device)
{
    device_list list;
    list_devices(&list);
    if (list.count == 0) {
        if (!list.loader_ok)
            return pkss__fail(ctx, PKSS_ERR_NO_DEVICE, "no OpenCL device: %s",
                              pkss__cl_load_error());
        if (list.platform_err != CL_SUCCESS)
            return pkss__fail(ctx, PKSS_ERR_NO_DEVICE,
                              "no OpenCL device: clGetPlatformIDs: %s (%d). %s",
                              pkss__cl_error_name(list.platform_err),
                              (int)list.platform_err, pkss_no_device_reason());
        return pkss__fail(ctx, PKSS_ERR_NO_DEVICE, "no OpenCL device: %s",
                          pkss_no_device_reason());
    }
    int pick = -1;
    const char *req = ctx->device_request;
    const char *source = "PKSS_PARAM_DEVICE";
    if (!req || !req[0]) {
        req = getenv("PKSS_DEVICE");
        source = "the PKSS_DEVICE environment variable";
    }
    if (req && req[0]) {
        pick = match_request(&list, req);
        if (pick < 0) {
            char buf[PKSS_DETAIL_SIZE];
            snprintf(buf, sizeof buf,
                     "no OpenCL device matches %s '%s' (an index or a "
                     "case-insensitive name substring); devices: ",
                     source, req);
            list_text(&list, buf, sizeof buf);
            return pkss__fail(ctx, PKSS_ERR_NO_DEVICE, "%s", buf);
        }
    }
    for (unsigned i = 0; pick < 0 && i < list.count; ++i)
        if (device_type(list.device[i]) & CL_DEVICE_TYPE_GPU)
            pick = (int)i;
    for (unsigned i = 0; pick < 0 && i < list.count; ++i)
        if (device_type(list.device[i]) & CL_DEVICE_TYPE_CPU)
            pick = (int)i;
    if (pick < 0)
        pick = 0;
    *platform = list.platform[pick];
    *device = list.device[pick];
    device_string(*device, CL_DEVICE_NAME, ctx->device_name,
                  sizeof ctx->device_name);
    if (!ctx->device_name[0])
        snprintf(ctx->device_name, sizeof ctx->device_name,
                 "OpenCL device %d", pick);
    return PKSS_OK;
}

#else
/* ISO C forbids an empty translation unit. */
typedef int pkss__device_unused;
#endif /* PKSS_WITH_OPENCL */
