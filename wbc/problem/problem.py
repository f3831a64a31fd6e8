"""What crosses from the controller to a solver (boundary type)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .rows import ContactData, Layout, Level


@dataclass(slots=True)
class Problem:
    """One cycle's problem over x = (q̈, f) (m/s², rad/s², N, N·m): the ``levels`` of
    affine rows in priority order (the stack's, then the controller's lowest), the
    ``layout`` of x (force slices, J_f), the joint-space dynamics M(q) (kg·m², …) and
    h(q, q̇) = C q̇ + g (N·m) with the unactuated (root) coordinates, for the solvers that
    need the equation of motion (5.26) outside their rows (the projection's force
    distribution), ``x_ref`` the state's nominal point the least-norm choices start from
    (None: 0), and ``contacts``, each
    contact's :class:`ContactData` in level order (filled for the solvers that
    ``distributes_forces``)."""

    levels: list[Level]
    layout: Layout
    M: np.ndarray
    h: np.ndarray
    unactuated_idx: np.ndarray
    x_ref: np.ndarray | None = None
    contacts: list[ContactData] = field(default_factory=list)
