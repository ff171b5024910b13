# SPDX-License-Identifier: MIT
"""``python -m pkss batch MANIFEST --out RESULTS [options]``: many pairs,
nothing lost.

MANIFEST is a CSV file with the columns ``id``, ``source``, ``target`` and
optionally one column per parameter of :func:`pkss.parameters` (an empty
cell keeps the default); relative paths are relative to the manifest's
folder. RESULTS (``.csv`` or ``.parquet``) gets one row per pair: id,
status ("ok" or the error's name), detail, t00..t33 (T_target_source,
row-major), scale, fit, overlap, rms, score, the C timings, the task's
seconds on the worker and the worker.

Rows are made durable as they arrive (CSV: appended and fsync'ed; Parquet:
row-group files in RESULTS.parts/, merged into RESULTS at the end), so a
killed run keeps every finished pair; ``--resume`` skips the ids already
in RESULTS. Without ``--resume`` an existing RESULTS is never touched.

Exit: 0 every pair of this run ok; 1 finished, this run wrote error rows; 2 usage error (bad
option, manifest or parameter); 3 I/O error (manifest or RESULTS); 130
interrupted (Ctrl-C: the finished rows are kept).

Execution: threads in this process by default (``--threads``); ``--workers
N`` a Dask LocalCluster of N worker processes; ``--scheduler ADDR`` an
existing Dask cluster (paths must be readable on every worker).
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Set, Tuple

PROG = "python -m pkss batch"

# Parquet rows are collected and written as one row-group file at most this
# often: one file per pair would make millions of tiny files on big batches,
# and a killed run recomputes at most this much work.
_PARQUET_FLUSH_SECONDS = 2.0
_PARQUET_FLUSH_ROWS = 256
# Plain progress lines (no terminal) at most this often.
_PROGRESS_LINE_SECONDS = 10.0

TIMING_FIELDS = ("validate", "preprocess", "search", "refine", "total")
COLUMNS: Tuple[str, ...] = (
    ("id", "status", "detail")
    + tuple("t%d%d" % (r, c) for r in range(4) for c in range(4))
    + ("scale", "fit", "overlap", "rms", "score")
    + tuple("seconds_" + f for f in TIMING_FIELDS)
    + ("seconds_task", "seconds_read", "backend", "worker"))


class UsageError(Exception):
    pass


class IOFailure(Exception):
    pass


def _say(msg: str) -> None:
    print("%s: %s" % ("pkss batch", msg), file=sys.stderr, flush=True)


# ------------------------------------------------------------------ manifest
def _param_value(p: Any, text: str) -> Any:
    t = text.strip()
    try:
        if p.type == "int":
            return int(t)
        if p.type == "double":
            return float(t)
    except ValueError:
        raise UsageError("parameter %s: %r is not %s" % (
            p.name, text, "an integer" if p.type == "int" else "a number")) from None
    if p.type == "switch":
        low = t.lower()
        if low in ("1", "true", "yes"):
            return True
        if low in ("0", "false", "no"):
            return False
        return low
    return t


def read_manifest(path: Path) -> List[Tuple[str, str, str, Dict[str, Any]]]:
    import pkss

    params = {p.name: p for p in pkss.parameters()}
    try:
        f = open(path, newline="", encoding="utf-8-sig")
    except OSError as e:
        raise IOFailure("cannot open manifest %s: %s" % (path, e.strerror)) from None
    base = path.resolve().parent
    out = []
    seen: Set[str] = set()
    with f:
        reader = csv.DictReader(f)
        cols = reader.fieldnames or []
        missing = [c for c in ("id", "source", "target") if c not in cols]
        if missing:
            raise UsageError("manifest %s: missing column(s) %s (it has: %s)"
                             % (path, ", ".join(missing), ", ".join(cols) or "none"))
        unknown = [c for c in cols if c not in ("id", "source", "target") and c not in params]
        if unknown:
            raise UsageError("manifest %s: unknown column(s) %s; parameter columns are named "
                             "as in pkss.parameters(): %s"
                             % (path, ", ".join(unknown), ", ".join(params)))
        for line, row in enumerate(reader, start=2):
            pid = (row.get("id") or "").strip()
            if not pid:
                raise UsageError("manifest %s line %d: empty id" % (path, line))
            if pid in seen:
                raise UsageError("manifest %s line %d: id %r appears twice" % (path, line, pid))
            seen.add(pid)
            src, tgt = (row.get("source") or "").strip(), (row.get("target") or "").strip()
            if not src or not tgt:
                raise UsageError("manifest %s line %d: empty source or target" % (path, line))
            extra = {k: _param_value(params[k], v) for k, v in row.items()
                     if k in params and v is not None and v.strip() != ""}
            out.append((pid, str(base / src), str(base / tgt), extra))
    return out


# ------------------------------------------------------------------- results
def row_of(r: Any) -> Dict[str, Any]:
    """A PairResult as a RESULTS row."""
    row: Dict[str, Any] = {c: None for c in COLUMNS}
    row.update(id=str(r.id), status=r.status, detail=r.detail, worker=r.worker,
               seconds_task=r.seconds, seconds_read=r.read_seconds)
    res = r.result
    if res is not None:
        for i, v in enumerate(res.transform.reshape(-1)):
            row["t%d%d" % (i // 4, i % 4)] = float(v)
        row.update(scale=res.scale, fit=res.fit, overlap=res.overlap, rms=res.rms,
                   score=res.score, backend=res.backend)
        for f in TIMING_FIELDS:
            row["seconds_" + f] = getattr(res.timings, f)
    return row


class CsvSink:
    """Appends rows, each flushed and fsync'ed before the next."""

    def __init__(self, path: Path, resume: bool) -> None:
        self.path = path
        self.done: Set[str] = set()
        exists = path.exists() and path.stat().st_size > 0
        if exists and resume:
            self._scan()
        try:
            self.f = open(path, "a", newline="", encoding="utf-8")
        except OSError as e:
            raise IOFailure("cannot open %s for appending: %s" % (path, e.strerror)) from None
        self.w = csv.DictWriter(self.f, fieldnames=list(COLUMNS), lineterminator="\n")
        if not exists:
            self.w.writeheader()
            self._sync()

    def _scan(self) -> None:
        with open(self.path, newline="", encoding="utf-8") as f:
            data = f.read()
        if data and not data.endswith("\n"):
            # a row cut by a kill: drop it (its pair runs again), keep the rest
            data = data[:data.rfind("\n") + 1]
            with open(self.path, "r+", encoding="utf-8") as f:
                f.truncate(len(data.encode("utf-8")))
        reader = csv.DictReader(data.splitlines())
        if reader.fieldnames != list(COLUMNS):
            raise IOFailure("%s: not a pkss batch result (its header differs); refusing to "
                            "append to it" % self.path)
        self.done = {row["id"] for row in reader}

    def _sync(self) -> None:
        self.f.flush()
        os.fsync(self.f.fileno())

    def add(self, row: Dict[str, Any]) -> None:
        self.w.writerow(row)
        self._sync()

    def close(self) -> None:
        self._sync()
        self.f.close()


