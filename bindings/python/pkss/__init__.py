# SPDX-License-Identifier: MIT
"""pkss -- robust global similarity registration of point clouds (PKSS-Align).

Finds the scale ``s``, rotation ``R`` and translation ``t`` that map a source
cloud onto a target cloud, ``x_t ~= s * R @ x_s + t``, without an initial
guess::

    import numpy as np, pkss
    result = pkss.register(source, target)        # (N, 3) and (M, 3) arrays
    result.transform                              # 4x4 T_target_source
    aligned = result.apply(source)                # source in the target frame

FRAME CONVENTION: ``T_target_source`` maps source points into the target
frame; its upper-left 3x3 block is ``s * R``.

* :func:`register` -- one call, one temporary :class:`Context`.
* :class:`Context` -- keeps parameters and the device between calls; prepares
  a :class:`Cloud` once to register many sources against one template.
* :func:`devices` -- the OpenCL devices the library sees.

Errors from the C library raise :class:`Error` (``.status``, ``.name``,
``.detail``); bad input raises :class:`InvalidArgument`, which is also a
``ValueError``. The library prints nothing. Every C call releases the GIL, so
threads with one context each run in parallel. A context (and a cloud) is
locked while in use, so sharing one between threads is safe but serialised.
"""
from __future__ import annotations

import difflib
import functools
import numbers
import operator
import textwrap
import threading
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple, TypeVar, Union

import numpy as np

from ._lib import ffi, lib, library_path

__all__ = [
    "register", "Context", "Cloud", "Result", "Candidate", "Timings", "Counts", "PairCounts",
    "devices", "Device", "DeviceList", "param_bounds", "default_params", "PARAM_NAMES",
    "Error", "InvalidArgument", "OutOfMemory", "DeviceError", "NumericalError",
    "status_name", "status_string", "build_info",
    "__version__", "library_version", "library_path", "MAX_CANDIDATES",
]

#: Version of the binding: the pkss.h it was built from.
__version__: str = "%d.%d.%d" % (lib.PKSS_VERSION_MAJOR, lib.PKSS_VERSION_MINOR,
                                 lib.PKSS_VERSION_PATCH)
#: Version of the C library actually loaded (same major version as __version__).
library_version: str = ffi.string(lib.pkss_version_string()).decode()
#: Most candidates a result can hold (the largest ``top_k``).
MAX_CANDIDATES: int = int(lib.pkss_max_candidates())

ArrayLike = Any  # anything np.asarray turns into an (N, 3) array of reals
PointsLike = Union["Cloud", ArrayLike]


def _str(p: Any) -> str:
    return ffi.string(p).decode("utf-8", errors="replace") if p != ffi.NULL else ""


# --------------------------------------------------------------------- errors
def status_name(status: int) -> str:
    """The symbol of a status code, e.g. ``'PKSS_ERR_NONFINITE'``."""
    return _str(lib.pkss_status_name(int(status)))


def status_string(status: int) -> str:
    """A one-sentence description of a status code."""
    return _str(lib.pkss_status_string(int(status)))


def build_info() -> str:
    """How the loaded C library was built (version, compiler, OpenCL or not)."""
    return _str(lib.pkss_build_info())


class Error(Exception):
    """A pkss failure: ``status`` (int code of pkss.h), ``name``
    (e.g. ``'PKSS_ERR_DEGENERATE'``) and ``detail`` (the specific reason, from
    ``pkss_context_last_error`` for C failures)."""

    status: int
    name: str
    detail: str

    def __init__(self, status: int, detail: str = "") -> None:
        super().__init__(status, detail)
        self.status = int(status)
        self.name = status_name(status)
        self.detail = detail

    def __str__(self) -> str:
        return "%s: %s" % (self.name, self.detail or status_string(self.status))

    @staticmethod
    def class_for(status: int) -> type:
        """The subclass raised for a status code."""
        s = int(status)
        if 1 <= s <= 99:
            return InvalidArgument
        if 100 <= s <= 199:
            return OutOfMemory
        if 200 <= s <= 299:
            return DeviceError
        if 300 <= s <= 398:
            return NumericalError
        return Error


class InvalidArgument(Error, ValueError):
    """Caller errors (status 1-99): bad shape, too few points, NaN/Inf,
    degenerate input, a parameter out of range. Also a ``ValueError``."""


class OutOfMemory(Error, MemoryError):
    """Resource errors (status 100-199). Also a ``MemoryError``."""


class DeviceError(Error):
    """Device and OpenCL errors (status 200-299): no device, a failed OpenCL
    call, a kernel build failure (log in ``detail``), a missing feature."""


class NumericalError(Error):
    """Numerical failures (status 300-398), e.g. the search found no
    candidate (``PKSS_ERR_NO_CONSENSUS``)."""


def _raise(status: int, detail: str) -> None:
    raise Error.class_for(status)(status, detail)


def _invalid(detail: str, status: int = lib.PKSS_ERR_INVALID_ARGUMENT) -> InvalidArgument:
    return InvalidArgument(status, detail)


def _closed(what: str) -> ValueError:
    return ValueError("%s is closed" % what)


