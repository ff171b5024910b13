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
* :func:`parameters` -- every tunable with its type, range, default and unit,
  read from the C library (the keyword arguments and their documentation are
  built from the same table at import).
* :func:`devices` -- the OpenCL devices the library sees.
* :func:`read_points` / :func:`write_points` -- point cloud files (PLY, PCD,
  XYZ, OFF, KITTI, VTK, .npy, .npz) through the C library's readers
  (:mod:`pkss.io`). Arrays, Open3D clouds (legacy and tensor) and
  ``o3d.core.Tensor`` are accepted wherever points are.
* ``python -m pkss align|info`` and the ``pkss-align`` / ``pkss-info``
  commands: the C tools bundled in the wheel (:mod:`pkss.__main__`).

Errors from the C library raise :class:`Error` (``.status``, ``.name``,
``.detail``); bad input raises :class:`InvalidArgument`, which is also a
``ValueError``; a call stopped by its ``progress`` callback raises
:class:`Cancelled`, and Ctrl-C during a call raises ``KeyboardInterrupt``
promptly. The library prints nothing. Every C call releases the GIL, so
threads with one context each run in parallel. A context (and a cloud) is
locked while in use, so sharing one between threads is safe but serialised.
"""
from __future__ import annotations

import difflib
import inspect
import numbers
import os
import textwrap
import threading
import warnings
from dataclasses import dataclass, fields
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple, Union

import numpy as np

from ._convert import open3d_points as _open3d_points
from ._lib import ffi, lib, library_path

__all__ = [
    "register", "Context", "Cloud", "Result", "Candidate", "Alternative", "Symmetry",
    "Timings", "Counts", "PairCounts",
    "devices", "Device", "DeviceList", "parameters", "Parameter", "param_bounds",
    "default_params", "PARAM_NAMES",
    "Error", "InvalidArgument", "OutOfMemory", "DeviceError", "NumericalError", "Cancelled",
    "DeviceWarning", "status_name", "status_string", "build_info",
    "__version__", "library_version", "library_path", "MAX_CANDIDATES",
    "read_points", "write_points", "FileError",
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
#: progress(stage, step, steps, elapsed) -> None/True to go on, False to cancel
ProgressFn = Callable[[str, int, int, float], Optional[bool]]


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

    def __reduce__(self) -> Any:
        # explicit, so that tblib's exception pickling (installed by Dask)
        # uses it too: its fallback cannot rebuild a MemoryError subclass
        return (type(self), (self.status, self.detail))

    @staticmethod
    def class_for(status: int) -> type:
        """The subclass raised for a status code."""
        s = int(status)
        if s == lib.PKSS_ERR_CANCELLED:  # not the caller's mistake: no ValueError
            return Cancelled
        if s == lib.PKSS_ERR_IO:  # a file, not memory, though in the 100s
            from .io import FileError
            return FileError
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
    degenerate input, a parameter out of range, parameters that cannot work
    together. Also a ``ValueError``."""


class OutOfMemory(Error, MemoryError):
    """Resource errors (status 100-199). Also a ``MemoryError``."""


class DeviceError(Error):
    """Device and OpenCL errors (status 200-299): no device, a failed OpenCL
    call, a kernel build failure (log in ``detail``), a missing feature."""


class NumericalError(Error):
    """Numerical failures (status 300-398), e.g. the search found no
    candidate (``PKSS_ERR_NO_CONSENSUS``)."""


class Cancelled(Error):
    """The ``progress`` callback returned False and the call stopped
    (``PKSS_ERR_CANCELLED``); no pose was computed. Ctrl-C raises
    ``KeyboardInterrupt`` instead."""


class DeviceWarning(RuntimeWarning):
    """A device was asked for (``device=`` or ``$PKSS_DEVICE``) but the
    registration ran on the reference backend; the message says why."""


def _raise(status: int, detail: str) -> None:
    raise Error.class_for(status)(status, detail)


def _invalid(detail: str, status: int = lib.PKSS_ERR_INVALID_ARGUMENT) -> InvalidArgument:
    return InvalidArgument(status, detail)


def _closed(what: str) -> ValueError:
    return ValueError("%s is closed" % what)


# ----------------------------------------------------------------- parameters
# Everything about a parameter -- name, kind, range, default, unit, value
# names, documentation -- comes from the C library's table (pkss_param_at),
# read once here: the keyword arguments of register()/Context()/Context.set(),
# their checks and their docstrings are all built from it (issue #20).
_TYPE_NAMES = {lib.PKSS_TYPE_INT: "int", lib.PKSS_TYPE_DOUBLE: "double",
               lib.PKSS_TYPE_SWITCH: "switch", lib.PKSS_TYPE_CHOICE: "choice",
               lib.PKSS_TYPE_STRING: "string"}


@dataclass(frozen=True)
class Parameter:
    """One tunable, as the C library describes it (``pkss_param_at``)."""

    name: str  #: the keyword argument, as ``pkss_param_name()``
    id: int  #: its ``pkss_param`` value
    #: ``'int'``, ``'double'``, ``'switch'`` (True/False, or 'on'/'off'),
    #: ``'choice'`` (one of ``choices``) or ``'string'``
    type: str
    #: the library default as Python takes it: int, float, bool (switch), a
    #: name of ``choices`` (choice) or None (string: see ``doc``)
    default: Any
    lower: Optional[Union[int, float]]  #: smallest value (int and double only)
    upper: Optional[Union[int, float]]  #: largest value (int and double only)
    unit: str  #: e.g. 'points', 'steps', 'fraction'; '' if none
    #: switch and choice: the names of the C values 0, 1, 2, ... ('default'
    #: at 0 means "library default"); () otherwise
    choices: Tuple[str, ...]
    constraint: str  #: 'even', 'odd' or ''
    doc: str  #: one line, no trailing period

    @property
    def value_names(self) -> Tuple[str, ...]:
        """The names a caller picks from (``choices`` without 'default')."""
        return tuple(c for c in self.choices if c != "default")

    def to_python(self, c_value: float) -> Any:
        """A value read from the C library (``pkss_context_get_double``) in
        the form the keyword argument takes."""
        v = int(c_value) if self.type != "double" else float(c_value)
        if self.type == "switch":
            return {lib.PKSS_SWITCH_ON: True, lib.PKSS_SWITCH_OFF: False}.get(v)
        if self.type == "choice":
            return self.choices[v] if 0 <= v < len(self.choices) else v
        return v


