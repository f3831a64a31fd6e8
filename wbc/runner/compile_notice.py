"""A visible notice while numba compiles the numerical kernels on a first run.

The kernels (``wbc/solvers/kernels/``, the task rows) are compiled on their first
call and cached on disk; a first run spends ~15 s there with nothing on screen. This
prints a line when loading takes longer than ``delay`` seconds (a cached load takes well
under one), and how long it took when it is done.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import TextIO


class CompileNotice:
    """``start()`` before the first kernels are needed, ``stop()`` after the first control
    cycle: if more than ``delay`` s (default 1.0) pass in between, the notice is written to
    ``stream`` (stderr) and, at ``stop()``, the time it took."""

    MESSAGE = "compiling numerical kernels (first run only, ~15 s; cached for later runs) ..."

    def __init__(self, enabled: bool = True, delay: float = 1.0, stream: TextIO | None = None) -> None:
        self.enabled = enabled
        self.delay = delay
        self.stream = stream if stream is not None else sys.stderr
        self.shown = False
        self._timer: threading.Timer | None = None
        self._t0 = 0.0

    def _show(self) -> None:
        self.shown = True
        self.stream.write(f"wbc: {self.MESSAGE}\n")
        self.stream.flush()

    def start(self) -> None:
        """Arm the notice (no effect when disabled)."""
        self._t0 = time.perf_counter()
        if self.enabled:
            self._timer = threading.Timer(self.delay, self._show)
            self._timer.daemon = True
            self._timer.start()

    def stop(self) -> float:
        """Disarm it; returns the seconds since :meth:`start`."""
        elapsed = time.perf_counter() - self._t0
        if self._timer is not None:
            self._timer.cancel()
            self._timer.join()
            self._timer = None
        if self.shown:
            self.stream.write(f"wbc: kernels ready after {elapsed:.1f} s\n")
            self.stream.flush()
        return elapsed
