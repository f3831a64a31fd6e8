"""Summaries of a run's per-cycle values in constant memory.

A run keeps, per task error, support margin and internal force, only what its metrics
report (:func:`wbc.runner.loop.run`): n, Σx, Σx², min, max, max |x| and the last value, so a
soak of any length holds the same few numbers (a list of every cycle's value grew the
process by ~190 B per cycle, 37 % of Talos's 300 MB over 10 simulated minutes at 1 kHz):

    rms = √(Σx² / n)      mean = Σx / n      final = the last value
"""

from __future__ import annotations

import math

import numba as nb


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


#: the columns of a table of running figures (:class:`RunningRow`): n, Σx, Σx², min, max, max |x|, last
N, TOTAL, TOTAL_SQ, MIN, MAX, MAX_ABS, LAST = range(7)


@nb.njit(cache=True)
def add_value(table, r, x):
    """:meth:`Running.add` of ``x`` on row ``r`` of ``table`` (:class:`RunningRow`'s columns): the
    same float operations in the same order, so the same bits."""
    table[r, N] += 1.0
    table[r, TOTAL] += x
    table[r, TOTAL_SQ] += x * x
    if x < table[r, MIN]:
        table[r, MIN] = x
    if x > table[r, MAX]:
        table[r, MAX] = x
    if abs(x) > table[r, MAX_ABS]:
        table[r, MAX_ABS] = abs(x)
    table[r, LAST] = x


class RunningRow:
    """A :class:`Running` kept in row ``r`` of a float64 table (columns :data:`N` ... :data:`LAST`)
    that compiled code updates (:func:`add_value`); the same reads as :class:`Running`.

    Args:
        table: the table (rows × 7), its row ``r`` set to the empty figures here.
        r: the row.
    """

    __slots__ = ("table", "r")

    def __init__(self, table, r: int) -> None:
        self.table, self.r = table, r
        table[r] = (0.0, 0.0, 0.0, math.inf, -math.inf, 0.0, math.nan)

    def add(self, x: float) -> None:
        """:meth:`Running.add` of ``x``: :func:`add_value` on the row."""
        add_value(self.table, self.r, float(x))

    def _get(self, c: int) -> float:
        return float(self.table[self.r, c])

    n = property(lambda self: int(self.table[self.r, N]))
    total = property(lambda self: self._get(TOTAL))
    total_sq = property(lambda self: self._get(TOTAL_SQ))
    min = property(lambda self: self._get(MIN))
    max = property(lambda self: self._get(MAX))
    max_abs = property(lambda self: self._get(MAX_ABS))
    last = property(lambda self: self._get(LAST))

    def __bool__(self) -> bool:
        return self.n > 0

    @property
    def mean(self) -> float:
        return self.total / self.n

    def stats(self) -> dict:
        """``{"rms", "max", "final"}``, as :meth:`Running.stats`."""
        return {"rms": math.sqrt(self.total_sq / self.n), "max": self.max, "final": self.last}