def _load_parameters() -> Tuple[Parameter, ...]:
    out = []
    info = ffi.new("pkss_param_info *")
    for i in range(int(lib.pkss_param_count())):
        lib.pkss_param_info_init(info, ffi.sizeof("pkss_param_info"))
        st = lib.pkss_param_at(i, info)
        if st:
            raise ImportError("pkss: pkss_param_at(%d) failed: %s" % (i, status_name(st)))
        kind = _TYPE_NAMES.get(int(info.type))
        if kind is None:
            continue  # a kind newer than this binding: it cannot set it
        choices = tuple(_str(info.choices).split("|")) if _str(info.choices) else ()
        numeric = kind in ("int", "double")
        conv = int if kind == "int" else float
        p = Parameter(name=_str(info.name), id=int(info.id), type=kind, default=None,
                      lower=conv(info.lower) if numeric else None,
                      upper=conv(info.upper) if numeric else None,
                      unit=_str(info.unit), choices=choices, constraint=_str(info.constraint),
                      doc=_str(info.doc))
        default = None if kind == "string" else p.to_python(info.default_value)
        out.append(Parameter(**dict(p.__dict__, default=default)))
    return tuple(out)


_PARAMETERS: Tuple[Parameter, ...] = _load_parameters()
_PARAMS: Dict[str, Parameter] = {p.name: p for p in _PARAMETERS}
#: The keyword arguments of :func:`register`, :class:`Context` and
#: :meth:`Context.set`, in the order of the C library's table.
PARAM_NAMES: Tuple[str, ...] = tuple(_PARAMS)


def parameters() -> List[Parameter]:
    """Every parameter the keyword arguments take, as the C library
    describes it (name, type, range, default, unit, value names, constraint,
    one-line doc), in table order. ``dataclasses.asdict(p)`` gives a dict."""
    return list(_PARAMETERS)


def _check_names(func: str, kwargs: Dict[str, Any]) -> None:
    """An unknown keyword -> TypeError listing the valid names."""
    for k in kwargs:
        if k not in _PARAMS:
            hint = difflib.get_close_matches(k, PARAM_NAMES, n=1)
            raise TypeError("%s() got an unknown parameter %r%s; valid parameters: %s" % (
                func, k, " (did you mean %r?)" % hint[0] if hint else "",
                ", ".join(PARAM_NAMES)))


class ParamBounds(tuple):
    """``(lower, upper, default)`` of a numeric parameter."""

    @property
    def lower(self) -> Any:
        return self[0]

    @property
    def upper(self) -> Any:
        return self[1]

    @property
    def default(self) -> Any:
        return self[2]


def param_bounds(name: str) -> ParamBounds:
    """Valid range and default of an integer or float parameter:
    ``ParamBounds(lower, upper, default)`` (see :func:`parameters` for all of
    them). Raises ValueError for switches, choices and strings."""
    p = _PARAMS.get(name)
    if p is None:
        raise ValueError("unknown parameter %r; valid parameters: %s" % (name, ", ".join(PARAM_NAMES)))
    if p.type not in ("int", "double"):
        raise ValueError("parameter %r is a %s, not a number" % (name, p.type))
    return ParamBounds((p.lower, p.upper, p.default))


def default_params() -> Dict[str, Any]:
    """The library defaults of every parameter, resolved by a fresh context
    (``device`` is None: the ``PKSS_DEVICE`` environment variable, then the
    first GPU, then the first CPU)."""
    with Context() as ctx:
        return ctx.params


def _annotation(p: Parameter) -> Any:
    return {"int": Optional[int], "double": Optional[float],
            "switch": Optional[Union[bool, str]], "choice": Optional[str],
            "string": Optional[Union[str, int]]}[p.type]


def _param_signature(head: List[inspect.Parameter], tail: List[inspect.Parameter],
                     returns: Any) -> inspect.Signature:
    kw = inspect.Parameter.KEYWORD_ONLY
    params = [inspect.Parameter(p.name, kw, default=None, annotation=_annotation(p))
              for p in _PARAMETERS]
    return inspect.Signature(head + params + tail, return_annotation=returns)


def _fmt_number(p: Parameter, v: Any) -> str:
    return "%d" % v if p.type == "int" else "%g" % v


def _param_doc(p: Parameter) -> str:
    """The numpydoc entry of one parameter, built from its table row."""
    if p.type == "switch":
        head = "%s : bool or {%s}, optional" % (p.name, ", ".join(map(repr, p.value_names)))
        facts = "Default %r." % p.default
    elif p.type == "choice":
        head = "%s : {%s}, optional" % (p.name, ", ".join(map(repr, p.value_names)))
        facts = "Default %r." % p.default
    elif p.type == "string":
        head = "%s : str or int, optional" % p.name
        facts = "Default None (the library picks, as described)."
    else:
        head = "%s : %s, optional" % (p.name, "int" if p.type == "int" else "float")
        facts = "Default %s; range %s..%s%s%s." % (
            _fmt_number(p, p.default), _fmt_number(p, p.lower), _fmt_number(p, p.upper),
            ", " + p.constraint if p.constraint else "", "; unit: " + p.unit if p.unit else "")
    body = textwrap.fill(p.doc + ". " + facts, width=72, break_long_words=False,
                         break_on_hyphens=False)
    return head + "\n" + textwrap.indent(body, "    ") + "\n"


