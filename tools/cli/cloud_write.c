/* SPDX-License-Identifier: MIT
 * cloud_write.c -- the aligned cloud in the format its name asks for,
 * written by the library (pkss_write_points_stream) into the output that
 * outfile.c opened. An extension the library cannot write is a usage error
 * found before the run, never a silent PLY.
 */
#include "cli.h"

#include <string.h>

static pkss_format writable(pkss_format f)
{
    return f == PKSS_FORMAT_PLY || f == PKSS_FORMAT_PCD || f == PKSS_FORMAT_XYZ ||
                   f == PKSS_FORMAT_NPY
               ? f
               : PKSS_FORMAT_AUTO;
}

pkss_format cli_cloud_format_from_name(const char *name)
{
    return writable(pkss_format_from_name(name));
}

pkss_format cli_cloud_format_from_path(const char *path)
{
    return writable(pkss_format_from_path(path));
}

int cli_write_cloud(cli_out *o, pkss_format fmt, const double *xyz, size_t n, int ascii)
{
    char err[512];
    pkss_status st;
    FILE *f = cli_out_open(o);
    if (!f)
        return EXIT_IO;
    st = pkss_write_points_stream(f, fmt, xyz, n, ascii ? PKSS_WRITE_ASCII : 0, err,
                                  sizeof err);
    if (st != PKSS_OK) {
        cli_fail(pkss_status_name(st), "%s: cannot write the aligned cloud (%s)",
                 o->kind == CLI_OUT_STDOUT ? "standard output" : o->path, err);
        cli_out_discard(o);
        return EXIT_IO;
    }
    return cli_out_close(o) == 0 ? EXIT_OK : EXIT_IO;
}