# ----------------------------------------------------------------- parameters
_SWITCH, _INT, _DOUBLE, _CHOICE, _DEVICE = "switch", "int", "double", "choice", "device"
_ROTATION_SETS = {"euler": lib.PKSS_ROTATIONS_EULER, "uniform": lib.PKSS_ROTATIONS_UNIFORM}
_BACKENDS = {"auto": lib.PKSS_BACKEND_AUTO, "reference": lib.PKSS_BACKEND_REFERENCE,
             "opencl": lib.PKSS_BACKEND_OPENCL}

# name -> (pkss_param value, kind, choices); names are pkss_param_name().
_PARAMS: Dict[str, Tuple[int, str, Optional[Dict[str, int]]]] = {
    "points": (lib.PKSS_PARAM_POINTS, _INT, None),
    "rotation_steps": (lib.PKSS_PARAM_ROTATION_STEPS, _INT, None),
    "offset_steps": (lib.PKSS_PARAM_OFFSET_STEPS, _INT, None),
    "cell_steps": (lib.PKSS_PARAM_CELL_STEPS, _INT, None),
    "cull_mutual": (lib.PKSS_PARAM_CULL_MUTUAL, _SWITCH, None),
    "cull_stat": (lib.PKSS_PARAM_CULL_STAT, _SWITCH, None),
    "use_features": (lib.PKSS_PARAM_USE_FEATURES, _SWITCH, None),
    "feature_frac": (lib.PKSS_PARAM_FEATURE_FRAC, _DOUBLE, None),
    "pca_prealign": (lib.PKSS_PARAM_PCA_PREALIGN, _SWITCH, None),
    "rotation_set": (lib.PKSS_PARAM_ROTATION_SET, _CHOICE, _ROTATION_SETS),
    "rotation_count": (lib.PKSS_PARAM_ROTATION_COUNT, _INT, None),
    "top_k": (lib.PKSS_PARAM_TOP_K, _INT, None),
    "refine": (lib.PKSS_PARAM_REFINE, _SWITCH, None),
    "seed": (lib.PKSS_PARAM_SEED, _INT, None),
    "max_raw_points": (lib.PKSS_PARAM_MAX_RAW_POINTS, _INT, None),
    "drop_nonfinite": (lib.PKSS_PARAM_DROP_NONFINITE, _SWITCH, None),
    "min_points": (lib.PKSS_PARAM_MIN_POINTS, _INT, None),
    "backend": (lib.PKSS_PARAM_BACKEND, _CHOICE, _BACKENDS),
    "device": (lib.PKSS_PARAM_DEVICE, _DEVICE, None),
}
#: The keyword arguments of :func:`register`, :class:`Context` and
#: :meth:`Context.set`, in the order of pkss.h.
PARAM_NAMES: Tuple[str, ...] = tuple(_PARAMS)

_F = TypeVar("_F", bound=Callable[..., Any])


def _check_keywords(func: _F) -> _F:
    """Turn an unknown keyword into a TypeError that lists the valid names
    (the wrapped signature keeps explicit, typed keyword arguments)."""
    valid = set(PARAM_NAMES)

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        unknown = [k for k in kwargs if k not in valid and k not in ("source", "target")]
        if unknown:
            hint = difflib.get_close_matches(unknown[0], PARAM_NAMES, n=1)
            raise TypeError("%s() got an unknown parameter %r%s; valid parameters: %s" % (
                func.__qualname__, unknown[0], " (did you mean %r?)" % hint[0] if hint else "",
                ", ".join(PARAM_NAMES)))
        return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


class ParamBounds(tuple):
    """``(lower, upper, default)`` of a numeric parameter."""

    lower = property(operator.itemgetter(0))
    upper = property(operator.itemgetter(1))
    default = property(operator.itemgetter(2))


def param_bounds(name: str) -> ParamBounds:
    """Valid range and default of an integer or float parameter, from the C
    library (``pkss_param_bounds``): ``ParamBounds(lower, upper, default)``.
    Raises ValueError for switches, choices and ``device``."""
    if name not in _PARAMS:
        raise ValueError("unknown parameter %r; valid parameters: %s" % (name, ", ".join(PARAM_NAMES)))
    pid, kind, _ = _PARAMS[name]
    if kind not in (_INT, _DOUBLE):
        raise ValueError("parameter %r is a %s, not a number" % (name, kind))
    lo, hi, de = ffi.new("double *"), ffi.new("double *"), ffi.new("double *")
    st = lib.pkss_param_bounds(pid, lo, hi, de)
    if st:
        _raise(st, "pkss_param_bounds(%s)" % name)
    conv = int if kind == _INT else float
    return ParamBounds((conv(lo[0]), conv(hi[0]), conv(de[0])))


def default_params() -> Dict[str, Any]:
    """The library defaults of every parameter, resolved (``device`` is None:
    the ``PKSS_DEVICE`` environment variable, then the first GPU, then the
    first CPU)."""
    with Context() as ctx:
        return ctx.params


# ------------------------------------------------------------------- results
@dataclass(frozen=True)
class Timings:
    """Wall-clock seconds spent in each stage of a registration."""

    validate: float
    preprocess: float  #: thinning, culling, resampling, features, PCA
    search: float  #: binning, scoring and selection
    refine: float
    total: float