def _param_section(indent: str) -> str:
    text = ("Every parameter below is keyword-only; ``None`` means the library\n"
            "default shown (see :func:`parameters`, which holds this table).\n\n")
    text += "".join(_param_doc(p) for p in _PARAMETERS)
    return textwrap.indent(text, indent)


_PARAMS_MARK = "<PARAMETERS>\n"


def _fill_param_doc(obj: Any, indent: str = "    ") -> None:
    """Replace the <PARAMETERS> line of a docstring by the generated entries
    (nothing to do under python -OO, where docstrings are None)."""
    if obj.__doc__ and _PARAMS_MARK in obj.__doc__:
        obj.__doc__ = obj.__doc__.replace(indent + _PARAMS_MARK, _param_section(indent))


def _c_value(p: Parameter, value: Any) -> Union[int, float, str]:
    """Check a keyword argument against its table row and turn it into what
    the C setter takes. TypeError for a wrong type, InvalidArgument for a
    value the row rules out here (the C library checks the rest)."""
    is_bool = isinstance(value, (bool, np.bool_))
    if p.type == "switch":
        if is_bool or (isinstance(value, numbers.Integral) and value in (0, 1)):
            return lib.PKSS_SWITCH_ON if value else lib.PKSS_SWITCH_OFF
        if isinstance(value, str):
            return _choice_index(p, value)
        raise TypeError("%s must be True or False (or one of %s), got %r"
                        % (p.name, ", ".join(map(repr, p.value_names)), value))
    if p.type == "choice":
        if not isinstance(value, str):
            raise TypeError("%s must be one of %s, got %r"
                            % (p.name, ", ".join(map(repr, p.value_names)), value))
        return _choice_index(p, value)
    if p.type == "string":
        if isinstance(value, numbers.Integral) and not is_bool:
            if value < 0:
                raise _invalid("%s index must be >= 0; got %d" % (p.name, value))
            value = str(int(value))
        if not isinstance(value, str) or not value:
            raise TypeError("%s must be a device index (int) or a non-empty name "
                            "substring (str), got %r" % (p.name, value))
        return value
    if is_bool or not isinstance(value, numbers.Integral if p.type == "int" else numbers.Real):
        raise TypeError("%s must be %s, got %s %r" % (
            p.name, "an integer" if p.type == "int" else "a real number",
            type(value).__name__, value))
    if (value == 0 and p.lower > 0) or not -2**62 < value < 2**62:
        # C reads 0 as "default"; in Python the default is None.
        raise _invalid("parameter '%s' must be in [%s, %s] (default %s; pass None for the "
                       "default); got %s" % (p.name, p.lower, p.upper, p.default, value))
    return int(value) if p.type == "int" else float(value)


def _choice_index(p: Parameter, value: str) -> int:
    v = value.lower()
    if v not in p.choices:
        raise _invalid("parameter '%s' must be one of %s; got %r"
                       % (p.name, ", ".join(map(repr, p.value_names)), value))
    return p.choices.index(v)


# ------------------------------------------------------------------- results
def _frozen(a: Any) -> np.ndarray:
    # Results are values: a caller must not change a pose in place (a shared
    # pickled copy, or an array another part of the program holds).
    out = np.array(a, dtype=np.float64)
    out.flags.writeable = False
    return out


class _Value:
    """Frozen dataclasses of plain data: arrays are read-only, and pickling
    goes through __init__ (so an unpickled copy is read-only too)."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                object.__setattr__(self, f.name, _frozen(v))
            elif isinstance(v, list):
                object.__setattr__(self, f.name, tuple(v))

    def __reduce__(self) -> Any:
        return (type(self), tuple(getattr(self, f.name) for f in fields(self)))  # type: ignore


@dataclass(frozen=True)
class Timings(_Value):
    """Wall-clock seconds spent in each stage of a registration."""

    validate: float
    preprocess: float  #: thinning, culling, resampling, features, PCA
    search: float  #: binning, scoring and selection
    refine: float
    total: float


@dataclass(frozen=True)
class Counts(_Value):
    """Points kept after each pre-processing step of one cloud."""

    input: int  #: points given
    nonfinite: int  #: dropped as NaN/Inf (drop_nonfinite=True)
    thinned: int  #: after duplicates, voxel thinning and the culling subset (<= a multiple of m)
    after_mutual: int  #: after mutual-kNN outlier culling
    after_stat: int  #: after the statistical outlier filter
    resampled: int  #: resampled points (``points``, or fewer)
    features: int  #: feature points
    duplicates: int  #: exact duplicate points dropped before thinning


@dataclass(frozen=True)
class PairCounts(_Value):
    """:class:`Counts` of the source and of the target cloud."""

    source: Counts
    target: Counts


def _transform_points(T: np.ndarray, points: ArrayLike) -> np.ndarray:
    a = _as_points(points, "points", finite=False)
    return a @ T[:3, :3].T + T[:3, 3]


@dataclass(frozen=True, repr=False, eq=False)
class Candidate(_Value):
    """One pose kept by a search and refined (coarse if ``refine=False``).
    Plain data: picklable, ``transform`` is read-only."""

    transform: np.ndarray  #: 4x4 T_target_source (read-only)
    scale: float  #: s
    #: G_K of the search, radians in [0, pi], smaller is better (trimmed G_K for
    #: the second search's candidates: the 80 % best-fitting matched cells)
    score: float
    score_contour: float  #: G of the contour representatives, radians
    score_feature: float  #: G of the feature representatives, radians
    rms: float  #: RMS of the final mutual pairs, target units
    overlap: float  #: overlap score in [0, 1]: sqrt(f_s f_t), shares within 2 spacings
    rotation_index: int  #: index into the rotation candidate set
    offset_index: int  #: index into the offset set of its search (see ``search``)
    #: the overlap score within 1 spacing (<= overlap); the winner is the
    #: refined candidate with the highest fit * fit / overlap
    fit: float
    #: how far its refinement went: ``"search"`` (the search's pose),
    #: ``"coarse"`` (the coarse rigid level), ``"stopped"`` (full refinement
    #: stopped short: behind the refined leader, or in another's minimum),
    #: ``"refined"`` (full refinement to its end; only these can win)
    stage: str
    #: 0: the paper's offset grid; 1: the wide second search (run when the
    #: first winner covers neither cloud); 2: a shift of the winner (its
    #: rotation and scale at another translation, docs/design.md §5); 3: a
    #: local-feature match where both clouds are parts (no grid indices:
    #: ``rotation_index`` and ``offset_index`` are 2**32 - 1; its scores are
    #: the paper's G at its start pose); 4: a shift of a candidate at another
    #: rotation, where the winner lies astray; 5: the winner at another scale
    #: and translation, where both clouds are parts (docs/design.md §5)
    search: int

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map (N, 3) source points into the target frame with this pose."""
        return _transform_points(self.transform, points)

    def __repr__(self) -> str:
        return ("Candidate(scale=%.6g, score=%.4g, rms=%.4g, overlap=%.3f, fit=%.3f, "
                "stage=%r, search=%d, rotation_index=%d, offset_index=%d)"
                % (self.scale, self.score, self.rms, self.overlap, self.fit,
                   self.stage, self.search, self.rotation_index, self.offset_index))


