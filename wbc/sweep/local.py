"""The local executor: a pool of worker processes with a watchdog.

``workers`` processes (default: the cores this process may use), each a fresh
``python -m wbc.sweep.local`` (so the caller's own ``__main__`` is never re-imported, as
``multiprocessing``'s spawn would) talking to the parent over two pipes in JSON bytes
(:func:`wbc.jsonable.send` / :func:`~wbc.jsonable.receive`: no pickle), each running
:func:`_serve`: it imports wbc once, then runs the cases it is
sent one at a time (:func:`wbc.sweep.worker.execute`) and keeps its robots loaded between
them. The parent sends a case only to an idle worker, so it knows when each case
started: a case that runs longer than ``timeout`` (s) has its process killed (SIGKILL)
and is recorded as ``timeout``; a process that dies under a case (segfault, abort, out of
memory) makes it ``failed``. Either way a fresh worker takes the slot and the sweep goes
on. Workers exit when the parent closes their pipe, and on Linux also when the parent
dies (``PR_SET_PDEATHSIG``).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as mp_wait

from ..jsonable import receive, send
from .jobs import Job, Outcome, default_workers


def _die_with_parent() -> None:
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)   # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass


def _serve(conn_in: Connection, conn_out: Connection) -> None:
    """A worker process: announce readiness, then run cases until the pipe closes."""
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # Ctrl-C is the parent's to handle
    import wbc.runner.loop  # noqa: F401  (imported before the clock of the first case starts)

    from . import worker

    send(conn_out, ("ready", os.getpid()))
    while True:
        try:
            key, payload = receive(conn_in)
        except (EOFError, OSError):
            return
        res = worker.execute(payload)
        try:
            send(conn_out, ("done", key, res))
        except (BrokenPipeError, OSError):
            return


@dataclass
class _Slot:
    proc: subprocess.Popen
    to_child: Connection
    conn: Connection                  # from the child: results, and EOF when it dies
    ready: bool = False
    job: Job | None = None
    started: float = 0.0


class LocalPool:
    """Executor over local processes (module docstring). ``timeout``: s per case."""

    name = "local"

    def __init__(self, workers: int | None = None, timeout: float = 300.0) -> None:
        self.workers = int(workers or default_workers())
        self.timeout = float(timeout)
        self._queue: deque[Job] = deque()
        self._start_failures = 0
        self._slots = [self._spawn() for _ in range(self.workers)]

    @property
    def capacity(self) -> int:
        """Cases run at once."""
        return self.workers

    def _spawn(self) -> _Slot:
        down_r, down_w = os.pipe()                   # parent -> child
        up_r, up_w = os.pipe()                       # child -> parent
        proc = subprocess.Popen([sys.executable, "-m", "wbc.sweep.local", str(down_r), str(up_w)],
                                pass_fds=(down_r, up_w), stdin=subprocess.DEVNULL, close_fds=True)
        os.close(down_r)
        os.close(up_w)
        return _Slot(proc, Connection(down_w, readable=False), Connection(up_r, writable=False))

    def submit(self, job: Job) -> None:
        """Queue ``job``; it starts when a worker is idle."""
        self._queue.append(job)

    def _dispatch(self) -> None:
        for s in self._slots:
            if s.ready and s.job is None and self._queue:
                s.job = self._queue.popleft()
                s.started = time.perf_counter()
                send(s.to_child, (s.job.key, s.job.payload))

    def _replace(self, i: int) -> None:
        s = self._slots[i]
        if s.proc.poll() is None:
            s.proc.kill()
        s.proc.wait()
        s.conn.close()
        s.to_child.close()
        self._slots[i] = self._spawn()

    def wait(self, timeout: float) -> list[Outcome]:
        """Outcomes of the cases that ended within ``timeout`` s (possibly none)."""
        self._dispatch()
        now = time.perf_counter()
        busy = [s.started + self.timeout - now for s in self._slots if s.job is not None]
        limit = max(0.0, min([timeout, *busy]))
        ready = set(mp_wait([s.conn for s in self._slots], timeout=limit))
        out: list[Outcome] = []
        for i, s in enumerate(list(self._slots)):
            dead = False
            while s.conn in ready and s.conn.poll():
                try:
                    msg = receive(s.conn)
                except (EOFError, OSError):
                    dead = True
                    break
                if msg[0] == "ready":
                    s.ready = True
                elif msg[0] == "done" and s.job is not None and msg[1] == s.job.key:
                    res = msg[2]
                    out.append(Outcome(s.job, res["status"], res["error"], res["metrics"], res["wall_s"]))
                    s.job = None
            if dead:
                code = s.proc.wait()
                if s.job is not None:
                    out.append(Outcome(s.job, "failed", f"worker process died ({_exit_text(code)})", {},
                                       time.perf_counter() - s.started))
                elif not s.ready:
                    self._start_failures += 1
                    if self._start_failures > 3 * self.workers:
                        raise RuntimeError(f"wbc sweep: worker processes exit before they are ready "
                                           f"({_exit_text(code)}); see their error output above")
                self._replace(i)
            elif s.job is not None and time.perf_counter() - s.started > self.timeout:
                out.append(Outcome(s.job, "timeout", f"no result after {self.timeout:g} s: worker killed", {},
                                   time.perf_counter() - s.started))
                self._replace(i)
        self._dispatch()
        return out

    def close(self) -> None:
        """Stop every worker (a case still running is abandoned, not recorded)."""
        for s in self._slots:
            s.to_child.close()                        # an idle worker exits on EOF
            if s.job is not None:
                s.proc.kill()
        deadline = time.perf_counter() + 2.0
        for s in self._slots:
            try:
                s.proc.wait(max(0.0, deadline - time.perf_counter()))
            except subprocess.TimeoutExpired:
                s.proc.kill()
                s.proc.wait()
            s.conn.close()
        self._slots = []


def _exit_text(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"signal {signal.Signals(-code).name}"
        except ValueError:
            return f"signal {-code}"
    return f"exit code {code}"


if __name__ == "__main__":          # a worker: python -m wbc.sweep.local READ_FD WRITE_FD
    _serve(Connection(int(sys.argv[1]), writable=False), Connection(int(sys.argv[2]), readable=False))
