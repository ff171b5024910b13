/* SPDX-License-Identifier: MIT
 * test_io.c -- the point cloud readers and writers of the library (src/io):
 * every format on small inputs (counts, first and last coordinates), every
 * shared-data file with the point count of MANIFEST.md, malformed and
 * lying inputs with their documented status, and the fuzzer regression
 * inputs and seeds (tests/fuzz/{regressions,corpus}/<fmt>/).
 */
#define _POSIX_C_SOURCE 200809L
#include "support.h"

#include "io/io_internal.h" /* pkss__io_lzf_decompress */
#include "pkss_io.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#ifndef PKSS_FUZZ_DIR
#define PKSS_FUZZ_DIR PKSS_TEST_DATA_DIR "/../fuzz"
#endif

/* ------------------------------------------------------------ helpers */

typedef struct buf {
    unsigned char *p;
    size_t n, cap;
} buf;

static void put(buf *b, const void *data, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = realloc(b->p, b->cap);
        assert_non_null(b->p);
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
}

static void puts_(buf *b, const char *s) { put(b, s, strlen(s)); }

/* Appends the nb low bytes of v in the given byte order. */
static void put_bits(buf *b, uint64_t v, int nb, int big_endian)
{
    unsigned char t[8];
    for (int i = 0; i < nb; ++i)
        t[big_endian ? nb - 1 - i : i] = (unsigned char)(v >> (8 * i));
    put(b, t, (size_t)nb);
}

static void put_f32(buf *b, float f, int be)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_bits(b, u, 4, be);
}

static void put_f64(buf *b, double d, int be)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put_bits(b, u, 8, be);
}

typedef struct loaded {
    pkss_status st;
    double *xyz;
    size_t n;
    char err[1024];
} loaded;

static loaded read_mem(const void *data, size_t size, pkss_format f)
{
    loaded r;
    r.xyz = (double *)1; /* must be reset by the reader */
    r.n = 777;
    r.st = pkss_read_points_buffer(data, size, f, NULL, &r.xyz, &r.n, r.err,
                                   sizeof r.err);
    if (r.st != PKSS_OK) {
        assert_null(r.xyz);
        assert_int_equal(r.n, 0);
        assert_true(r.err[0] != '\0'); /* every error says what is wrong */
    } else {
        assert_non_null(r.xyz);
        assert_true(r.n > 0);
    }
    return r;
}

static loaded read_str(const char *s, pkss_format f)
{
    return read_mem(s, strlen(s), f);
}

#define assert_point(xyz, i, X, Y, Z)                                         \
    do {                                                                      \
        assert_float_equal((xyz)[3 * (i)], (X), 1e-12);                       \
        assert_float_equal((xyz)[3 * (i) + 1], (Y), 1e-12);                   \
        assert_float_equal((xyz)[3 * (i) + 2], (Z), 1e-12);                   \
    } while (0)

/* Expects status st and, if `needle` is given, that the message has it. */
static void expect(const loaded *r, pkss_status st, const char *needle)
{
    if (r->st != st || (needle && !strstr(r->err, needle)))
        fail_msg("expected %s%s%s%s, got %s: %s", pkss_status_name(st),
                 needle ? " with \"" : "", needle ? needle : "",
                 needle ? "\"" : "", pkss_status_name(r->st), r->err);
}

static char tmpdir[256];

static int setup_tmp(void **state)
{
    (void)state;
    const char *t = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/pkss_test_io_XXXXXX",
             t && t[0] ? t : "/tmp");
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int teardown_tmp(void **state)
{
    (void)state;
    DIR *d = opendir(tmpdir);
    if (d) {
        struct dirent *e;
        char p[512];
        while ((e = readdir(d)) != NULL) {
            if (e->d_name[0] == '.')
                continue;
            snprintf(p, sizeof p, "%s/%s", tmpdir, e->d_name);
            remove(p);
        }
        closedir(d);
    }
    rmdir(tmpdir);
    return 0;
}

static const char *tmp_file(const char *name, const void *data, size_t n)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    if (n)
        assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
    return path;
}

/* -------------------------------------------------------------- names */

static void test_names(void **state)
{
    (void)state;
    assert_int_equal(pkss_format_from_name("PLY"), PKSS_FORMAT_PLY);
    assert_int_equal(pkss_format_from_name("csv"), PKSS_FORMAT_XYZ);
    assert_int_equal(pkss_format_from_name("txt"), PKSS_FORMAT_XYZ);
    assert_int_equal(pkss_format_from_name("bin"), PKSS_FORMAT_KITTI);
    assert_int_equal(pkss_format_from_name("kitti"), PKSS_FORMAT_KITTI);
    assert_int_equal(pkss_format_from_name("vtk"), PKSS_FORMAT_VTK);
    assert_null(pkss_format_name(pkss_format_from_name("nope")));
    assert_int_equal(pkss_format_from_path("a/b.c/scan.PCD"), PKSS_FORMAT_PCD);
    assert_int_equal(pkss_format_from_path("x.off"), PKSS_FORMAT_OFF);
    assert_int_equal(pkss_format_from_path("x.pts"), PKSS_FORMAT_XYZ);
    assert_int_equal(pkss_format_from_path("dir.ply/noext"), PKSS_FORMAT_AUTO);
    assert_int_equal(pkss_format_from_path("x.kitti"), PKSS_FORMAT_AUTO);
    assert_int_equal(pkss_format_from_content("ply\nformat", 10),
                     PKSS_FORMAT_PLY);
    assert_int_equal(pkss_format_from_content("COFF\n", 5), PKSS_FORMAT_OFF);
    assert_int_equal(pkss_format_from_content("OFF490 1 0", 10),
                     PKSS_FORMAT_OFF);
    assert_int_equal(pkss_format_from_content("1 2 3\n", 6), PKSS_FORMAT_AUTO);
    assert_string_equal(pkss_status_name(PKSS_ERR_EMPTY_INPUT),
                        "PKSS_ERR_EMPTY_INPUT");
    assert_string_equal(pkss_status_name((pkss_status)99),
                        "PKSS_UNKNOWN_STATUS");
    /* AUTO on memory needs recognisable content */
    loaded r = read_str("1 2 3\n", PKSS_FORMAT_AUTO);
    expect(&r, PKSS_ERR_INVALID_ARGUMENT, "format");
    double *xyz;
    size_t n;
    assert_int_equal(pkss_read_points_buffer("1", 1, PKSS_FORMAT_XYZ, NULL, NULL, &n,
                                             NULL, 0),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_read_points_buffer("1", 1, PKSS_FORMAT_XYZ, NULL, &xyz, NULL,
                                             NULL, 0),
                     PKSS_ERR_NULL_ARGUMENT);
    /* an array name selects only an .npz member */
    assert_int_equal(pkss_read_points_buffer("1 2 3\n", 6, PKSS_FORMAT_XYZ, "points",
                                             &xyz, &n, NULL, 0),
                     PKSS_ERR_INVALID_ARGUMENT);
}

/* ---------------------------------------------------------------- PLY */

static void test_ply_ascii(void **state)
{
    (void)state;
    const char *s =
        "ply\nformat ascii 1.0\ncomment c\nobj_info o\n"
        "element face 2\nproperty list uchar int vertex_indices\n"
        "element vertex 3\nproperty uchar red\nproperty double z\n"
        "property float y\nproperty float x\nproperty list uint8 float nrm\n"
        "element range_grid 4\nproperty list uchar int vertex_indices\n"
        "end_header\n"
        "3 0 1 2\n4 0 1 2 1\n"
        "255 3 2 1 0\n0 -6 -5 -4 3 0 0 1\n7 9.5 8.5 7.5 1 2\n"
        "1 0\n0\n0\n1 2\n";
    loaded r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_point(r.xyz, 1, -4, -5, -6);
    assert_point(r.xyz, 2, 7.5, 8.5, 9.5);
    pkss_points_free(r.xyz);

    /* CRLF header, no trailing newline, scientific notation, NaN/Inf */
    r = read_str("ply\r\nformat ascii 1.0\r\nelement vertex 2\r\n"
                 "property float x\r\nproperty float y\r\nproperty float z\r\n"
                 "end_header\r\n1e-3 -2E+2 nan\r\ninf 0 -0", PKSS_FORMAT_PLY);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    assert_float_equal(r.xyz[0], 1e-3, 0);
    assert_float_equal(r.xyz[1], -200, 0);
    assert_true(isnan(r.xyz[2]));
    assert_true(isinf(r.xyz[3]));
    pkss_points_free(r.xyz);
}

