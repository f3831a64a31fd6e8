"""x₀'s compiled call with its arrays held by address (:mod:`wbc.controller.reference_call`): the same
x₀ as ``reference_point`` of the arrays, bit for bit, and the table built again when an array is
replaced by another object (a held address of a replaced array would read the old values)."""

from __future__ import annotations

import numpy as np

from wbc.controller.reference_call import ReferenceCall, reference_at
from wbc.tasks.contact_regularization import reference_point


def _arrays(rng, nv=12, nf=6, ni=5):
    idx = np.sort(rng.choice(nv, ni, replace=False)).astype(np.int64)
    lo = rng.uniform(-2.0, 1.0, ni)
    hi = lo + rng.uniform(0.01, 3.0, ni)
    Jf = rng.standard_normal((nf, nv))
    h = rng.standard_normal(nv)
    u = np.arange(6, dtype=np.int64)
    w = rng.uniform(0.5, 2.0, nf)
    return idx, lo, hi, Jf, h, u, w


def _expected(nv, nx, args):
    idx, lo, hi, Jf, h, u, w = args
    x = np.zeros(nx)
    reference_point(x, nv, idx, lo, hi, 0.01, Jf, h, u, w)
    return x


def test_the_held_call_gives_reference_points_bits_and_follows_replaced_arrays():
    rng = np.random.default_rng(3)
    nv, nf = 12, 6
    call, x = ReferenceCall(), np.zeros(nv + nf)
    args = list(_arrays(rng, nv, nf))
    first = None
    for k in range(8):
        if k:                                      # one array replaced by a new object each cycle
            j = k % 7
            args[j] = _arrays(rng, nv, nf)[j]
        x[:] = 0.0
        at = call.table(x, nv, tuple(args[:3]), tuple(args[3:]))
        assert at is not None
        first = at if first is None else first
        reference_at(at, 0.01)
        assert np.array_equal(x.view(np.int64), _expected(nv, len(x), args).view(np.int64)), k
    # the same objects: the same table; no force (J_f (0, 0)) and no box: x₀ = 0
    assert call.table(x, nv, tuple(args[:3]), tuple(args[3:])) is call.table(x, nv, tuple(args[:3]), tuple(args[3:]))
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))
    x[:] = 1.0
    at = call.table(x, nv, empty, (np.zeros((0, 0)), args[4], args[5], np.zeros(0)))
    reference_at(at, 0.01)
    assert np.array_equal(x, np.ones(len(x)))      # nothing to write: x as it was (reference_point's)
    assert call.table(x, nv, (args[0].astype(np.int32), args[1], args[2]), tuple(args[3:])) is None
