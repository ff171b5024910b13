#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the serialised-cloud fuzzer's seed and its hand-made regression
input with the library at hand (the bytes carry the library's format and
version, so they are written again whenever either changes):
  corpus/cloud/random70.pkc            a 70-point cloud prepared with points = 256
  regressions/cloud/hostile-reserved   the same with a non-zero reserved header
                                       field, resealed (must load as corrupt)
Run: PKSS_LIBRARY=build/src/libpkss.so PYTHONPATH=bindings/python \\
     python3 tests/fuzz/make_cloud_seed.py
"""
import os

import numpy as np

import pkss

HERE = os.path.dirname(os.path.abspath(__file__))
RESERVED = 40 + 48   # the 8-byte reserved field of the parameters (cloud_bytes.c)


def checksum(b: bytes) -> int:
    """FNV-1a 64 over bytes 0..31 and 40..end (cloud_bytes.c:checksum)."""
    h = 0xcbf29ce484222325
    for x in b[:32] + b[40:]:
        h = ((h ^ x) * 0x100000001b3) & 0xffffffffffffffff
    return h


def reseal(b: bytearray) -> bytes:
    b[32:40] = checksum(bytes(b)).to_bytes(8, "little")
    return bytes(b)


def main():
    xyz = np.random.default_rng(70).normal(size=(70, 3)) * [3.0, 2.0, 1.0]
    seed = pkss.PreparedCloud.prepare(xyz, points=256).to_bytes()
    with open(os.path.join(HERE, "corpus", "cloud", "random70.pkc"), "wb") as f:
        f.write(seed)
    bad = bytearray(seed)
    bad[RESERVED] = 1
    with open(os.path.join(HERE, "regressions", "cloud", "hostile-reserved"), "wb") as f:
        f.write(reseal(bad))


if __name__ == "__main__":
    main()
