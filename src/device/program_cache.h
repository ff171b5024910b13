/* SPDX-License-Identifier: MIT
 * program_cache.h -- the on-disk cache of built OpenCL programs
 * (program_cache.c; docs/design.md "Program cache"). One entry per device,
 * driver, build options and kernel source; the entry's header names the
 * library version and the kernel source hash it was built from and
 * checksums the binary, so that a stale or damaged entry is rebuilt, never
 * used. Private to the OpenCL modules and their tests.
 */
#ifndef PKSS_PROGRAM_CACHE_H
#define PKSS_PROGRAM_CACHE_H

#include "pkss_cl.h"

#ifdef PKSS_WITH_OPENCL

#include <stdint.h>

/* What the last build of a context did with the cache. */
typedef enum pkss__cache_outcome {
    PKSS__CACHE_NONE = 0,     /* no build yet */
    PKSS__CACHE_HIT,          /* built from a valid cached binary */
    PKSS__CACHE_STORED,       /* no entry: built from source, entry written */
    PKSS__CACHE_REBUILT,      /* entry invalid (see note): rebuilt, replaced */
    PKSS__CACHE_UNWRITABLE    /* folder unusable: built from source only */
} pkss__cache_outcome;

/* Entry layout, native byte order (the magic tells a foreign one apart);
 * the binary of `size` bytes follows. */
#define PKSS__CACHE_MAGIC "PKSSCLB"
#define PKSS__CACHE_FORMAT 1u
typedef struct pkss__cache_header {
    char magic[8];            /* PKSS__CACHE_MAGIC, NUL-padded */
    uint32_t format;          /* PKSS__CACHE_FORMAT */
    uint32_t lib_version;     /* PKSS_VERSION_NUMBER */
    uint64_t key_hash;        /* device identity + driver + options */
    uint64_t source_hash;     /* the kernel source built */
    uint64_t size;            /* bytes of the binary */
    uint64_t checksum;        /* FNV-1a 64 of the binary */
} pkss__cache_header;

/* One lookup: where the entry lives and what it must say. */
typedef struct pkss__cache_key {
    char path[4096];          /* entry file; "" when the folder is unusable */
    uint64_t key_hash, source_hash;
    pkss__cache_outcome outcome;
    char note[512];           /* what happened, for the detail and tests */
} pkss__cache_key;

/* FNV-1a 64 of n bytes, continuing from h (start with PKSS__FNV_INIT). */
#define PKSS__FNV_INIT 0xcbf29ce484222325ull
uint64_t pkss__fnv1a(uint64_t h, const void *data, size_t n);

/* The cache folder: $PKSS_CACHE_DIR, else $XDG_CACHE_HOME/pkss, else
 * $HOME/.cache/pkss; 0 and "" when none can be named. */
int pkss__cache_dir(char *out, size_t size);

/* Fills key for this device, options and source; creates the folder. An
 * unusable folder leaves key->path "" and the outcome UNWRITABLE. */
void pkss__cache_key_init(pkss__cache_key *key, cl_platform_id platform,
                          cl_device_id device, const char *options,
                          const char *source, size_t source_len);

/* A program built from the valid cached binary, or NULL (no entry, or an
 * invalid one: key->outcome and key->note say which). */
cl_program pkss__cache_load(pkss__cache_key *key, cl_context context,
                            cl_device_id device, const char *options);

/* Writes the binary of a program built from source into the entry (temp
 * file + rename); failures only change key->outcome and key->note. */
void pkss__cache_store(pkss__cache_key *key, cl_program program);

/* Writes an entry with this header and payload (temp file + rename);
 * 0 on success. Used by pkss__cache_store and by the tests. */
int pkss__cache_write(const char *path, const pkss__cache_header *h,
                      const void *binary);

/* What the last program build of ctx's device did with the cache, and its
 * note (evaluate_cl.c; NONE and "" without a prepared device). */
pkss__cache_outcome pkss__cl_cache_outcome(const pkss_context *ctx,
                                           const char **note);

#endif /* PKSS_WITH_OPENCL */
#endif /* PKSS_PROGRAM_CACHE_H */