@dataclass(frozen=True)
class Counts:
    """Points kept after each pre-processing step of one cloud."""

    input: int  #: points given
    nonfinite: int  #: dropped as NaN/Inf (drop_nonfinite=True)
    thinned: int  #: after dropping duplicates and voxel thinning
    after_mutual: int  #: after mutual-kNN outlier culling
    after_stat: int  #: after the statistical outlier filter
    resampled: int  #: resampled points (``points``, or fewer)
    features: int  #: feature points
    duplicates: int  #: exact duplicate points dropped before thinning


@dataclass(frozen=True)
class PairCounts:
    """:class:`Counts` of the source and of the target cloud."""

    source: Counts
    target: Counts


def _decompose(T: np.ndarray) -> Tuple[float, np.ndarray, np.ndarray]:
    sR = T[:3, :3]
    s = float(np.cbrt(np.linalg.det(sR)))
    return s, sR / s, T[:3, 3].copy()


def _transform_points(T: np.ndarray, points: ArrayLike) -> np.ndarray:
    a = _as_points(points, "points", finite=False)
    return a @ T[:3, :3].T + T[:3, 3]


@dataclass(frozen=True, repr=False)
class Candidate:
    """One pose kept by the search and refined (coarse if ``refine=False``)."""

    transform: np.ndarray  #: 4x4 T_target_source
    scale: float  #: s
    #: G_K of the search, radians in [0, pi], smaller is better (trimmed G_K for
    #: the second search's candidates: the 80 % best-fitting matched cells)
    score: float
    score_contour: float  #: G of the contour representatives, radians
    score_feature: float  #: G of the feature representatives, radians
    rms: float  #: RMS of the final mutual pairs, target units
    overlap: float  #: overlap score in [0, 1]: sqrt(f_s f_t), shares within 2 spacings
    rotation_index: int  #: index into the rotation candidate set
    offset_index: int  #: index into the offset set; ``n_offsets + i``: wide grid (second search)
    #: the overlap score within 1 spacing (<= overlap); the winner is the
    #: refined candidate with the highest fit
    fit: float
    #: how far its refinement went: ``"search"`` (the search's pose),
    #: ``"coarse"`` (the coarse rigid level), ``"stopped"`` (full refinement
    #: stopped short: behind the refined leader, or in another's minimum),
    #: ``"refined"`` (full refinement to its end; only these can win)
    stage: str

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map (N, 3) source points into the target frame with this pose."""
        return _transform_points(self.transform, points)

    def __repr__(self) -> str:
        return ("Candidate(scale=%.6g, score=%.4g, rms=%.4g, overlap=%.3f, fit=%.3f, "
                "stage=%r, rotation_index=%d, offset_index=%d)"
                % (self.scale, self.score, self.rms, self.overlap, self.fit,
                   self.stage, self.rotation_index, self.offset_index))


@dataclass(frozen=True, repr=False)
class Result:
    """A registration: ``transform`` maps source points into the target frame,
    ``x_t ~= scale * rotation @ x_s + translation``."""

    transform: np.ndarray  #: 4x4 float64 T_target_source, upper-left 3x3 = s*R
    scale: float  #: s > 0
    rotation: np.ndarray  #: 3x3 R, det +1
    translation: np.ndarray  #: (3,) t, target units
    score: float  #: the winner's G_K, radians (smaller is better; trimmed if from the second search)
    rms: float  #: the winner's RMS residual, target units
    overlap: float  #: the winner's overlap score in [0, 1]
    winner: int  #: index of the winner in ``candidates``
    #: refined candidates, best search score first; a second search's (on the
    #: wide offset grid, run when the first winner covers neither cloud) follow
    candidates: List[Candidate]
    n_rotations: int  #: rotation candidates searched
    n_offsets: int  #: offset candidates per search
    n_evaluations: int  #: shape measurements computed
    timings: Timings  #: seconds per stage
    counts: PairCounts  #: points kept per pre-processing step
    backend: str  #: 'reference' or 'opencl', the backend actually used
    device: str  #: the device name
    fit: float  #: the winner's overlap score within 1 spacing, by which it won

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map (N, 3) source points into the target frame: ``s R x + t``."""
        return _transform_points(self.transform, points)

    def __repr__(self) -> str:
        axis_angle = np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1) / 2, -1, 1)))
        return ("Result(scale=%.6g, rotation=%.3f deg, translation=%s, score=%.4g rad, "
                "rms=%.4g, overlap=%.3f, fit=%.3f, backend=%r, device=%r, total=%.3f s)"
                % (self.scale, axis_angle, np.array2string(self.translation, precision=4),
                   self.score, self.rms, self.overlap, self.fit, self.backend, self.device,
                   self.timings.total))


_BACKEND_NAMES = {v: k for k, v in _BACKENDS.items()}
_STAGE_NAMES = {lib.PKSS_STAGE_SEARCH: "search", lib.PKSS_STAGE_COARSE: "coarse",
                lib.PKSS_STAGE_STOPPED: "stopped", lib.PKSS_STAGE_REFINED: "refined"}


def _matrix(cdata: Any, shape: Tuple[int, ...]) -> np.ndarray:
    return np.array(list(cdata), dtype=np.float64).reshape(shape)


