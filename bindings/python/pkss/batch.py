# SPDX-License-Identifier: MIT
"""Many pairs: :func:`register_many`, :func:`identify` and :class:`PreparedCloud`.

* :class:`PreparedCloud` -- a cloud pre-processed once, with the parameters
  it was prepared under; it pickles as its serialised bytes
  (``pkss_cloud_serialize``), so a template library can be cached on disk
  or shipped to workers without preparing it again.
* :func:`register_many` -- pairs (or sources x templates) through threads
  in this process (default), any ``concurrent.futures.Executor``, or a
  ``dask.distributed.Client``. Each template is prepared once per worker
  process (cached by content hash and preparation parameters); inputs given
  as paths are read on the worker.
* :func:`identify` -- which of several templates a source shows, and in
  what pose (``pkss_register_templates``: ranked by fit, then overlap).

Results are bit for bit those of :func:`pkss.register` with the same
parameters on the same backend: a restored cloud registers exactly like the
cloud it was serialised from.
"""
from __future__ import annotations

import collections
import concurrent.futures
import hashlib
import os
import socket
import threading
import time
from dataclasses import dataclass
from typing import Any, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import Cloud, Context, Error, Result, _as_points, _check_names, _locked, _raise, \
    _result, _str, _thread_context
from ._lib import ffi, lib

__all__ = ["PreparedCloud", "PairResult", "Match", "register_many", "identify",
           "PREP_PARAMS"]

#: The parameters that pre-processing reads: a cloud prepared under other
#: values of these is rejected when restored (PKSS_ERR_STALE_DATA).
PREP_PARAMS: Tuple[str, ...] = ("points", "cull_mutual", "cull_stat", "use_features",
                                "feature_frac", "seed", "max_raw_points", "drop_nonfinite",
                                "min_points")

# Prepared templates kept per process (serialised bytes, ~50 B per point):
# 256 templates of the default 3000 points are ~40 MB, more than the largest
# template library a batch has used so far; least recently used go first.
_TEMPLATE_CACHE_SIZE = 256

PointsSource = Union[str, os.PathLike, np.ndarray, "PreparedCloud", Any]


# ------------------------------------------------------------------ reading
def _read(path: Union[str, os.PathLike]) -> np.ndarray:
    """Points of a file, (N, 3) float64, through the library's readers
    (pkss.read_points: every format pkss-align reads)."""
    from .io import read_points
    return read_points(os.fspath(path))


def _prep_subset(params: Dict[str, Any]) -> Dict[str, Any]:
    return {k: params[k] for k in PREP_PARAMS if params.get(k) is not None}


def _restore(data: bytes, params: Dict[str, Any]) -> "PreparedCloud":
    return PreparedCloud.from_bytes(data, **params)