/* x y z of every PLY scalar type, both byte orders. */
static void test_ply_binary_types(void **state)
{
    (void)state;
    static const char *types[] = {
        "char", "int8", "uchar", "uint8", "short", "int16", "ushort",
        "uint16", "int", "int32", "uint", "uint32", "float", "float32",
        "double", "float64"};
    static const int sizes[] = {1, 1, 1, 1, 2, 2, 2, 2, 4, 4, 4, 4, 4, 4, 8, 8};
    for (int be = 0; be < 2; ++be)
        for (size_t t = 0; t < sizeof types / sizeof types[0]; ++t) {
            buf b = {0};
            char hdr[512];
            snprintf(hdr, sizeof hdr,
                     "ply\nformat %s 1.0\nelement vertex 2\n"
                     "property %s x\nproperty %s y\nproperty int16 pad\n"
                     "property %s z\nend_header\n",
                     be ? "binary_big_endian" : "binary_little_endian",
                     types[t], types[t], types[t]);
            puts_(&b, hdr);
            int is_signed = types[t][0] != 'u';
            int is_float = strstr(types[t], "float") || !strcmp(types[t], "double");
            for (int v = 0; v < 2; ++v)
                for (int a = 0; a < 3; ++a) {
                    double val = v == 0 ? 1 + a : (is_signed ? -(10 + a) : 100 + a);
                    if (is_float && sizes[t] == 4)
                        put_f32(&b, (float)val, be);
                    else if (is_float)
                        put_f64(&b, val, be);
                    else
                        put_bits(&b, (uint64_t)(int64_t)val, sizes[t], be);
                    if (a == 1)
                        put_bits(&b, 0xBEEF, 2, be);
                }
            loaded r = read_mem(b.p, b.n, PKSS_FORMAT_PLY);
            if (r.st != PKSS_OK)
                fail_msg("type %s be=%d: %s", types[t], be, r.err);
            assert_int_equal(r.n, 2);
            assert_point(r.xyz, 0, 1, 2, 3);
            if (is_signed)
                assert_point(r.xyz, 1, -10, -11, -12);
            else
                assert_point(r.xyz, 1, 100, 101, 102);
            pkss_points_free(r.xyz);
            free(b.p);
        }
}

static void test_ply_binary_lists(void **state)
{
    (void)state;
    /* element with lists before the vertex element, list inside vertex */
    buf b = {0};
    puts_(&b, "ply\nformat binary_little_endian 1.0\nelement face 2\n"
              "property list uchar int vertex_indices\nproperty float q\n"
              "element vertex 2\nproperty list ushort double extra\n"
              "property float x\nproperty float y\nproperty float z\n"
              "element edge 1\nproperty int a\nend_header\n");
    put_bits(&b, 3, 1, 0);
    for (int i = 0; i < 3; ++i)
        put_bits(&b, (uint64_t)i, 4, 0);
    put_f32(&b, 9, 0);
    put_bits(&b, 0, 1, 0);
    put_f32(&b, 9, 0);
    put_bits(&b, 1, 2, 0);
    put_f64(&b, 42, 0);
    put_f32(&b, 1, 0);
    put_f32(&b, 2, 0);
    put_f32(&b, 3, 0);
    put_bits(&b, 0, 2, 0);
    put_f32(&b, 4, 0);
    put_f32(&b, 5, 0);
    put_f32(&b, 6, 0);
    /* the edge element is missing: data after the vertices is not read */
    loaded r = read_mem(b.p, b.n, PKSS_FORMAT_PLY);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_point(r.xyz, 1, 4, 5, 6);
    pkss_points_free(r.xyz);

    /* the same file cut inside the vertices */
    r = read_mem(b.p, b.n - 5, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, NULL);
    free(b.p);
}

static void test_ply_malformed(void **state)
{
    (void)state;
    const char *xyzf = "property float x\nproperty float y\nproperty float z\n";
    char s[1024];
    loaded r;

    snprintf(s, sizeof s, "ply\nformat binary_little_endian 1.0\n"
             "element vertex 1000000000000\n%send_header\n0123456789ab", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "1000000000000 vertices");
    assert_non_null(strstr(r.err, "12 bytes")); /* says what is there */

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement vertex 5\n%s"
             "end_header\n1 2 3\n4 5 6\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY); /* lying but plausible: ends early */
    expect(&r, PKSS_ERR_FORMAT, NULL);

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement vertex -3\n%s"
             "end_header\n1 2 3\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "negative");

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\n"
             "element vertex 99999999999999999999999\n%send_header\n1 2 3\n",
             xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "overflows");

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement face 3000000000\n"
             "property list uchar int v\nelement vertex 1\n%send_header\n"
             "3 0 1 2\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY); /* huge element before the vertices */
    expect(&r, PKSS_ERR_FORMAT, "face");

    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\n"
                 "end_header\n1\n", PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "unknown property type 'half'");

    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\n"
                 "property list uchar float x\nproperty float y\n"
                 "property float z\nend_header\n1 1 2 3\n", PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "lists");

    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\n"
                 "property list float int idx\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n", PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "integer");

    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nend_header\n1 2\n", PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "'z'");

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement vertex 1\n%s"
             "1 2 3\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, NULL); /* no end_header */

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement vertex 1\n%s"
             "end_header\n1 two 3\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "'two' is not a number");

    snprintf(s, sizeof s, "ply\nformat ascii 1.0\nelement vertex 0\n%s"
             "end_header\n", xyzf);
    r = read_str(s, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_EMPTY_INPUT, NULL);

    r = read_str("ply\nformat ascii 1.0\nelement face 1\n"
                 "property list uchar int v\nend_header\n3 0 1 2\n",
                 PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "no 'vertex' element");

    r = read_str("PLY garbage", PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "not a PLY file");

    r = read_str("ply\nformat binary_middle_endian 1.0\nend_header\n",
                 PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "binary_middle_endian");

    /* binary list with a negative length */
    buf b = {0};
    snprintf(s, sizeof s, "ply\nformat binary_little_endian 1.0\n"
             "element vertex 1\nproperty list char float l\n%send_header\n",
             xyzf);
    puts_(&b, s);
    put_bits(&b, 0xFF, 1, 0);
    for (int i = 0; i < 16; ++i)
        put_bits(&b, 0, 1, 0);
    r = read_mem(b.p, b.n, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "negative list length");
    free(b.p);
}

/* ---------------------------------------------------------------- PCD */

/* Literal-only LZF stream (valid input for any LZF decoder). */
static void lzf_literal(buf *out, const unsigned char *in, size_t n)
{
    for (size_t i = 0; i < n; i += 32) {
        size_t l = n - i < 32 ? n - i : 32;
        unsigned char c = (unsigned char)(l - 1);
        put(out, &c, 1);
        put(out, in + i, l);
    }
}