def _counts(c: Any) -> Counts:
    return Counts(int(c.input), int(c.nonfinite), int(c.thinned), int(c.after_mutual),
                  int(c.after_stat), int(c.resampled), int(c.features),
                  int(c.duplicates))


def _result(r: Any) -> Result:
    cands = []
    for i in range(r.n_candidates):
        c = r.candidates[i]
        cands.append(Candidate(_matrix(c.T_target_source, (4, 4)), c.scale, c.score,
                               c.score_contour, c.score_feature, c.rms, c.overlap,
                               int(c.rotation_index), int(c.offset_index),
                               float(r.candidate_fit[i]),
                               _STAGE_NAMES[int(r.candidate_stage[i])]))
    t = r.timings
    return Result(
        transform=_matrix(r.T_target_source, (4, 4)), scale=r.scale,
        rotation=_matrix(r.rotation, (3, 3)), translation=_matrix(r.translation, (3,)),
        score=r.score, rms=r.rms, overlap=r.overlap, winner=int(r.winner), candidates=cands,
        n_rotations=int(r.n_rotations), n_offsets=int(r.n_offsets),
        n_evaluations=int(r.n_evaluations),
        timings=Timings(t.validate, t.preprocess, t.search, t.refine, t.total),
        counts=PairCounts(_counts(r.source_counts), _counts(r.target_counts)),
        backend=_BACKEND_NAMES.get(r.backend, str(r.backend)), device=_str(r.device),
        fit=r.fit)


def _new_result() -> Any:
    # Zeroed by ffi.new. Not pkss_result_init(): a newer library would clear
    # its own, larger sizeof(pkss_result); struct_size tells it ours.
    res = ffi.new("pkss_result *")
    res.struct_size = ffi.sizeof("pkss_result")
    return res


# --------------------------------------------------------------------- input
def _as_points(obj: Any, what: str, finite: bool = True) -> np.ndarray:
    """Any (N, 3) array-like of reals -> C-contiguous float64 (N, 3)."""
    if not isinstance(obj, np.ndarray) and hasattr(obj, "points"):
        obj = obj.points  # Open3D PointCloud and similar containers
    try:
        a = np.asarray(obj)
    except (TypeError, ValueError) as e:
        raise _invalid("%s: expected an (N, 3) array of real numbers; cannot convert %s (%s)"
                       % (what, type(obj).__name__, e)) from None
    if a.dtype.kind not in "iuf":
        raise _invalid("%s: expected an (N, 3) array of real numbers, got dtype %s"
                       % (what, a.dtype))
    if a.ndim != 2 or a.shape[1] != 3:
        raise _invalid("%s: expected an (N, 3) array, got shape %s" % (what, a.shape))
    if a.shape[0] == 0:
        raise _invalid("%s: the array is empty, shape %s" % (what, a.shape),
                       lib.PKSS_ERR_EMPTY_INPUT)
    a = np.ascontiguousarray(a, dtype=np.float64)
    if finite:
        ok = np.isfinite(a).all(axis=1)
        if not ok.all():
            bad = np.flatnonzero(~ok)
            raise _invalid("%s: row %d has a non-finite coordinate %s; %d such rows in all "
                           "(pass drop_nonfinite=True to drop them)"
                           % (what, bad[0], tuple(float(v) for v in a[bad[0]]), bad.size),
                           lib.PKSS_ERR_NONFINITE)
    return a


def _buffer(a: np.ndarray) -> Any:
    return ffi.from_buffer("double[]", a)


# ------------------------------------------------------------------- context
class Cloud:
    """A point cloud pre-processed once (validated, thinned, culled,
    resampled, mapped to pre-shape space) by :meth:`Context.prepare_cloud`.

    Register many sources against one prepared template with
    :meth:`Context.register`. A cloud does not depend on the context that
    made it (close either in any order). ``len(cloud)`` is the number of
    resampled points.
    """

    def __init__(self, ptr: Any) -> None:
        # Private: use Context.prepare_cloud().
        self._ptr: Any = ffi.gc(ptr, lib.pkss_cloud_destroy)
        self._lock = threading.Lock()

    def _live(self) -> Any:
        if self._ptr is None:
            raise _closed("Cloud")
        return self._ptr

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._ptr is None

    def close(self) -> None:
        """Free the C cloud now. Calling it again does nothing."""
        with self._lock:
            if self._ptr is not None:
                ptr, self._ptr = self._ptr, None
                ffi.release(ptr)  # runs pkss_cloud_destroy

    def __enter__(self) -> "Cloud":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __len__(self) -> int:
        with self._lock:
            return int(lib.pkss_cloud_size(self._live()))

    @property
    def counts(self) -> Counts:
        """Points kept after each pre-processing step."""
        out = ffi.new("pkss_counts *")
        with self._lock:
            st = lib.pkss_cloud_counts(self._live(), out)
        if st:
            _raise(st, "pkss_cloud_counts")
        return _counts(out)

    @property
    def points(self) -> np.ndarray:
        """The resampled points, (m, 3) float64, in the caller's coordinates."""
        with self._lock:
            ptr = self._live()
            n = int(lib.pkss_cloud_size(ptr))
            out = np.empty((n, 3), dtype=np.float64)
            st = lib.pkss_cloud_points(ptr, _buffer(out), n)
        if st:
            _raise(st, "pkss_cloud_points")
        return out

    def __repr__(self) -> str:
        if self._ptr is None:
            return "<pkss.Cloud (closed)>"
        return "<pkss.Cloud of %d resampled points>" % len(self)


