"""The distance phase's compiled pieces around coal (:meth:`wbc.collision.model.CollisionModel.distance_rows`).

Each replaces a run of small numpy calls (~1-3 µs each at this machine's load) by one call, and computes what
the numpy code computed, operation for operation (the same products and sums in the same order, no fused
multiply-add), so the rows are the same bits (``tests/collision/test_row_kernels.py`` compares them):

- :func:`moved_bound`: the broad phase's bound d₀ − Σ_cycles Σⱼ wₖⱼ |δⱼ| and the pairs it keeps
  (:meth:`CollisionModel._near`; summed joint by joint into the accumulated motion, not in BLAS's order: a
  bound, the rows do not depend on its last bits);
- :func:`near_rows`: from coal's results of the computed pairs ([d, n, p₁] per pair, :mod:`.result_table`), the
  bound's new references d₀, the pairs within the influence distance, their witness points p₁, p₂ = p₁ + d n,
  normals, and each side's coefficients [n_s; p_s × n_s] (n₁ = −n, n₂ = n) of J_d = Σ_s [n_s; p_s × n_s]ᵀ J_j(s);
- :func:`toggles`: which pairs a pass must activate and deactivate (most are the last pass's);
- :func:`broad_phase` and :func:`held_near_rows`: the cycle's path (:meth:`CollisionModel._near`), one call on each
  side of coal: |δ|, the bound and the toggles before; the rows read from the held table of every pair after (no
  gathered copy of the computed pairs' rows); the same arithmetic as the pieces above;
- :func:`masked_pair_sum`: each side's (coefficients @ ``data.J``) row masked by its joint's supporting chain, the
  two sides summed (the product itself stays one BLAS call: its bits are numpy's).

Units: m, m/s.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def moved_bound(weights_t, step, moved, d0, influence, add, near):
    """Accumulate the joints' motion ``step`` (nv, |pin.difference|) into ``moved`` (pairs,) as
    ``moved += weightsᵀ step`` when ``add`` (``weights_t``: the (nv × pairs) transpose of the weights, so that the
    inner loop runs over the pairs, contiguous), and write into ``near`` the pairs whose bound d₀ − moved is below
    ``influence`` (m; a NaN bound, an infinite weight times a zero step, counts as −∞); returns how many."""
    return _bound(weights_t, step, False, moved, d0, influence, add, near)


@nb.njit(cache=True)
def _bound(weights_t, step, take_abs, moved, d0, influence, add, near):
    """:func:`moved_bound`, on |``step``| when ``take_abs``."""
    nv, npairs = weights_t.shape
    if add:
        for j in range(nv):
            sj = abs(step[j]) if take_abs else step[j]
            for k in range(npairs):
                moved[k] += weights_t[j, k] * sj
    n = 0
    for k in range(npairs):
        b = d0[k] - moved[k]
        if math.isnan(b) or b < influence:
            near[n] = k
            n += 1
    return n


@nb.njit(cache=True)
def broad_phase(weights_t, spans, diff, moved, d0, influence, add, near, active, on, off):
    """One call before coal: :func:`moved_bound` on the joints' motion |``diff``| (``diff``: the last
    ``pin.difference``, its absolute value taken here), joint j's sum over the pairs ``spans[j, 0]`` to
    ``spans[j, 1]`` − 1 only (:func:`weight_spans`: its weights are 0 outside, and moved + 0 |δⱼ| is moved, so the same
    bits with ~40 % fewer terms on Talos), then :func:`toggles` of the kept pairs ``near[:n]`` against
    ``active``, in the same pass over the pairs (the kept pairs come in increasing order, so the switches are those
    :func:`toggles` gives, in its order, without its (pairs,) scratch). Returns (n kept, how many to activate into
    ``on``, how many to deactivate into ``off``)."""
    nv, npairs = weights_t.shape
    if add:
        for j in range(nv):
            sj = abs(diff[j])
            lo, hi = spans[j, 0], spans[j, 1]
            mj = moved[lo:hi]                   # views from 0: indices known ≥ 0, so the loop is vectorised
            wj = weights_t[j, lo:hi]
            for k in range(hi - lo):
                mj[k] += wj[k] * sj
    n = 0
    n_on = 0
    n_off = 0
    for k in range(npairs):
        b = d0[k] - moved[k]
        if math.isnan(b) or b < influence:
            near[n] = k
            n += 1
            if not active[k]:
                on[n_on] = k
                n_on += 1
                active[k] = True
        elif active[k]:
            off[n_off] = k
            n_off += 1
            active[k] = False
    return n, n_on, n_off


@nb.njit(cache=True)
def near_rows(table, near, influence, d0, moved, pairs, joint_of):
    """The rows of the computed pairs ``near`` (c,) whose distance is below ``influence`` (m).

    ``table`` (c × 7): coal's [d, n, p₁] of each computed pair, in the order of ``near``. Updates the broad phase's
    references (``d0[k]`` = d, ``moved[k]`` = 0 for every computed pair). Returns (ks (m,), d (m,), P (2m × 3) the
    witness points [p₁; p₂], NN (2m × 3) the sides' normals [−n; n], coef (2m × 6) [n_s; p_s × n_s], jid (2m,)
    each side's joint, geoms (2m,) each side's geometry), first sides then second sides."""
    return _near_rows(table, False, near, influence, d0, moved, pairs, joint_of)


@nb.njit(cache=True)
def held_near_rows(table, near, influence, d0, moved, pairs, joint_of):
    """:func:`near_rows` reading the held table of every pair (:mod:`.result_table`; ``table`` (pairs × 7), pair k's
    row k) at the pairs ``near``: the same rows, without first gathering the computed pairs' rows into an array."""
    return _near_rows(table, True, near, influence, d0, moved, pairs, joint_of)


