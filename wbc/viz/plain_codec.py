"""Plain data across the live view's process boundary: JSON, with numpy arrays tagged.

The control process writes each snapshot into a shared-memory slot that the drawing process
reads (:mod:`wbc.viz.shared_state`), and the two exchange messages on a socket pair (the scene's
description, the page's commands: :func:`send` and :func:`receive`, a
``multiprocessing.connection.Connection``'s ``send_bytes`` / ``recv_bytes``, never its pickling
``send`` / ``recv``). The bytes are JSON, not pickle: a reader only ever builds numbers,
strings, lists, dicts and arrays from them, whatever was written there (nothing in the package
unpickles: ``tests/reliability/test_no_eval.py``).

Encoding: an ``ndarray`` becomes ``{"__nd__": [dtype, shape, flat values]}`` (its dtype
kept: float64 values round-trip exactly through ``repr``); numpy scalars their Python
value; tuples lists; NaN and ±inf JSON's ``NaN``/``Infinity``. Dict keys must be strings
(JSON's), else a TypeError names the key.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

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
                raise TypeError(f"live view snapshot: a dict key must be a string, got {k!r}")
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
