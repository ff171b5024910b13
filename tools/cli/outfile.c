/* SPDX-License-Identifier: MIT
 * outfile.c -- outputs that never lose or corrupt a file (issue #21).
 *
 * A regular output is written to a temporary file in the final path's own
 * folder (so rename() stays on one file system and is atomic), flushed,
 * fsync'd, closed with every error checked, and only then renamed over the
 * final path; the folder is fsync'd so the rename survives a crash. A run
 * that fails or is killed leaves the old file (or none) at the final path;
 * at worst a hidden ".NAME.XXXXXX" temporary file stays behind after
 * kill -9. An existing final path that is a symlink is followed: the file
 * it points to is replaced, the link kept.
 *
 * "-" is standard output and FIFOs, character devices and sockets are
 * streams: written directly, never opened before the run (opening a FIFO
 * blocks until the other end opens) and never opened for reading.
 */
#define _XOPEN_SOURCE 700 /* mkstemp, fsync, realpath, fdopen, fileno */
#include "cli.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef PATH_MAX
#define PATH_MAX 4096
#endif

/* --------------------------------------------------- identity of paths */

typedef struct ident {
    char real[PATH_MAX]; /* realpath, or realpath(folder)/name, or as given */
    int exists;
    dev_t dev;
    ino_t ino;
    mode_t mode;
} ident;

static void split(const char *path, char *dir, size_t dsize, const char **base)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, dsize, ".");
        *base = path;
    } else if (slash == path) {
        snprintf(dir, dsize, "/");
        *base = slash + 1;
    } else {
        snprintf(dir, dsize, "%.*s", (int)(slash - path), path);
        *base = slash + 1;
    }
}

static void identify(const char *path, ident *id)
{
    struct stat sb;
    memset(id, 0, sizeof *id);
    if (stat(path, &sb) == 0) {
        id->exists = 1;
        id->dev = sb.st_dev;
        id->ino = sb.st_ino;
        id->mode = sb.st_mode;
    }
    if (realpath(path, id->real) == NULL) {
        char dir[PATH_MAX], rdir[PATH_MAX];
        const char *base;
        split(path, dir, sizeof dir, &base);
        size_t lr, lb = strlen(base);
        if (realpath(dir, rdir) != NULL &&
            (lr = strlen(rdir)) + lb + 2 <= sizeof id->real) {
            memcpy(id->real, rdir, lr);
            if (strcmp(rdir, "/") != 0)
                id->real[lr++] = '/';
            memcpy(id->real + lr, base, lb + 1);
        } else {
            snprintf(id->real, sizeof id->real, "%s", path);
        }
    }
}

int cli_check_distinct(const char *const *paths, const char *const *roles,
                       size_t n, size_t first_output)
{
    size_t i, j;
    ident *ids = (ident *)calloc(n ? n : 1, sizeof *ids);
    int rc = 0;
    if (!ids) {
        cli_fail("PKSS_ERR_OUT_OF_MEMORY", "cannot compare the paths");
        return EXIT_IO;
    }
    for (i = 0; i < n; i++)
        if (paths[i] && strcmp(paths[i], "-") != 0)
            identify(paths[i], &ids[i]);
    for (j = first_output; j < n && !rc; j++) {
        if (!paths[j])
            continue;
        for (i = 0; i < j && !rc; i++) {
            int same;
            if (!paths[i])
                continue;
            if (strcmp(paths[j], "-") == 0 || strcmp(paths[i], "-") == 0) {
                /* stdin and stdout differ; two outputs on stdout do not */
                same = i >= first_output && strcmp(paths[i], paths[j]) == 0;
            } else if (ids[i].exists && ids[j].exists) {
                same = ids[i].dev == ids[j].dev && ids[i].ino == ids[j].ino;
                /* /dev/null and the like may take several outputs */
                if (same && S_ISCHR(ids[j].mode))
                    same = 0;
            } else {
                same = strcmp(ids[i].real, ids[j].real) == 0;
            }
            if (same) {
                cli_fail(USAGE_STATUS,
                         "%s '%s' is the same file as %s '%s': refusing to "
                         "overwrite it",
                         roles[j], paths[j], roles[i], paths[i]);
                rc = EXIT_USAGE;
            }
        }
    }
    free(ids);
    return rc;
}

