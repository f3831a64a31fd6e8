"""The weighted QP: level 0 hard, every lower level folded into one weighted objective
(the soft hierarchy of TSID), solved by the hierarchical QP's cascade on two levels.

Near-singular levels: the folded rows are damped as one (their σ scaled by the weights), and a
posture folded in regularises every direction, so the folded level's damping says nothing of
one level's singularity (a hand at its workspace boundary above a posture is never damped).
Each folded level that can lose rank (one without a posture, whose rows are the identity on
its joints) is therefore tested on its own rows in level 0's null space: when their σ_min < ε it is
reported ``singular`` with their rank and σ_min (the solver's :class:`~wbc.solvers.cascade.Damping`
threshold; the hierarchical QP projects into every higher level's null space, this solver has
no order among the folded levels). One compiled call per cycle (:func:`own_sigma`): the rows
projected on the basis of level 0's null space the cascade left (level 0 is not factorised a
second time) and a Cholesky test of an m_k × m_k Gram per such level.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numba as nb
import numpy as np

from ..cholesky import cholesky_lower
from ..problem.result import LevelInfo, SolveResult
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
    #: the cascade keeps level 0's null-space basis for :meth:`_own_conditioning`
    keep_level0_basis = True

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
        #: the levels :meth:`_own_conditioning` tests, their row offsets and the array their rows
        #: are copied into, for the merge plan they were worked out with
        self._sigma_plan: tuple | None = None

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
        # the merged level's info for every folded level, with its own conditioning (module doc)
        res.levels = res.levels[:1] + self._own_conditioning(levels[0], rest, res.levels[1]) + res.levels[2:]
        return res

    #: kinds whose rows are the identity on their joints: a level with one never loses rank
    FULL_RANK_KINDS = frozenset({"posture"})

    def _own_conditioning(self, top: Level, rest: list[Level], merged: LevelInfo) -> list[LevelInfo]:
        """``merged`` for each folded level; for a level without a posture whose equality rows
        in the null space of level 0's have σ_min < ε (:func:`own_sigma`, in the basis of that
        null space the cascade left after level 0), their rank and σ_min and ``singular``
        (module doc)."""
        d = self.damping
        out = [merged] * len(rest)
        if d.threshold <= 0.0:
            return out
        plan = self._sigma_plan
        if plan is None or plan[0] is not self._merge_plan or self._merge_plan is None:
            check = [i for i, lvl in enumerate(rest)
                     if lvl.A.shape[0] and not set(lvl.kinds) & self.FULL_RANK_KINDS and not lvl.regularizers_only]
            offsets = np.cumsum([0] + [rest[i].A.shape[0] for i in check]).astype(np.int64)
            plan = self._sigma_plan = (self._merge_plan, check, offsets,
                                       np.empty((int(offsets[-1]), top.A.shape[1])))
        _, check, offsets, A = plan
        if not check:
            return out
        for i, a, b in zip(check, offsets[:-1], offsets[1:]):
            A[a:b] = rest[i].A
        basis = self.level0_basis
        if basis is None:                    # (every solve sets it; a basis of null(A0) all the same)
            basis = (_null_space(top.A, d.rank_tol), False) if top.A.shape[0] else (np.empty((0, 0)), True)
        ranks, smins = own_sigma(basis[0], basis[1], A, offsets, d.rank_tol, d.threshold)
        for i, rank, smin in zip(check, ranks.tolist(), smins.tolist()):
            if rank and smin < d.threshold:
                out[i] = replace(merged, index=merged.index + i, rank=rank, sigma_min=smin, R=None, singular=True)
        return out

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


#: σ² from a Gram matrix is exact to ~1e-16 ‖A‖²: singular values below this (relative) count as 0
GRAM_SIGMA_FLOOR = 1e-7


def _null_space(A0: np.ndarray, rank_tol: float) -> np.ndarray:
    """An orthonormal basis of A0's null space (numpy's SVD; singular values above
    ``rank_tol``·max(1, σ_max) count)."""
    _, s, Vt = np.linalg.svd(A0)
    rank = int(np.sum(s > rank_tol * max(1.0, s[0] if len(s) else 0.0)))
    return np.ascontiguousarray(Vt[rank:].T)


@nb.njit(cache=True)
def own_sigma(Z0, identity, A, offsets, rank_tol, threshold):
    """(rank, σ_min) per row block k of ``A`` (rows ``offsets[k]:offsets[k+1]``) in level 0's
    null space, whose orthonormal basis is ``Z0`` (``identity``: level 0 leaves every
    direction free, ``Z0`` then unused), worked out only when σ_min < ``threshold`` ε;
    (0, ∞) for a block whose σ are all ≥ ε. σ² are the eigenvalues of
    G = A_k P A_kᵀ = (A_k Z0)(A_k Z0)ᵀ (P = Z0 Z0ᵀ, the projector onto level 0's null space;
    Z0 is the basis the cascade left after level 0, so level 0 is not factorised again).
    σ_min ≥ ε exactly when G − ε² I has a Cholesky factor: the eigenvalues only then.
    Singular values below (``rank_tol`` + :data:`GRAM_SIGMA_FLOOR`)·max(1, σ_max) count as zero."""
    nb_ = offsets.shape[0] - 1
    ranks = np.zeros(nb_, dtype=np.int64)
    smins = np.full(nb_, np.inf)
    AZ = A if identity else A @ Z0
    for k in range(nb_):
        a, b = offsets[k], offsets[k + 1]
        P = AZ[a:b]
        G = P @ P.T
        Gs = G.copy()
        for i in range(G.shape[0]):
            Gs[i, i] -= threshold * threshold
        if cholesky_lower(Gs, 0.0)[1]:
            continue
        s2 = np.linalg.eigvalsh(G)
        smax = np.sqrt(max(s2.max(), 0.0))
        floor = (rank_tol + GRAM_SIGMA_FLOOR) * max(1.0, smax)
        r = 0
        smin = np.inf
        for v in s2:
            sv = np.sqrt(max(v, 0.0))
            if sv > floor:
                r += 1
                smin = min(smin, sv)
        ranks[k] = r
        smins[k] = smin
    return ranks, smins
