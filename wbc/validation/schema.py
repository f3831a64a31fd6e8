"""Checks of plain data (a YAML document's values, a constructor's arguments).

Each check returns the value converted (a float, an int, a numpy vector) or raises an error
of the class asked for (:class:`~wbc.errors.ConfigError` by default) carrying the key path
of the bad value and a message "must be <what was expected>, got <what was found>";
a caller one level up places it under its own key path (:func:`wbc.errors.placed`).

Numbers are Python or numpy ints and floats, never booleans (YAML's ``yes``/``on`` are
booleans) nor text (PyYAML reads ``1e-3`` as text: the message says so). Found values
are shown shortened (:func:`show`), whatever their size or depth.
"""

from __future__ import annotations

import difflib
import math
import reprlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wbc.errors import ConfigError, WbcError

_repr = reprlib.Repr()
_repr.maxlevel, _repr.maxlist, _repr.maxtuple, _repr.maxdict = 3, 8, 8, 6
_repr.maxstring, _repr.maxother, _repr.maxlong = 60, 60, 40


def show(value: Any) -> str:
    """A short, bounded ``repr`` of a found value (at most a few dozen characters per item)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    try:
        return _repr.repr(value)
    except Exception:        # a value whose repr fails: its type is still worth naming
        return f"<{type(value).__name__}>"


def found(value: Any) -> str:
    """What was found, for a message: the value shortened, and its kind where the value alone
    could mislead (text that looks like a number, a boolean, null)."""
    if value is None:
        return "null (no value)"
    if isinstance(value, (bool, np.bool_)):
        return f"{bool(value)} (a boolean)"
    if isinstance(value, str):
        try:
            looks_numeric = math.isfinite(float(value.replace("_", "")))
        except ValueError:
            looks_numeric = False
        if looks_numeric:
            return (f"{show(value)} (text: PyYAML reads {show(value)[1:-1]} as text; write a number with a decimal "
                    "point and a signed exponent, e.g. 1.0e-3)")
        return f"{show(value)} (text)"
    if isinstance(value, (list, tuple, dict)):
        return show(value)
    return f"{show(value)} ({type(value).__name__})" if not is_number(value) else show(value)


def suggest(word: Any, choices: Iterable[str]) -> str:
    """``" (did you mean 'dt'?)"`` for a near miss of one of ``choices``, else ``""``."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def is_file(path: Path) -> bool:
    """``path.is_file()``, False where the OS refuses the name itself (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def is_number(value: Any) -> bool:
    """An int or float (Python or numpy), not a boolean."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _bounds_text(gt, ge, lt, le) -> str:
    lo = f"({gt:g}" if gt is not None else (f"[{ge:g}" if ge is not None else None)
    hi = f"{lt:g})" if lt is not None else (f"{le:g}]" if le is not None else None)
    if lo and hi:
        return f" in {lo}, {hi}"
    if lo:
        return f" > {gt:g}" if gt is not None else f" >= {ge:g}"
    if hi:
        return f" < {lt:g}" if lt is not None else f" <= {le:g}"
    return ""


#: the keyword bounds of :func:`number` and :func:`vector`
BOUNDS = ("gt", "ge", "lt", "le", "allow_inf")


_BOUND_SET = frozenset(BOUNDS)
_UNBOUNDED = (None, None, None, None, False)


def _bounds(bounds: dict[str, Any]) -> tuple[Any, Any, Any, Any, bool]:
    """(gt, ge, lt, le, allow_inf) of a ``**bounds`` (absent: None, None, None, None, False)."""
    if not bounds:
        return _UNBOUNDED
    if not _BOUND_SET.issuperset(bounds):
        raise TypeError(f"unknown bound(s) {sorted(bounds.keys() - _BOUND_SET)}: expected one of {list(BOUNDS)}")
    get = bounds.get
    return get("gt"), get("ge"), get("lt"), get("le"), bool(get("allow_inf", False))