/* ------------------------------------------- temp files and the signals */

/* Temporary paths the signal handler removes; fixed storage so that the
 * handler only reads memory that is never freed or moved. */
#define MAX_TEMPS 8
static char g_temps[MAX_TEMPS][PATH_MAX];
static volatile sig_atomic_t g_temp_used[MAX_TEMPS];

static int register_temp(const char *path)
{
    int k;
    for (k = 0; k < MAX_TEMPS; k++)
        if (!g_temp_used[k]) {
            snprintf(g_temps[k], sizeof g_temps[k], "%s", path);
            g_temp_used[k] = 1;
            return k;
        }
    return -1;
}

static void unregister_temp(int k)
{
    if (k >= 0 && k < MAX_TEMPS)
        g_temp_used[k] = 0;
}

void cli_out_unlink_all_from_signal(void)
{
    int k;
    for (k = 0; k < MAX_TEMPS; k++)
        if (g_temp_used[k])
            unlink(g_temps[k]);
}

/* ------------------------------------------------------------- outputs */

int cli_out_plan(cli_out *o, const char *what, const char *path)
{
    struct stat sb;
    char dir[PATH_MAX];
    const char *base;
    memset(o, 0, sizeof *o);
    o->what = what;
    o->path = path;
    o->registered = -1;
    if (!path)
        return EXIT_OK;
    if (strcmp(path, "-") == 0) {
        o->kind = CLI_OUT_STDOUT;
        return EXIT_OK;
    }
    if (stat(path, &sb) == 0) {
        if (S_ISDIR(sb.st_mode)) {
            cli_fail(IO_STATUS, "%s: cannot write %s: it is a directory",
                     path, what);
            return EXIT_IO;
        }
        if (!S_ISREG(sb.st_mode)) {
            o->kind = CLI_OUT_STREAM;
            return EXIT_OK;
        }
        if (access(path, W_OK) != 0) {
            cli_fail(IO_STATUS, "%s: cannot write %s: %s", path, what,
                     strerror(errno));
            return EXIT_IO;
        }
        o->mode = sb.st_mode & 07777;
        o->final = realpath(path, NULL);
    } else {
        mode_t mask = umask(0);
        umask(mask);
        o->mode = 0666 & ~mask;
        o->final = malloc(strlen(path) + 1);
        if (o->final)
            strcpy(o->final, path);
    }
    if (!o->final) {
        cli_fail(IO_STATUS, "%s: cannot resolve the path of %s: %s", path,
                 what, strerror(errno));
        return EXIT_IO;
    }
    o->kind = CLI_OUT_FILE;
    split(o->final, dir, sizeof dir, &base);
    if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) {
        cli_fail(IO_STATUS, "%s: cannot write %s: folder '%s' does not exist",
                 path, what, dir);
        return EXIT_IO;
    }
    if (access(dir, W_OK | X_OK) != 0) {
        cli_fail(IO_STATUS, "%s: cannot write %s in folder '%s': %s", path,
                 what, dir, strerror(errno));
        return EXIT_IO;
    }
    if (!*base) {
        cli_fail(IO_STATUS, "%s: cannot write %s: no file name", path, what);
        return EXIT_IO;
    }
    return EXIT_OK;
}