static void test_pcd(void **state)
{
    (void)state;
    const char *hdr =
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        "FIELDS x y z rgb\nSIZE 4 4 8 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
        "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\n";
    buf b = {0};
    puts_(&b, hdr);
    puts_(&b, "DATA ascii\n1 2 3 0\nnan nan nan 0\n7 8 9 4278190080\n");
    loaded r = read_mem(b.p, b.n, PKSS_FORMAT_PCD);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_true(isnan(r.xyz[3]) && isnan(r.xyz[4]) && isnan(r.xyz[5]));
    assert_point(r.xyz, 2, 7, 8, 9);
    pkss_points_free(r.xyz);
    free(b.p);

    /* binary: array of structures */
    memset(&b, 0, sizeof b);
    puts_(&b, hdr);
    puts_(&b, "DATA binary\n");
    for (int i = 0; i < 3; ++i) {
        put_f32(&b, (float)(10 * i + 1), 0);
        put_f32(&b, (float)(10 * i + 2), 0);
        put_f64(&b, 10 * i + 3, 0);
        put_bits(&b, 0xFFFFFFFF, 4, 0);
    }
    r = read_mem(b.p, b.n, PKSS_FORMAT_PCD);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_point(r.xyz, 2, 21, 22, 23);
    pkss_points_free(r.xyz);
    r = read_mem(b.p, b.n - 1, PKSS_FORMAT_PCD); /* truncated */
    expect(&r, PKSS_ERR_FORMAT, "3 points");
    free(b.p);

    /* binary_compressed: structure of arrays, literal runs */
    buf soa = {0}, lz = {0};
    for (int i = 0; i < 3; ++i) put_f32(&soa, (float)(i + 0.5), 0);
    for (int i = 0; i < 3; ++i) put_f32(&soa, (float)(i + 10), 0);
    for (int i = 0; i < 3; ++i) put_f64(&soa, -(i + 100.0), 0);
    for (int i = 0; i < 3; ++i) put_bits(&soa, 7, 4, 0);
    lzf_literal(&lz, soa.p, soa.n);
    memset(&b, 0, sizeof b);
    puts_(&b, hdr);
    puts_(&b, "DATA binary_compressed\n");
    put_bits(&b, lz.n, 4, 0);
    put_bits(&b, soa.n, 4, 0);
    put(&b, lz.p, lz.n);
    r = read_mem(b.p, b.n, PKSS_FORMAT_PCD);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 0.5, 10, -100);
    assert_point(r.xyz, 2, 2.5, 12, -102);
    pkss_points_free(r.xyz);
    /* lying uncompressed size */
    b.p[b.n - lz.n - 4] ^= 0x10;
    r = read_mem(b.p, b.n, PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "uncompressed size");
    free(b.p);
    free(soa.p);
    free(lz.p);

    /* a back reference: 1 literal byte, then copy it 8 times */
    static const unsigned char lzf_ref[] = {0x00, 0x41, 0xC0, 0x00};
    unsigned char out[16];
    size_t bad = 0;
    assert_int_equal(pkss__io_lzf_decompress(lzf_ref, 4, out, 9, &bad), 9);
    for (int i = 0; i < 9; ++i)
        assert_int_equal(out[i], 0x41);
    /* reference before the start of the output */
    static const unsigned char lzf_bad[] = {0x00, 0x41, 0x20, 0x05};
    assert_int_equal(pkss__io_lzf_decompress(lzf_bad, 4, out, 16, &bad), 0);

    /* header problems */
    r = read_str("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                 "WIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "WIDTH x HEIGHT");
    r = read_str("VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\n"
                 "WIDTH 1\nDATA ascii\n1 2\n", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "no field 'z'");
    r = read_str("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                 "WIDTH 9000000000000\nDATA binary\n1234", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "9000000000000 points");
    r = read_str("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 2\nTYPE F F F\n"
                 "WIDTH 1\nDATA binary\n1234567890", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "'z'");
    r = read_str("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                 "WIDTH -1\nDATA ascii\n", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "negative");
    r = read_str("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                 "WIDTH 0\nHEIGHT 1\nDATA ascii\n", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_EMPTY_INPUT, NULL);
    r = read_str("VERSION 0.7\nFIELDS x y z\nWIDTH 1\nDATA lzma\n",
                 PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "lzma");
    r = read_str("VERSION 0.7\nFIELDS x y z\nWIDTH 1\n", PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "DATA");
    r = read_str("VERSION 0.7\nFIELDS x y z\nWIDTH 2\nDATA ascii\n1 2 3\n4 5\n",
                 PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, NULL);
}

/* --------------------------------------------------------- XYZ family */

static void test_xyz(void **state)
{
    (void)state;
    loaded r = read_str("1 2 3\n4\t5\t6 extra columns\n\n  7 8 9", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_point(r.xyz, 2, 7, 8, 9);
    pkss_points_free(r.xyz);

    r = read_str("x,y,z,nx,ny,nz\r\n-3.5 , 0.25 , -1 , 0,0,1\r\n"
                 "# comment\r\n1e2,2e2,3e2,0,0,1 # trailing\r\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    assert_point(r.xyz, 0, -3.5, 0.25, -1);
    assert_point(r.xyz, 1, 100, 200, 300);
    pkss_points_free(r.xyz);

    r = read_str("3\n1 2 3\n4 5 6\n7 8 9\n", PKSS_FORMAT_XYZ); /* Go-ICP */
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 2, 7, 8, 9);
    pkss_points_free(r.xyz);

    r = read_str("4\n1 2 3\n4 5 6\n7 8 9\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "says 4 points but 3 rows");
    r = read_str("1000000000000\n1 2 3\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "1000000000000");
    r = read_str("1 2 3\n4 5\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "line 2");
    r = read_str("1 2 3\n4 5 six\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "line 2");
    r = read_str("# only a comment\n\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_EMPTY_INPUT, NULL);
    r = read_str("x y z\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "header");
    r = read_str("1 2 nan\n4 5 6\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_OK, NULL);
    assert_true(isnan(r.xyz[2]));
    pkss_points_free(r.xyz);
    static const unsigned char garbage[] = {0x7f, 'E', 'L', 'F', 0, 1, 2, '\n',
                                            '1', ' ', '2', ' ', '3', '\n'};
    r = read_mem(garbage, sizeof garbage, PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "NUL");
}

/* ---------------------------------------------------------------- OFF */

static void test_off(void **state)
{
    (void)state;
    loaded r = read_str("OFF\n# comment\n\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n"
                        "0 0 1.5\n3 0 1 2\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 4);
    assert_point(r.xyz, 3, 0, 0, 1.5);
    pkss_points_free(r.xyz);
    r = read_str("COFF 2 0 0\n1 2 3 255 0 0 255\n4 5 6 0 0 0 255\n",
                 PKSS_FORMAT_OFF);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    assert_point(r.xyz, 1, 4, 5, 6);
    pkss_points_free(r.xyz);
    r = read_str("OFF2 0 0\n1 2 3\n4 5 6\n", PKSS_FORMAT_OFF); /* ModelNet */
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    pkss_points_free(r.xyz);
    r = read_str("NOFF\r\n1 0\r\n1 2 3 0 0 1\r\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_OK, NULL);
    assert_point(r.xyz, 0, 1, 2, 3);
    pkss_points_free(r.xyz);

    r = read_str("OFF BINARY\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "binary");
    r = read_str("4OFF\n1 0 0\n1 2 3 4\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, NULL);
    r = read_str("OFF\n-1 0 0\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_FORMAT, "negative");
    r = read_str("OFF\n100000000000 0 0\n1 2 3\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_FORMAT, "100000000000 vertices");
    r = read_str("OFF\n3 0 0\n1 2 3\n4 5 6\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_FORMAT, NULL);
    r = read_str("OFF\n0 0 0\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_EMPTY_INPUT, NULL);
    r = read_str("PLY\n", PKSS_FORMAT_OFF);
    expect(&r, PKSS_ERR_FORMAT, "not an OFF keyword");
}

/* -------------------------------------------------------- KITTI, VTK */

static void test_kitti(void **state)
{
    (void)state;
    buf b = {0};
    for (int i = 0; i < 3; ++i) {
        put_f32(&b, (float)i, 0);
        put_f32(&b, (float)(i + 0.5), 0);
        put_f32(&b, (float)-i, 0);
        put_f32(&b, 0.25f, 0);
    }
    loaded r = read_mem(b.p, b.n, PKSS_FORMAT_KITTI);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 0, 0.5, 0);
    assert_point(r.xyz, 2, 2, 2.5, -2);
    pkss_points_free(r.xyz);
    r = read_mem(b.p, b.n - 3, PKSS_FORMAT_KITTI);
    expect(&r, PKSS_ERR_FORMAT, "multiple of 16");
    free(b.p);
}

static void test_vtk(void **state)
{
    (void)state;
    loaded r = read_str("# vtk DataFile Version 3.0\ntitle\nASCII\n"
                        "DATASET POLYDATA\nPOINTS 3 float\n1 2 3 4 5 6\n"
                        "7 8 9\nVERTICES 3 6\n1 0\n1 1\n1 2\n", PKSS_FORMAT_VTK);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 3);
    assert_point(r.xyz, 0, 1, 2, 3);
    assert_point(r.xyz, 2, 7, 8, 9);
    pkss_points_free(r.xyz);

    for (int dbl = 0; dbl < 2; ++dbl) {
        buf b = {0};
        puts_(&b, "# vtk DataFile Version 2.0\nbinary\nBINARY\n"
                  "DATASET UNSTRUCTURED_GRID\n");
        puts_(&b, dbl ? "POINTS 2 double\n" : "POINTS 2 float\n");
        for (int i = 0; i < 6; ++i) {
            if (dbl)
                put_f64(&b, i + 0.5, 1);
            else
                put_f32(&b, (float)(i + 0.5), 1);
        }
        puts_(&b, "\nCELLS 0 0\n");
        r = read_mem(b.p, b.n, PKSS_FORMAT_VTK);
        expect(&r, PKSS_OK, NULL);
        assert_int_equal(r.n, 2);
        assert_point(r.xyz, 1, 3.5, 4.5, 5.5);
        pkss_points_free(r.xyz);
        free(b.p);
    }
    r = read_str("# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\n"
                 "POINTS 100000 double\n0123", PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_FORMAT, "100000 points");
    r = read_str("# vtk DataFile Version 3.0\nt\nASCII\n"
                 "DATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n", PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "STRUCTURED_POINTS");
    r = read_str("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"
                 "POINTS 2 float\n1 2 3 4 5\n", PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_FORMAT, "2 points");
    r = read_str("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"
                 "POINTS 2 quaternion\n", PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_FORMAT, "data type");
    r = read_str("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"
                 "FIELD FieldData 1\nTIME 1 1 double\n0\nPOINTS 1 float\n1 2 3\n",
                 PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "FIELD");
    r = read_str("hello\n", PKSS_FORMAT_VTK);
    expect(&r, PKSS_ERR_FORMAT, "not a legacy VTK");
}

/* ---------------------------------------------------------- NPY, NPZ */

/* An .npy of header text h (padded as numpy does) and `data` bytes. */
static size_t npy_make(unsigned char *out, int major, const char *h, const void *data,
                       size_t data_size)
{
    size_t pre = major == 1 ? 10 : 12, hl = strlen(h);
    size_t total = (pre + hl + 1 + 63) / 64 * 64, padded = total - pre;
    memcpy(out, "\x93NUMPY", 6);
    out[6] = (unsigned char)major;
    out[7] = 0;
    for (size_t k = 0; k < pre - 8; ++k)
        out[8 + k] = (unsigned char)(padded >> (8 * k));
    memcpy(out + pre, h, hl);
    memset(out + pre + hl, ' ', padded - hl - 1);
    out[total - 1] = '\n';
    memcpy(out + total, data, data_size);
    return total + data_size;
}

static loaded read_fixture(const char *rel)
{
    char path[1024];
    loaded r;
    snprintf(path, sizeof path, "%s/%s", PKSS_FUZZ_DIR, rel);
    r.xyz = NULL;
    r.n = 0;
    r.st = pkss_read_points(path, PKSS_FORMAT_AUTO, &r.xyz, &r.n, r.err, sizeof r.err);
    return r;
}

static void test_npy_npz(void **state)
{
    (void)state;
    static const double seed[5][3] = {{0.5, -1.25, 2.0}, {1.0, 2.0, 3.0}, {-4.5, 0.0, 1e-3},
                                      {7.0, 8.0, 9.0}, {1.5, 1.5, 1.5}};
    static const struct {
        const char *file;
        size_t n;
        int f32;
    } good[] = {
        {"corpus/npy/f8_c_v1.npy", 5, 0},   {"corpus/npy/f4_fortran.npy", 5, 1},
        {"corpus/npy/f8_be_v2.npy", 2, 0},  {"corpus/npy/f4_v3.npy", 3, 1},
        {"corpus/npy/py2_long.npy", 2, 0},  {"corpus/npz/single.npz", 5, 0},
        {"corpus/npz/points_and_more.npz", 5, 0}, /* "points" of two */
        {"corpus/npz/xyz.npz", 3, 1},       /* "xyz" of two, Fortran float32 */
        {"corpus/npz/points_and_more.npz:normals", 2, 1},
    };
    for (size_t i = 0; i < sizeof good / sizeof good[0]; ++i) {
        loaded r = read_fixture(good[i].file);
        if (r.st != PKSS_OK)
            fail_msg("%s: %s %s", good[i].file, pkss_status_name(r.st), r.err);
        assert_int_equal(r.n, good[i].n);
        for (size_t k = 0; k < 3 * r.n; ++k) {
            double want = seed[k / 3][k % 3];
            if (good[i].f32)
                want = (double)(float)want;
            assert_memory_equal(&r.xyz[k], &want, sizeof want);
        }
        pkss_points_free(r.xyz);
    }
    static const struct {
        const char *file;
        pkss_status st;
        const char *needle;
    } bad[] = {
        {"regressions/npz/hostile-deflate.npz", PKSS_ERR_UNSUPPORTED_FORMAT, "np.savez_compressed"},
        {"regressions/npz/hostile-crc.npz", PKSS_ERR_FORMAT, "CRC-32"},
        {"regressions/npz/hostile-entries.npz", PKSS_ERR_FORMAT, "does not fit"},
        {"regressions/npy/hostile-int32.npy", PKSS_ERR_UNSUPPORTED_FORMAT, "'<i4'"},
        {"regressions/npy/hostile-shape-n2.npy", PKSS_ERR_UNSUPPORTED_FORMAT, "(3, 2)"},
        {"regressions/npy/hostile-huge-shape.npy", PKSS_ERR_FORMAT, "truncated at byte"},
        {"regressions/npy/hostile-header-4g.npy", PKSS_ERR_FORMAT, "at most 65536"},
        {"corpus/npz/points_and_more.npz:nope", PKSS_ERR_FORMAT, "no array 'nope'"},
        /* a member name's escape sequence is shown defused */
        {"regressions/npz/hostile-name-escape.npz:nope", PKSS_ERR_FORMAT, "a?[31m"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        loaded r = read_fixture(bad[i].file);
        if (r.st != bad[i].st || !strstr(r.err, bad[i].needle))
            fail_msg("%s: expected %s \"%s\", got %s: %s", bad[i].file,
                     pkss_status_name(bad[i].st), bad[i].needle, pkss_status_name(r.st), r.err);
        assert_null(r.xyz);
    }

    /* header grammar, on memory */
    unsigned char buf[512];
    const double d6[6] = {1, 2, 3, 4, 5, 6};
    static const struct {
        const char *h;
        pkss_status st;
        const char *needle;
    } hdr[] = {
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }", PKSS_OK, NULL},
        {"{\"descr\":\"<f8\",\"shape\":(2,3),\"fortran_order\":False}", PKSS_OK, NULL},
        {"{'descr': '<f8', 'fortran_order': False}", PKSS_ERR_FORMAT, "lacks 'shape'"},
        {"{'descr': '<f8', 'descr': '<f8', 'fortran_order': False, 'shape': (2, 3)}",
         PKSS_ERR_FORMAT, "twice"},
        {"{'descr': '<f8', 'fortran_order': 0, 'shape': (2, 3)}", PKSS_ERR_FORMAT,
         "not True or False"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), 'x': 1}", PKSS_ERR_FORMAT,
         "unknown header key"},
        {"{'descr': [('x', '<f8')], 'fortran_order': False, 'shape': (2,)}",
         PKSS_ERR_UNSUPPORTED_FORMAT, "structured"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (6,)}", PKSS_ERR_UNSUPPORTED_FORMAT,
         "1-dimensional"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (-2, 3)}", PKSS_ERR_FORMAT,
         "not a dimension"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (1, 3)}", PKSS_ERR_FORMAT,
         "24 bytes after"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (0, 3)}", PKSS_ERR_EMPTY_INPUT,
         "no points"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3)} x", PKSS_ERR_FORMAT,
         "text after"},
        {"['descr']", PKSS_ERR_FORMAT, "not a dict"},
    };
    for (size_t i = 0; i < sizeof hdr / sizeof hdr[0]; ++i) {
        for (int major = 1; major <= 3; ++major) {
            size_t len = npy_make(buf, major, hdr[i].h, d6, sizeof d6);
            loaded r = read_mem(buf, len, PKSS_FORMAT_AUTO);
            if (r.st != hdr[i].st || (hdr[i].needle && !strstr(r.err, hdr[i].needle)))
                fail_msg("v%d %s: expected %s \"%s\", got %s: %s", major, hdr[i].h,
                         pkss_status_name(hdr[i].st), hdr[i].needle ? hdr[i].needle : "",
                         pkss_status_name(r.st), r.err);
            if (r.st == PKSS_OK)
                assert_memory_equal(r.xyz, d6, sizeof d6);
            pkss_points_free(r.xyz);
            /* every cut of the file is an error, never a crash or a point */
            for (size_t cut = 0; cut < len; cut += 7) {
                loaded c = read_mem(buf, cut, PKSS_FORMAT_NPY);
                assert_int_not_equal(c.st, PKSS_OK);
            }
        }
    }
    buf[6] = 4; /* format version 4.0 */
    loaded r = read_mem(buf, 200, PKSS_FORMAT_NPY);
    expect(&r, PKSS_ERR_UNSUPPORTED_FORMAT, "version 4.0");
}

/* Every writable format reads back bit-identically; the others refuse. */
static void test_writers(void **state)
{
    (void)state;
    const double pts[] = {1.0 / 3.0, -2e-300, 1e300, 0.1, 0.2, 0.3, -0.0, 12345.6789, -7.25,
                          4.9e-324, -1.7976931348623157e308, 2.5};
    static const char *const names[] = {"w.ply", "w.pcd", "w.xyz", "w.npy"};
    char path[600], err[1024];
    double *xyz;
    size_t n;
    for (size_t i = 0; i < 4; ++i) {
        snprintf(path, sizeof path, "%s/%s", tmpdir, names[i]);
        assert_int_equal(pkss_write_points(path, PKSS_FORMAT_AUTO, pts, 4, 0, err, sizeof err),
                         PKSS_OK);
        assert_int_equal(pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                         PKSS_OK);
        assert_int_equal(n, 4);
        assert_memory_equal(xyz, pts, sizeof pts);
        pkss_points_free(xyz);
    }
    /* a failed write leaves the existing file as it was */
    snprintf(path, sizeof path, "%s/w.ply", tmpdir);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_PLY, pts, 0, 0, err, sizeof err),
                     PKSS_ERR_EMPTY_INPUT);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_OFF, pts, 4, 0, err, sizeof err),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err, "cannot write format 'off'"));
    assert_int_equal(pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_OK);
    assert_int_equal(n, 4);
    pkss_points_free(xyz);
    snprintf(path, sizeof path, "%s/w.vtk", tmpdir);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_AUTO, pts, 4, 0, err, sizeof err),
                     PKSS_ERR_INVALID_ARGUMENT);
    struct stat st;
    assert_int_not_equal(stat(path, &st), 0); /* nothing created */
    snprintf(path, sizeof path, "%s/w.noext", tmpdir);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_AUTO, pts, 4, 0, err, sizeof err),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_write_points(NULL, PKSS_FORMAT_PLY, pts, 4, 0, err, sizeof err),
                     PKSS_ERR_NULL_ARGUMENT);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_PLY, NULL, 4, 0, err, sizeof err),
                     PKSS_ERR_NULL_ARGUMENT);
    /* the stream writer fails cleanly on a full device */
    FILE *full = fopen("/dev/full", "w");
    if (full) {
        static double many[3 * 4096];
        assert_int_equal(pkss_write_points_stream(full, PKSS_FORMAT_XYZ, many, 4096, 0, err,
                                                  sizeof err),
                         PKSS_ERR_IO);
        fclose(full);
    }
}

