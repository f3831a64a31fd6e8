"""What a solver hands back: x = (q̈, f) and a record per level (boundary type).

Every solver returns a :class:`SolveResult` from ``solve(problem)``; the controller turns
it into torques and a :class:`~wbc.controller.solution.Solution` without knowing which solver ran.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import get_lapack_funcs

#: ``LevelInfo.qp_status`` of a level whose QP was solved by its KKT certificate
#: (:mod:`wbc.solvers.kernels.active_set`) instead of a back-end
CERTIFIED = "certified"

_gesdd, = get_lapack_funcs(("gesdd",), (np.zeros((1, 1)),))


def singular_values(R: np.ndarray) -> tuple[float, float]:
    """(σ_min, σ_max) of an upper-triangular factor (its lower part ignored)."""
    s = _gesdd(np.triu(R), compute_uv=0)[1]
    return float(s[-1]), float(s[0])


@dataclass(slots=True)
class LevelInfo:
    """What a solver reports for one level (feeds ``Solution.diagnostics``): the rank of
    J̄_k = J_k N_{k−1} (5.38) and its σ_min, the damping λ² used, the free directions before
    it, whether a QP was solved and how, whether its inequalities were relaxed, the joints
    saturated in its null space (SNS) and its task scale s ∈ [0, 1]."""

    index: int
    rank: int = 0
    sigma_min: float = np.inf
    damping: float = 0.0
    dof_before: int = 0
    used_qp: bool = False
    qp_status: str = ""
    relaxed: bool = False
    saturated: list = field(default_factory=list)
    scale: float = 1.0
    #: triangular factor of J̄_k when the solver did not compute its singular values
    #: (square, or flat row by row as a compiled run hands it over); ``sigma()`` works them out
    R: np.ndarray | None = None
    #: σ_min fell below the damping threshold ε though no damping was applied to this level
    #: alone (a level the weighted QP folds: the folded rows are damped, or regularised by a
    #: posture, as one; ``rank`` and ``sigma_min`` are then the level's own rows' in level 0's
    #: null space)
    singular: bool = False

    def sigma(self) -> float:
        """σ_min of J̄_k (computed on demand from ``R`` if the solver took the QR path)."""
        R = self.R
        if R is not None:
            if R.ndim == 1:
                m = math.isqrt(R.shape[0])
                R = R.reshape(m, m)
            self.sigma_min = singular_values(R)[0]
            self.R = None
        return self.sigma_min


class DeferredLevels(Sequence):
    """The :class:`LevelInfo` list of a solve, decoded when first read: a compiled run hands its
    levels over as two flat arrays (:func:`wbc.solvers.kernels.records.decode` reads them),
    and a cycle whose diagnostics nobody asks for need not decode them. ``relaxed`` is known
    without decoding (a run that solved every level relaxed none).

    Args:
        decode: () -> the list of LevelInfo (called once, on first access).
        relaxed: whether a level was relaxed.
        singular: the positions of the levels whose LevelInfo has ``damping > 0`` or ``singular``
            (what ``Solution.singular_levels`` lists), when the solver knows them without
            decoding; None: read from the decoded list.
    """

    __slots__ = ("_decode", "_infos", "relaxed", "_singular")

    def __init__(self, decode: Callable[[], list[LevelInfo]], relaxed: bool = False,
                 singular: list[int] | None = None) -> None:
        self._decode, self.relaxed, self._singular = decode, relaxed, singular
        self._infos: list[LevelInfo] | None = None

    def _list(self) -> list[LevelInfo]:
        infos = self._infos
        if infos is None:
            infos = self._infos = self._decode()
        return infos

    def __getitem__(self, i):
        return self._list()[i]

    def singular(self) -> list[int]:
        """The positions of the levels damped (``damping > 0``) or flagged ``singular``."""
        got = self._singular
        if got is None:
            got = self._singular = [k for k, info in enumerate(self._list()) if info.damping > 0.0 or info.singular]
        return list(got)

    def __len__(self) -> int:
        return len(self._list())

    def __iter__(self) -> Iterator[LevelInfo]:
        return iter(self._list())

    def __add__(self, other: list) -> list[LevelInfo]:
        return self._list() + list(other)


@dataclass
class SolveResult:
    """x = (q̈, f) (m/s², rad/s², N, N·m), a :class:`LevelInfo` per level, ``ok`` (False: a
    QP failed and x is not to be used as is), the QPs solved, a message, ``degraded`` (a
    level was held at a feasible point after its QP failed). The projection's force
    distribution also gives ``dynamics_gap``, how far the root dynamics are from holding,
    and their scale (N, N·m). ``enforces_inequality_rows`` False: the solver did not meet
    the levels' general inequality rows (the projection: torque limits, friction cones),
    which the diagnostics then report apart. ``outside_cascade``: the tasks whose equality
    rows the solver met outside its priority cascade (the projection: the floating-base
    dynamics, by its force distribution, how well in ``dynamics_gap``), left out of the
    levels' residuals."""

    x: np.ndarray
    levels: list[LevelInfo] | DeferredLevels
    ok: bool = True
    qp_count: int = 0
    message: str = ""
    degraded: bool = False
    dynamics_gap: float = 0.0
    dynamics_scale: float = 0.0
    enforces_inequality_rows: bool = True
    outside_cascade: tuple[str, ...] = ()

