/* SPDX-License-Identifier: MIT
 * test_cl_cache.c -- the OpenCL program cache (src/device/program_cache.c):
 * a first context writes the entry and a second one builds from it; a
 * corrupt, truncated, stale (other kernel source hash) or driver-rejected
 * entry is detected, rebuilt from source and replaced; another build's
 * entry is kept beside this one's, and the folder stays bounded; an unusable folder
 * still prepares and registers, with the reason in the detail; and a
 * registration through a cached program gives the bit-identical pose of
 * one built from source. Each test uses its own folder (PKSS_CACHE_DIR).
 * Skips with a reason when there is no OpenCL device.
 */
#define _POSIX_C_SOURCE 200809L /* setenv, mkdtemp */
#include "support.h"

#include "device/program_cache.h"
#include "pkss_internal.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *PROGRAM = "test_cl_cache";

#ifdef PKSS_WITH_OPENCL

static char g_dir[256];

/* A fresh, empty cache folder for the calling test. */
static void fresh_dir(void)
{
    pkss_test_need_device();
    snprintf(g_dir, sizeof g_dir, "/tmp/pkss-cache-test-XXXXXX");
    assert_non_null(mkdtemp(g_dir));
    assert_int_equal(setenv("PKSS_CACHE_DIR", g_dir, 1), 0);
}

static void remove_dir(void)
{
    DIR *dir = opendir(g_dir);
    assert_non_null(dir);
    struct dirent *e;
    char path[512];
    while ((e = readdir(dir)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        snprintf(path, sizeof path, "%s/%s", g_dir, e->d_name);
        unlink(path);
    }
    closedir(dir);
    rmdir(g_dir);
}

/* The one entry of the folder; fails the test if there is not exactly one
 * (a leftover temp file counts too). */
static const char *entry_path(void)
{
    static char path[512];
    DIR *dir = opendir(g_dir);
    assert_non_null(dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(dir)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        ++n;
        snprintf(path, sizeof path, "%s/%s", g_dir, e->d_name);
    }
    closedir(dir);
    assert_int_equal(n, 1);
    assert_non_null(strstr(path, ".bin"));
    return path;
}

/* Prepares a new OpenCL context; checks the cache outcome and that the
 * note names it. The caller destroys the context. */
static pkss_context *prepared(pkss__cache_outcome want, const char *note_has)
{
    pkss_context *ctx = NULL;
    assert_int_equal(pkss_context_create(&ctx), PKSS_OK);
    assert_int_equal(pkss_context_set_int(ctx, PKSS_PARAM_BACKEND,
                                          PKSS_BACKEND_OPENCL), PKSS_OK);
    pkss_status st = pkss_context_prepare(ctx);
    if (st != PKSS_OK)
        fail_msg("prepare: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));
    const char *note = NULL;
    pkss__cache_outcome got = pkss__cl_cache_outcome(ctx, &note);
    if (got != want || (note_has && !strstr(note, note_has)))
        fail_msg("cache outcome %d (want %d), note '%s' (want '%s')", (int)got,
                 (int)want, note, note_has ? note_has : "");
    return ctx;
}

static void prepare_once(pkss__cache_outcome want, const char *note_has)
{
    pkss_context_destroy(prepared(want, note_has));
}

static long file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fseek(f, 0, SEEK_END), 0);
    long n = ftell(f);
    fclose(f);
    return n;
}

/* Overwrites `len` bytes at `offset` of the file. */
static void patch(const char *path, long offset, const void *bytes, size_t len)
{
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    assert_int_equal(fseek(f, offset, SEEK_SET), 0);
    assert_int_equal(fwrite(bytes, 1, len, f), len);
    fclose(f);
}

static void test_warm_cache_used(void **state)
{
    (void)state;
    fresh_dir();
    prepare_once(PKSS__CACHE_STORED, "entry written");
    const char *path = entry_path();
    assert_true(file_size(path) > (long)sizeof(pkss__cache_header));
    prepare_once(PKSS__CACHE_HIT, "used the cached binary");
    prepare_once(PKSS__CACHE_HIT, NULL);
    remove_dir();
}

static void test_corrupt_entry_rebuilt(void **state)
{
    (void)state;
    fresh_dir();
    prepare_once(PKSS__CACHE_STORED, NULL);
    const char *path = entry_path();
    long size = file_size(path);
    unsigned char flip = 0x5a; /* a payload byte changed: the checksum fails */
    long mid = (long)sizeof(pkss__cache_header) +
               (size - (long)sizeof(pkss__cache_header)) / 2;
    unsigned char was = 0;
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fseek(f, mid, SEEK_SET), 0);
    assert_int_equal(fread(&was, 1, 1, f), 1);
    fclose(f);
    flip ^= was;
    patch(path, mid, &flip, 1);
    prepare_once(PKSS__CACHE_REBUILT, "corrupt");
    assert_int_equal(file_size(entry_path()), size); /* replaced whole */
    prepare_once(PKSS__CACHE_HIT, NULL);
    assert_int_equal(truncate(path, size - 7), 0);
    prepare_once(PKSS__CACHE_REBUILT, "size");
    prepare_once(PKSS__CACHE_HIT, NULL);
    assert_int_equal(truncate(path, 10), 0);
    prepare_once(PKSS__CACHE_REBUILT, "truncated header");
    prepare_once(PKSS__CACHE_HIT, NULL);
    remove_dir();
}