/* ------------------------------------------------- files and writing */

static void test_empty_every_format(void **state)
{
    (void)state;
    for (int f = PKSS_FORMAT_PLY; f <= PKSS_FORMAT_NPZ; ++f) {
        loaded r = read_mem("", 0, (pkss_format)f);
        expect(&r, PKSS_ERR_EMPTY_INPUT, "empty");
        /* binary garbage: never OK for the text-headed formats */
        unsigned char g[256];
        for (int i = 0; i < 256; ++i)
            g[i] = (unsigned char)(i * 37 + 11);
        r = read_mem(g, sizeof g, (pkss_format)f);
        if (f == PKSS_FORMAT_KITTI)
            expect(&r, PKSS_OK, NULL); /* any 16*k bytes are records */
        else if (r.st != PKSS_ERR_FORMAT && r.st != PKSS_ERR_UNSUPPORTED_FORMAT)
            fail_msg("%s on garbage: %s %s", pkss_format_name(f),
                     pkss_status_name(r.st), r.err);
        pkss_points_free(r.xyz);
    }
}

static void test_files_and_writer(void **state)
{
    (void)state;
    char err[1024];
    double *xyz = NULL;
    size_t n = 0;
    char path[600];

    snprintf(path, sizeof path, "%s/does_not_exist.ply", tmpdir);
    assert_int_equal(pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_ERR_IO);
    assert_non_null(strstr(err, path));
    assert_int_equal(pkss_read_points(tmpdir, PKSS_FORMAT_PLY, &xyz, &n, err, sizeof err),
                     PKSS_ERR_IO); /* a directory */

    const char *p = tmp_file("cloud.unknown", "1 2 3\n", 6);
    assert_int_equal(pkss_read_points(p, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_ERR_INVALID_ARGUMENT);
    assert_int_equal(pkss_read_points(p, PKSS_FORMAT_XYZ, &xyz, &n, err, sizeof err),
                     PKSS_OK);
    pkss_points_free(xyz);
    static const char ply1[] =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n1 2 3\n";
    p = tmp_file("cloud.noext", ply1, strlen(ply1));
    assert_int_equal(pkss_read_points(p, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_OK); /* content sniffing */
    pkss_points_free(xyz);
    p = tmp_file("bad.ply", "ply\nformat ascii 1.0\n", 21);
    assert_int_equal(pkss_read_points(p, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_ERR_FORMAT);
    assert_true(strncmp(err, p, strlen(p)) == 0); /* names the file */
    p = tmp_file("empty.xyz", "", 0);
    assert_int_equal(pkss_read_points(p, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err),
                     PKSS_ERR_EMPTY_INPUT);

    /* writer round trip, binary and ascii, exact doubles */
    const double pts[] = {1.0 / 3.0, -2e-300, 1e300, 0.1, 0.2, 0.3,
                          -0.0, 12345.6789, -7.25};
    for (int ascii = 0; ascii < 2; ++ascii) {
        snprintf(path, sizeof path, "%s/out%d.ply", tmpdir, ascii);
        assert_int_equal(pkss_write_points(path, PKSS_FORMAT_AUTO, pts, 3,
                                           ascii ? PKSS_WRITE_ASCII : 0, err, sizeof err),
                         PKSS_OK);
        assert_int_equal(pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &n, err,
                                      sizeof err),
                         PKSS_OK);
        assert_int_equal(n, 3);
        assert_memory_equal(xyz, pts, sizeof pts);
        pkss_points_free(xyz);
    }
    snprintf(path, sizeof path, "%s/no/such/dir/out.ply", tmpdir);
    assert_int_equal(pkss_write_points(path, PKSS_FORMAT_PLY, pts, 3, 0, err, sizeof err),
                     PKSS_ERR_IO);
    assert_non_null(strstr(err, path));
}

/* ------------------------------------------------------- shared data */

typedef struct data_file {
    const char *path;
    size_t points;  /* MANIFEST.md */
    size_t finite;  /* 0 = all */
} data_file;

static const data_file k_data[] = {
    {"3dmatch/7-scenes-redkitchen/cloud_bin_0.ply", 258342, 0},
    {"3dmatch/7-scenes-redkitchen/cloud_bin_4.ply", 313395, 0},
    {"3dmatch/geotransformer_demo/converted/ref.ply", 18977, 0},
    {"3dmatch/geotransformer_demo/converted/src.ply", 15953, 0},
    {"goicp/data_bunny.txt", 30379, 0},
    {"goicp/model_bunny.txt", 35947, 0},
    {"kitti_patchworkpp/000000.bin", 124668, 0},
    {"kitti_patchworkpp/000001.bin", 124605, 0},
    {"libpointmatcher/car_cloud400.csv", 24989, 0},
    {"libpointmatcher/car_cloud400_scaled.csv", 24989, 0},
    {"libpointmatcher/car_cloud401.csv", 25193, 0},
    {"libpointmatcher/converted/car_cloud400.ply", 24989, 0},
    {"libpointmatcher/converted/car_cloud400_scaled.ply", 24989, 0},
    {"libpointmatcher/converted/car_cloud401.ply", 25193, 0},
    {"libpointmatcher/icp_tutorial/cloud_0.vtk", 36674, 0},
    {"libpointmatcher/icp_tutorial/cloud_1.vtk", 36670, 0},
    {"libpointmatcher/icp_tutorial/converted/cloud_0.ply", 36674, 0},
    {"libpointmatcher/icp_tutorial/converted/cloud_1.ply", 36670, 0},
    {"lidar_small_gicp/source.ply", 69792, 0},
    {"lidar_small_gicp/target.ply", 69088, 0},
    {"modelnet40_pkss/airplane_0001_s.ply", 10001, 0},
    {"modelnet40_pkss/airplane_0001_t.ply", 10001, 0},
    {"pcl/bun0.pcd", 397, 0},
    {"pcl/bun4.pcd", 361, 0},
    {"pcl/bunny.pcd", 397, 0},
    {"pcl/car6.pcd", 10031, 0},
    {"pcl/chef.pcd", 5092, 0},
    {"pcl/lamppost.pcd", 1771, 0},
    {"pcl/milk.pcd", 13704, 0},
    {"pcl/milk_cartoon_all_small_clorox.pcd", 307200, 241407},
    {"pcl/rs1.pcd", 289541, 0},
    {"pcl/tum_rabbit.vtk", 10429, 0},
    {"pcl/converted/bun0.ply", 397, 0},
    {"pcl/converted/bun4.ply", 361, 0},
    {"pcl/converted/bunny.ply", 397, 0},
    {"pcl/converted/car6.ply", 10031, 0},
    {"pcl/converted/chef.ply", 5092, 0},
    {"pcl/converted/lamppost.ply", 1771, 0},
    {"pcl/converted/milk.ply", 13704, 0},
    {"pcl/converted/milk_cartoon_all_small_clorox.ply", 241407, 0},
    {"pcl/converted/rs1.ply", 289541, 0},
    {"pcl/converted/tum_rabbit.ply", 10429, 0},
    {"stanford_bunny/bun000.ply", 40256, 0},
    {"stanford_bunny/bun045.ply", 40097, 0},
    {"stanford_bunny/bun090.ply", 30379, 0},
    {"stanford_bunny/bun180.ply", 40251, 0},
    {"stanford_bunny/bun270.ply", 31701, 0},
    {"stanford_bunny/bun315.ply", 35336, 0},
    {"stanford_bunny/chin.ply", 37738, 0},
    {"stanford_bunny/top2.ply", 38298, 0},
    {"stanford_bunny/converted/bun000.ply", 40256, 0},
    {"stanford_bunny/converted/bun045.ply", 40097, 0},
    {"stanford_bunny/converted/bun090.ply", 30379, 0},
    {"stanford_bunny/converted/bun180.ply", 40251, 0},
    {"stanford_bunny/converted/bun270.ply", 31701, 0},
    {"stanford_bunny/converted/bun315.ply", 35336, 0},
    {"stanford_bunny/converted/chin.ply", 37738, 0},
    {"stanford_bunny/converted/top2.ply", 38298, 0},
    {"stanford_bunny/reconstruction/bun_zipper_res2.ply", 8171, 0},
    {"stanford_dragon_stand/dragonStandRight_0.ply", 41841, 0},
    {"stanford_dragon_stand/dragonStandRight_24.ply", 34836, 0},
    {"stanford_dragon_stand/dragonStandRight_48.ply", 22092, 0},
    {"stanford_dragon_stand/dragonStandRight_72.ply", 14879, 0},
    {"stanford_dragon_stand/dragonStandRight_96.ply", 20645, 0},
    {"stanford_dragon_stand/converted/dragonStandRight_0.ply", 41841, 0},
    {"stanford_dragon_stand/converted/dragonStandRight_24.ply", 34836, 0},
    {"stanford_dragon_stand/converted/dragonStandRight_48.ply", 22092, 0},
    {"stanford_dragon_stand/converted/dragonStandRight_72.ply", 14879, 0},
    {"stanford_dragon_stand/converted/dragonStandRight_96.ply", 20645, 0},
    {"uwa_opencv/parasaurolophus_6700.ply", 6700, 0},
};

static double *load_data(const char *rel, size_t *n)
{
    const char *p = pkss_test_data_path(rel);
    char err[1024];
    double *xyz = NULL;
    if (!p)
        fail_msg("%s is listed in MANIFEST.md but missing", rel);
    pkss_status st = pkss_read_points(p, PKSS_FORMAT_AUTO, &xyz, n, err, sizeof err);
    if (st != PKSS_OK)
        fail_msg("%s: %s", pkss_status_name(st), err);
    return xyz;
}

static void skip_without_data(void)
{
    if (!pkss_test_data_path("MANIFEST.md")) {
        print_message("SKIP: the shared data folder (PKSS_DATA_DIR=%s or "
                      "$PKSS_DATA_DIR) is absent\n", PKSS_DATA_DIR);
        skip();
    }
}

static void test_shared_data(void **state)
{
    (void)state;
    skip_without_data();
    for (size_t i = 0; i < sizeof k_data / sizeof k_data[0]; ++i) {
        size_t n = 0, fin = 0;
        double *xyz = load_data(k_data[i].path, &n);
        for (size_t k = 0; k < n; ++k)
            fin += isfinite(xyz[3 * k]) && isfinite(xyz[3 * k + 1]) &&
                   isfinite(xyz[3 * k + 2]);
        if (n != k_data[i].points)
            fail_msg("%s: %zu points, MANIFEST.md says %zu", k_data[i].path,
                     n, k_data[i].points);
        if (fin != (k_data[i].finite ? k_data[i].finite : n))
            fail_msg("%s: %zu finite points", k_data[i].path, fin);
        pkss_points_free(xyz);
    }
    print_message("loaded %zu shared-data files\n",
                  sizeof k_data / sizeof k_data[0]);
}

/* The converted/ copies hold the originals' x y z exactly (NaN points
 * dropped; float32 where the original is float32 or float text): a
 * cross-check of each parser against the binary PLY one. */
static void test_shared_data_converted_match(void **state)
{
    (void)state;
    skip_without_data();
    static const char *pairs[][2] = {
        {"stanford_bunny/bun000.ply", "stanford_bunny/converted/bun000.ply"},
        {"stanford_dragon_stand/dragonStandRight_48.ply",
         "stanford_dragon_stand/converted/dragonStandRight_48.ply"},
        {"pcl/bun0.pcd", "pcl/converted/bun0.ply"},
        {"pcl/rs1.pcd", "pcl/converted/rs1.ply"},
        {"pcl/milk_cartoon_all_small_clorox.pcd",
         "pcl/converted/milk_cartoon_all_small_clorox.ply"},
        {"pcl/tum_rabbit.vtk", "pcl/converted/tum_rabbit.ply"},
        {"libpointmatcher/icp_tutorial/cloud_0.vtk",
         "libpointmatcher/icp_tutorial/converted/cloud_0.ply"},
        {"libpointmatcher/car_cloud400_scaled.csv",
         "libpointmatcher/converted/car_cloud400_scaled.ply"},
        {"libpointmatcher/car_cloud401.csv",
         "libpointmatcher/converted/car_cloud401.ply"},
    };
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; ++i) {
        size_t na, nb, k, j = 0;
        double *a = load_data(pairs[i][0], &na);
        double *b = load_data(pairs[i][1], &nb);
        for (k = 0; k < na; ++k) {
            const double *p = a + 3 * k;
            if (!(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2])))
                continue;
            /* text originals hold decimals, their copies float32 (or
             * float64): equal once both are rounded to float32 */
            if (j >= nb || (float)p[0] != (float)b[3 * j] ||
                (float)p[1] != (float)b[3 * j + 1] ||
                (float)p[2] != (float)b[3 * j + 2])
                fail_msg("%s point %zu differs from %s point %zu",
                         pairs[i][0], k, pairs[i][1], j);
            ++j;
        }
        assert_int_equal(j, nb);
        pkss_points_free(a);
        pkss_points_free(b);
    }
}