/* Creates the temporary file; @return its fd or -1 (printed). */
static int make_temp(cli_out *o)
{
    char dir[PATH_MAX];
    const char *base;
    size_t need;
    int fd;
    split(o->final, dir, sizeof dir, &base);
    need = strlen(dir) + strlen(base) + 16;
    o->tmp = (char *)malloc(need);
    if (!o->tmp) {
        cli_fail("PKSS_ERR_OUT_OF_MEMORY", "%s: cannot name a temporary file",
                 o->path);
        return -1;
    }
    snprintf(o->tmp, need, "%s/.%s.XXXXXX", dir, base);
    /* block the signals while the name is created and registered, so the
     * handler never misses a file that exists */
    {
        sigset_t all, old;
        sigfillset(&all);
        sigprocmask(SIG_BLOCK, &all, &old);
        fd = mkstemp(o->tmp);
        if (fd >= 0)
            o->registered = register_temp(o->tmp);
        sigprocmask(SIG_SETMASK, &old, NULL);
    }
    if (fd < 0) {
        cli_fail(IO_STATUS, "%s: cannot create a temporary file in '%s': %s",
                 o->path, dir, strerror(errno));
        free(o->tmp);
        o->tmp = NULL;
        return -1;
    }
    /* mkstemp makes 0600: give the result the old file's mode, or what a
     * plain create would have given */
    if (fchmod(fd, o->mode) != 0) {
        /* not fatal: the file stays private */
    }
    return fd;
}

FILE *cli_out_open(cli_out *o)
{
    int fd;
    errno = 0;
    switch (o->kind) {
    case CLI_OUT_STDOUT:
        o->f = stdout;
        return o->f;
    case CLI_OUT_STREAM:
        o->f = fopen(o->path, "w");
        if (!o->f)
            cli_fail(IO_STATUS, "%s: cannot write %s: %s", o->path, o->what,
                     errno ? strerror(errno) : "unknown error");
        return o->f;
    case CLI_OUT_FILE:
    default:
        fd = make_temp(o);
        if (fd < 0)
            return NULL;
        o->f = fdopen(fd, "w");
        if (!o->f) {
            cli_fail(IO_STATUS, "%s: cannot write %s: %s", o->path, o->what,
                     strerror(errno));
            close(fd);
            cli_out_discard(o);
        }
        return o->f;
    }
}

static int sync_path(const char *path)
{
    int fd = open(path, O_RDONLY), rc;
    if (fd < 0)
        return -1;
    rc = fsync(fd);
    close(fd);
    return rc;
}

int cli_out_close(cli_out *o)
{
    int bad = 0, err = 0;
    if (o->f) {
        /* errno is not reset: a failed write before this flush left its
         * reason there (ENOSPC, EPIPE...) */
        if (fflush(o->f) != 0 || ferror(o->f)) {
            bad = 1;
            err = errno;
        }
        if (o->kind == CLI_OUT_FILE && !bad && fsync(fileno(o->f)) != 0) {
            bad = 1;
            err = errno;
        }
        if (o->kind != CLI_OUT_STDOUT) {
            if (fclose(o->f) != 0 && !bad) {
                bad = 1;
                err = errno;
            }
        }
        o->f = NULL;
    }
    if (bad) {
        cli_fail(IO_STATUS, "%s: write failed while writing %s: %s",
                 o->kind == CLI_OUT_STDOUT ? "standard output" : o->path,
                 o->what, err ? strerror(err) : "unknown error");
        cli_out_discard(o);
        return -1;
    }
    return 0;
}

int cli_out_commit(cli_out *o)
{
    char dir[PATH_MAX];
    const char *base;
    if (o->kind != CLI_OUT_FILE || !o->tmp)
        return 0;
    if (rename(o->tmp, o->final) != 0) {
        cli_fail(IO_STATUS, "%s: cannot replace it with the new %s: %s",
                 o->path, o->what, strerror(errno));
        cli_out_discard(o);
        return -1;
    }
    unregister_temp(o->registered);
    o->registered = -1;
    free(o->tmp);
    o->tmp = NULL;
    /* make the rename itself durable; failure here loses nothing */
    split(o->final, dir, sizeof dir, &base);
    (void)sync_path(dir);
    return 0;
}

void cli_out_discard(cli_out *o)
{
    if (o->f && o->kind != CLI_OUT_STDOUT)
        fclose(o->f);
    o->f = NULL;
    if (o->tmp) {
        unlink(o->tmp);
        unregister_temp(o->registered);
        o->registered = -1;
        free(o->tmp);
        o->tmp = NULL;
    }
    free(o->final);
    o->final = NULL;
}