class ParquetSink:
    """Row groups written to RESULTS.parts/ (each file complete or absent:
    written under a temporary name, fsync'ed, renamed), merged into RESULTS
    at the end."""

    def __init__(self, path: Path, resume: bool) -> None:
        try:
            import pyarrow  # noqa: F401
            import pyarrow.parquet  # noqa: F401
        except ImportError:
            raise UsageError("Parquet output needs pyarrow: pip install 'pkss[batch]' "
                             "(or write .csv)") from None
        self.path = path
        self.parts = path.with_name(path.name + ".parts")
        self.rows: List[Dict[str, Any]] = []
        self.last = time.monotonic()
        self.done: Set[str] = set()
        if resume:
            for t in self._tables():
                self.done.update(t.column("id").to_pylist())
        self.parts.mkdir(exist_ok=True)
        self.n = len(list(self.parts.glob("part-*.parquet")))

    def _tables(self) -> List[Any]:
        import pyarrow.parquet as pq

        files = [self.path] if self.path.exists() else []
        if self.parts.exists():
            files += sorted(self.parts.glob("part-*.parquet"))
        out = []
        for f in files:
            try:
                out.append(pq.read_table(f))
            except Exception as e:
                raise IOFailure("%s: cannot read it as Parquet (%s); refusing to touch it"
                                % (f, e)) from None
        return out

    def _schema(self) -> Any:
        import pyarrow as pa

        types = {"id": pa.string(), "status": pa.string(), "detail": pa.string(),
                 "backend": pa.string(), "worker": pa.string()}
        return pa.schema([(c, types.get(c, pa.float64())) for c in COLUMNS])

    def add(self, row: Dict[str, Any]) -> None:
        self.rows.append(row)
        if (len(self.rows) >= _PARQUET_FLUSH_ROWS
                or time.monotonic() - self.last >= _PARQUET_FLUSH_SECONDS):
            self.flush()

    def flush(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.last = time.monotonic()
        if not self.rows:
            return
        table = pa.Table.from_pylist(self.rows, schema=self._schema())
        name = self.parts / ("part-%06d.parquet" % self.n)
        tmp = name.with_suffix(".tmp")
        pq.write_table(table, tmp)
        _fsync_file(tmp)
        os.replace(tmp, name)
        _fsync_dir(self.parts)
        self.n += 1
        self.rows = []

    def close(self) -> None:
        """Flush, then merge RESULTS and the parts into RESULTS."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.flush()
        tables = self._tables()
        if tables:
            merged = pa.concat_tables([t.cast(self._schema()) for t in tables])
            tmp = self.path.with_name(self.path.name + ".tmp")
            pq.write_table(merged, tmp)
            _fsync_file(tmp)
            os.replace(tmp, self.path)
            _fsync_dir(self.path.parent)
        for f in self.parts.glob("part-*.parquet"):
            f.unlink()
        try:
            self.parts.rmdir()
        except OSError:
            pass


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(path: Path) -> None:
    try:
        _fsync_file(path)
    except OSError:
        pass  # not every file system lets a directory be fsync'ed


def read_results(path: Path) -> List[Dict[str, Any]]:
    """The rows of a RESULTS file (CSV or Parquet, parts included)."""
    if path.suffix.lower() == ".parquet":
        sink = ParquetSink.__new__(ParquetSink)
        sink.path, sink.parts = path, path.with_name(path.name + ".parts")
        rows: List[Dict[str, Any]] = []
        for t in sink._tables():
            rows.extend(t.to_pylist())
        return rows
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


# ------------------------------------------------------------------ progress
class Progress:
    def __init__(self, total: int, skipped: int, mode: str) -> None:
        self.total, self.done, self.errors = total, 0, 0
        self.t0 = self.last = time.monotonic()
        self.bar = None
        if mode == "auto":
            mode = "bar" if sys.stderr.isatty() else "lines"
        if mode == "bar":
            try:
                from tqdm import tqdm  # type: ignore

                self.bar = tqdm(total=total, unit="pair", file=sys.stderr, dynamic_ncols=True)
            except ImportError:
                mode = "lines"
        self.mode = mode
        if mode != "none":
            _say("%d pairs to run%s" % (total, ", %d already in RESULTS (skipped)" % skipped
                                        if skipped else ""))

    def update(self, ok: bool) -> None:
        self.done += 1
        self.errors += 0 if ok else 1
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix(errors=self.errors, refresh=False)
        elif (self.mode == "lines" and self.done < self.total
              and time.monotonic() - self.last >= _PROGRESS_LINE_SECONDS):
            self.last = time.monotonic()
            _say(self.line())

    def line(self) -> str:
        dt = time.monotonic() - self.t0
        rate = self.done / dt if dt > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("nan")
        return ("%d/%d done, %d errors, %.2f pairs/s, %.0f s elapsed, ETA %.0f s"
                % (self.done, self.total, self.errors, rate, dt, eta))

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


# ---------------------------------------------------------------- execution
def _executor(args: argparse.Namespace) -> Tuple[Any, List[Any]]:
    """(executor or None, things to close)."""
    if args.scheduler or args.workers:
        try:
            from distributed import Client, LocalCluster  # type: ignore
        except ImportError:
            raise UsageError("--scheduler/--workers need Dask: pip install 'pkss[batch]'") \
                from None
        if args.scheduler:
            client = Client(args.scheduler)
            return client, [client]
        # one thread per worker process: each pkss call already uses up to
        # four threads (pkss.h, THREAD SAFETY)
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=args.threads or 1,
                               processes=True, dashboard_address=None)
        client = Client(cluster)
        return client, [client, cluster]
    if args.threads:
        import concurrent.futures

        ex = concurrent.futures.ThreadPoolExecutor(max_workers=args.threads,
                                                   thread_name_prefix="pkss-batch")
        return ex, [ex]
    return None, []


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("manifest", type=Path, help="CSV: id, source, target[, parameters]")
    ap.add_argument("--out", type=Path, required=True, help="RESULTS (.csv or .parquet)")
    ap.add_argument("--scheduler", metavar="ADDR", help="address of a Dask scheduler")
    ap.add_argument("--workers", type=int, metavar="N",
                    help="a Dask LocalCluster with N worker processes")
    ap.add_argument("--threads", type=int, metavar="N",
                    help="threads (in this process, or per Dask worker with --workers)")
    ap.add_argument("--resume", action="store_true",
                    help="append to RESULTS, skipping the ids it already has")
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="a parameter for every pair (manifest columns override it)")
    ap.add_argument("--progress", choices=("auto", "bar", "lines", "none"), default="auto")
    return ap


def main(argv: Optional[List[str]] = None) -> int:
    """The arguments after ``batch``; returns the exit status."""
    ap = _parser()
    try:
        args = ap.parse_args(argv)
    except SystemExit as e:
        return 0 if e.code == 0 else 2
    try:
        return _run(args)
    except UsageError as e:
        _say("PKSS_ERR_INVALID_ARGUMENT: %s" % e)
        return 2
    except IOFailure as e:
        _say("I/O error: %s" % e)
        return 3


def _run(args: argparse.Namespace) -> int:
    import pkss
    from pkss import batch

    for name, v in (("--workers", args.workers), ("--threads", args.threads)):
        if v is not None and v < 1:
            raise UsageError("%s must be >= 1, got %d" % (name, v))
    if args.scheduler and args.workers:
        raise UsageError("give --scheduler or --workers, not both")
    suffix = args.out.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise UsageError("--out must end in .csv or .parquet, got %r" % args.out.name)
    params = {p.name: p for p in pkss.parameters()}
    common: Dict[str, Any] = {}
    for item in args.param:
        name, sep, value = item.partition("=")
        if not sep or name not in params:
            raise UsageError("--param %r: expected NAME=VALUE with NAME one of %s"
                             % (item, ", ".join(params)))
        common[name] = _param_value(params[name], value)
    tasks = read_manifest(args.manifest)
    checked: Set[Tuple[Any, ...]] = set()
    for pid, _, _, extra in tasks:  # bad values fail now, not as 1000 error rows
        key = tuple(sorted((k, repr(v)) for k, v in extra.items()))
        if key in checked:
            continue
        try:
            pkss.Context(**dict(common, **extra)).close()
        except (TypeError, ValueError) as e:
            raise UsageError("pair %s: %s" % (pid, e)) from None
        checked.add(key)
    out_parts = args.out.with_name(args.out.name + ".parts")
    if not args.resume and (args.out.exists() or out_parts.exists()):
        raise UsageError("%s exists: pass --resume to add the missing pairs to it, or "
                         "choose another --out (it is never overwritten)" % args.out)
    try:
        sink: Any = ParquetSink(args.out, args.resume) if suffix == ".parquet" \
            else CsvSink(args.out, args.resume)
    except OSError as e:
        raise IOFailure("%s: %s" % (args.out, e)) from None
    pending = [t for t in tasks if t[0] not in sink.done]
    progress = Progress(len(pending), len(tasks) - len(pending), args.progress)
    executor, closers = _executor(args)
    written: Set[str] = set(sink.done)
    interrupted = False
    gen = batch.iter_register(pending, executor, **common)
    try:
        for r in gen:
            row = row_of(r)
            if row["id"] in written:  # never twice, whatever the executor did
                continue
            sink.add(row)
            written.add(row["id"])
            progress.update(r.ok)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        try:
            gen.close()
        except KeyboardInterrupt:
            interrupted = True
        progress.close()
        sink.close()
        for c in closers:
            try:
                c.close() if hasattr(c, "close") else c.shutdown()
            except Exception:
                pass
    if interrupted:
        _say("interrupted: %d of %d pairs are in %s; run again with --resume for the rest"
             % (progress.done, len(pending), args.out))
        return 130
    if progress.mode != "none":
        _say("done: " + progress.line())
    return 1 if progress.errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