@dataclass(frozen=True, repr=False, eq=False)
class Alternative(_Value):
    """Another pose that fits as well as the result's (``Result.ambiguous``):
    the result's aligned source turned by ``angle`` degrees about ``axis``
    through ``center`` (target frame)."""

    transform: np.ndarray  #: 4x4 float64 T_target_source of this pose
    fit: float  #: as ``Candidate.fit``
    overlap: float  #: as ``Candidate.overlap``
    angle: float  #: degrees, (0, 180]
    axis: np.ndarray  #: (3,) unit axis of the turn, target frame
    center: np.ndarray  #: (3,) a point on that axis, target units
    #: the candidate it was refined from, or -1 for a turn found by the
    #: symmetry test
    candidate: int

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map (N, 3) source points into the target frame with this pose."""
        return _transform_points(self.transform, points)

    def __repr__(self) -> str:
        return ("Alternative(angle=%.1f deg, axis=%s, fit=%.3f, candidate=%d)"
                % (self.angle, np.array2string(self.axis, precision=3), self.fit,
                   self.candidate))


@dataclass(frozen=True)
class Symmetry:
    """The symmetry the data shows (``Result.symmetry``): ``kind`` is
    ``"none"``, ``"discrete"`` (a few poses fit: ``Result.alternatives``),
    ``"axial"`` (any turn about ``axis`` fits) or ``"spherical"``."""

    kind: str
    order: int  #: discrete: n of the 360/n-degree turn about axis (0: none)
    axis: Tuple[float, float, float]  #: unit axis (axial, discrete), else zeros
    center: Tuple[float, float, float]  #: a point on the axis, target units


@dataclass(frozen=True, repr=False, eq=False)
class Result(_Value):
    """A registration: ``transform`` maps source points into the target frame,
    ``x_t ~= scale * rotation @ x_s + translation``. Plain data: picklable,
    and its arrays are read-only."""

    transform: np.ndarray  #: 4x4 float64 T_target_source, upper-left 3x3 = s*R
    scale: float  #: s > 0
    rotation: np.ndarray  #: 3x3 R, det +1
    translation: np.ndarray  #: (3,) t, target units
    score: float  #: the winner's G_K, radians (smaller is better; trimmed if from the second search)
    rms: float  #: the winner's RMS residual, target units
    overlap: float  #: the winner's overlap score in [0, 1]
    winner: int  #: index of the winner in ``candidates``
    #: refined candidates (a tuple), best search score first within each
    #: search; the second search's (``search == 1``) follow
    candidates: Tuple[Candidate, ...]
    n_rotations: int  #: rotation candidates searched
    n_offsets: int  #: offset candidates per search
    n_evaluations: int  #: shape measurements computed
    timings: Timings  #: seconds per stage
    counts: PairCounts  #: points kept per pre-processing step
    backend: str  #: 'reference' or 'opencl', the backend actually used
    device: str  #: the device name
    fit: float  #: the winner's overlap score within 1 spacing, by which it won
    #: True if backend 'auto' found no usable device (or none matching the
    #: device string) and ran on the reference backend; ``note`` says why
    fell_back: bool = False
    note: str = ""  #: why ``fell_back`` is set, or ""
    #: EXPERIMENTAL (may change in a minor release): seconds of device
    #: preparation within this call (0 when the device was already open)
    prepare_seconds: float = 0.0
    #: estimated probability in [0, 1] that the pose is right (rotation < 5
    #: deg, translation < 2 % of the diameter, scale < 2 %, or equivalent
    #: under a symmetry of the shape); calibrated on generated pairs
    confidence: float = 0.0
    #: True when other poses fit as well within the fit's noise: the
    #: ``alternatives``, or a continuous symmetry
    ambiguous: bool = False
    alternatives: Tuple[Alternative, ...] = ()  #: best fit first
    symmetry: Symmetry = Symmetry("none", 0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map (N, 3) source points into the target frame: ``s R x + t``."""
        return _transform_points(self.transform, points)

    def __repr__(self) -> str:
        axis_angle = np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1) / 2, -1, 1)))
        return ("Result(scale=%.6g, rotation=%.3f deg, translation=%s, score=%.4g rad, "
                "rms=%.4g, overlap=%.3f, fit=%.3f, confidence=%.3f%s, backend=%r, device=%r%s, "
                "total=%.3f s)"
                % (self.scale, axis_angle, np.array2string(self.translation, precision=4),
                   self.score, self.rms, self.overlap, self.fit, self.confidence,
                   ", ambiguous (%s)" % self.symmetry.kind if self.ambiguous else "",
                   self.backend, self.device,
                   ", fell_back=True" if self.fell_back else "", self.timings.total))