class PreparedCloud:
    """A cloud pre-processed once, with the parameters it was prepared
    under (those of :data:`PREP_PARAMS` that were set).

    ``PreparedCloud.prepare(points, **params)`` pre-processes an (N, 3)
    array (or a path); :meth:`to_bytes` / :meth:`from_bytes` serialise it
    (a pickle is those bytes); :attr:`cloud` is the :class:`pkss.Cloud` to
    register with. The bytes are portable between machines but tied to one
    library version: restoring bytes of another version, or under other
    preparation parameters, raises :class:`pkss.Error` (``PKSS_ERR_STALE_DATA``);
    damaged bytes raise ``PKSS_ERR_CORRUPT_DATA``.
    """

    def __init__(self, cloud: Cloud, params: Dict[str, Any]) -> None:
        # Private: use prepare() or from_bytes().
        self.cloud = cloud
        self.params: Dict[str, Any] = dict(params)
        self._bytes: Optional[bytes] = None

    @classmethod
    def prepare(cls, xyz: PointsSource, /, **params: Any) -> "PreparedCloud":
        """Pre-process `xyz` (an (N, 3) array-like or a file path) with
        `params` (the keyword arguments of :func:`pkss.register`)."""
        _check_names("PreparedCloud.prepare", params)
        if isinstance(xyz, (str, os.PathLike)):
            xyz = _read(xyz)
        prep = _prep_subset(params)
        with Context(**prep) as ctx:
            return cls(ctx.prepare_cloud(xyz), prep)

    @classmethod
    def from_bytes(cls, data: Union[bytes, bytearray, memoryview], /, **params: Any) -> "PreparedCloud":
        """Restore the bytes of :meth:`to_bytes`. `params` must hold the
        preparation parameters it was prepared under (what :attr:`params`
        held); other parameters are ignored."""
        _check_names("PreparedCloud.from_bytes", params)
        prep = _prep_subset(params)
        buf = bytes(data)
        with Context(**prep) as ctx:
            out = ffi.new("pkss_cloud **")
            with ctx._lock:
                ptr = ctx._live()
                ctx._check(lib.pkss_cloud_deserialize(ptr, buf, len(buf), out))
        pc = cls(Cloud(out[0]), prep)
        pc._bytes = buf
        return pc

    def to_bytes(self) -> bytes:
        """The serialised cloud (``pkss_cloud_serialize``)."""
        if self._bytes is None:
            need = ffi.new("size_t *")
            with self.cloud._lock:
                ptr = self.cloud._live()
                st = lib.pkss_cloud_serialize(ptr, ffi.NULL, 0, need)
                if st:
                    _raise(st, "pkss_cloud_serialize")
                buf = ffi.new("unsigned char[]", need[0])
                st = lib.pkss_cloud_serialize(ptr, buf, need[0], need)
                if st:
                    _raise(st, "pkss_cloud_serialize")
            self._bytes = bytes(ffi.buffer(buf, need[0]))
        return self._bytes

    @property
    def content_hash(self) -> str:
        """SHA-256 of the serialised bytes (hex)."""
        return hashlib.sha256(self.to_bytes()).hexdigest()

    def __reduce__(self) -> Any:
        return (_restore, (self.to_bytes(), dict(self.params)))

    def __len__(self) -> int:
        return len(self.cloud)

    def __repr__(self) -> str:
        return "<pkss.PreparedCloud of %d points, %s>" % (
            len(self.cloud), ", ".join("%s=%r" % kv for kv in sorted(self.params.items()))
            or "default parameters")


# The per-process template cache: key -> serialised bytes (prepared once per
# process), and per thread the clouds restored from them (a cloud must not
# be used by two threads at once; restoring only rebuilds two kd-trees).
_cache_lock = threading.Lock()
_prepared: "collections.OrderedDict[Tuple[Any, ...], bytes]" = collections.OrderedDict()
_inflight: Dict[Tuple[Any, ...], threading.Event] = {}
_per_thread = threading.local()
_stats = {"prepared": 0, "restored": 0}


# File hashes by (path, size, mtime, inode): a template file is hashed once
# per process, not once per pair, unless it changes.
_file_hashes: Dict[Tuple[Any, ...], str] = {}


def _content_key(obj: Any) -> Tuple[str, ...]:
    """A key for a template's content: file bytes, array values or the
    prepared cloud's bytes (hashed)."""
    if isinstance(obj, PreparedCloud):
        return ("prepared", obj.content_hash)
    if isinstance(obj, (str, os.PathLike)):
        st = os.stat(obj)
        stamp = (os.path.abspath(obj), st.st_size, st.st_mtime_ns, st.st_ino)
        digest = _file_hashes.get(stamp)
        if digest is None:
            h = hashlib.sha256()
            with open(obj, "rb") as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
            digest = _file_hashes[stamp] = h.hexdigest()
        return ("file", digest)
    a = _as_points(obj, "template", finite=False)
    return ("array", hashlib.sha256(a.tobytes()).hexdigest() + str(a.shape))


def _template_bytes(obj: Any, ctx: Context, key: Tuple[Any, ...]) -> bytes:
    """The template's prepared bytes, preparing it at most once per process
    (other threads asking for it meanwhile wait)."""
    while True:
        with _cache_lock:
            if key in _prepared:
                _prepared.move_to_end(key)
                return _prepared[key]
            ev = _inflight.get(key)
            if ev is None:
                ev = _inflight[key] = threading.Event()
                break
        ev.wait()
    try:
        if isinstance(obj, PreparedCloud):
            data = obj.to_bytes()
        else:
            pts = _read(obj) if isinstance(obj, (str, os.PathLike)) else obj
            data = PreparedCloud(ctx.prepare_cloud(pts, progress=None), {}).to_bytes()
            _stats["prepared"] += 1
        with _cache_lock:
            _prepared[key] = data
            while len(_prepared) > _TEMPLATE_CACHE_SIZE:
                _prepared.popitem(last=False)
        return data
    finally:
        with _cache_lock:
            _inflight.pop(key, None)
        ev.set()