/* ------------------------------------------- fuzz corpus and crashes */

static int feed_dir(const char *root, const char *fmt, int expect_ok)
{
    char dir[1024], path[2048];
    snprintf(dir, sizeof dir, "%s/%s", root, fmt);
    DIR *d = opendir(dir);
    int count = 0;
    if (!d)
        return 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        FILE *f = fopen(path, "rb");
        assert_non_null(f);
        unsigned char *data = NULL;
        size_t n = 0, cap = 0, got;
        do {
            if (n == cap) {
                cap = cap ? 2 * cap : 4096;
                data = realloc(data, cap);
                assert_non_null(data);
            }
            got = fread(data + n, 1, cap - n, f);
            n += got;
        } while (got > 0);
        fclose(f);
        /* exact-size copy so a sanitizer build sees any over-read */
        unsigned char *exact = malloc(n ? n : 1);
        assert_non_null(exact);
        memcpy(exact, data, n);
        free(data);
        loaded r = read_mem(exact, n, pkss_format_from_name(fmt));
        if (expect_ok && r.st != PKSS_OK)
            fail_msg("seed %s: %s %s", path, pkss_status_name(r.st), r.err);
        pkss_points_free(r.xyz);
        free(exact);
        ++count;
    }
    closedir(d);
    return count;
}

