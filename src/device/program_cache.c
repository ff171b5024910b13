/* SPDX-License-Identifier: MIT
 * program_cache.c -- built OpenCL programs kept on disk, so that a new
 * context (every CLI call) loads the device binary instead of compiling
 * the kernels again (docs/design.md "Program cache"). An entry is named by
 * a hash of the device identity, driver version and build options and by
 * the kernel source hash; its header repeats both and adds the library
 * version, and the binary is checksummed. The folder keeps the CACHE_KEEP
 * most recently written entries. Anything that does not match
 * is rebuilt from source and replaced through a temp file and rename(), so
 * concurrent processes never read half an entry. The cache never fails a
 * call: an unusable folder only means building from source.
 */
#define _POSIX_C_SOURCE 200809L /* mkstemp, fdopen */
#include "device/program_cache.h"

#ifdef PKSS_WITH_OPENCL

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Entries kept in the folder: every device and driver of a machine, and a
 * few pkss builds each, at ~150-200 KB an entry */
#define CACHE_KEEP 16

/* Larger entries are not believed (a PoCL binary of our kernels is about
 * 150 KB; GPU drivers' are of the same order). */
#define CACHE_MAX_BINARY ((uint64_t)64 << 20)

uint64_t pkss__fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

int pkss__cache_dir(char *out, size_t size)
{
    const char *dir = getenv("PKSS_CACHE_DIR");
    const char *xdg = getenv("XDG_CACHE_HOME");
    const char *home = getenv("HOME");
    int w = -1;
    if (dir && dir[0])
        w = snprintf(out, size, "%s", dir);
    else if (xdg && xdg[0] == '/') /* XDG: relative values are ignored */
        w = snprintf(out, size, "%s/pkss", xdg);
    else if (home && home[0])
        w = snprintf(out, size, "%s/.cache/pkss", home);
    if (w <= 0 || (size_t)w >= size) {
        out[0] = '\0';
        return 0;
    }
    return 1;
}

/* mkdir -p; 0 on success, else errno. */
static int make_dirs(char *path)
{
    for (char *p = path + 1;; ++p) {
        if (*p != '/' && *p != '\0')
            continue;
        char c = *p;
        *p = '\0';
        int bad = mkdir(path, 0700) != 0 && errno != EEXIST;
        int err = errno;
        *p = c;
        if (bad)
            return err;
        if (c == '\0')
            break;
    }
    struct stat sb;
    if (stat(path, &sb) != 0)
        return errno;
    return S_ISDIR(sb.st_mode) ? 0 : ENOTDIR;
}

static uint64_t hash_device_string(uint64_t h, cl_device_id d,
                                   cl_device_info what)
{
    char buf[512] = "";
    if (clGetDeviceInfo(d, what, sizeof buf, buf, NULL) != CL_SUCCESS)
        buf[0] = '\0';
    buf[sizeof buf - 1] = '\0';
    return pkss__fnv1a(h, buf, strlen(buf) + 1);
}

static uint64_t hash_platform_string(uint64_t h, cl_platform_id p,
                                     cl_platform_info what)
{
    char buf[512] = "";
    if (clGetPlatformInfo(p, what, sizeof buf, buf, NULL) != CL_SUCCESS)
        buf[0] = '\0';
    buf[sizeof buf - 1] = '\0';
    return pkss__fnv1a(h, buf, strlen(buf) + 1);
}

static void set_note(pkss__cache_key *key, pkss__cache_outcome outcome,
                     const char *what, const char *why)
{
    key->outcome = outcome;
    snprintf(key->note, sizeof key->note, "OpenCL program cache: %.400s%s%s",
             what, why ? ": " : "", why ? why : "");
}