_BACKEND_NAMES = dict(enumerate(_PARAMS["backend"].choices)) if "backend" in _PARAMS else {}
# PKSS_STAGE_REFINED -> "refined": names from the header's enum, not a copy
_STAGE_NAMES = {v: k[len("PKSS_STAGE_"):].lower()
                for v, k in ffi.typeof("pkss_candidate_stage").elements.items()}


def _matrix(cdata: Any, shape: Tuple[int, ...]) -> np.ndarray:
    return np.array(list(cdata), dtype=np.float64).reshape(shape)


def _counts(c: Any) -> Counts:
    return Counts(int(c.input), int(c.nonfinite), int(c.thinned), int(c.after_mutual),
                  int(c.after_stat), int(c.resampled), int(c.features),
                  int(c.duplicates))


def _new_result() -> Any:
    res = ffi.new("pkss_result *")
    # our sizeof: a newer library fills only the fields this binding knows
    lib.pkss_result_init(res, ffi.sizeof("pkss_result"))
    return res


def _candidates(ctx_ptr: Any, n: int) -> List[Candidate]:
    """The candidates of the last registration on ctx (call with its lock
    held, before the next call on it)."""
    out = []
    c = ffi.new("pkss_candidate *")
    for i in range(n):
        lib.pkss_candidate_init(c, ffi.sizeof("pkss_candidate"))
        st = lib.pkss_context_candidate(ctx_ptr, i, c)
        if st:
            _raise(st, _str(lib.pkss_context_last_error(ctx_ptr)) or "pkss_context_candidate(%d)" % i)
        out.append(Candidate(_matrix(c.T_target_source, (4, 4)), float(c.scale), float(c.score),
                             float(c.score_contour), float(c.score_feature), float(c.rms),
                             float(c.overlap), int(c.rotation_index), int(c.offset_index),
                             float(c.fit), _STAGE_NAMES.get(int(c.stage), str(int(c.stage))),
                             int(c.search)))
    return out


_SYMMETRY_NAMES = {v: k[len("PKSS_SYMMETRY_"):].lower()
                   for v, k in ffi.typeof("pkss_symmetry").elements.items()}


def _alternatives(ctx_ptr: Any, n: int) -> List[Alternative]:
    """The alternatives of the last registration on ctx (as _candidates)."""
    out = []
    a = ffi.new("pkss_alternative *")
    for i in range(n):
        lib.pkss_alternative_init(a, ffi.sizeof("pkss_alternative"))
        st = lib.pkss_context_alternative(ctx_ptr, i, a)
        if st:
            _raise(st, _str(lib.pkss_context_last_error(ctx_ptr)) or
                   "pkss_context_alternative(%d)" % i)
        out.append(Alternative(_matrix(a.T_target_source, (4, 4)), float(a.fit),
                               float(a.overlap), float(a.angle_degrees),
                               _matrix(a.axis, (3,)), _matrix(a.center, (3,)),
                               int(a.candidate)))
    return out


def _result(r: Any, candidates: List[Candidate],
            alternatives: Tuple[Alternative, ...] = ()) -> Result:
    t = r.timings
    sym = Symmetry(_SYMMETRY_NAMES.get(int(r.symmetry), str(int(r.symmetry))),
                   int(r.symmetry_order), tuple(float(v) for v in r.symmetry_axis),
                   tuple(float(v) for v in r.symmetry_center))
    return Result(
        transform=_matrix(r.T_target_source, (4, 4)), scale=float(r.scale),
        rotation=_matrix(r.rotation, (3, 3)), translation=_matrix(r.translation, (3,)),
        score=float(r.score), rms=float(r.rms), overlap=float(r.overlap), winner=int(r.winner),
        candidates=tuple(candidates),
        n_rotations=int(r.n_rotations), n_offsets=int(r.n_offsets),
        n_evaluations=int(r.n_evaluations),
        timings=Timings(t.validate, t.preprocess, t.search, t.refine, t.total),
        counts=PairCounts(_counts(r.source_counts), _counts(r.target_counts)),
        backend=_BACKEND_NAMES.get(int(r.backend), str(int(r.backend))), device=_str(r.device),
        fit=float(r.fit), fell_back=bool(r.flags & lib.PKSS_FLAG_FELL_BACK), note=_str(r.note),
        prepare_seconds=float(r.prepare_seconds), confidence=float(r.confidence),
        ambiguous=bool(r.ambiguous), alternatives=tuple(alternatives), symmetry=sym)


# ------------------------------------------------------------------- progress
# One C callback serves every context. It runs on the thread that made the C
# call (pkss.h guarantees it), so the state of that call lives in a
# thread-local: no handle back to the Context (which would keep it alive).
# It is also what makes Ctrl-C work: while C runs without the GIL, SIGINT
# only sets a flag; the callback (every ~20 ms) runs Python code, Python then
# raises KeyboardInterrupt inside it, onerror records it and returns 1, and
# the C call stops with PKSS_ERR_CANCELLED; _call() re-raises it.
_STAGES = {v: k[len("PKSS_PROGRESS_"):].lower()
           for v, k in ffi.typeof("pkss_progress_stage").elements.items()}
_call_state = threading.local()


class _CallState:
    __slots__ = ("progress", "error")

    def __init__(self, progress: Optional[ProgressFn]) -> None:
        self.progress = progress
        self.error: Optional[BaseException] = None