def number(value: Any, key: str | None = None, *, unit: str = "", error: type[WbcError] = ConfigError,
           owner: str | None = None, what: str = "a number", **bounds: Any) -> float:
    """``value`` as a float: a finite number (``allow_inf``: or ±inf) within the bounds
    (``gt`` < value, ``ge`` <= value, value < ``lt``, value <= ``le``); ``unit`` for the
    message (``"s"``, ``"1/s²"``).

    Args:
        value: what to check.
        key: its key path, for the message.
        unit: its unit, for the message.
        error: the error class raised.
        owner: what it belongs to, for the message.
        what: what is expected, for the message.
        **bounds: :data:`BOUNDS` by name: ``gt``, ``ge``, ``lt``, ``le`` (float or None) and
            ``allow_inf`` (bool, default False); another name is a TypeError.
    """
    limits = _bounds(bounds)
    gt, ge, lt, le, _ = limits
    expected = what + _bounds_text(gt, ge, lt, le) + (f" ({unit})" if unit else "")
    return _checked(value, key, expected, limits, (error, owner))


def _checked(value: Any, key: str | None, expected: str, limits: tuple, raised: tuple) -> float:
    """:func:`number`'s check, its message's ``expected`` text and (gt, ge, lt, le,
    allow_inf) worked out by the caller (once for a whole :func:`vector`); ``raised`` =
    (the error class, the owner)."""
    gt, ge, lt, le, allow_inf = limits
    error, owner = raised

    def bad(found: str) -> WbcError:
        return error(f"must be {expected}, got {found}", key=key, owner=owner)

    if not is_number(value):
        raise bad(found(value))
    try:
        x = float(value)
    except OverflowError:
        raise bad("a number too large for a float") from None
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        raise bad(show(x))
    if (gt is not None and not x > gt) or (ge is not None and not x >= ge) or \
            (lt is not None and not x < lt) or (le is not None and not x <= le):
        raise bad(show(value))
    return x


def integer(value: Any, key: str | None = None, *, ge: int | None = None, le: int | None = None,
            error: type[WbcError] = ConfigError, owner: str | None = None, unit: str = "") -> int:
    """``value`` as an int (an integral float such as ``2.0`` is accepted) within [ge, le]."""
    expected = "an integer" + _bounds_text(None, ge, None, le) + (f" ({unit})" if unit else "")
    if not is_number(value) or (isinstance(value, (float, np.floating)) and not float(value).is_integer()):
        raise error(f"must be {expected}, got {found(value)}", key=key, owner=owner)
    n = int(value)
    if (ge is not None and n < ge) or (le is not None and n > le):
        raise error(f"must be {expected}, got {show(value)}", key=key, owner=owner)
    return n


