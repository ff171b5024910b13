/* SPDX-License-Identifier: MIT
 * cloud_write.c -- the aligned cloud in the format its name asks for:
 * PLY through the tools/io writer, PCD and XYZ here (tools/io writes only
 * PLY). Both text formats print %.17g, so every double reads back
 * bit-identically. An extension the tool cannot write is a usage error
 * found before the run, never a silent PLY.
 */
#define _XOPEN_SOURCE 700 /* mkstemp */
#include "cli.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int ieq(const char *a, const char *b)
{
    for (; *a && *b; a++, b++) {
        char x = *a, y = *b;
        if (x >= 'A' && x <= 'Z')
            x = (char)(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z')
            y = (char)(y - 'A' + 'a');
        if (x != y)
            return 0;
    }
    return *a == *b;
}

cli_cloud_format cli_cloud_format_from_name(const char *name)
{
    if (ieq(name, "ply"))
        return CLI_CLOUD_PLY;
    if (ieq(name, "pcd"))
        return CLI_CLOUD_PCD;
    if (ieq(name, "xyz"))
        return CLI_CLOUD_XYZ;
    return CLI_CLOUD_NONE;
}

cli_cloud_format cli_cloud_format_from_path(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    return dot ? cli_cloud_format_from_name(dot + 1) : CLI_CLOUD_NONE;
}

const char *cli_cloud_format_name(cli_cloud_format f)
{
    switch (f) {
    case CLI_CLOUD_PLY: return "ply";
    case CLI_CLOUD_PCD: return "pcd";
    case CLI_CLOUD_XYZ: return "xyz";
    default: return "none";
    }
}

static void write_pcd(FILE *f, const double *xyz, size_t n)
{
    size_t i;
    fprintf(f,
            "# .PCD v0.7 - Point Cloud Data file format (written by " TOOL
            ")\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\n"
            "COUNT 1 1 1\nWIDTH %llu\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
            "POINTS %llu\nDATA ascii\n",
            (unsigned long long)n, (unsigned long long)n);
    for (i = 0; i < n && !ferror(f); i++)
        fprintf(f, "%.17g %.17g %.17g\n", xyz[3 * i], xyz[3 * i + 1],
                xyz[3 * i + 2]);
}

static void write_xyz(FILE *f, const double *xyz, size_t n)
{
    size_t i;
    for (i = 0; i < n && !ferror(f); i++)
        fprintf(f, "%.17g %.17g %.17g\n", xyz[3 * i], xyz[3 * i + 1],
                xyz[3 * i + 2]);
}

/* Copies a file to stdout. @return 0 or -1 (errno set). */
static int copy_to_stdout(const char *path)
{
    char buf[1 << 16];
    size_t got;
    FILE *in = fopen(path, "rb");
    int bad = 0;
    if (!in)
        return -1;
    while ((got = fread(buf, 1, sizeof buf, in)) > 0)
        if (fwrite(buf, 1, got, stdout) != got) {
            bad = 1;
            break;
        }
    if (ferror(in))
        bad = 1;
    fclose(in);
    return bad ? -1 : 0;
}

/* PLY on stdout: the tools/io writer takes a path, so it writes a private
 * temporary file that is then copied (reopening /dev/stdout would truncate
 * a redirected file). */
static int ply_to_stdout(const double *xyz, size_t n, int ascii)
{
    const char *tmpdir = getenv("TMPDIR");
    char path[4096], err[1024];
    int fd, rc = EXIT_OK;
    pkss_io_status st;
    snprintf(path, sizeof path, "%s/pkss-align-XXXXXX",
             tmpdir && *tmpdir ? tmpdir : "/tmp");
    fd = mkstemp(path);
    if (fd < 0) {
        cli_fail(IO_STATUS, "cannot create a temporary file for the PLY: %s",
                 strerror(errno));
        return EXIT_IO;
    }
    close(fd);
    st = pkss_io_write_ply(path, xyz, n, ascii, err, sizeof err);
    if (st != PKSS_IO_OK) {
        cli_fail(pkss_io_status_name(st), "%s", err);
        rc = EXIT_IO;
    } else if (copy_to_stdout(path) != 0) {
        cli_fail(IO_STATUS, "standard output: write failed while writing "
                 "the aligned cloud: %s", strerror(errno));
        rc = EXIT_IO;
    }
    unlink(path);
    return rc;
}

int cli_write_cloud(cli_out *o, cli_cloud_format fmt, const double *xyz,
                    size_t n, int ascii)
{
    if (fmt == CLI_CLOUD_PLY) {
        char err[1024];
        const char *path;
        pkss_io_status st;
        if (o->kind == CLI_OUT_STDOUT)
            return ply_to_stdout(xyz, n, ascii) == EXIT_OK &&
                           cli_out_close(o) == 0
                       ? EXIT_OK
                       : EXIT_IO;
        path = cli_out_reserve(o);
        if (!path)
            return EXIT_IO;
        st = pkss_io_write_ply(path, xyz, n, ascii, err, sizeof err);
        if (st != PKSS_IO_OK) {
            /* name the final path, not the temporary one */
            cli_fail(pkss_io_status_name(st), "%s: cannot write the aligned "
                     "cloud (%s)", o->path, err);
            cli_out_discard(o);
            return EXIT_IO;
        }
        return cli_out_close(o) == 0 ? EXIT_OK : EXIT_IO;
    } else {
        FILE *f = cli_out_open(o);
        if (!f)
            return EXIT_IO;
        if (fmt == CLI_CLOUD_PCD)
            write_pcd(f, xyz, n);
        else
            write_xyz(f, xyz, n);
        return cli_out_close(o) == 0 ? EXIT_OK : EXIT_IO;
    }
}
