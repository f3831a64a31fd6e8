"""What crosses from the controller to a solver (boundary type)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .rows import ContactData, Layout, Level, StackedRows

#: default room (units of each inequality row: N, N·m, rad/s²) a solution keeps from a limit
#: where it can (``Problem.margin``)
ROW_MARGIN = 1.0


@dataclass(slots=True)
class Problem:
    """One cycle's problem over x = (q̈, f) (m/s², rad/s², N, N·m), the same whichever solver
    takes it; each solver reads what it needs.

    - ``levels``: the affine rows in priority order (the stack's, then the controller's
      lowest), as views of ``rows``; level 0 holds the floating-base dynamics rows (5.26)
      of a robot with an unactuated root (``RowBlock.equation_of_motion``);
    - ``layout``: where the contact forces live in x, and J_f;
    - ``M`` (kg·m², …), ``h`` = C q̇ + g (N·m) and the unactuated (root) coordinates: the
      equation of motion (5.26) for the solvers that use it outside their rows (the
      projection's force distribution);
    - ``x_ref``: the state's nominal point the least-norm choices start from (None: 0);
    - ``contacts``: each contact's :class:`ContactData`, in level order (friction cones,
      normal-force bounds), for a solver that distributes the forces itself;
    - ``rows``: every level's rows in five arrays (:class:`StackedRows`; None for levels
      built outside a stack), for a solver that reads them in one pass;
    - ``margin``: the room (units of each inequality row) a solution keeps from a limit where
      it can, the same as ``x_ref`` keeps from the joint-acceleration bounds (the controller
      sets :data:`ROW_MARGIN`; None: the solver's own)."""

    levels: list[Level]
    layout: Layout
    M: np.ndarray
    h: np.ndarray
    unactuated_idx: np.ndarray
    x_ref: np.ndarray | None = None
    contacts: list[ContactData] = field(default_factory=list)
    rows: StackedRows | None = None
    margin: float | None = None