class Context:
    """Parameters, the device and the last error, kept between calls.

    ``Context(**params)`` takes the keyword arguments of :func:`register`
    (listed below); ``None`` leaves the library default. Settings stick until
    :meth:`set` changes them or :meth:`reset` restores the defaults. The
    device is opened on first use (or by :meth:`prepare`) and kept, which
    saves the kernel build on repeated registrations.

    Use as a context manager, or call :meth:`close` (idempotent); the C
    context is also freed when the object is garbage collected. Calls on a
    closed context raise ``ValueError``. For parallel work use one context
    per thread: every C call releases the GIL.
    """

    @_check_keywords
    def __init__(
        self,
        *,
        points: Optional[int] = None,
        rotation_steps: Optional[int] = None,
        offset_steps: Optional[int] = None,
        cell_steps: Optional[int] = None,
        cull_mutual: Optional[bool] = None,
        cull_stat: Optional[bool] = None,
        use_features: Optional[bool] = None,
        feature_frac: Optional[float] = None,
        pca_prealign: Optional[bool] = None,
        rotation_set: Optional[str] = None,
        rotation_count: Optional[int] = None,
        top_k: Optional[int] = None,
        refine: Optional[bool] = None,
        seed: Optional[int] = None,
        max_raw_points: Optional[int] = None,
        drop_nonfinite: Optional[bool] = None,
        min_points: Optional[int] = None,
        backend: Optional[str] = None,
        device: Optional[Union[str, int]] = None,
    ) -> None:
        self._ptr: Any = None
        self._lock = threading.Lock()
        self._device: Optional[str] = None
        out = ffi.new("pkss_context **")
        st = lib.pkss_context_create(out)
        if st:
            _raise(st, "pkss_context_create failed")
        self._ptr = ffi.gc(out[0], lib.pkss_context_destroy)
        try:
            self.set(**{k: v for k, v in locals().items() if k in _PARAMS})
        except BaseException:
            self.close()
            raise

    # -- lifecycle
    def _live(self) -> Any:
        if self._ptr is None:
            raise _closed("Context")
        return self._ptr

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._ptr is None

    def close(self) -> None:
        """Free the C context (and its device) now. Calling it again does
        nothing."""
        with self._lock:
            if self._ptr is not None:
                ptr, self._ptr = self._ptr, None
                ffi.release(ptr)  # runs pkss_context_destroy

    def __enter__(self) -> "Context":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        if self._ptr is None:
            return "<pkss.Context (closed)>"
        return "<pkss.Context backend=%r device=%r>" % (self.params["backend"], self.device_name)

    def _check(self, status: int) -> None:
        """Raise the Error for `status` with this context's detail (call with
        the lock held, before the next call on the context)."""
        if status:
            _raise(status, _str(lib.pkss_context_last_error(self._ptr)))

    # -- parameters
    @_check_keywords
    def set(
        self,
        *,
        points: Optional[int] = None,
        rotation_steps: Optional[int] = None,
        offset_steps: Optional[int] = None,
        cell_steps: Optional[int] = None,
        cull_mutual: Optional[bool] = None,
        cull_stat: Optional[bool] = None,
        use_features: Optional[bool] = None,
        feature_frac: Optional[float] = None,
        pca_prealign: Optional[bool] = None,
        rotation_set: Optional[str] = None,
        rotation_count: Optional[int] = None,
        top_k: Optional[int] = None,
        refine: Optional[bool] = None,
        seed: Optional[int] = None,
        max_raw_points: Optional[int] = None,
        drop_nonfinite: Optional[bool] = None,
        min_points: Optional[int] = None,
        backend: Optional[str] = None,
        device: Optional[Union[str, int]] = None,
    ) -> None:
        """Change parameters (the keyword arguments of :func:`register`);
        ``None`` leaves a parameter as it is. Applied in the order given; a
        bad value raises (TypeError for a wrong type, InvalidArgument, also a
        ValueError, for a value out of range) and leaves that parameter and
        the ones after it unchanged."""
        values = {k: v for k, v in locals().items() if k in _PARAMS and v is not None}
        with self._lock:
            ptr = self._live()
            for name, value in values.items():
                self._set_one(ptr, name, value)

    def _set_one(self, ptr: Any, name: str, value: Any) -> None:
        pid, kind, choices = _PARAMS[name]
        if kind == _SWITCH:
            if isinstance(value, (bool, np.bool_)) or (
                    isinstance(value, numbers.Integral) and value in (0, 1)):
                st = lib.pkss_context_set_int(
                    ptr, pid, lib.PKSS_SWITCH_ON if value else lib.PKSS_SWITCH_OFF)
            else:
                raise TypeError("%s must be True or False, got %r" % (name, value))
        elif kind == _INT or kind == _DOUBLE:
            if isinstance(value, (bool, np.bool_)) or not isinstance(
                    value, numbers.Integral if kind == _INT else numbers.Real):
                raise TypeError("%s must be %s, got %s %r" % (
                    name, "an integer" if kind == _INT else "a real number",
                    type(value).__name__, value))
            lo, hi, de = param_bounds(name)
            if value == 0 and lo > 0 or not -2**62 < value < 2**62:
                # C reads 0 as "default"; in Python the default is None.
                raise _invalid("parameter '%s' must be in [%s, %s] (default %s; pass None for "
                               "the default); got %s" % (name, lo, hi, de, value))
            if kind == _INT:
                st = lib.pkss_context_set_int(ptr, pid, int(value))
            else:
                st = lib.pkss_context_set_double(ptr, pid, float(value))
        elif kind == _CHOICE:
            assert choices is not None
            if not isinstance(value, str):
                raise TypeError("%s must be one of %s, got %r" % (name, ", ".join(map(repr, choices)), value))
            if value.lower() not in choices:
                raise _invalid("parameter '%s' must be one of %s; got %r"
                               % (name, ", ".join(map(repr, choices)), value))
            st = lib.pkss_context_set_int(ptr, pid, choices[value.lower()])
        else:  # device: index or name substring
            if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
                if value < 0:
                    raise _invalid("device index must be >= 0; got %d" % value)
                value = str(int(value))
            if not isinstance(value, str) or not value:
                raise TypeError("device must be a device index (int) or a non-empty name "
                                "substring (str), got %r" % (value,))
            st = lib.pkss_context_set_string(ptr, pid, value.encode())
            if st == 0:
                self._device = value
        self._check(st)

    def reset(self) -> None:
        """Put every parameter back to its default (and release the device)."""
        with self._lock:
            ptr = self._live()
            self._check(lib.pkss_context_reset(ptr, lib.PKSS_RESET_ALL))
            self._check(lib.pkss_context_set_string(ptr, lib.PKSS_PARAM_DEVICE, ffi.NULL))
            self._device = None

    @property
    def params(self) -> Dict[str, Any]:
        """Every parameter's value in force (defaults resolved), keyed by the
        names of :func:`register`; ``device`` is None unless set."""
        out: Dict[str, Any] = {}
        v = ffi.new("double *")
        with self._lock:
            ptr = self._live()
            for name, (pid, kind, choices) in _PARAMS.items():
                if kind == _DEVICE:
                    out[name] = self._device
                    continue
                self._check(lib.pkss_context_get_double(ptr, pid, v))
                if kind == _SWITCH:
                    out[name] = v[0] == lib.PKSS_SWITCH_ON
                elif kind == _CHOICE:
                    assert choices is not None
                    out[name] = {c: k for k, c in choices.items()}.get(int(v[0]), int(v[0]))
                elif kind == _INT:
                    out[name] = int(v[0])
                else:
                    out[name] = float(v[0])
        return out

    # -- device
    def prepare(self) -> None:
        """Open the device and build the kernels now rather than on the first
        registration (to fail early or to time it apart). Raises
        :class:`DeviceError` if the selected backend/device cannot be used."""
        with self._lock:
            ptr = self._live()
            self._check(lib.pkss_context_prepare(ptr))

    @property
    def device_name(self) -> str:
        """The device the context runs on after :meth:`prepare` or a
        registration ("reference (C, CPU)" or an OpenCL device name); ""
        before."""
        with self._lock:
            return _str(lib.pkss_context_device_name(self._live()))

    # -- work
    def prepare_cloud(self, points: ArrayLike) -> Cloud:
        """Pre-process (N, 3) points once with this context's parameters
        (validation, thinning, outlier culling, resampling, features, PCA) and
        return a :class:`Cloud` for :meth:`register`."""
        with self._lock:
            ptr = self._live()
            return self._cloud(ptr, points, "points")

    def _cloud(self, ptr: Any, points: ArrayLike, what: str) -> Cloud:
        a = _as_points(points, what, finite=not self._drop_nonfinite(ptr))
        out = ffi.new("pkss_cloud **")
        self._check(lib.pkss_cloud_create(ptr, _buffer(a), a.shape[0], out))
        return Cloud(out[0])

    def _drop_nonfinite(self, ptr: Any) -> bool:
        v = ffi.new("long long *")
        self._check(lib.pkss_context_get_int(ptr, lib.PKSS_PARAM_DROP_NONFINITE, v))
        return v[0] == lib.PKSS_SWITCH_ON

    def register(self, source: PointsLike, target: PointsLike) -> Result:
        """Register `source` onto `target` with this context's parameters.

        Each argument is an (N, 3) array-like of real numbers (any dtype,
        layout or a list; an Open3D ``PointCloud`` works too) or a
        :class:`Cloud` from :meth:`prepare_cloud`. Returns a :class:`Result`
        whose ``transform`` maps source points into the target frame.
        Raises :class:`InvalidArgument` (a ValueError) for bad input and
        another :class:`Error` subclass if the C library fails; never returns
        a default pose.
        """
        res = _new_result()
        with self._lock:
            ptr = self._live()
            if not isinstance(source, Cloud) and not isinstance(target, Cloud):
                finite = not self._drop_nonfinite(ptr)
                s = _as_points(source, "source", finite)
                t = _as_points(target, "target", finite)
                st = lib.pkss_register(ptr, _buffer(s), s.shape[0], _buffer(t), t.shape[0], res)
                self._check(st)
                return _result(res)
            temp: List[Cloud] = []
            try:
                s_cloud = source if isinstance(source, Cloud) else self._cloud(ptr, source, "source")
                if s_cloud is not source:
                    temp.append(s_cloud)
                t_cloud = target if isinstance(target, Cloud) else self._cloud(ptr, target, "target")
                if t_cloud is not target:
                    temp.append(t_cloud)
                with _locked(s_cloud, t_cloud):
                    st = lib.pkss_register_clouds(ptr, s_cloud._live(), t_cloud._live(), res)
                    self._check(st)
            finally:
                for c in temp:
                    c.close()
        return _result(res)


