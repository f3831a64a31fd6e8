"""Per-group bisection: the largest value of one axis that survives, to a tolerance.

One :class:`Bisection` per point of the grid axes (a *group*: e.g. one push direction
with one solver). Its probes follow from its own results only: ``hi`` first (survived:
the limit is at least ``hi``, done), then ``lo`` (not survived: the limit is below
``lo``, done), then midpoints of the bracket [lo, hi) until ``hi - lo <= tol``. The
sequence of probed values is a pure function of the survival outcomes, so the search is
deterministic and the same whichever executor runs the cases, in whatever order groups
finish; the probes of one group run one after the other, groups in parallel.

The search assumes survival is monotone along the axis (survives at x ⇒ survives below
x); where it is not, it returns one boundary between a survived and a failed value.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .axes import Axis


@dataclass
class Bisection:
    """Bisection state of one group along ``axis`` (module docstring)."""

    axis: Axis
    lo: float = 0.0
    hi: float = 0.0
    phase: str = "hi"                                   # hi, lo, mid, done
    probes: list[tuple[float, bool]] = field(default_factory=list)   # (value, survived), in order
    outcome: str = ""                                   # bracketed | at_least_hi | below_lo

    def __post_init__(self) -> None:
        assert self.axis.lo is not None and self.axis.hi is not None, "a bisect axis has lo and hi"
        self.lo, self.hi = self._num(self.axis.lo), self._num(self.axis.hi)

    def _num(self, x: float) -> float | int:
        return int(x) if self.axis.integer else float(x)

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def next_value(self) -> float | int | None:
        """The value to probe next, or None when the search is over."""
        if self.phase == "hi":
            return self.hi
        if self.phase == "lo":
            return self.lo
        if self.phase == "mid":
            return (self.lo + self.hi) // 2 if self.axis.integer else 0.5 * (self.lo + self.hi)
        return None

    def record(self, value: float | int, survived: bool) -> None:
        """The outcome of probing ``value`` (which must be :meth:`next_value`)."""
        expected = self.next_value()
        if value != expected:
            raise ValueError(f"bisection expected a probe at {expected}, got {value}")
        self.probes.append((value, bool(survived)))
        if self.phase == "hi":
            self.phase, self.outcome = ("done", "at_least_hi") if survived else ("lo", "")
        elif self.phase == "lo":
            self.phase, self.outcome = ("done", "below_lo") if not survived else ("mid", "")
        elif survived:
            self.lo = value
        else:
            self.hi = value
        if self.phase == "mid" and not self._open():
            self.phase, self.outcome = "done", "bracketed"

    def _open(self) -> bool:
        assert self.axis.tol is not None, "a bisect axis has tol"
        if self.axis.integer:
            return self.hi - self.lo > max(1, self.axis.tol) and (self.lo + self.hi) // 2 not in (self.lo, self.hi)
        return self.hi - self.lo > self.axis.tol

    @property
    def limit(self) -> float | int | None:
        """Largest value found to survive (``hi`` when ``hi`` survived), None if ``lo`` did not."""
        if self.outcome == "below_lo":
            return None
        if self.outcome == "at_least_hi":
            return self.hi
        return self.lo if self.done else None

    def describe(self) -> str:
        """The result in words: ``'>= 800'``, ``'< 0'``, ``'312.5 (fails at 325)'``."""
        if self.outcome == "at_least_hi":
            return f">= {self.hi:g} (survived the upper bound)"
        if self.outcome == "below_lo":
            return f"< {self.lo:g} (failed at the lower bound)"
        if self.done:
            return f"{self.lo:g} (fails at {self.hi:g})"
        return f"searching in [{self.lo:g}, {self.hi:g})"