void pkss__cache_key_init(pkss__cache_key *key, cl_platform_id platform,
                          cl_device_id device, const char *options,
                          const char *source, size_t source_len)
{
    memset(key, 0, sizeof *key);
    uint64_t h = PKSS__FNV_INIT;
    h = hash_platform_string(h, platform, CL_PLATFORM_NAME);
    h = hash_platform_string(h, platform, CL_PLATFORM_VERSION);
    h = hash_device_string(h, device, CL_DEVICE_NAME);
    h = hash_device_string(h, device, CL_DEVICE_VENDOR);
    h = hash_device_string(h, device, CL_DEVICE_VERSION);
    h = hash_device_string(h, device, CL_DRIVER_VERSION);
    const char *lib = pkss_build_info();
    h = pkss__fnv1a(h, lib, strlen(lib) + 1);
    key->key_hash = pkss__fnv1a(h, options, strlen(options) + 1);
    key->source_hash = pkss__fnv1a(PKSS__FNV_INIT, source, source_len);

    char dir[sizeof key->path - 64]; /* room for the entry's name */
    if (!pkss__cache_dir(dir, sizeof dir)) {
        set_note(key, PKSS__CACHE_UNWRITABLE,
                 "no folder (set PKSS_CACHE_DIR, XDG_CACHE_HOME or HOME); "
                 "built from source", NULL);
        return;
    }
    int err = make_dirs(dir);
    if (err) {
        char what[sizeof key->note];
        snprintf(what, sizeof what, "cannot use '%.300s' (%s); built from "
                 "source", dir, strerror(err));
        set_note(key, PKSS__CACHE_UNWRITABLE, what, NULL);
        return;
    }
    /* two builds with other kernels (two installed versions, an A/B
     * benchmark) keep one entry each instead of replacing each other's */
    snprintf(key->path, sizeof key->path, "%s/cl-%016llx-%016llx.bin", dir,
             (unsigned long long)key->key_hash,
             (unsigned long long)key->source_hash);
}

/* Reads and checks the entry into a new buffer; NULL with the reason in
 * *why (NULL reason: there is no entry). */
static unsigned char *read_entry(const pkss__cache_key *key, size_t *size,
                                 const char **why)
{
    *why = NULL;
    FILE *f = fopen(key->path, "rb");
    if (!f)
        return NULL;
    pkss__cache_header h;
    unsigned char *bin = NULL;
    char magic[8] = PKSS__CACHE_MAGIC;
    long end = -1;
    if (fread(&h, sizeof h, 1, f) != 1)
        *why = "truncated header";
    else if (memcmp(h.magic, magic, sizeof magic) != 0 ||
             h.format != PKSS__CACHE_FORMAT)
        *why = "not an entry of this format";
    else if (h.lib_version != PKSS_VERSION_NUMBER || h.key_hash != key->key_hash)
        *why = "stale (another library version or device)";
    else if (h.source_hash != key->source_hash)
        *why = "stale (built from another kernel source)";
    else if (h.size == 0 || h.size > CACHE_MAX_BINARY ||
             fseek(f, 0, SEEK_END) != 0 || (end = ftell(f)) < 0 ||
             (uint64_t)end != sizeof h + h.size)
        *why = "size does not match the header";
    else if (fseek(f, (long)sizeof h, SEEK_SET) != 0 ||
             !(bin = pkss__malloc((size_t)h.size)) ||
             fread(bin, 1, (size_t)h.size, f) != (size_t)h.size)
        *why = bin ? "unreadable" : "out of memory";
    else if (pkss__fnv1a(PKSS__FNV_INIT, bin, (size_t)h.size) != h.checksum)
        *why = "corrupt (checksum mismatch)";
    fclose(f);
    if (*why) {
        pkss__free(bin);
        return NULL;
    }
    *size = (size_t)h.size;
    return bin;
}

cl_program pkss__cache_load(pkss__cache_key *key, cl_context context,
                            cl_device_id device, const char *options)
{
    if (!key->path[0])
        return NULL;
    size_t size = 0;
    const char *why = NULL;
    unsigned char *bin = read_entry(key, &size, &why);
    if (!bin) {
        if (why)
            set_note(key, PKSS__CACHE_REBUILT, "entry rebuilt and replaced",
                     why);
        return NULL;
    }
    cl_int err = CL_SUCCESS, bin_status = CL_SUCCESS;
    const unsigned char *bins[1] = {bin};
    cl_program p = clCreateProgramWithBinary(context, 1, &device, &size, bins,
                                             &bin_status, &err);
    pkss__free(bin);
    if (p && err == CL_SUCCESS && bin_status == CL_SUCCESS)
        err = clBuildProgram(p, 1, &device, options, NULL, NULL);
    if (!p || err != CL_SUCCESS || bin_status != CL_SUCCESS) {
        PKSS_CL_RELEASE(clReleaseProgram, p);
        set_note(key, PKSS__CACHE_REBUILT, "entry rebuilt and replaced",
                 "the driver rejected the cached binary");
        return NULL;
    }
    set_note(key, PKSS__CACHE_HIT, "used the cached binary", NULL);
    return p;
}

