"""Plain data passed from tasks to the stack and from the stack to the solvers.

Following TSID's split, a solver never sees a task: it sees levels of affine rows
over the decision vector x = (q̈, f), q̈ ∈ R^nv the joint accelerations (m/s², rad/s²)
and f ∈ R^nf the stacked contact forces/wrenches (N, N·m) in each contact's frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np


@dataclass
class Rows:
    """What one task contributes: ``A x = b`` and/or ``l ≤ C x ≤ u`` and/or box bounds.

    ``box = (idx, lo, hi)`` bounds q̈[idx] (joint limits); solvers treat it either
    as rows or, in the projection solver, by saturation in the null space.
    """

    A: np.ndarray | None = None
    b: np.ndarray | None = None
    C: np.ndarray | None = None
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    box: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    @property
    def n_eq(self) -> int:
        return 0 if self.A is None else self.A.shape[0]

    @property
    def n_in(self) -> int:
        return (0 if self.C is None else self.C.shape[0]) + (0 if self.box is None else len(self.box[0]))


@dataclass
class Layout:
    """Where each contact's force lives in x, the force Jacobian J_f (nf × nv), and each
    contact's surface.

    J_fᵀ f is the joint torque the contact forces produce, so the equation of
    motion reads M q̈ + h = Sᵀτ + J_fᵀ f (5.26).
    """

    nv: int
    contact_slices: dict[str, slice] = field(default_factory=dict)
    #: refilled in place every cycle, never replaced (``nf`` and ``nx`` are set from it once)
    force_jacobian: np.ndarray | None = None
    #: contact task name -> its :class:`~wbc.robot.model.ContactSurface` (kind and sole half sizes),
    #: for the tasks whose rows depend on the contact geometry (contact regularisation)
    surfaces: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        #: number of force variables, and of decision variables x = (q̈, f)
        self.nf = 0 if self.force_jacobian is None else self.force_jacobian.shape[0]
        self.nx = self.nv + self.nf
        self._key = (self.nx, tuple((n, s.start) for n, s in self.contact_slices.items()))

    def structure_key(self) -> tuple:
        """(nx, each contact's name and force offset): equal for layouts whose x means the
        same thing."""
        return self._key


@dataclass(frozen=True, slots=True)
class RowBlock:
    """One task's equality rows in its level: ``rows`` (a slice of the level's rows),
    whether they act on the contact forces only (``on_forces``: a wrench target, the
    contact regularisation), whether the task is a ``regularizer`` (decides only what the
    others leave free), whether its A depends on the layout only (``constant_A``: the
    rows change with the state through b alone) and whether they are the unactuated rows
    of the equation of motion (``equation_of_motion``: a solver that finds the forces after
    q̈ meets them there, not among q̈'s rows)."""

    name: str
    rows: slice
    on_forces: bool = False
    regularizer: bool = False
    constant_A: bool = False
    equation_of_motion: bool = False


class ContactData(NamedTuple):
    """What a solver may know of one contact this cycle: its name (its force slice is
    ``Layout.contact_slices[name]``), friction μ (None: the surface's), the normal-force
    bounds ``fmin`` ≤ f_n ≤ ``fmax`` (N; fmax finite while the contact is being made or
    released), ``bilateral``, the CoP margin (fraction of the sole) and ``generators()``,
    (f₀, V) with every admissible force f₀ + V λ, λ ≥ 0 (its friction/CoP cone). A named
    tuple (immutable, built for every contact every cycle: 0.7 µs, a frozen dataclass 2.3)."""

    name: str
    mu: float | None
    fmin: float
    fmax: float
    bilateral: bool
    cop_margin: float
    generators: Callable[[], tuple[np.ndarray, np.ndarray]]

    def params(self) -> tuple:
        """What the cone and the ramp depend on."""
        return (self.mu, self.fmin, self.bilateral, self.cop_margin, self.fmax != np.inf)


@dataclass(slots=True)
class RowSlot:
    """Where one task writes its equality rows A x = b in one call of ``Task.rows``: arrays
    the problem owns (a block of the stack's row buffer, or the buffer's scratch for a task
    whose rows it scales by √weight), handed in for that call only; the task keeps no
    reference to them. ``written`` is what the task last wrote into A here (None: nothing,
    A is zero): a task whose A changes only with the layout writes it when that differs
    (:func:`~wbc.tasks.base.eq_rows`)."""

    A: np.ndarray
    b: np.ndarray
    written: object = None


@dataclass(frozen=True, slots=True)
class StackedRows:
    """Every level's rows in five arrays, level after level (what the levels' arrays are
    views of): equalities (A, b), level k's rows ``[eq_end[k−1], eq_end[k])``; inequalities
    (C, lo, hi), general rows then box bounds as unit rows, level k's rows
    ``[ineq_end[k−1], ineq_end[k])``; ``spans[k]`` = (e0, e1, i0, number of general rows,
    i1). ``structure`` is equal for two problems only when their rows have the same
    structure (the same buffer): what a solver may key what it keeps across cycles on."""

    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    eq_end: np.ndarray
    ineq_end: np.ndarray
    spans: list
    structure: tuple


@dataclass
class Level:
    """All rows of one priority level, stacked; equality rows pre-scaled by √weight. The
    tasks are known by their ``names`` (and type names, ``kinds``), in their order."""

    index: int
    names: list[str]
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    box: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    eq_slices: dict[str, slice]
    in_slices: dict[str, slice]
    #: each task's equality rows, in the order of ``names`` (tasks without any left out)
    blocks: list[RowBlock] = field(default_factory=list)
    #: every task of the level is a regularizer (the contact regularisation's level)
    regularizers_only: bool = False
    #: each task's type name (``Task.kind``), in the order of ``names``
    kinds: list[str] = field(default_factory=list)
    #: the tasks that are regularisations (``Task.regularizer``: never reported as sacrificed)
    regularizers: frozenset[str] = frozenset()
    #: all inequality rows (general, then box bounds as unit rows), when built
    ineq: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    @property
    def n_eq(self) -> int:
        return self.A.shape[0]

    @property
    def n_in(self) -> int:
        return self.C.shape[0] + (0 if self.box is None else len(self.box[0]))

    def contact_rows(self) -> np.ndarray:
        """Indices, among :meth:`inequalities`' rows (general rows first), of the level's
        contact tasks' rows (``kind`` "contact"): their friction/CoP cones and normal-force
        bounds, what a relaxed level still keeps (a force the ground cannot give is never
        planned)."""
        idx: list[int] = []
        for name, kind in zip(self.names, self.kinds):
            sl = self.in_slices.get(name)
            if kind == "contact" and sl is not None:
                idx.extend(range(sl.start, sl.stop))
        return np.asarray(idx, dtype=np.int64)

    def inequalities(self, nx: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All inequality rows (general rows, then box bounds as unit rows): C, lo, hi.
        Built once per level and cycle (the solver and the diagnostics both read it)."""
        if self.box is None:
            return self.C, self.lo, self.hi
        cached = self.ineq
        if cached is not None and cached[0].shape[1] == nx:
            return cached
        idx, blo, bhi = self.box
        B = np.zeros((len(idx), nx))
        B[np.arange(len(idx)), idx] = 1.0
        self.ineq = (np.vstack([self.C, B]), np.concatenate([self.lo, blo]), np.concatenate([self.hi, bhi]))
        return self.ineq
