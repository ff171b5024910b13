# SPDX-License-Identifier: MIT
"""Development stand-in for the `pkss` Python package (ABI-mode cffi).

Used ONLY when run.py is given --pkss-lib PATH/libpkss.so (the published
benchmark uses the real bindings, `pip install ./bindings/python`). It
exposes the same call: register(source, target, **params) -> Result.
"""
from __future__ import annotations

import os
import re
from types import SimpleNamespace

import numpy as np

_HEADER = os.environ.get("PKSS_HEADER", os.path.join(os.path.dirname(__file__), "..", "..", "include", "pkss.h"))
_ffi = None
_lib = None

_PARAMS = {
    "points": 100, "rotation_steps": 101, "offset_steps": 102,
    "cell_steps": 103, "cull_mutual": 110, "cull_stat": 111,
    "use_features": 112, "feature_frac": 113, "pca_prealign": 114,
    "rotation_set": 120, "rotation_count": 121, "top_k": 122, "refine": 123,
    "seed": 130, "max_raw_points": 131, "drop_nonfinite": 132,
    "min_points": 133, "backend": 140,
}
_SWITCH = {"cull_mutual", "cull_stat", "use_features", "pca_prealign",
           "refine", "drop_nonfinite"}
_BACKENDS = {"auto": 0, "reference": 1, "opencl": 2}


def load(lib_path: str):
    global _ffi, _lib
    import cffi
    src = open(_HEADER).read()
    cdef = src.split("/* PKSS_CDEF_BEGIN */")[1].split("/* PKSS_CDEF_END */")[0]
    cdef = cdef.replace("PKSS_API ", "")
    cdef = re.sub(r"/\*.*?\*/", "", cdef, flags=re.S)
    _ffi = cffi.FFI()
    _ffi.cdef(cdef)
    _lib = _ffi.dlopen(lib_path)
    return _lib


def _check(st, ctx=None):
    if st != 0:
        msg = _ffi.string(_lib.pkss_status_name(st)).decode()
        if ctx is not None:
            msg += ": " + _ffi.string(_lib.pkss_context_last_error(ctx)).decode()
        raise RuntimeError(msg)


def register(source, target, **params):
    src = np.ascontiguousarray(source, dtype=np.float64)
    tgt = np.ascontiguousarray(target, dtype=np.float64)
    ctxp = _ffi.new("pkss_context **")
    _check(_lib.pkss_context_create(ctxp))
    ctx = ctxp[0]
    try:
        for k, v in params.items():
            if k == "backend":
                v = _BACKENDS[v] if isinstance(v, str) else v
            elif k in _SWITCH and isinstance(v, bool):
                v = 1 if v else 2
            if isinstance(v, float) and k == "feature_frac":
                _check(_lib.pkss_context_set_double(ctx, _PARAMS[k], v), ctx)
            else:
                _check(_lib.pkss_context_set_int(ctx, _PARAMS[k], int(v)), ctx)
        res = _ffi.new("pkss_result *")
        _lib.pkss_result_init(res)
        st = _lib.pkss_register(
            ctx, _ffi.cast("const double *", src.ctypes.data), len(src),
            _ffi.cast("const double *", tgt.ctypes.data), len(tgt), res)
        _check(st, ctx)
        T = np.array(list(res.T_target_source), dtype=np.float64).reshape(4, 4)
        return SimpleNamespace(
            transform=T, scale=res.scale,
            rotation=np.array(list(res.rotation)).reshape(3, 3),
            translation=np.array(list(res.translation)), score=res.score,
            rms=res.rms, overlap=res.overlap,
            candidates=res.n_candidates,
            timings={"total": res.timings.total, "search": res.timings.search,
                     "refine": res.timings.refine,
                     "preprocess": res.timings.preprocess},
            device=_ffi.string(res.device).decode())
    finally:
        _lib.pkss_context_destroy(ctx)
