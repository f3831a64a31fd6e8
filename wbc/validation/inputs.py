"""Input checks shared by the task library and the chapter controllers: every bad value
raises :class:`~wbc.errors.TargetError` naming its owner (``"task 'com'"``,
``"ImpedanceControl(hand)"``), the quantity and what was expected."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.errors import TargetError
from wbc.validation.schema import show

_FLOAT = np.dtype(float)


def finite_vector(owner: str, what: str, value, n: int) -> np.ndarray:
    """``value`` as a finite float vector of exactly ``n`` entries.

    A float64 array of shape (n,) whose entries' sum is finite is returned as it is: a sum
    with a NaN or an inf in it is not finite, so its entries are (the tasks' references,
    set every cycle, take this path: one ``tolist`` and a sum instead of numpy's
    conversion, reshape and ``isfinite``). Anything else, or a sum that overflowed, takes
    the full check below."""
    if type(value) is np.ndarray and value.dtype is _FLOAT and value.shape == (n,) \
            and math.isfinite(sum(value.tolist())):
        return value
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise TargetError(f"must be {n} numbers, got {show(value)}", key=what, owner=owner) from None
    if arr.shape != (n,):
        raise TargetError(f"must have shape ({n},), got shape {np.shape(value)}", key=what, owner=owner)
    if not np.isfinite(arr).all():      # the method: np.all's Python wrapper costs more than the test
        raise TargetError(f"contains NaN or inf: {show(arr.tolist())}", key=what, owner=owner)
    return arr


def se3_from(owner: str, what: str, value, current: pin.SE3 | None = None) -> pin.SE3:
    """A placement from a pinocchio SE3, a 4 × 4 homogeneous matrix (finite, with a
    rotation block), or a 3-vector position (m; orientation of ``current``, else identity)."""
    if isinstance(value, pin.SE3):
        return value.copy()
    expected = "must be a pinocchio.SE3, a 4x4 homogeneous matrix or a 3-vector position"
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise TargetError(f"{expected}, got {show(value)}", key=what, owner=owner) from None
    if arr.shape == (4, 4):
        R = arr[:3, :3]
        if not np.all(np.isfinite(arr)) or np.abs(R).max() > 1.0 + 1e-6 or \
                not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise TargetError("rotation block is not a rotation matrix (or not finite)", key=what, owner=owner)
        return pin.SE3(R.copy(), arr[:3, 3].copy())
    if arr.shape == (3,):
        rot = np.eye(3) if current is None else current.rotation.copy()
        return pin.SE3(rot, finite_vector(owner, what, arr, 3))
    raise TargetError(f"{expected}, got shape {arr.shape}", key=what, owner=owner)