static void test_stale_entry_rebuilt(void **state)
{
    (void)state;
    fresh_dir();
    prepare_once(PKSS__CACHE_STORED, NULL);
    const char *path = entry_path();
    uint64_t other = 0x0123456789abcdefull; /* another kernel source's hash */
    patch(path, (long)offsetof(pkss__cache_header, source_hash), &other,
          sizeof other);
    prepare_once(PKSS__CACHE_REBUILT, "another kernel source");
    prepare_once(PKSS__CACHE_HIT, NULL);
    uint32_t old_version = PKSS_VERSION_NUMBER - 1;
    patch(path, (long)offsetof(pkss__cache_header, lib_version), &old_version,
          sizeof old_version);
    prepare_once(PKSS__CACHE_REBUILT, "stale");
    prepare_once(PKSS__CACHE_HIT, NULL);
    remove_dir();
}

/* Names the folder's cl-*.bin entries: how many, and whether `name` is
 * one of them. */
static int count_entries(const char *name, int *has)
{
    DIR *dir = opendir(g_dir);
    assert_non_null(dir);
    int n = 0;
    *has = 0;
    struct dirent *e;
    while ((e = readdir(dir)) != NULL)
        if (!strncmp(e->d_name, "cl-", 3) && strstr(e->d_name, ".bin")) {
            ++n;
            *has |= name && !strcmp(e->d_name, name);
        }
    closedir(dir);
    return n;
}

/* Another kernel source's entry (another pkss build) is left alone: the
 * two builds keep an entry each instead of rebuilding every other call. */
static void test_other_source_entry_kept(void **state)
{
    (void)state;
    fresh_dir();
    prepare_once(PKSS__CACHE_STORED, NULL);
    char mine[512], other[512];
    snprintf(mine, sizeof mine, "%s", entry_path());
    const char *base = strrchr(mine, '/') + 1;
    assert_int_equal(strlen(base), strlen("cl-0123456789abcdef-0123456789abcdef.bin"));
    snprintf(other, sizeof other, "%s/%.20s0123456789abcdef.bin", g_dir, base);
    assert_string_not_equal(other, mine);
    FILE *in = fopen(mine, "rb"), *out = fopen(other, "wb");
    assert_true(in && out);
    int ch;
    while ((ch = fgetc(in)) != EOF)
        fputc(ch, out);
    fclose(in);
    fclose(out);
    uint64_t other_hash = 0x0123456789abcdefull;
    patch(other, (long)offsetof(pkss__cache_header, source_hash), &other_hash,
          sizeof other_hash);
    prepare_once(PKSS__CACHE_HIT, NULL); /* its own entry, untouched */
    int has = 0;
    assert_int_equal(count_entries(strrchr(other, '/') + 1, &has), 2);
    assert_true(has);
    remove_dir();
}

/* Two kernel sources (two pkss builds) on one device and driver are two
 * entries: alternating builds would otherwise rebuild on every call. */
static void test_sources_have_their_own_entries(void **state)
{
    (void)state;
    fresh_dir();
    assert_true(pkss__cl_load());
    cl_platform_id p;
    cl_device_id d;
    cl_uint np = 0;
    assert_int_equal(clGetPlatformIDs(1, &p, &np), CL_SUCCESS);
    assert_int_equal(clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &d, NULL), CL_SUCCESS);
    pkss__cache_key a, b, a2;
    pkss__cache_key_init(&a, p, d, "-DPKSS_TEST", "kernel one", 10);
    pkss__cache_key_init(&b, p, d, "-DPKSS_TEST", "kernel two", 10);
    pkss__cache_key_init(&a2, p, d, "-DPKSS_TEST", "kernel one", 10);
    assert_string_not_equal(a.path, b.path);
    assert_string_equal(a.path, a2.path);
    remove_dir();
}

/* The folder keeps the 16 most recently written entries. */
static void test_folder_bounded(void **state)
{
    (void)state;
    fresh_dir();
    char path[512];
    for (int i = 0; i < 20; ++i) {
        snprintf(path, sizeof path, "%s/cl-%016x-%016x.bin", g_dir, 0xabc, i);
        FILE *f = fopen(path, "wb");
        assert_non_null(f);
        fputs("an entry of another build", f);
        fclose(f);
        struct timespec t[2] = {{1000000 + i, 0}, {1000000 + i, 0}}; /* oldest: i = 0 */
        assert_int_equal(utimensat(AT_FDCWD, path, t, 0), 0);
    }
    snprintf(path, sizeof path, "%s/notes.txt", g_dir); /* not an entry: kept */
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fclose(f);
    prepare_once(PKSS__CACHE_STORED, NULL);
    int has = 0;
    assert_int_equal(count_entries(NULL, &has), 16);
    char name[64];
    snprintf(name, sizeof name, "cl-%016x-%016x.bin", 0xabc, 19);
    count_entries(name, &has);
    assert_true(has); /* the newest of the others stay ... */
    snprintf(name, sizeof name, "cl-%016x-%016x.bin", 0xabc, 4);
    count_entries(name, &has);
    assert_false(has); /* ... the oldest went */
    assert_int_equal(access(path, F_OK), 0);
    prepare_once(PKSS__CACHE_HIT, NULL); /* and this build's own is there */
    remove_dir();
}