static void test_fuzz_regressions(void **state)
{
    (void)state;
    static const char *fmts[] = {"ply", "pcd", "xyz", "off", "kitti", "vtk", "npy", "npz"};
    int seeds = 0, regressions = 0;
    for (size_t i = 0; i < sizeof fmts / sizeof fmts[0]; ++i) {
        seeds += feed_dir(PKSS_FUZZ_DIR "/corpus", fmts[i], 1);
        regressions += feed_dir(PKSS_FUZZ_DIR "/regressions", fmts[i], 0);
    }
    print_message("fed %d seed inputs and %d regression inputs from %s\n",
                  seeds, regressions, PKSS_FUZZ_DIR);
    assert_true(seeds > 0);
}

/* ---------------------------------------- bounded reads (issue #21) */

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Peak resident set of this process in MiB (Linux: ru_maxrss is KiB). */
static double peak_rss_mib(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_maxrss / 1024.0;
}

/* Reads path and checks the status, a message fragment and that it took
 * under a second. */
static void read_fast(const char *path, pkss_format f, pkss_status st,
                      const char *needle, size_t *n_out)
{
    char err[1024];
    double *xyz = (double *)1;
    size_t n = 777;
    double t0 = now_s();
    pkss_status got = pkss_read_points(path, f, &xyz, &n, err, sizeof err);
    double dt = now_s() - t0;
    if (got != st || (needle && !strstr(err, needle)))
        fail_msg("%s as %s: expected %s with \"%s\", got %s: %s", path,
                 pkss_format_name(f), pkss_status_name(st),
                 needle ? needle : "", pkss_status_name(got), err);
    if (dt > 1.0)
        fail_msg("%s as %s took %.2f s", path, pkss_format_name(f), dt);
    for (const char *c = err; *c; ++c) /* messages stay printable */
        assert_true((unsigned char)*c >= 0x20 && (unsigned char)*c < 0x7f);
    if (n_out)
        *n_out = n;
    if (got == PKSS_OK)
        pkss_points_free(xyz);
    else
        assert_null(xyz);
}