class _locked:
    """Hold the locks of one or two clouds, in a fixed order (no deadlock)."""

    def __init__(self, *clouds: Cloud) -> None:
        unique = {id(c): c for c in clouds}
        self._locks = [unique[k]._lock for k in sorted(unique)]

    def __enter__(self) -> None:
        for lk in self._locks:
            lk.acquire()

    def __exit__(self, *exc: Any) -> None:
        for lk in reversed(self._locks):
            lk.release()


@_check_keywords
def register(
    source: PointsLike,
    target: PointsLike,
    *,
    points: Optional[int] = None,
    rotation_steps: Optional[int] = None,
    offset_steps: Optional[int] = None,
    cell_steps: Optional[int] = None,
    cull_mutual: Optional[bool] = None,
    cull_stat: Optional[bool] = None,
    use_features: Optional[bool] = None,
    feature_frac: Optional[float] = None,
    pca_prealign: Optional[bool] = None,
    rotation_set: Optional[str] = None,
    rotation_count: Optional[int] = None,
    top_k: Optional[int] = None,
    refine: Optional[bool] = None,
    seed: Optional[int] = None,
    max_raw_points: Optional[int] = None,
    drop_nonfinite: Optional[bool] = None,
    min_points: Optional[int] = None,
    backend: Optional[str] = None,
    device: Optional[Union[str, int]] = None,
) -> Result:
    """Register `source` onto `target`: find s, R, t with
    ``target ~= s * R @ source + t``, without an initial guess.

    Successive calls from one thread share one :class:`Context` while the
    parameters other than ``seed`` stay the same, so the device is opened
    once; results are the same as with a fresh context.

    Parameters
    ----------
    source, target : (N, 3) array-like of real numbers, or Cloud
        Points in any units (no parameter is in absolute units: distances
        are relative to each cloud's size). Any dtype, layout or nesting
        numpy accepts; objects with a ``.points`` attribute (Open3D
        ``PointCloud``) work too. NaN/Inf rows raise ValueError unless
        ``drop_nonfinite=True``.

    Every parameter below is keyword-only; ``None`` means the library
    default shown (see also :func:`default_params`, :func:`param_bounds`).

    points : int, optional
        m, the points each cloud is resampled to (farthest-point sampling).
        Default 3000; range 256..20000. Time grows about linearly with m.
    rotation_steps : int, optional
        n, rotation steps per axis of the Euler grid: the step is 360/n
        degrees. Default 12; range 4..36, even.
    offset_steps : int, optional
        N, offsets per PCA axis of the translation search (N**3 offsets).
        Default 5; range 1..9, odd; 1 disables the translation search.
    cell_steps : int, optional
        Azimuth bins of the spherical cell partition (elevation bins are
        half). Default 12 (follows rotation_steps); range 4..48, even.
    cull_mutual : bool, optional
        Mutual-kNN outlier culling. Default True.
    cull_stat : bool, optional
        Density-aware statistical outlier filter. Default True.
    use_features : bool, optional
        Score feature representatives too, G_K = max(G_c, G_f).
        Default True.
    feature_frac : float, optional
        Share of the resampled points kept as feature points (a fraction,
        not a percentage). Default 0.1; range 0.01..0.5.
    pca_prealign : bool, optional
        PCA pre-alignment of the source to the template. Default True.
    rotation_set : {'euler', 'uniform'}, optional
        Rotation candidates: the Euler grid (744 distinct rotations at the
        default step) or a near-uniform set of ``rotation_count``.
        Default 'euler'.
    rotation_count : int, optional
        Rotations in the 'uniform' set. Default 1728; range 24..20000.
    top_k : int, optional
        Candidates kept after the search and refined. Default 10;
        range 1..32. A second search (wide offset grid, run when the
        first winner covers neither cloud) keeps as many more, up to 32.
    refine : bool, optional
        Overlap-aware similarity ICP on each candidate; False returns the
        best search candidate unrefined. Default True.
    seed : int, optional
        Seed of every random choice (results are reproducible for a given
        seed and backend). Default 0; range 0..2147483647.
    max_raw_points : int, optional
        Inputs with more points are voxel-thinned to about this many first.
        Default 200000; range 1000..100000000.
    drop_nonfinite : bool, optional
        Drop NaN/Inf rows instead of raising ValueError. Default False.
    min_points : int, optional
        Fewest finite points (and points left after culling) accepted.
        Default 32; range 16..1000000.
    backend : {'auto', 'reference', 'opencl'}, optional
        'reference' is plain C on the calling thread; 'opencl' fails with
        DeviceError when no device is usable; 'auto' uses OpenCL if a device
        is usable, else the reference backend. Default 'auto'.
    device : str or int, optional
        OpenCL device by index (see :func:`devices`) or case-insensitive
        name substring ('cpu', 'pthread', 'NVIDIA'). Default: the
        PKSS_DEVICE environment variable, then the first GPU, then the
        first CPU.

    Returns
    -------
    Result
        ``transform`` (4x4 float64 T_target_source), ``scale``,
        ``rotation``, ``translation``, ``score`` (radians), ``rms`` (target
        units), ``overlap`` ([0, 1]), ``candidates``, ``timings`` (seconds),
        ``counts``, ``backend``, ``device``; ``apply(points)`` maps source
        points into the target frame.

    Raises
    ------
    InvalidArgument
        (also ValueError) wrong shape or dtype, empty input, too few points,
        NaN/Inf, degenerate (collinear/coplanar) input, a parameter out of
        range. ``.detail`` says which.
    TypeError
        An unknown keyword or a parameter of the wrong type.
    DeviceError
        The OpenCL backend was requested and cannot run.
    Error
        Any other failure of the C library (``.status``, ``.name``,
        ``.detail``).
    """
    params = dict(points=points, rotation_steps=rotation_steps, offset_steps=offset_steps,
                  cell_steps=cell_steps, cull_mutual=cull_mutual, cull_stat=cull_stat,
                  use_features=use_features, feature_frac=feature_frac,
                  pca_prealign=pca_prealign, rotation_set=rotation_set,
                  rotation_count=rotation_count, top_k=top_k, refine=refine, seed=seed,
                  max_raw_points=max_raw_points, drop_nonfinite=drop_nonfinite,
                  min_points=min_points, backend=backend, device=device)
    return _thread_context(params).register(source, target)


