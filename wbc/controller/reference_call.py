"""The torque cycle's reference point x₀ (:func:`~wbc.tasks.contact_regularization.reference_point`)
in a call of two arguments: its arrays held by address in one int64 table, its margin.

``reference_point`` takes ten arguments, eight of them arrays; numba's dispatch unboxes each one
each call (~0.1-0.2 µs an array on this host, two to three times that in the closed loop). The
arrays are the same objects cycle after cycle (the controller's x₀, level 0's joint-acceleration
box, the layout's J_f, ``RobotModel.h``, the unactuated indices, the regularisation's weights), so
:class:`ReferenceCall` holds them and their addresses and builds the table again only when one of
them is another object (``is`` on live objects held here, not ids). :func:`reference_at` calls
``reference_point`` on views of the same memory: the same function on the same numbers, bit for bit.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.tasks.contact_regularization import reference_point
from wbc.tasks.velocity_stack import float_pointer, int_pointer

__all__ = ["ReferenceCall", "reference_at"]

#: the table's slots: sizes, then addresses
_NX, _NV, _NI, _NF, _NU, _X, _IDX, _LO, _HI, _JF, _H, _U, _W, _NJ = range(14)


@nb.njit(cache=True)
def reference_at(at, margin):
    """``reference_point(x, nv, idx, lo, hi, margin, Jf, h, u, w)`` of the arrays at the addresses of
    ``at`` (:meth:`ReferenceCall.table`): x (nx), idx (int64, ni), lo, hi (ni), J_f (nf × its columns, row-major;
    nf = 0: none), h (nv), u (int64, nu), w (nf)."""
    nx, nv, ni, nf = at[_NX], at[_NV], at[_NI], at[_NF]
    x = nb.carray(float_pointer(at[_X]), nx)
    idx = nb.carray(int_pointer(at[_IDX]), ni)
    lo, hi = nb.carray(float_pointer(at[_LO]), ni), nb.carray(float_pointer(at[_HI]), ni)
    Jf = nb.carray(float_pointer(at[_JF]), (nf, at[_NJ]))
    h = nb.carray(float_pointer(at[_H]), nv)
    u = nb.carray(int_pointer(at[_U]), at[_NU])
    w = nb.carray(float_pointer(at[_W]), nf)
    reference_point(x, nv, idx, lo, hi, margin, Jf, h, u, w)


def _address(a: np.ndarray, dtype: type) -> int:
    """The data address of a contiguous 1-d or row-major array of ``dtype``; ValueError else."""
    if not (isinstance(a, np.ndarray) and a.dtype == dtype and a.flags.c_contiguous):
        raise ValueError("an array is not laid out as reference_at reads it")
    return a.__array_interface__["data"][0]


class ReferenceCall:
    """:func:`reference_point` of held arrays through :func:`reference_at` (module docstring)."""

    def __init__(self) -> None:
        #: (x, idx, lo, hi, J_f, h, u, w, nv, the table) of the last call; None: none yet
        self._held: tuple | None = None

    def table(self, x: np.ndarray, nv: int, box: tuple, forces: tuple) -> np.ndarray | None:
        """The int64 table of :func:`reference_at` for these arrays (the held one while each is the same
        object); None where one is not laid out as it reads it (the caller then calls
        ``reference_point`` itself).

        Args:
            x: x₀, written (nx).
            nv: the number of joint accelerations.
            box: (idx, lo, hi), level 0's joint-acceleration bounds (empty arrays: none).
            forces: (J_f, h, u, w) as ``reference_point`` takes them (J_f (0, 0) and w empty: no force).
        """
        idx, lo, hi = box
        Jf, h, u, w = forces
        got = self._held
        if got is not None and got[0] is x and got[1] is idx and got[2] is lo and got[3] is hi and got[4] is Jf \
                and got[5] is h and got[6] is u and got[7] is w and got[8] == nv:
            return got[9]
        try:
            nf = Jf.shape[0]
            if Jf.ndim != 2 or len(h) != nv or len(lo) != len(idx) or len(hi) != len(idx) or len(w) != nf:
                raise ValueError("sizes")
            at = np.array([len(x), nv, len(idx), nf, len(u), _address(x, np.float64), _address(idx, np.int64),
                           _address(lo, np.float64), _address(hi, np.float64), _address(Jf, np.float64),
                           _address(h, np.float64), _address(u, np.int64), _address(w, np.float64),
                           Jf.shape[1]], dtype=np.int64)
        except ValueError:
            self._held = None
            return None
        self._held = (x, idx, lo, hi, Jf, h, u, w, nv, at)
        return at
