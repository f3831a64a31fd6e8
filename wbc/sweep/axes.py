"""The axes of a sweep spec: how each one's values are given, and what each mode accepts.

    solver.type: [hqp, projection]                         # grid values (or {values: [...]})
    pushes[0].force@direction_deg: {linspace: [0, 315, 8]} # grid, n values from lo to hi (deg)
    environment[0].mu: {range: [0.4, 1.0]}                 # random: uniform (integer: true for whole numbers)
    solver.type: {choices: [hqp, projection]}              # random: one of them, uniformly
    pushes[0].force@magnitude: {bisect: {lo: 0, hi: 800, tol: 10}}   # the largest value that survives

Values are in the units of the key they set (N for a push force, unitless for μ, s for a
duration). ``grid`` takes grid axes only; ``random`` draws the range and choices axes
``samples`` times and crosses each draw with the grid axes; ``bisect`` has exactly one
bisect axis, searched once per point of the grid axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from wbc.validation.schema import boolean, integer, mapping, number, sequence

from ..errors import ConfigError
from . import keypath

MAX_CASES = 1_000_000


@dataclass(frozen=True)
class Axis:
    """One axis: a key path and how its values are chosen (module docstring)."""

    key: str
    kind: str                                  # values | range | choices | bisect
    values: tuple = ()                         # values, choices
    lo: float | None = None                    # range, bisect
    hi: float | None = None
    tol: float | None = None                   # bisect
    integer: bool = False

    @property
    def random(self) -> bool:
        return self.kind in ("range", "choices")

    @property
    def model(self) -> bool:
        return self.key.startswith("model.")

    def probes(self) -> list:
        """Values worth building a case with in a validation: every listed value, or the ends."""
        return list(self.values) if self.values else [self.lo, self.hi]


def check_key(k: str, where: str) -> None:
    """``k`` is a well-formed key path (ConfigError at ``where`` if not)."""
    try:
        keypath.parse(k)
    except ConfigError as exc:
        raise ConfigError(exc.message, key=where) from None
    if k.startswith("model.") and "@" in k:
        raise ConfigError("a model perturbation has no vector components (@...)", key=where)


def parse_axis(key: str, v: Any) -> Axis:
    """The axis ``key: v`` of a spec's ``axes:`` (module docstring); ConfigError at ``axes.<key>``."""
    where = f"axes.{key}"
    check_key(key, where)
    if isinstance(v, list):
        v = {"values": v}
    v = mapping(v, where, allowed={"values", "linspace", "range", "choices", "bisect", "integer"},
                what="a list of values or a mapping with one of values, linspace, range, choices, bisect")
    kinds = [k for k in ("values", "linspace", "range", "choices", "bisect") if k in v]
    if len(kinds) != 1:
        raise ConfigError(f"give exactly one of values, linspace, range, choices, bisect; got {kinds or 'none'}",
                          key=where)
    kind = kinds[0]
    is_int = boolean(v.get("integer", False), f"{where}.integer")
    if is_int and kind not in ("range", "bisect"):
        raise ConfigError("integer: applies to range and bisect axes", key=f"{where}.integer")
    if kind in ("values", "choices"):
        vals = sequence(v[kind], f"{where}.{kind}", min_len=1, what="a non-empty list")
        return Axis(key, kind, tuple(vals))
    if kind == "linspace":
        lin = sequence(v[kind], f"{where}.linspace", min_len=3, max_len=3, what="[lo, hi, n]")
        lo, hi = (number(x, f"{where}.linspace[{i}]") for i, x in enumerate(lin[:2]))
        n = integer(lin[2], f"{where}.linspace[2]", ge=1, le=MAX_CASES)
        vals = [lo] if n == 1 else [lo + (hi - lo) * i / (n - 1) for i in range(n)]
        return Axis(key, "values", tuple(vals))
    if kind == "range":
        rng = sequence(v[kind], f"{where}.range", min_len=2, max_len=2, what="[lo, hi]")
        lo, hi = (number(x, f"{where}.range[{i}]") for i, x in enumerate(rng))
        if not hi >= lo:
            raise ConfigError(f"must have lo <= hi, got [{lo:g}, {hi:g}]", key=f"{where}.range")
        if is_int and not (float(lo).is_integer() and float(hi).is_integer()):
            raise ConfigError("an integer range needs whole-number ends", key=f"{where}.range")
        return Axis(key, "range", (), lo, hi, integer=is_int)
    b = mapping(v["bisect"], f"{where}.bisect", allowed={"lo", "hi", "tol"}, required=("lo", "hi", "tol"))
    lo = number(b["lo"], f"{where}.bisect.lo")
    hi = number(b["hi"], f"{where}.bisect.hi", gt=lo)
    tol = number(b["tol"], f"{where}.bisect.tol", gt=0, unit="units of the axis")
    if is_int and not (lo.is_integer() and hi.is_integer() and tol >= 1):
        raise ConfigError("an integer bisection needs whole-number lo, hi and tol >= 1", key=f"{where}.bisect")
    if (hi - lo) / tol > 2**40:
        raise ConfigError(f"(hi - lo) / tol = {(hi - lo) / tol:.3g}: the search would not end",
                          key=f"{where}.bisect.tol")
    return Axis(key, "bisect", (), lo, hi, tol, is_int)


def check_mode(mode: str, axes: list[Axis]) -> None:
    """The axes suit ``mode`` (module docstring), no key path twice."""
    for a in axes:
        bad = (mode == "grid" and a.kind != "values") or (mode == "random" and a.kind == "bisect") or \
            (mode == "bisect" and a.kind in ("range", "choices"))
        if bad:
            allowed = {"grid": "values, linspace", "random": "values, linspace, range, choices",
                       "bisect": "values, linspace and one bisect"}[mode]
            raise ConfigError(f"a {a.kind} axis does not belong in mode {mode} (its axes: {allowed})",
                              key=f"axes.{a.key}")
    if mode == "bisect" and sum(a.kind == "bisect" for a in axes) != 1:
        raise ConfigError("mode bisect needs exactly one axis {bisect: {lo, hi, tol}}; the others are a grid",
                          key="axes")
    if mode == "random" and not any(a.random for a in axes):
        raise ConfigError("mode random needs at least one range or choices axis", key="axes")
    keys = [keypath.parse(a.key) for a in axes]
    for i, a in enumerate(axes):
        for j in range(i):
            if keys[i] == keys[j]:
                raise ConfigError(f"the same key as axes.{axes[j].key}", key=f"axes.{a.key}")


def grid_size(axes: list[Axis]) -> int:
    """Points of the grid axes."""
    return math.prod(len(a.values) for a in axes if a.kind == "values")


def max_probes(a: Axis) -> int:
    """Most cases one bisection takes: hi, lo, then halvings until the bracket is <= tol."""
    return 2 + max(0, math.ceil(math.log2((a.hi - a.lo) / a.tol)))