# register() keeps one Context per thread and reuses it while all parameters
# but the seed stay the same: a fresh context opens the OpenCL device and
# loads the kernel again on its first call, ~0.06 s of a 0.2 s registration
# (measured on the bunny with PoCL). Results do not depend on it: every call
# starts from the parameters (the seed included), and a context keeps no
# other state.
_per_thread = threading.local()
_DEFAULT_SEED = default_params()["seed"]


def _thread_context(params: Dict[str, Any]) -> "Context":
    # the seed changes from call to call in seeded experiments: it is set on
    # the reused context rather than being part of the key
    seed = params.pop("seed")
    key = tuple(sorted((k, repr(v)) for k, v in params.items()))
    cached = getattr(_per_thread, "context", None)
    if cached is None or cached[0] != key or cached[1].closed:
        ctx = Context(**params)  # raises on bad parameters: nothing cached then
        if cached is not None:
            cached[1].close()
        cached = _per_thread.context = (key, ctx)
    cached[1].set(seed=_DEFAULT_SEED if seed is None else seed)
    return cached[1]


def _param_section() -> str:
    doc = register.__doc__ or ""
    start = doc.index("    Every parameter below")
    return doc[start:doc.index("    Returns\n")].rstrip() + "\n"


# The parameters are documented once, in register(); the Context docs share it.
if Context.__doc__ is not None and register.__doc__ is not None:
    Context.__doc__ += "\n    Parameters\n    ----------\n" + _param_section()
    Context.set.__doc__ = (Context.set.__doc__ or "") + textwrap.indent(
        "\n\n    Parameters\n    ----------\n" + _param_section(), "    ")