def _template_cloud(obj: Any, ctx: Context, prep: Dict[str, Any]) -> Cloud:
    """This thread's cloud of the template, under ctx's preparation
    parameters `prep` (resolved values)."""
    key = _content_key(obj) + tuple(sorted((k, repr(v)) for k, v in prep.items()))
    clouds = getattr(_per_thread, "clouds", None)
    if clouds is None:
        clouds = _per_thread.clouds = collections.OrderedDict()
    c = clouds.get(key)
    if c is not None and not c.closed:
        clouds.move_to_end(key)
        return c
    data = _template_bytes(obj, ctx, key)
    out = ffi.new("pkss_cloud **")
    with ctx._lock:
        ptr = ctx._live()
        ctx._check(lib.pkss_cloud_deserialize(ptr, data, len(data), out))
    c = clouds[key] = Cloud(out[0])
    _stats["restored"] += 1
    while len(clouds) > _TEMPLATE_CACHE_SIZE:
        clouds.popitem(last=False)[1].close()
    return c


def _resolved_prep(ctx: Context) -> Dict[str, Any]:
    p = ctx.params
    return {k: p[k] for k in PREP_PARAMS}


# ------------------------------------------------------------------ one pair
@dataclass(frozen=True)
class PairResult:
    """One pair's outcome. ``status`` is "ok" or the error's name (a
    ``PKSS_ERR_*`` status, e.g. ``PKSS_ERR_FORMAT`` or ``PKSS_ERR_IO`` for a
    file the reader refused, ``READ_ERROR`` for another OS error, or the
    exception's class name); ``detail`` the message; ``result`` the
    :class:`pkss.Result` (None on error); ``worker`` where it ran;
    ``seconds`` the task's wall time on the worker (reading included),
    ``read_seconds`` the share spent reading files."""

    id: Any
    status: str
    detail: str
    result: Optional[Result]
    worker: str
    seconds: float
    read_seconds: float

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def _worker_name() -> str:
    try:
        from distributed import get_worker  # type: ignore
        return get_worker().address
    except Exception:
        return "%s:%d:%s" % (socket.gethostname(), os.getpid(), threading.current_thread().name)


def _trace(pair_id: Any) -> None:
    # Diagnostic: $PKSS_BATCH_TRACE names a file that gets one line per pair
    # computed (how often each id ran: retries, resumed batches).
    path = os.environ.get("PKSS_BATCH_TRACE")
    if path:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, ("%s\n" % (pair_id,)).encode())
        finally:
            os.close(fd)


def _run_pair(pair_id: Any, source: PointsSource, target: PointsSource,
              params: Dict[str, Any]) -> PairResult:
    """The task: read what is a path, register, never raise for bad input."""
    t0 = time.perf_counter()
    read_s = 0.0
    worker = _worker_name()
    _trace(pair_id)
    try:
        ctx = _thread_context(params)
        if isinstance(source, (str, os.PathLike)):
            tr = time.perf_counter()
            try:
                source = _read(source)
            finally:
                read_s += time.perf_counter() - tr
        src = source.cloud if isinstance(source, PreparedCloud) else source
        tr = time.perf_counter()
        try:
            tgt = _template_cloud(target, ctx, _resolved_prep(ctx))
        finally:
            if isinstance(target, (str, os.PathLike)):
                read_s += time.perf_counter() - tr
        res = ctx.register(src, tgt)
        return PairResult(pair_id, "ok", "", res, worker, time.perf_counter() - t0, read_s)
    except Error as e:
        status, detail = e.name, e.detail or str(e)
    except (OSError, ValueError) as e:
        status, detail = "READ_ERROR", str(e)
    except (KeyboardInterrupt, SystemExit, MemoryError):
        raise
    except Exception as e:  # a bug or an unexpected input type: the batch goes on
        status, detail = type(e).__name__, str(e)
    return PairResult(pair_id, status, detail, None, worker, time.perf_counter() - t0, read_s)


