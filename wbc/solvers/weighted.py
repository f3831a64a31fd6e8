"""The weighted QP: level 0 hard, every lower level folded into one weighted objective
(the soft hierarchy of TSID), solved by the hierarchical QP's cascade on two levels.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..problem.result import SolveResult
from ..problem.rows import Level, StackedRows
from .cascade import Damping
from .hqp import HierarchicalQP


class WeightedQP(HierarchicalQP):
    """One weighted QP: level 0 kept hard, every lower level k folded into one
    objective with weight ``level_weight``^(k−1) (a soft hierarchy, as in TSID).

    A lowest level of regularisation tasks only (``Task.regularizer``: the contact
    regularisation) is not folded: it stays a strict level below the folded one, deciding
    only what the others leave free. Folded, its rows (N, hundreds of them for a
    humanoid's weight) traded against the motion tasks' (m/s², rad/s²) despite its weight:
    on Talos at rest, 0.29 rad/s² of posture error at weight 1e-9."""

    name = "weighted"

    #: the options :meth:`create` takes beyond ``backend`` and ``damping`` (:mod:`wbc.solvers.options`)
    options: tuple[str, ...] = ("level_weight",)

    @classmethod
    def create(cls, backend: str = "daqp", damping: Damping | None = None,
               level_weight: float = 1e-3) -> WeightedQP:
        """The solver from the controller's options (:func:`wbc.solvers.create_solver` checks them)."""
        return cls(backend=backend, damping=damping, level_weight=level_weight)

    def __init__(self, *args, level_weight: float = 1e-3, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.level_weight = level_weight
        #: the folded Level and its row blocks per level, refilled in place while the levels
        #: folded have the same structure (:meth:`_merge`)
        self._merge_plan: _MergePlan | None = None

    def solve_levels(self, levels: list[Level], nx: int, key: str = "", x_ref: np.ndarray | None = None,
                     dampings: dict | None = None, stacked: StackedRows | None = None, own: int | None = None,
                     margin: float | None = None) -> SolveResult:
        """The soft hierarchy's two strict levels (level 0, the folded rest) and the
        regularisation tail, by the strict cascade (``dampings`` as there: unused here,
        the folded level gets its own; ``stacked``, ``own``, ``margin`` as there)."""
        tail = []
        if len(levels) > 2 and levels[-1].regularizers_only:
            levels, tail = levels[:-1], levels[-1:]
        if len(levels) <= 2:
            return super().solve_levels(levels + tail, nx, key, x_ref=x_ref, stacked=stacked, own=own,
                                        margin=margin)
        rest = levels[1:]
        w = [np.sqrt(self.level_weight ** k) for k in range(len(rest))]
        merged = self._merge(rest, w)
        # The singularity damping acts on σ of the merged rows, which the weights scale:
        # a folded level of weight w has σ ~ √w however well conditioned it is, and an
        # unscaled threshold damped the lower levels away (Talos' torso orientation at
        # weight 1e-6 drifted 0.47 rad in talos_reach and the robot tipped over). The
        # threshold and the damping are scaled by the smallest √w, so only a real
        # singularity of the folded rows is damped.
        d, wmin = self.damping, w[-1]
        folded = {1: Damping(threshold=d.threshold * wmin, max_damping=d.max_damping * wmin, rank_tol=d.rank_tol)}
        res = super().solve_levels([levels[0], merged] + tail, nx, key, x_ref=x_ref, dampings=folded,
                                   stacked=stacked, own=1 if own is None else min(own, 1), margin=margin)
        # report the merged level's info for every folded level
        res.levels = res.levels[:1] + [res.levels[1]] * len(rest) + res.levels[2:]
        return res

    def _merge(self, rest: list[Level], w: list[float]) -> Level:
        """Levels 1.. folded into one, row blocks scaled by √weight. The folded level's
        arrays are kept and refilled while the levels have the same structure (their
        names and row counts)."""
        plan = self._merge_plan
        structure = [(l.names, l.A.shape, l.C.shape, l.box is not None) for l in rest]
        if plan is not None and plan.structure == structure:
            merged = plan.merged
            for (A, b, C, lo, hi), l, wk in zip(plan.parts, rest, w):
                np.multiply(l.A, wk, out=A)
                np.multiply(l.b, wk, out=b)
                if C is not None:
                    np.copyto(C, l.C)
                    np.copyto(lo, l.lo)
                    np.copyto(hi, l.hi)
            return merged
        boxes = [l.box for l in rest if l.box is not None]
        box = None
        if boxes:
            b_idx, b_lo, b_hi = (np.concatenate(p) for p in zip(*boxes))
            box = (b_idx, b_lo, b_hi)
        merged = Level(
            index=1,
            names=[n for l in rest for n in l.names],
            kinds=[n for l in rest for n in l.kinds],
            regularizers=frozenset().union(*(l.regularizers for l in rest)),
            A=np.vstack([wk * l.A for wk, l in zip(w, rest)]),
            b=np.concatenate([wk * l.b for wk, l in zip(w, rest)]),
            C=np.vstack([l.C for l in rest]),
            lo=np.concatenate([l.lo for l in rest]),
            hi=np.concatenate([l.hi for l in rest]),
            box=box,
            eq_slices={}, in_slices={},
        )
        if boxes:                       # box bounds are refilled by the levels only: no plan
            self._merge_plan = None
            return merged
        parts, e, i = [], 0, 0
        for l in rest:
            me, mi = l.A.shape[0], l.C.shape[0]
            parts.append((merged.A[e:e + me], merged.b[e:e + me],
                          merged.C[i:i + mi] if mi else None, merged.lo[i:i + mi], merged.hi[i:i + mi]))
            e, i = e + me, i + mi
        self._merge_plan = _MergePlan(structure, merged, parts)
        return merged


class _MergePlan(NamedTuple):
    """The folded level of :meth:`WeightedQP._merge` for levels of one ``structure``
    ((names, A's shape, C's shape, a box or not) per level), and its (A, b, C, lo, hi) blocks per level."""

    structure: list
    merged: Level
    parts: list
