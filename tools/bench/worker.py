# SPDX-License-Identifier: MIT
"""One persistent worker process per method, so that a hanging or crashing
peer cannot stall or kill the run: a call that exceeds the time limit gets
its worker killed (recorded as a failure with status 'timeout'), and the
next call starts a fresh worker. Calls run one at a time (no two methods
compete for the cores while being timed)."""
from __future__ import annotations

import multiprocessing as mp
import time
import traceback


def _worker_main(conn, method):
    import methods
    fn = methods.METHODS[method]
    while True:
        try:
            msg = conn.recv()
        except EOFError:
            return
        if msg is None:
            return
        if msg == "probe":
            conn.send(methods.available(method))
            continue
        src, tgt, seed = msg
        t0 = time.perf_counter()
        try:
            T, info = fn(src, tgt, seed)
            dt = time.perf_counter() - t0
            conn.send(("ok", T, dt, info, ""))
        except Exception as e:
            dt = time.perf_counter() - t0
            conn.send(("error", None, dt, {}, f"{type(e).__name__}: {e}\n"
                       + traceback.format_exc(limit=3)))


class MethodWorker:
    def __init__(self, method, timeout):
        self.method = method
        self.timeout = timeout
        self.ctx = mp.get_context("spawn")
        self.proc = None
        self.conn = None

    def _start(self):
        parent, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_worker_main, args=(child, self.method),
                                     daemon=True)
        self.proc.start()
        child.close()
        self.conn = parent

    def probe(self):
        """(ok, message): can the method be imported in its worker?"""
        if self.proc is None or not self.proc.is_alive():
            self._start()
        try:
            self.conn.send("probe")
            if self.conn.poll(max(self.timeout, 120)):
                return self.conn.recv()
            self.kill()
            return False, "probe timed out"
        except (EOFError, BrokenPipeError, ConnectionResetError, OSError) as e:
            self.kill()
            return False, f"worker died during import ({type(e).__name__})"

    def warmup(self, src, tgt):
        """One untimed call so imports and first-call costs are not timed."""
        return self.call(src, tgt, 0)

    def call(self, src, tgt, seed):
        """-> (status, T or None, seconds, info, message)"""
        if self.proc is None or not self.proc.is_alive():
            self._start()
        t0 = time.perf_counter()
        try:
            self.conn.send((src, tgt, seed))
            if self.conn.poll(self.timeout):
                return self.conn.recv()
            self.kill()
            return ("timeout", None, time.perf_counter() - t0, {},
                    f"killed after {self.timeout:.0f} s")
        except (EOFError, BrokenPipeError, ConnectionResetError, OSError) as e:
            code = self.proc.exitcode if self.proc is not None else None
            self.kill()
            return ("crash", None, time.perf_counter() - t0, {},
                    f"worker died ({type(e).__name__}, exit code {code})")

    def kill(self):
        if self.proc is not None:
            if self.proc.is_alive():
                self.proc.kill()  # this worker only, by its own handle
            self.proc.join(5)
        self.proc = None
        self.conn = None

    def close(self):
        if self.proc is not None and self.proc.is_alive():
            try:
                self.conn.send(None)
                self.proc.join(5)
            except Exception:
                pass
        self.kill()