# ------------------------------------------------------------------- devices
@dataclass(frozen=True)
class Device:
    """An OpenCL device as pkss sees it; ``index`` is what ``device=`` takes."""

    index: int
    name: str
    vendor: str
    platform: str
    version: str  #: CL_DEVICE_VERSION
    is_gpu: bool
    has_fp64: bool
    compute_units: int
    global_mem_bytes: int


class DeviceList(List[Device]):
    """A list of :class:`Device`; ``reason`` says why it is empty ("" if not)."""

    reason: str

    def __init__(self, items: Iterable[Device] = (), reason: str = "") -> None:
        super().__init__(items)
        self.reason = reason


def devices() -> DeviceList:
    """The OpenCL devices of all platforms, in the order ``device=<index>``
    uses. Empty, with ``.reason`` explaining why, when no OpenCL platform is
    installed or the library was built without OpenCL."""
    count = ffi.new("unsigned *")
    st = lib.pkss_device_count(count)
    if st == lib.PKSS_ERR_UNSUPPORTED or (st == 0 and count[0] == 0):
        return DeviceList(reason=_str(lib.pkss_no_device_reason()))
    if st:
        _raise(st, "pkss_device_count failed")
    out = DeviceList()
    d = ffi.new("pkss_device_desc *")
    for i in range(count[0]):
        st = lib.pkss_device_info(i, d)
        if st:
            _raise(st, "pkss_device_info(%d) failed" % i)
        out.append(Device(i, _str(d.name), _str(d.vendor), _str(d.platform), _str(d.version),
                          bool(d.is_gpu), bool(d.has_fp64), int(d.compute_units),
                          int(d.global_mem_bytes)))
    return out
