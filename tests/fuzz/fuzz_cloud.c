/* SPDX-License-Identifier: MIT
 * fuzz_cloud.c -- libFuzzer harness: pkss_cloud_deserialize() on arbitrary
 * bytes, under the parameters the seed corpus was prepared with (points
 * 256, the rest default; corpus/cloud/).
 *
 * Contract checked beyond "no crash, no sanitizer report": failure gives
 * out == NULL, a CORRUPT/STALE/OOM status and a non-empty detail; success
 * gives a cloud whose points can all be read and which serialises back to
 * exactly the input bytes. Each input is tried as it is and with its
 * checksum resealed, so the fuzzer also reaches the payload checks behind
 * the checksum.
 */
#include "pkss.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* FNV-1a 64 over every byte but the checksum field (cloud_bytes.c). */
static void reseal(uint8_t *b, size_t size)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < size; ++i)
        if (i < 32 || i >= 40) {
            h ^= b[i];
            h *= 0x100000001b3ull;
        }
    for (int i = 0; i < 8; ++i)
        b[32 + i] = (uint8_t)(h >> (8 * i));
}

static void check_one(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check_one(data, size);
    if (size >= 40) {
        uint8_t *copy = malloc(size);
        if (!copy)
            return 0;
        memcpy(copy, data, size);
        reseal(copy, size);
        check_one(copy, size);
        free(copy);
    }
    return 0;
}

static void check_one(const uint8_t *data, size_t size)
{
    static pkss_context *ctx;
    if (!ctx) {
        if (pkss_context_create(&ctx) != PKSS_OK ||
            pkss_context_set_int(ctx, PKSS_PARAM_POINTS, 256) != PKSS_OK)
            __builtin_trap();
    }
    pkss_cloud *c = (pkss_cloud *)&ctx;
    pkss_status st = pkss_cloud_deserialize(ctx, data, size, &c);
    if (st != PKSS_OK) {
        if (c != NULL || pkss_context_last_error(ctx)[0] == '\0')
            __builtin_trap();
        if (st != PKSS_ERR_CORRUPT_DATA && st != PKSS_ERR_STALE_DATA &&
            st != PKSS_ERR_OUT_OF_MEMORY)
            __builtin_trap();
        return;
    }
    size_t m = pkss_cloud_size(c), need = 0;
    double *xyz = malloc(3 * m * sizeof(double) + 1);
    unsigned char *back = malloc(size);
    if (!xyz || !back || pkss_cloud_points(c, xyz, m) != PKSS_OK ||
        pkss_cloud_serialize(c, back, size, &need) != PKSS_OK || need != size ||
        memcmp(back, data, size) != 0)
        __builtin_trap();
    free(xyz);
    free(back);
    pkss_cloud_destroy(c);
}