def _progress_error(exc_type: Any, exc_value: Optional[BaseException], tb: Any) -> int:
    state = getattr(_call_state, "state", None)
    if state is not None and state.error is None:
        state.error = exc_value if exc_value is not None else exc_type()
    return 1  # cancel: the exception is re-raised when the C call returns


@ffi.callback("int(void *, const pkss_progress *)", onerror=_progress_error)
def _progress_trampoline(user: Any, p: Any) -> int:
    state = getattr(_call_state, "state", None)
    if state is None or state.progress is None:
        return 0
    go_on = state.progress(_STAGES.get(int(p.stage), str(int(p.stage))), int(p.step),
                           int(p.steps), float(p.elapsed))
    return 1 if go_on is not None and not go_on else 0


def _check_progress(progress: Any) -> Optional[ProgressFn]:
    if progress is not None and not callable(progress):
        raise TypeError("progress must be a callable (stage, step, steps, elapsed) or None, "
                        "got %r" % (progress,))
    return progress


# --------------------------------------------------------------------- input
def _as_points(obj: Any, what: str, finite: bool = True) -> np.ndarray:
    """Any (N, 3) array-like of reals -> C-contiguous float64 (N, 3)."""
    obj = _open3d_points(obj, what, _invalid)  # tensor clouds and tensors: pkss/_convert.py
    if not isinstance(obj, np.ndarray) and hasattr(obj, "points"):
        obj = obj.points  # Open3D PointCloud and similar containers
    if isinstance(obj, np.ma.MaskedArray):
        # np.asarray would silently drop the mask and register the masked
        # values too; which rows to drop is the caller's call, so refuse.
        mask = np.ma.getmaskarray(obj)
        if mask.any():
            rows = int(mask.reshape(mask.shape[0], -1).any(axis=1).sum()) if mask.ndim else 1
            raise _invalid("%s: a masked array with %d masked entries (in %d rows); pkss does "
                           "not drop masked points itself: pass the rows to keep, e.g. "
                           "a[~np.ma.getmaskarray(a).any(axis=1)].data, or a.filled(np.nan) "
                           "with drop_nonfinite=True" % (what, int(mask.sum()), rows))
        obj = obj.data  # nothing masked: the plain values
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
    # a NaN or an infinity makes the sum non-finite, so a finite sum proves
    # every row finite in one pass; a sum that overflows is checked row by row
    if finite and not np.isfinite(np.add.reduce(a, axis=None)):
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
class _Lock:
    """The lock of a Context or Cloud. The thread that holds it taking it
    again can only be a progress callback using the object its own call is
    running on (pkss.h forbids that): raise rather than deadlock."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._owner: Optional[int] = None

    def acquire(self) -> None:
        me = threading.get_ident()
        if self._owner == me:  # only this thread writes its own id here
            raise RuntimeError("pkss: a Context or Cloud cannot be used from the progress "
                               "callback of a call running on it")
        self._lock.acquire()
        self._owner = me

    def release(self) -> None:
        self._owner = None
        self._lock.release()

    def __enter__(self) -> None:
        self.acquire()

    def __exit__(self, *exc: Any) -> None:
        self.release()


class Cloud:
    """A point cloud pre-processed once (validated, thinned, culled,
    resampled, mapped to pre-shape space) by :meth:`Context.prepare_cloud`.

    Register many sources against one prepared template with
    :meth:`Context.register`. A cloud does not depend on the context that
    made it (close either in any order). ``len(cloud)`` is the number of
    resampled points. A cloud holds C data and cannot be pickled.
    """

    def __init__(self, ptr: Any) -> None:
        # Private: use Context.prepare_cloud().
        self._ptr: Any = ffi.gc(ptr, lib.pkss_cloud_destroy)
        self._lock = _Lock()

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

    def __reduce__(self) -> Any:
        # Re-preparing the resampled points would not give the same cloud
        # (pre-processing is lossy), so there is no faithful pickle.
        raise TypeError("pkss.Cloud cannot be pickled; it holds pre-processed C data: pickle "
                        "the input points (or cloud.points) and the Context, and call "
                        "Context.prepare_cloud() again, or use pkss.PreparedCloud, which pickles")

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


def _make_context(params: Dict[str, Any]) -> "Context":
    return Context(**params)  # the unpickler of Context


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
    per thread: every C call releases the GIL. Pickling (and ``copy``) gives
    a new context with the parameters set on this one; the device is opened
    again on first use.

    Parameters
    ----------
    <PARAMETERS>
    """

    def __init__(self, **params: Any) -> None:
        _check_names("Context", params)
        self._ptr: Any = None
        self._lock = _Lock()
        # the values set explicitly (None = default is not kept): what a
        # pickle needs, and whether a device string was asked for
        self._set: Dict[str, Any] = {}
        out = ffi.new("pkss_context **")
        st = lib.pkss_context_create(out)
        if st:
            _raise(st, "pkss_context_create failed")
        self._ptr = ffi.gc(out[0], lib.pkss_context_destroy)
        try:
            self._check(lib.pkss_context_set_progress(self._ptr, _progress_trampoline, ffi.NULL))
            self.set(**params)
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

    def __reduce__(self) -> Any:
        with self._lock:
            self._live()
            return (_make_context, (dict(self._set),))

    def __repr__(self) -> str:
        if self._ptr is None:
            return "<pkss.Context (closed)>"
        return "<pkss.Context backend=%r device=%r>" % (self.params["backend"], self.device_name)

    def _check(self, status: int) -> None:
        """Raise the Error for `status` with this context's detail (call with
        the lock held, before the next call on the context)."""
        if status:
            _raise(status, _str(lib.pkss_context_last_error(self._ptr)))

    def _call(self, fn: Any, *args: Any, progress: Optional[ProgressFn] = None) -> None:
        """Run a C call that may report progress (lock held): a recorded
        exception (KeyboardInterrupt, or one raised by `progress`) wins over
        the PKSS_ERR_CANCELLED it caused."""
        state = _CallState(progress)
        outer = getattr(_call_state, "state", None)
        _call_state.state = state
        try:
            st = fn(*args)
        finally:
            _call_state.state = outer
        if state.error is not None:
            raise state.error
        self._check(st)

    # -- parameters
    def set(self, **params: Any) -> None:
        """Change parameters (the keyword arguments of :func:`register`);
        ``None`` leaves a parameter as it is. Applied in the order given; a
        bad value raises (TypeError for a wrong type, InvalidArgument, also a
        ValueError, for a value out of range) and leaves that parameter and
        the ones after it unchanged.

        Parameters
        ----------
        <PARAMETERS>
        """
        _check_names("Context.set", params)
        with self._lock:
            ptr = self._live()
            for name, value in params.items():
                if value is not None:
                    self._set_one(ptr, _PARAMS[name], value)

    def _set_one(self, ptr: Any, p: Parameter, value: Any) -> None:
        v = _c_value(p, value)
        if isinstance(v, str):
            st = lib.pkss_context_set_string(ptr, p.id, v.encode())
        elif isinstance(v, float):
            st = lib.pkss_context_set_double(ptr, p.id, v)
        else:
            st = lib.pkss_context_set_int(ptr, p.id, v)
        self._check(st)
        self._set[p.name] = v if isinstance(v, str) else value

    def reset(self) -> None:
        """Put every parameter back to its default (and release the device)."""
        with self._lock:
            ptr = self._live()
            self._check(lib.pkss_context_reset(ptr, lib.PKSS_RESET_ALL))
            for p in _PARAMETERS:
                if p.type == "string":
                    self._check(lib.pkss_context_set_string(ptr, p.id, ffi.NULL))
            self._set.clear()

    @property
    def params(self) -> Dict[str, Any]:
        """Every parameter's value in force (defaults resolved), keyed by the
        names of :func:`register`; string parameters (``device``) are None
        unless set."""
        out: Dict[str, Any] = {}
        v = ffi.new("double *")
        with self._lock:
            ptr = self._live()
            for p in _PARAMETERS:
                if p.type == "string":
                    out[p.name] = self._set.get(p.name)
                    continue
                self._check(lib.pkss_context_get_double(ptr, p.id, v))
                out[p.name] = p.to_python(v[0])
        return out

    # -- device
    def prepare(self, *, progress: Optional[ProgressFn] = None) -> None:
        """Open the device and build the kernels now rather than on the first
        registration (to fail early or to time it apart). Raises
        :class:`DeviceError` if the selected backend/device cannot be used.
        `progress` as in :meth:`register`."""
        progress = _check_progress(progress)
        with self._lock:
            ptr = self._live()
            self._call(lib.pkss_context_prepare, ptr, progress=progress)

    @property
    def device_name(self) -> str:
        """The device the context runs on after :meth:`prepare` or a
        registration ("reference (C, CPU)" or an OpenCL device name); ""
        before."""
        with self._lock:
            return _str(lib.pkss_context_device_name(self._live()))

    # -- work
    def prepare_cloud(self, points: ArrayLike, *,
                      progress: Optional[ProgressFn] = None) -> Cloud:
        """Pre-process (N, 3) points once with this context's parameters
        (validation, thinning, outlier culling, resampling, features, PCA) and
        return a :class:`Cloud` for :meth:`register`. `progress` as in
        :meth:`register`."""
        progress = _check_progress(progress)
        with self._lock:
            ptr = self._live()
            return self._cloud(ptr, points, "points", progress)

    def _cloud(self, ptr: Any, points: ArrayLike, what: str,
               progress: Optional[ProgressFn]) -> Cloud:
        a = _as_points(points, what, finite=not self._drop_nonfinite(ptr))
        out = ffi.new("pkss_cloud **")
        self._call(lib.pkss_cloud_create, ptr, _buffer(a), a.shape[0], out, progress=progress)
        return Cloud(out[0])

    def _drop_nonfinite(self, ptr: Any) -> bool:
        v = ffi.new("long long *")
        self._check(lib.pkss_context_get_int(ptr, lib.PKSS_PARAM_DROP_NONFINITE, v))
        return v[0] == lib.PKSS_SWITCH_ON

    def register(self, source: PointsLike, target: PointsLike, *,
                 progress: Optional[ProgressFn] = None) -> Result:
        """Register `source` onto `target` with this context's parameters.

        Each argument is an (N, 3) array-like of real numbers (any dtype,
        layout or a list; an Open3D ``PointCloud`` works too; a masked array
        only if nothing is masked) or a :class:`Cloud` from
        :meth:`prepare_cloud`. Returns a :class:`Result` whose ``transform``
        maps source points into the target frame. Raises
        :class:`InvalidArgument` (a ValueError) for bad input and another
        :class:`Error` subclass if the C library fails; never returns a
        default pose.

        `progress`, if given, is called on this thread as
        ``progress(stage, step, steps, elapsed)`` at each stage change and
        about every 20 ms: `stage` is 'device', 'preprocess', 'search',
        'refine' or 'done', `step` of `steps` (0: unknown) the work done in
        it, `elapsed` the seconds since the call began. Returning False
        stops the call with :class:`Cancelled`; an exception it raises
        stops the call and propagates. Ctrl-C raises ``KeyboardInterrupt``
        within a fraction of a second, with or without `progress`.

        If the registration ran on the reference backend because no device
        was usable, ``Result.fell_back`` is set, and a :class:`DeviceWarning`
        is issued when a device was asked for (``device=`` or
        ``$PKSS_DEVICE``).
        """
        progress = _check_progress(progress)
        res = _new_result()
        with self._lock:
            ptr = self._live()
            if not isinstance(source, Cloud) and not isinstance(target, Cloud):
                finite = not self._drop_nonfinite(ptr)
                s = _as_points(source, "source", finite)
                t = _as_points(target, "target", finite)
                self._call(lib.pkss_register, ptr, _buffer(s), s.shape[0], _buffer(t),
                           t.shape[0], res, progress=progress)
            else:
                temp: List[Cloud] = []
                try:
                    s_cloud = source if isinstance(source, Cloud) else \
                        self._cloud(ptr, source, "source", progress)
                    if s_cloud is not source:
                        temp.append(s_cloud)
                    t_cloud = target if isinstance(target, Cloud) else \
                        self._cloud(ptr, target, "target", progress)
                    if t_cloud is not target:
                        temp.append(t_cloud)
                    with _locked(s_cloud, t_cloud):
                        self._call(lib.pkss_register_clouds, ptr, s_cloud._live(),
                                   t_cloud._live(), res, progress=progress)
                finally:
                    for c in temp:
                        c.close()
            cands = _candidates(ptr, int(res.n_candidates))
            alts = _alternatives(ptr, int(res.n_alternatives))
            asked = self._set.get("device") or os.environ.get("PKSS_DEVICE")
        result = _result(res, cands, alts)
        if result.fell_back and asked:
            # AUTO falling back is by design when nothing was asked for; a
            # device named and not used is worth telling.
            warnings.warn(DeviceWarning("device %r was asked for but not used: %s"
                                        % (asked, result.note)), stacklevel=_stacklevel())
        return result


