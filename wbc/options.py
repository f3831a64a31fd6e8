"""Option records: many settings of one object in one frozen dataclass.

A constructor with many settings takes a record of them, ``options``, and the same fields
given one by one as keywords over it (``Simulator(model, points, env, q0, dt=1e-3)`` or
``Simulator(model, points, env, q0, SimOptions(dt=1e-3))``). :meth:`Options.of` merges the
two; a keyword that is not a field is a TypeError naming it, the owner and the fields. No
function outside the compiled kernels takes more than 8 parameters
(tests/architecture/test_parameter_counts.py).

Imports nothing of wbc: every package may use it.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable
from typing import Any, TypeVar

R = TypeVar("R", bound="Options")


class Options:
    """Base of the option records (each a frozen dataclass)."""

    @classmethod
    def of(cls: type[R], options: R | None, settings: dict[str, Any], owner: str = "") -> R:
        """``options`` (default: the record's defaults) with the keyword ``settings`` put in.

        Args:
            options: a record of this class, or None for its defaults.
            settings: field name -> value, over ``options``.
            owner: what takes the options, for the error message.

        Raises:
            TypeError: a key of ``settings`` is not a field of the record.
        """
        base = options if options is not None else cls()
        if not settings:
            return base
        names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unknown = sorted(set(settings) - names)
        if unknown:
            raise TypeError(f"{owner or cls.__name__}: unknown setting(s) {unknown}: expected {sorted(names)}")
        return dataclasses.replace(base, **settings)  # type: ignore[type-var]


def flat_parameters(fn: Callable[..., Any], record: type[Options] | None) -> dict[str, inspect.Parameter]:
    """``fn``'s parameters (``self`` left out) as a caller may give them one by one: with
    ``record`` (its ``options`` parameter's class), ``options`` and ``**settings`` are replaced
    by the record's fields, keyword parameters with their defaults (what a YAML mapping may
    hold, what ``wbc tasks`` lists).

    Args:
        fn: a function or a constructor (``cls.__init__``).
        record: the class of its ``options`` parameter, or None (its parameters as they are).
    """
    params = {n: p for n, p in inspect.signature(fn).parameters.items() if n != "self"}
    if record is None:
        return params
    out = {n: p for n, p in params.items() if n != "options" and p.kind is not inspect.Parameter.VAR_KEYWORD}
    for f in dataclasses.fields(record):  # type: ignore[arg-type]
        out[f.name] = inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default)
    return out