/* Devices of endless data are refused from their first bytes, not read
 * until memory runs out. KITTI (headerless binary) from a device is the
 * one case bounded only by the stream cap; it is not read here. */
static void test_bounded_devices(void **state)
{
    (void)state;
    static const pkss_format text[] = {PKSS_FORMAT_PLY, PKSS_FORMAT_PCD,
                                          PKSS_FORMAT_XYZ, PKSS_FORMAT_OFF,
                                          PKSS_FORMAT_VTK};
    if (access("/dev/zero", R_OK) != 0 || access("/dev/urandom", R_OK) != 0)
        skip();
    read_fast("/dev/zero", PKSS_FORMAT_AUTO, PKSS_ERR_INVALID_ARGUMENT,
              "cannot tell the format", NULL);
    read_fast("/dev/urandom", PKSS_FORMAT_AUTO, PKSS_ERR_INVALID_ARGUMENT,
              "cannot tell the format", NULL);
    for (size_t i = 0; i < sizeof text / sizeof text[0]; ++i)
        read_fast("/dev/zero", text[i], PKSS_ERR_FORMAT, NULL, NULL);
    /* magic checks, deterministic whatever the random bytes are */
    read_fast("/dev/urandom", PKSS_FORMAT_PLY, PKSS_ERR_FORMAT,
              "first line is not 'ply'", NULL);
    read_fast("/dev/urandom", PKSS_FORMAT_VTK, PKSS_ERR_FORMAT, NULL, NULL);
    assert_true(peak_rss_mib() < 64.0);
}

/* A 2 GiB sparse file: refused from its first bytes when it is not the
 * format; with a valid header of 10 vertices, refused for the data after
 * them without reading the rest (the file is mapped, not copied). */
static void test_bounded_sparse_file(void **state)
{
    (void)state;
    const off_t big = (off_t)2 << 30;
    char path[600];
    size_t n = 0;
    snprintf(path, sizeof path, "%s/sparse.ply", tmpdir);
    int fd = open(path, O_CREAT | O_TRUNC | O_WRONLY, 0600);
    assert_true(fd >= 0);
    if (ftruncate(fd, big) != 0) {
        close(fd);
        remove(path);
        skip(); /* no sparse files here */
    }
    close(fd);
    read_fast(path, PKSS_FORMAT_AUTO, PKSS_ERR_FORMAT,
              "first line is not 'ply'", NULL);
    read_fast(path, PKSS_FORMAT_XYZ, PKSS_ERR_FORMAT, "NUL", NULL);
    remove(path);

    static const char hdr[] =
        "ply\nformat binary_little_endian 1.0\nelement vertex 10\n"
        "property float x\nproperty float y\nproperty float z\nend_header\n";
    snprintf(path, sizeof path, "%s/sparse_hdr.ply", tmpdir);
    fd = open(path, O_CREAT | O_TRUNC | O_WRONLY, 0600);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, hdr, strlen(hdr)), (ssize_t)strlen(hdr));
    assert_int_equal(ftruncate(fd, big), 0);
    close(fd);
    read_fast(path, PKSS_FORMAT_AUTO, PKSS_ERR_FORMAT,
              "data after the 10 vertices", &n);
    assert_int_equal(n, 0);
    remove(path);
    assert_true(peak_rss_mib() < 64.0);
}