# ----------------------------------------------------------------- execution
def _is_dask(executor: Any) -> bool:
    return type(executor).__module__.split(".")[0] == "distributed"


def _pairs_from(pairs: Optional[Iterable[Any]], sources: Optional[Sequence[Any]],
                templates: Optional[Sequence[Any]]) -> List[Tuple[Any, Any, Any, Dict[str, Any]]]:
    """(id, source, target, per-pair params) tuples."""
    out: List[Tuple[Any, Any, Any, Dict[str, Any]]] = []
    if pairs is not None:
        if sources is not None or templates is not None:
            raise TypeError("register_many: give pairs, or sources and templates, not both")
        for i, p in enumerate(pairs):
            if isinstance(p, dict):
                extra = {k: v for k, v in p.items() if k not in ("id", "source", "target")}
                _check_names("register_many (pair %r)" % p.get("id", i), extra)
                out.append((p.get("id", i), p["source"], p["target"], extra))
            else:
                s, t = p
                out.append((i, s, t, {}))
    elif sources is not None and templates is not None:
        for i, s in enumerate(sources):
            for j, t in enumerate(templates):
                out.append(((i, j), s, t, {}))
    else:
        raise TypeError("register_many: give pairs, or sources and templates")
    ids = [p[0] for p in out]
    if len(set(map(repr, ids))) != len(ids):
        raise ValueError("register_many: pair ids are not unique")
    return out


def _submit_all(executor: Any, tasks: List[Tuple[Any, Any, Any, Dict[str, Any]]],
                params: Dict[str, Any]) -> List[Any]:
    dask = _is_dask(executor)
    scattered: Dict[int, Any] = {}

    def ship(obj: Any, broadcast: bool) -> Any:
        # Arrays and prepared clouds go to the cluster once each (templates
        # to every worker), not once per task; paths travel as strings and
        # are read on the worker.
        if not dask or isinstance(obj, (str, os.PathLike)):
            return obj
        if id(obj) not in scattered:
            scattered[id(obj)] = executor.scatter(obj, broadcast=broadcast, hash=False)
        return scattered[id(obj)]

    futures = []
    for pid, s, t, extra in tasks:
        merged = dict(params)
        merged.update(extra)
        args = (pid, ship(s, False), ship(t, True), merged)
        if dask:
            futures.append(executor.submit(_run_pair, *args, pure=False,
                                           key="pkss-pair-%s-%s" % (pid, os.urandom(4).hex())))
        else:
            futures.append(executor.submit(_run_pair, *args))
    return futures


def _as_completed(executor: Any, futures: List[Any]) -> Iterator[Any]:
    if _is_dask(executor):
        from distributed import as_completed  # type: ignore
        return iter(as_completed(futures))
    return concurrent.futures.as_completed(futures)


def _outcome(pid: Any, fut: Any) -> PairResult:
    """A finished future's PairResult; a task that failed as a whole (a
    worker killed too often, an unpicklable input) becomes an error row."""
    try:
        return fut.result()
    except (KeyboardInterrupt, SystemExit):
        raise
    except Exception as e:
        return PairResult(pid, type(e).__name__, str(e), None, "", 0.0, 0.0)


def iter_register(tasks: List[Tuple[Any, Any, Any, Dict[str, Any]]], executor: Any = None,
                  **params: Any) -> Iterator[PairResult]:
    """Yields each task's :class:`PairResult` as it finishes (any order).
    `tasks` are (id, source, target, per-pair params) tuples. Closing the
    generator (or Ctrl-C while iterating) cancels what has not started."""
    own = executor is None
    if own:
        executor = concurrent.futures.ThreadPoolExecutor(
            max_workers=os.cpu_count() or 1, thread_name_prefix="pkss-batch")
    futures = _submit_all(executor, tasks, params)
    ids = {id(f): t[0] for f, t in zip(futures, tasks)}
    try:
        for fut in _as_completed(executor, futures):
            yield _outcome(ids[id(fut)], fut)
    finally:
        for f in futures:
            f.cancel()
        if own:
            executor.shutdown(wait=True, cancel_futures=True)