def boolean(value: Any, key: str | None = None, *, error: type[WbcError] = ConfigError,
            owner: str | None = None) -> bool:
    """``value`` as a bool: only ``true``/``false`` (not 0/1, not text)."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"must be true or false, got {found(value)}", key=key, owner=owner)
    return bool(value)


def text(value: Any, key: str | None = None, *, choices: Sequence[str] | None = None,
         error: type[WbcError] = ConfigError, owner: str | None = None, what: str = "a name") -> str:
    """``value`` as a non-empty string, one of ``choices`` when given (with a did-you-mean)."""
    if choices is not None:
        if not isinstance(value, str) or value not in choices:
            hint = suggest(value, choices) if isinstance(value, str) else ""
            raise error(f"must be one of {list(choices)}, got {show(value)}{hint}", key=key, owner=owner)
        return value
    if not isinstance(value, str) or not value.strip():
        raise error(f"must be {what} (non-empty text), got {found(value)}", key=key, owner=owner)
    return value


def sequence(value: Any, key: str | None = None, *, min_len: int = 0, max_len: int | None = None,
             error: type[WbcError] = ConfigError, owner: str | None = None, what: str = "a list") -> list:
    """``value`` as a list (a YAML sequence) of ``min_len`` to ``max_len`` items."""
    if not isinstance(value, (list, tuple)):
        raise error(f"must be {what}, got {found(value)}", key=key, owner=owner)
    if len(value) < min_len or (max_len is not None and len(value) > max_len):
        span = f"{min_len}" if max_len == min_len else (f"{min_len} to {max_len}" if max_len else f"at least {min_len}")
        raise error(f"must be {what} of {span} items, got {len(value)}: {show(value)}", key=key, owner=owner)
    return list(value)


def vector(value: Any, key: str | None = None, n: int | Sequence[int] | None = None, *, unit: str = "",
           max_len: int = 100_000, error: type[WbcError] = ConfigError, owner: str | None = None,
           **bounds: Any) -> np.ndarray:
    """``value`` as a float vector: a list (or numpy array) of ``n`` numbers (any of the
    lengths if ``n`` is a sequence, any length >= 1 if None), each checked by :func:`number`
    under ``key[i]`` (``unit``, ``error``, ``owner`` and the ``bounds`` as :func:`number`'s);
    at most ``max_len`` of them."""
    limits = _bounds(bounds)
    gt, ge, lt, le, _ = limits
    lengths = (n,) if isinstance(n, int) else (tuple(n) if n is not None else None)
    count = " or ".join(str(k) for k in lengths) if lengths else "1 or more"
    what = f"a list of {count} number{'s' if lengths != (1,) else ''}" + _bounds_text(gt, ge, lt, le) + \
        (f" ({unit})" if unit else "")
    if isinstance(value, np.ndarray):
        if value.ndim != 1 or not (np.issubdtype(value.dtype, np.number) and value.dtype != np.bool_):
            raise error(f"must be {what}, got an array of shape {value.shape} ({value.dtype})", key=key, owner=owner)
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise error(f"must be {what}, got {found(value)}", key=key, owner=owner)
    if (lengths and len(value) not in lengths) or not value or len(value) > max_len:
        raise error(f"must be {what}, got {len(value)}: {show(value)}", key=key, owner=owner)
    out = np.empty(len(value))
    expected = "a number" + _bounds_text(gt, ge, lt, le) + (f" ({unit})" if unit else "")   # as number()'s
    raised = (error, owner)
    for i, v in enumerate(value):
        sub = f"{key}[{i}]" if key else f"[{i}]"
        out[i] = _checked(v, sub, expected, limits, raised)
    return out


def matrix(value: Any, key: str | None = None, shape: tuple[int | None, int | None] = (None, None), *,
           unit: str = "", error: type[WbcError] = ConfigError, owner: str | None = None) -> np.ndarray:
    """``value`` as a 2-D float array of ``shape`` (None: any size >= 1), given as a list of
    rows (or a 2-D numpy array); every entry finite."""
    rows, cols = shape
    what = f"a {rows or 'n'} x {cols or 'm'} matrix (a list of rows)" + (f" ({unit})" if unit else "")
    if isinstance(value, np.ndarray):
        if value.ndim != 2:
            raise error(f"must be {what}, got an array of shape {value.shape}", key=key, owner=owner)
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or not value or (rows is not None and len(value) != rows):
        raise error(f"must be {what}, got {show(value)}", key=key, owner=owner)
    first = value[0]
    width = cols if cols is not None else (len(first) if isinstance(first, (list, tuple)) and first else 1)
    out = np.empty((len(value), width))
    for i, row in enumerate(value):
        out[i] = vector(row, f"{key}[{i}]" if key else f"[{i}]", width, unit=unit, error=error, owner=owner)
    return out


def mapping(value: Any, key: str | None = None, *, allowed: Iterable[str] | None = None,
            required: Iterable[str] = (), error: type[WbcError] = ConfigError, owner: str | None = None,
            what: str = "a mapping") -> dict:
    """``value`` as a dict with text keys: unknown keys (not in ``allowed``) refused with a
    did-you-mean, ``required`` keys present. ``None`` (an empty YAML value) is ``{}``."""
    if value is None:
        value = {}
    if not isinstance(value, dict):
        raise error(f"must be {what} (key: value), got {found(value)}", key=key, owner=owner)
    allowed = None if allowed is None else sorted(allowed)
    for k in value:
        name = k if not isinstance(k, str) or len(k) <= 60 else f"{k[:40]}…({len(k)} characters)"
        sub = f"{key}.{name}" if key else str(name)
        if not isinstance(k, str):
            raise error(f"keys must be text, got {show(k)}", key=sub, owner=owner)
        if allowed is not None and k not in allowed:
            raise error(f"unknown key{suggest(k, allowed)}; expected one of {allowed}", key=sub, owner=owner)
    for k in required:
        if k not in value:
            raise error("missing (required)", key=f"{key}.{k}" if key else k, owner=owner)
    return value
