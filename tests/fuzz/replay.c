/* SPDX-License-Identifier: MIT
 * replay.c -- prints what the readers make of each input, to prove that a
 * change to src/io keeps their behaviour (not a fuzz harness, not built by
 * CMake). For every file named on standard input, one line per read:
 * pkss_read_points_buffer() with each format (AUTO and the 8 formats),
 * pkss_read_points() on the path (AUTO, NPZ) and on a pipe carrying the same
 * bytes (the stream path of the bounded reader); each line holds the status,
 * n, an FNV-1a hash of the points and the message. Build it against the
 * sources before and after a change and compare the outputs:
 *
 *   cc -O1 -std=c11 -Iinclude -Isrc -Isrc/io -Ikernels tests/fuzz/replay.c \
 *      src/io/io_*.c src/io/pkss_io.c src/common/status.c -lm -o replay
 *   find tests/fuzz/corpus tests/fuzz/regressions WORK_DIRS -type f | sort \
 *      | ./replay > after.tsv          # likewise before.tsv; cmp the two
 */
#define _GNU_SOURCE
#include "pkss_io.h"
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

static uint64_t fnv(const void *p, size_t n)
{
    const unsigned char *b = p;
    uint64_t h = 1469598103934665603ULL;
    for (size_t i = 0; i < n; i++) { h ^= b[i]; h *= 1099511628211ULL; }
    return h;
}

static void show(const char *name, const char *how, pkss_status st, double *xyz,
                 size_t n, const char *err)
{
    printf("%s\t%s\t%d\t%zu\t%016llx\t%s\n", name, how, (int)st, n,
           (unsigned long long)(xyz ? fnv(xyz, 3 * n * sizeof *xyz) : 0),
           st == PKSS_OK ? "" : err);
}

int main(void)
{
    char line[4096];
    while (fgets(line, sizeof line, stdin)) {
        line[strcspn(line, "\n")] = 0;
        FILE *f = fopen(line, "rb");
        if (!f) continue;
        fseek(f, 0, SEEK_END); long sz = ftell(f); fseek(f, 0, SEEK_SET);
        if (sz < 0) { fclose(f); continue; }
        unsigned char *buf = malloc(sz ? (size_t)sz : 1);
        if (fread(buf, 1, (size_t)sz, f) != (size_t)sz) { fclose(f); free(buf); continue; }
        fclose(f);
        for (int fmt = 0; fmt <= 8; fmt++) {
            double *xyz = NULL; size_t n = 777; char err[512]; char how[16];
            memset(err, 'x', sizeof err); err[511] = 0;
            pkss_status st = pkss_read_points_buffer(buf, (size_t)sz, (pkss_format)fmt,
                                                     NULL, &xyz, &n, err, sizeof err);
            snprintf(how, sizeof how, "buf%d", fmt);
            show(line, how, st, xyz, n, err);
            pkss_points_free(xyz);
        }
        for (int fmt = 0; fmt <= 8; fmt += 8) {
            double *xyz = NULL; size_t n = 777; char err[512]; char how[16];
            memset(err, 'x', sizeof err); err[511] = 0;
            pkss_status st = pkss_read_points(line, (pkss_format)fmt, &xyz, &n, err, sizeof err);
            snprintf(how, sizeof how, "path%d", fmt);
            show(line, how, st, xyz, n, err);
            pkss_points_free(xyz);
        }
        { /* the same bytes from a pipe: the stream path of the bounded reader */
            int fd[2];
            if (pipe(fd) == 0) {
                pid_t pid = fork();
                if (pid == 0) {
                    close(fd[0]);
                    size_t off = 0;
                    while (off < (size_t)sz) {
                        ssize_t w = write(fd[1], buf + off, (size_t)sz - off);
                        if (w <= 0) break;
                        off += (size_t)w;
                    }
                    _exit(0);
                }
                close(fd[1]);
                char path[64]; double *xyz = NULL; size_t n = 777; char err[512];
                memset(err, 'x', sizeof err); err[511] = 0;
                snprintf(path, sizeof path, "/dev/fd/%d", fd[0]);
                pkss_status st = pkss_read_points(path, PKSS_FORMAT_AUTO, &xyz, &n, err, sizeof err);
                /* the message names the path, which holds the fd number: same in both runs */
                show(line, "pipe", st, xyz, n, err);
                pkss_points_free(xyz);
                close(fd[0]);
                waitpid(pid, NULL, 0);
            }
        }
        free(buf);
    }
    return 0;
}
