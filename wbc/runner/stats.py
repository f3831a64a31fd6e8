"""Summaries of a run's per-cycle values in constant memory.

A run keeps, per task error, support margin and internal force, only what its metrics
report (:func:`wbc.runner.loop.run`): n, Σx, Σx², min, max, max |x| and the last value, so a
soak of any length holds the same few numbers (a list of every cycle's value grew the
process by ~190 B per cycle, 37 % of Talos's 300 MB over 10 simulated minutes at 1 kHz):

    rms = √(Σx² / n)      mean = Σx / n      final = the last value
"""

from __future__ import annotations

import math


class Running:
    """One sequence of floats, seen a value at a time; ``bool(r)``: whether it has any."""

    __slots__ = ("n", "total", "total_sq", "min", "max", "max_abs", "last")

    def __init__(self) -> None:
        self.n = 0
        self.total = self.total_sq = 0.0
        self.min, self.max, self.max_abs = math.inf, -math.inf, 0.0
        self.last = math.nan

    def add(self, x: float) -> None:
        self.n += 1
        self.total += x
        self.total_sq += x * x
        if x < self.min:
            self.min = x
        if x > self.max:
            self.max = x
        if abs(x) > self.max_abs:
            self.max_abs = abs(x)
        self.last = x

    def __bool__(self) -> bool:
        return self.n > 0

    @property
    def mean(self) -> float:
        return self.total / self.n

    def stats(self) -> dict:
        """``{"rms", "max", "final"}`` (the runner's per-task summary; units of the values)."""
        return {"rms": math.sqrt(self.total_sq / self.n), "max": float(self.max), "final": float(self.last)}