int pkss__cache_write(const char *path, const pkss__cache_header *h,
                      const void *binary)
{
    char tmp[4096 + 16];
    if (snprintf(tmp, sizeof tmp, "%s.tmpXXXXXX", path) >= (int)sizeof tmp)
        return ENAMETOOLONG;
    int fd = mkstemp(tmp);
    if (fd < 0)
        return errno;
    FILE *f = fdopen(fd, "wb");
    if (!f) {
        int err = errno;
        close(fd);
        unlink(tmp);
        return err;
    }
    int ok = fwrite(h, sizeof *h, 1, f) == 1 &&
             fwrite(binary, 1, (size_t)h->size, f) == (size_t)h->size;
    int err = ok ? 0 : (errno ? errno : EIO);
    if (fclose(f) != 0 && !err)
        err = errno ? errno : EIO;
    if (!err && rename(tmp, path) != 0)
        err = errno;
    if (err)
        unlink(tmp);
    return err;
}

/* An entry's name: cl-<16 hex>-<16 hex>.bin, or cl-<16 hex>.bin as
 * written before the source hash was in it (temp files and others differ). */
static int is_entry_name(const char *name)
{
    size_t n = strlen(name);
    int now = n == 3 + 16 + 1 + 16 + 4 && name[19] == '-';
    return (now || n == 3 + 16 + 4) && !strncmp(name, "cl-", 3) &&
           !strcmp(name + n - 4, ".bin");
}

/* Keeps the folder of `path` to CACHE_KEEP entries: the least recently
 * written others go (each kernel source, driver or device has its own). A
 * file that another process removed first is no error. */
static void prune(const char *path)
{
    char dir[sizeof ((pkss__cache_key *)0)->path];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash)
        return;
    *slash = '\0';
    for (;;) {
        DIR *d = opendir(dir);
        if (!d)
            return;
        int count = 0;
        time_t oldest_time = 0;
        char oldest[sizeof dir + 64] = "";
        struct dirent *e;
        while ((e = readdir(d)) != NULL) {
            char full[sizeof dir + 64];
            struct stat sb;
            if (!is_entry_name(e->d_name) ||
                snprintf(full, sizeof full, "%s/%s", dir, e->d_name) >= (int)sizeof full ||
                stat(full, &sb) != 0)
                continue;
            ++count;
            if (strcmp(full, path) != 0 && (!oldest[0] || sb.st_mtime < oldest_time)) {
                oldest_time = sb.st_mtime;
                memcpy(oldest, full, sizeof oldest);
            }
        }
        closedir(d);
        if (count <= CACHE_KEEP || !oldest[0] || (unlink(oldest) != 0 && errno != ENOENT))
            return;
    }
}

void pkss__cache_store(pkss__cache_key *key, cl_program program)
{
    if (!key->path[0])
        return;
    size_t size = 0;
    unsigned char *bin = NULL;
    if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof size, &size,
                         NULL) != CL_SUCCESS || size == 0 ||
        size > CACHE_MAX_BINARY || !(bin = pkss__malloc(size)) ||
        clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof bin, &bin,
                         NULL) != CL_SUCCESS) {
        pkss__free(bin);
        set_note(key, PKSS__CACHE_UNWRITABLE, "not written",
                 "the driver gave no program binary");
        return;
    }
    pkss__cache_header h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, PKSS__CACHE_MAGIC, sizeof PKSS__CACHE_MAGIC);
    h.format = PKSS__CACHE_FORMAT;
    h.lib_version = PKSS_VERSION_NUMBER;
    h.key_hash = key->key_hash;
    h.source_hash = key->source_hash;
    h.size = size;
    h.checksum = pkss__fnv1a(PKSS__FNV_INIT, bin, size);
    int err = pkss__cache_write(key->path, &h, bin);
    pkss__free(bin);
    if (err) {
        char what[sizeof key->note];
        snprintf(what, sizeof what, "cannot write '%.300s' (%s); built from "
                 "source", key->path, strerror(err));
        set_note(key, PKSS__CACHE_UNWRITABLE, what, NULL);
    } else {
        if (key->outcome == PKSS__CACHE_NONE)
            set_note(key, PKSS__CACHE_STORED, "built from source, entry written",
                     NULL);
        prune(key->path);
    }
}

#else
/* ISO C forbids an empty translation unit. */
typedef int pkss__program_cache_unused;
#endif /* PKSS_WITH_OPENCL */