/* A file cut mid-body names the byte where it ends. */
static void test_truncated_offset(void **state)
{
    (void)state;
    buf b = {0};
    char needle[64];
    puts_(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
              "property float x\nproperty float y\nproperty float z\n"
              "end_header\n");
    for (int i = 0; i < 500; ++i) {
        put_f32(&b, (float)i, 0);
        put_f32(&b, (float)i + 1, 0);
        put_f32(&b, (float)i + 2, 0);
    }
    put(&b, "\1\2\3\4\5\6\7", 7);
    snprintf(needle, sizeof needle, "truncated at byte %zu", b.n);
    loaded r = read_mem(b.p, b.n, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, needle);
    read_fast(tmp_file("cut.ply", b.p, b.n), PKSS_FORMAT_AUTO, PKSS_ERR_FORMAT,
              needle, NULL);
    free(b.p);

    static const char ascii[] =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n1 2 3\n4 5";
    snprintf(needle, sizeof needle, "truncated at byte %zu", strlen(ascii));
    r = read_str(ascii, PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, needle);

    /* the other formats say it the same way */
    static const struct {
        pkss_format f;
        const char *text;
    } cut[] = {
        {PKSS_FORMAT_PCD, "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                      "COUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\n"
                      "DATA ascii\n1 2 3\n4 5 6\n7.000000 8"},
        {PKSS_FORMAT_OFF, "OFF\n3 0 0\n1 2 3\n4 5 6\n# cut here\n"},
        {PKSS_FORMAT_VTK, "# vtk DataFile Version 3.0\nx\nASCII\n"
                      "DATASET POLYDATA\nPOINTS 3 float\n"
                      "1 2 3 4 5 6 7.00000000 8"},
        {PKSS_FORMAT_XYZ, "3\n1 2 3\n4 5 6\n"},
    };
    for (size_t i = 0; i < sizeof cut / sizeof cut[0]; ++i) {
        snprintf(needle, sizeof needle, "truncated at byte %zu",
                 strlen(cut[i].text));
        r = read_str(cut[i].text, cut[i].f);
        expect(&r, PKSS_ERR_FORMAT, needle);
    }
}

/* The same rules in every text format: a UTF-8 BOM is accepted; rows past
 * a declared count, a second x or a second vertex element and decimal
 * commas are errors that say so. */
static void test_format_consistency(void **state)
{
    (void)state;
    static const struct {
        pkss_format f;
        const char *name, *text;
    } bom[] = {
        {PKSS_FORMAT_PLY, "bom.noext",
         "\xEF\xBB\xBFply\nformat ascii 1.0\nelement vertex 1\n"
         "property float x\nproperty float y\nproperty float z\n"
         "end_header\n1 2 3\n"},
        {PKSS_FORMAT_PCD, "bom.pcd",
         "\xEF\xBB\xBFVERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
         "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
         "POINTS 1\nDATA ascii\n1 2 3\n"},
        {PKSS_FORMAT_XYZ, "bom.csv", "\xEF\xBB\xBF" "1,2,3\n"},
        {PKSS_FORMAT_OFF, "bom.off", "\xEF\xBB\xBFOFF\n1 0 0\n1 2 3\n"},
        {PKSS_FORMAT_VTK, "bom.vtk",
         "\xEF\xBB\xBF# vtk DataFile Version 3.0\nx\nASCII\n"
         "DATASET POLYDATA\nPOINTS 1 float\n1 2 3\n"},
    };
    for (size_t i = 0; i < sizeof bom / sizeof bom[0]; ++i) {
        loaded r = read_str(bom[i].text, bom[i].f);
        expect(&r, PKSS_OK, NULL);
        assert_int_equal(r.n, 1);
        assert_point(r.xyz, 0, 1, 2, 3);
        pkss_points_free(r.xyz);
        if (bom[i].f != PKSS_FORMAT_XYZ) { /* content sniffing */
            r = read_str(bom[i].text, PKSS_FORMAT_AUTO);
            expect(&r, PKSS_OK, NULL);
            pkss_points_free(r.xyz);
        }
        read_fast(tmp_file(bom[i].name, bom[i].text, strlen(bom[i].text)),
                  PKSS_FORMAT_AUTO, PKSS_OK, NULL, NULL);
    }

    loaded r = read_str("ply\nformat ascii 1.0\nelement vertex 1\n"
                        "property float x\nproperty float y\n"
                        "property float z\nend_header\n1 2 3\n4 5 6\n",
                        PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "after the 1 vertices");
    r = read_str("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                 "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n"
                 "1 2 3\n4 5 6\n",
                 PKSS_FORMAT_PCD);
    expect(&r, PKSS_ERR_FORMAT, "after the 1 points");
    {
        buf b = {0};
        puts_(&b, "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                  "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\n"
                  "DATA binary\n");
        for (int k = 0; k < 6; ++k)
            put_f32(&b, (float)k, 0);
        r = read_mem(b.p, b.n, PKSS_FORMAT_PCD);
        expect(&r, PKSS_ERR_FORMAT, "after the 1 points");
        b.n = 0;
        puts_(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 1\n"
                  "property float x\nproperty float y\nproperty float z\n"
                  "end_header\n");
        for (int k = 0; k < 6; ++k)
            put_f32(&b, (float)k, 1);
        r = read_mem(b.p, b.n, PKSS_FORMAT_PLY);
        expect(&r, PKSS_ERR_FORMAT, "after the 1 vertices");
        free(b.p);
    }
    r = read_str("2\n1 2 3\n4 5 6\n7 8 9\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "says 2 points but 3 rows");
    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\nproperty float x\n"
                 "end_header\n1 2 3 4\n",
                 PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "second property 'x'");
    r = read_str("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                 "property float y\nproperty float z\nelement vertex 1\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "end_header\n1 2 3\n4 5 6\n",
                 PKSS_FORMAT_PLY);
    expect(&r, PKSS_ERR_FORMAT, "second 'vertex' element");

    r = read_str("1,5 2,5 3,5\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "decimal commas");
    r = read_str("1,5;2,5;3,5\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "decimal commas");
    r = read_str("x y z\n0,25\t1,5\t-2,0\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_ERR_FORMAT, "decimal commas");
    /* not decimal commas: CSV columns, then blank-separated extras */
    r = read_str("1.0,2.0,3.0 255 255 255\n1,2,3 7\n", PKSS_FORMAT_XYZ);
    expect(&r, PKSS_OK, NULL);
    assert_int_equal(r.n, 2);
    assert_point(r.xyz, 1, 1, 2, 3);
    pkss_points_free(r.xyz);

    /* every byte value in a header token comes back escaped */
    unsigned char junk[300];
    memcpy(junk, "VERSION .7\n", 11);
    for (size_t i = 11; i < sizeof junk; ++i)
        junk[i] = (unsigned char)(i * 37 + 1);
    static const pkss_format fm[] = {PKSS_FORMAT_PLY, PKSS_FORMAT_PCD, PKSS_FORMAT_XYZ,
                                        PKSS_FORMAT_OFF, PKSS_FORMAT_VTK};
    for (size_t k = 0; k < sizeof fm / sizeof fm[0]; ++k) {
        r = read_mem(junk, sizeof junk, fm[k]);
        assert_int_not_equal(r.st, PKSS_OK);
        for (const char *c = r.err; *c; ++c)
            assert_true((unsigned char)*c >= 0x20 && (unsigned char)*c < 0x7f);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        /* first, so the peak-RSS checks see no earlier test's memory */
        cmocka_unit_test(test_bounded_devices),
        cmocka_unit_test(test_bounded_sparse_file),
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_ply_ascii),
        cmocka_unit_test(test_ply_binary_types),
        cmocka_unit_test(test_ply_binary_lists),
        cmocka_unit_test(test_ply_malformed),
        cmocka_unit_test(test_pcd),
        cmocka_unit_test(test_xyz),
        cmocka_unit_test(test_off),
        cmocka_unit_test(test_kitti),
        cmocka_unit_test(test_vtk),
        cmocka_unit_test(test_empty_every_format),
        cmocka_unit_test(test_files_and_writer),
        cmocka_unit_test(test_shared_data),
        cmocka_unit_test(test_shared_data_converted_match),
        cmocka_unit_test(test_truncated_offset),
        cmocka_unit_test(test_format_consistency),
        cmocka_unit_test(test_npy_npz),
        cmocka_unit_test(test_writers),
        cmocka_unit_test(test_fuzz_regressions),
    };
    return cmocka_run_group_tests_name("test_io", tests, setup_tmp,
                                       teardown_tmp);
}