def _stacklevel() -> int:
    """The warning's stacklevel: the first frame outside this module."""
    f, level = inspect.currentframe(), 0
    while f is not None and f.f_globals.get("__name__") == __name__:
        f, level = f.f_back, level + 1
    return level


Context.__init__.__signature__ = _param_signature(  # type: ignore[attr-defined]
    [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)], [], None)
Context.set.__signature__ = _param_signature(  # type: ignore[attr-defined]
    [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)], [], None)
_fill_param_doc(Context)
_fill_param_doc(Context.set, "        ")


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


def register(source: PointsLike, target: PointsLike, *,
             progress: Optional[ProgressFn] = None, **params: Any) -> Result:
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
        ``drop_nonfinite=True``; a masked array with masked entries raises
        ValueError (select the rows to keep first).
    progress : callable, optional
        ``progress(stage, step, steps, elapsed)``, called on this thread at
        each stage change and about every 20 ms; returning False cancels
        the call (:class:`Cancelled`). See :meth:`Context.register`.
        Ctrl-C raises ``KeyboardInterrupt`` promptly either way.

    <PARAMETERS>

    Returns
    -------
    Result
        ``transform`` (4x4 float64 T_target_source, read-only), ``scale``,
        ``rotation``, ``translation``, ``score`` (radians), ``rms`` (target
        units), ``overlap`` ([0, 1]), ``candidates``, ``timings`` (seconds),
        ``counts``, ``backend``, ``device``, ``fell_back`` and ``note``;
        ``apply(points)`` maps source points into the target frame.

    Raises
    ------
    InvalidArgument
        (also ValueError) wrong shape or dtype, empty input, too few points,
        NaN/Inf, degenerate (collinear/coplanar) input, a parameter out of
        range. ``.detail`` says which.
    TypeError
        An unknown keyword or a parameter of the wrong type.
    Cancelled
        `progress` returned False.
    KeyboardInterrupt
        Ctrl-C during the call.
    DeviceError
        The OpenCL backend was requested and cannot run.
    Error
        Any other failure of the C library (``.status``, ``.name``,
        ``.detail``).

    Warns
    -----
    DeviceWarning
        A device was asked for (``device=`` or ``$PKSS_DEVICE``) but the
        'auto' backend fell back to the reference backend.
    """
    _check_names("register", params)
    progress = _check_progress(progress)
    return _thread_context(params).register(source, target, progress=progress)


register.__signature__ = _param_signature(  # type: ignore[attr-defined]
    [inspect.Parameter("source", inspect.Parameter.POSITIONAL_OR_KEYWORD),
     inspect.Parameter("target", inspect.Parameter.POSITIONAL_OR_KEYWORD)],
    [inspect.Parameter("progress", inspect.Parameter.KEYWORD_ONLY, default=None,
                       annotation=Optional[ProgressFn])], Result)
_fill_param_doc(register)

# register() keeps one Context per thread and reuses it while all parameters
# but the seed stay the same: a fresh context opens the OpenCL device and
# loads the kernel again on its first call, ~0.06 s of a 0.2 s registration
# (measured on the bunny with PoCL). Results do not depend on it: every call
# starts from the parameters (the seed included), and a context keeps no
# other state.
_per_thread = threading.local()
_DEFAULT_SEED = _PARAMS["seed"].default


def _thread_context(params: Dict[str, Any]) -> "Context":
    # the seed changes from call to call in seeded experiments: it is set on
    # the reused context rather than being part of the key
    params = {k: v for k, v in params.items() if v is not None}
    seed = params.pop("seed", None)
    key = tuple(sorted((k, repr(v)) for k, v in params.items()))
    cached = getattr(_per_thread, "context", None)
    if cached is None or cached[0] != key or cached[1].closed:
        ctx = Context(**params)  # raises on bad parameters: nothing cached then
        if cached is not None:
            cached[1].close()
        cached = _per_thread.context = (key, ctx)
    cached[1].set(seed=_DEFAULT_SEED if seed is None else seed)
    return cached[1]


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


from .io import FileError, read_points, write_points  # noqa: E402  (uses the above)
# Many pairs (pkss/batch.py): imported last, it builds on the names above.
from .batch import Match, PairResult, PreparedCloud, identify, register_many  # noqa: E402
__all__ += ["PreparedCloud", "register_many", "identify", "PairResult", "Match"]
