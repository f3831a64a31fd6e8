"""Plain data as JSON: numpy scalars and arrays as plain JSON values (:func:`plain`, a
``json.dumps`` ``default`` hook), and a codec that keeps arrays (:func:`encode`, :func:`decode`)
for messages between the package's processes (:func:`send`, :func:`receive`).

Processes exchange JSON bytes, not pickle: a reader only ever builds numbers, strings, lists,
dicts and arrays from them, whatever was written there (nothing in the package unpickles:
``tests/reliability/test_no_eval.py``). The live view's control and drawing processes
(:mod:`wbc.viz.live`, :mod:`wbc.viz.drawing`) and a sweep's worker processes
(:mod:`wbc.sweep.local`) use :func:`send` / :func:`receive`, a
``multiprocessing.connection.Connection``'s ``send_bytes`` / ``recv_bytes``, never its pickling
``send`` / ``recv``.

Encoding: an ``ndarray`` becomes ``{"__nd__": [dtype, shape, flat values]}`` (its dtype
kept: float64 values round-trip exactly through ``repr``); numpy scalars their Python
value; tuples lists; NaN and ±inf JSON's ``NaN``/``Infinity``. Dict keys must be strings
(JSON's), else a TypeError names the key.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np


def plain(o: Any) -> Any:
    """``int``/``float``/``list`` for a numpy integer, floating or array; anything else
    raises ``TypeError`` (json's contract for a ``default`` hook)."""
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not plain data: {type(o).__name__}")


_ND = "__nd__"


def _plain(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return {_ND: [obj.dtype.str, list(obj.shape), obj.ravel().tolist()]}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        out = {}
        for k, v in obj.items():
            if not isinstance(k, str):
                raise TypeError(f"plain data: a dict key must be a string, got {k!r}")
            out[k] = _plain(v)
        return out
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    return obj


def _array(d: dict) -> Any:
    if _ND in d and len(d) == 1:
        dtype, shape, flat = d[_ND]
        return np.array(flat, dtype=np.dtype(dtype)).reshape(shape)
    return d


def encode(obj: Any) -> bytes:
    """``obj`` (dicts with string keys, lists, tuples, numbers, strings, None, arrays) as bytes."""
    return json.dumps(_plain(obj), separators=(",", ":")).encode()


def decode(payload: bytes) -> Any:
    """The value :func:`encode` wrote (tuples come back as lists, arrays as arrays)."""
    return json.loads(payload, object_hook=_array)


def send(conn, obj: Any) -> None:
    """Send ``obj`` (as :func:`encode` takes it) on a ``multiprocessing.connection.Connection``,
    as one length-prefixed message of JSON bytes (``send_bytes``: no pickle)."""
    conn.send_bytes(encode(obj))


def receive(conn) -> Any:
    """The next message :func:`send` sent on ``conn`` (blocks until one arrives; ``EOFError``
    when the other end has closed)."""
    return decode(conn.recv_bytes())