def register_many(pairs: Optional[Iterable[Any]] = None, *,
                  sources: Optional[Sequence[PointsSource]] = None,
                  templates: Optional[Sequence[PointsSource]] = None,
                  executor: Any = None, **params: Any) -> List[PairResult]:
    """Register many pairs; returns one :class:`PairResult` per pair, in
    input order (errors are rows with ``status != "ok"``, never raised).

    `pairs` is an iterable of ``(source, target)`` tuples (ids 0, 1, ...) or
    of dicts ``{"id", "source", "target", <parameter>: value ...}``;
    alternatively `sources` and `templates` give every source against every
    template (ids ``(i, j)``). Each cloud is an (N, 3) array, a file path
    (read on the worker) or a :class:`PreparedCloud`. Targets are prepared
    once per worker process and reused.

    `executor`: None (threads in this process: the C calls release the
    GIL), any ``concurrent.futures.Executor``, or a
    ``dask.distributed.Client`` (arrays are scattered to the workers once;
    paths must be readable on every worker). `params` are those of
    :func:`pkss.register`; a pair's own parameters override them.
    """
    _check_names("register_many", params)
    tasks = _pairs_from(pairs, sources, templates)
    order = {repr(t[0]): i for i, t in enumerate(tasks)}
    out: List[Optional[PairResult]] = [None] * len(tasks)
    for r in iter_register(tasks, executor, **params):
        out[order[repr(r.id)]] = r
    return [r for r in out if r is not None]


# ------------------------------------------------------------------ identify
@dataclass(frozen=True)
class Match:
    """One template's place in :func:`identify`'s ranking: ``rank`` (0 =
    best), ``index`` into the templates given, ``status``/``detail`` as in
    :class:`PairResult`, and ``result`` (its pose, fit and overlap; None if
    the template could not be registered)."""

    rank: int
    index: int
    status: str
    detail: str
    result: Optional[Result]

    @property
    def transform(self) -> Optional[np.ndarray]:
        return None if self.result is None else self.result.transform


def identify(source: PointsSource, templates: Sequence[PointsSource],
             **params: Any) -> List[Match]:
    """Which template does `source` show, and in what pose? Registers the
    source (prepared once) against every template in one C call
    (``pkss_register_templates``) and returns a :class:`Match` per template,
    best first: by fit, then overlap (templates that failed come last).
    Each result equals ``pkss.register(source, template, **params)`` bit
    for bit. Templates are arrays, paths or :class:`PreparedCloud`; they
    are prepared once per process and cached."""
    _check_names("identify", params)
    if len(templates) == 0:
        raise ValueError("identify: no templates given")
    ctx = _thread_context(params)
    prep = _resolved_prep(ctx)
    if isinstance(source, (str, os.PathLike)):
        source = _read(source)
    temp: List[Cloud] = []
    if isinstance(source, PreparedCloud):
        src = source.cloud
    else:
        src = ctx.prepare_cloud(source)
        temp.append(src)
    try:
        clouds = [_template_cloud(t, ctx, prep) for t in templates]
        n = len(clouds)
        results = ffi.new("pkss_result[]", n)
        for i in range(n):
            lib.pkss_result_init(results + i, ffi.sizeof("pkss_result"))
        status = ffi.new("pkss_status[]", n)
        order = ffi.new("size_t[]", n)
        ptrs = ffi.new("pkss_cloud *[]", [c._live() for c in clouds])
        with ctx._lock, _locked(src, *clouds):
            ptr = ctx._live()
            ctx._call(lib.pkss_register_templates, ptr, src._live(), ptrs, n, results,
                      status, order)
            detail = _str(lib.pkss_context_last_error(ptr))
    finally:
        for c in temp:
            c.close()
    out = []
    for rank in range(n):
        i = int(order[rank])
        st = int(status[i])
        if st == 0:
            out.append(Match(rank, i, "ok", "", _result(results[i], [])))
        else:
            name = _str(lib.pkss_status_name(st))
            mine = "template %d: " % i
            out.append(Match(rank, i, name, detail[len(mine):] if detail.startswith(mine)
                             else _str(lib.pkss_status_string(st)), None))
    return out