/* A well-formed entry (right header and checksum) whose binary the driver
 * cannot load: detected at clBuildProgram, rebuilt from source. */
static void test_rejected_binary_rebuilt(void **state)
{
    (void)state;
    fresh_dir();
    prepare_once(PKSS__CACHE_STORED, NULL);
    const char *path = entry_path();
    pkss__cache_header h;
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fread(&h, sizeof h, 1, f), 1);
    fclose(f);
    unsigned char junk[4096];
    for (size_t i = 0; i < sizeof junk; ++i)
        junk[i] = (unsigned char)(i * 131u + 7u);
    h.size = sizeof junk;
    h.checksum = pkss__fnv1a(PKSS__FNV_INIT, junk, sizeof junk);
    assert_int_equal(pkss__cache_write(path, &h, junk), 0);
    prepare_once(PKSS__CACHE_REBUILT, "rejected");
    prepare_once(PKSS__CACHE_HIT, NULL);
    remove_dir();
}

/* Registers the bundled pair; returns the pose. */
static void register_pair(pkss_context *ctx, double T[16])
{
    size_t ns = 0, nt = 0;
    double *src = pkss_test_load_bundled("airplane_0001_s.ply", &ns);
    double *tgt = pkss_test_load_bundled("airplane_0001_t.ply", &nt);
    assert_non_null(src);
    assert_non_null(tgt);
    pkss_result res;
    res.struct_size = sizeof res;
    pkss_status st = pkss_register(ctx, src, ns, tgt, nt, &res);
    if (st != PKSS_OK)
        fail_msg("register: %s: %s", pkss_status_name(st),
                 pkss_context_last_error(ctx));
    assert_int_equal(res.backend, PKSS_BACKEND_OPENCL);
    memcpy(T, res.T_target_source, sizeof res.T_target_source);
    free(src);
    free(tgt);
}

static void test_unwritable_folder_registers(void **state)
{
    (void)state;
    fresh_dir();
    char file[300], bad[320];
    snprintf(file, sizeof file, "%s/plain-file", g_dir);
    FILE *f = fopen(file, "w");
    assert_non_null(f);
    fclose(f);
    /* a folder below a regular file cannot exist, even for root */
    snprintf(bad, sizeof bad, "%s/sub", file);
    assert_int_equal(setenv("PKSS_CACHE_DIR", bad, 1), 0);
    pkss_context *ctx = prepared(PKSS__CACHE_UNWRITABLE, "built from source");
    assert_non_null(strstr(pkss_context_last_error(ctx), "program cache"));
    double T[16];
    register_pair(ctx, T);
    pkss_context_destroy(ctx);
    assert_int_equal(setenv("PKSS_CACHE_DIR", g_dir, 1), 0);
    remove_dir();
}

/* The pose through a cached program equals the one built from source. */
static void test_cached_program_same_result(void **state)
{
    (void)state;
    fresh_dir();
    double T_built[16], T_cached[16];
    pkss_context *ctx = prepared(PKSS__CACHE_STORED, NULL);
    register_pair(ctx, T_built);
    pkss_context_destroy(ctx);
    ctx = prepared(PKSS__CACHE_HIT, NULL);
    register_pair(ctx, T_cached);
    pkss_context_destroy(ctx);
    assert_memory_equal(T_built, T_cached, sizeof T_built);
    remove_dir();
}

int main(void)
{
    (void)pkss_test_seed(PROGRAM, 1);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_warm_cache_used),
        cmocka_unit_test(test_corrupt_entry_rebuilt),
        cmocka_unit_test(test_stale_entry_rebuilt),
        cmocka_unit_test(test_other_source_entry_kept),
        cmocka_unit_test(test_sources_have_their_own_entries),
        cmocka_unit_test(test_folder_bounded),
        cmocka_unit_test(test_rejected_binary_rebuilt),
        cmocka_unit_test(test_unwritable_folder_registers),
        cmocka_unit_test(test_cached_program_same_result),
    };
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}

#else
static void test_built_without_opencl(void **state)
{
    (void)state;
    print_message("SKIP: built without OpenCL\n");
    skip();
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_built_without_opencl)};
    return cmocka_run_group_tests_name(PROGRAM, tests, NULL, NULL);
}
#endif /* PKSS_WITH_OPENCL */
