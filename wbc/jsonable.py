"""numpy scalars and arrays as plain JSON values (``json.dumps(..., default=plain)``)."""

from __future__ import annotations

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
