"""Fault injection for the run-time fault tests: QP back-ends that fail on purpose (passed
to ``Controller(backend=...)`` as instances, nothing patched), and a sensor dropout."""

from __future__ import annotations

import time

import numpy as np

from wbc.solvers.backends import DAQP, Backend, QPResult


class FaultyBackend(Backend):
    """daqp with a fault injected into every call (``calls`` counts them): ``"raise"`` (a
    RuntimeError), ``"nan"`` (a NaN answer reported solved), ``"garbage"`` (a finite answer
    far off its rows, reported solved) or ``"slow"`` (daqp's answer after ``delay`` s)."""

    def __init__(self, mode: str, delay: float = 0.05) -> None:
        assert mode in ("raise", "nan", "garbage", "slow")
        self.mode, self.delay, self.calls = mode, delay, 0
        self.name = f"faulty-{mode}"
        self._real = DAQP()

    def solve(self, H, g, C, lo, hi, key=None, feasible: bool = False) -> QPResult:
        self.calls += 1
        if self.mode == "raise":
            raise RuntimeError("injected back-end fault")
        if self.mode == "slow":
            time.sleep(self.delay)
            return self._real.solve(H, g, C, lo, hi, key=key, feasible=feasible)
        z = np.full(H.shape[0], np.nan if self.mode == "nan" else 1e6)
        return QPResult(z, True, "solved (injected)")


class Dropout:
    """A runner ``callback`` that makes the simulator's sensor repeat its last reading for
    ``cycles`` control cycles from the ``start``-th measurement on (``cycles`` None: for
    ever): the simulator keeps moving, the controller sees the same (q, v)."""

    def __init__(self, start: int, cycles: int | None) -> None:
        self.start, self.cycles, self.k = start, cycles, 0
        self.real = None
        self.last = None
        self.repeated = 0

    def __call__(self, t, sim, sol) -> None:
        if self.real is None:           # after the first cycle: read through the dropout from now on
            self.real, sim.measure = sim.measure, self.measure

    def measure(self):
        self.k += 1
        end = np.inf if self.cycles is None else self.start + self.cycles
        if self.last is not None and self.start <= self.k < end:
            self.repeated += 1
        else:
            self.last = self.real()
        return self.last[0].copy(), self.last[1].copy()