@nb.njit(cache=True)
def _near_rows(table, by_pair, near, influence, d0, moved, pairs, joint_of):
    """:func:`near_rows`, the computed pair ``near[i]``'s row of ``table`` being ``table[near[i]]`` when ``by_pair``,
    else ``table[i]``."""
    c = len(near)
    m = 0
    for i in range(c):
        k = near[i]
        t = k if by_pair else i
        d0[k] = table[t, 0]
        moved[k] = 0.0
        if table[t, 0] < influence:
            m += 1
    ks = np.empty(m, dtype=np.int64)
    d = np.empty(m)
    P = np.empty((2 * m, 3))
    NN = np.empty((2 * m, 3))
    coef = np.empty((2 * m, 6))
    jid = np.empty(2 * m, dtype=np.int64)
    geoms = np.empty(2 * m, dtype=np.int64)
    r = 0
    for i in range(c):
        k = near[i]
        t = k if by_pair else i
        di = table[t, 0]
        if not di < influence:
            continue
        ks[r] = k
        d[r] = di
        for a in range(3):
            n = table[t, 1 + a]
            p = table[t, 4 + a]
            P[r, a] = p
            P[m + r, a] = p + di * n
            NN[r, a] = -n
            NN[m + r, a] = n
        for s in (r, m + r):
            geoms[s] = pairs[k, 0] if s == r else pairs[k, 1]
            jid[s] = joint_of[geoms[s]]
            a0, a1, a2 = P[s, 0], P[s, 1], P[s, 2]
            b0, b1, b2 = NN[s, 0], NN[s, 1], NN[s, 2]
            coef[s, 0] = b0
            coef[s, 1] = b1
            coef[s, 2] = b2
            coef[s, 3] = a1 * b2 - a2 * b1
            coef[s, 4] = a2 * b0 - a0 * b2
            coef[s, 5] = a0 * b1 - a1 * b0
        r += 1
    return ks, d, P, NN, coef, jid, geoms


@nb.njit(cache=True)
def masked_pair_sum(both, support, jid):
    """J_d (m × nv) from ``both`` (2m × nv, each side's coefficients @ ``data.J``): row i is ``both[i] ⊙
    support[jid[i]] + both[m + i] ⊙ support[jid[m + i]]`` (each joint's supporting chain, 0/1)."""
    m2, nv = both.shape
    m = m2 // 2
    out = np.empty((m, nv))
    for i in range(m):
        j1, j2 = jid[i], jid[m + i]
        for c in range(nv):
            out[i, c] = both[i, c] * support[j1, c] + both[m + i, c] * support[j2, c]
    return out


@nb.njit(cache=True)
def toggles(active, ks, on, off):
    """The pairs to switch so that exactly ``ks`` are active: those of ``ks`` not ``active`` into ``on``, the
    ``active`` ones not in ``ks`` into ``off``; ``active`` becomes that set. Returns (how many on, how many off)."""
    n = len(active)
    want = np.zeros(n, dtype=np.bool_)
    for i in range(len(ks)):
        want[ks[i]] = True
    n_on = 0
    n_off = 0
    for k in range(n):
        if want[k] and not active[k]:
            on[n_on] = k
            n_on += 1
        elif active[k] and not want[k]:
            off[n_off] = k
            n_off += 1
        active[k] = want[k]
    return n_on, n_off



def weight_spans(weights_t: np.ndarray) -> np.ndarray:
    """Per joint j (row of ``weights_t``, nv × pairs), the pairs [first, last + 1) between its first and last non-zero
    weight ((nv × 2); [0, 0) for a joint with none): :func:`broad_phase`'s range for it. A weight that is not 0 (a
    positive, infinite or NaN one) is inside its joint's range."""
    out = np.zeros((weights_t.shape[0], 2), dtype=np.int64)
    for j, row in enumerate(weights_t):
        idx = np.flatnonzero(row != 0.0)
        if len(idx):
            out[j] = idx[0], idx[-1] + 1
    return out
